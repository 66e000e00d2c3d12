"""``nightloc demo``: the whole method on the embedded default data (the README's main command).

    nightloc demo [--out nightloc_demo] [--seed 0] [--repeats 1] [--cache DIR] [--no-figures]
                  [--figure-format png|pdf|svg]

The embedded default is the synthetic world of :mod:`nightloc.synth` (generated once into the
user cache, about ten seconds): a garden and a living room, each with a day-time reference
traverse and a night-time query traverse along another path (the paper's Table I). For each
world the demo builds the reference map from the day traverse, localizes every night query
frame for sequence lengths 1-10, odometry noise models 0-3 and interpolation on/off
(:func:`nightloc.localization.evaluation.evaluate`), prints the median distance errors and writes
``OUT/<world>/errors.csv``, ``summary.csv`` and the figures, as ``nightloc evaluate`` does.
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path

from .._validate import MAX_REPEATS
from ..figures import add_figure_format_option
from ..io.atomic import make_folder, output_set
from ..io.reference_map import ReferenceMap
from ..localization.evaluation import EvaluationSettings, evaluate
from ..localization.localizer import LocalizationParams

#: (world, reference traverse, query traverse) pairs the demo evaluates.
DEMO_PAIRS = (("garden", "day_reference", "night_query"), ("living_room", "day_reference", "night_query"))

#: The paper's headline results, printed beside ours.
PAPER_RESULTS = {
    "garden": "paper (real garden, night query): median ~0.5 m with 10-frame sequences",
    "living_room": "paper (real living room, night query): median up to ~0.25 m with 7-frame sequences under noise",
}


def register(subparsers: argparse._SubParsersAction[argparse.ArgumentParser]) -> None:
    """Adds the sub-command's parser to ``subparsers``."""
    parser = subparsers.add_parser(
        "demo",
        help="run the method on the embedded default data (synthetic garden and living room at night)",
        description="Localizes the synthetic night-time query traverses of a garden and a living room against "
        "their day-time reference maps for sequence lengths 1-10, odometry noise models 0-3 and interpolation "
        "on/off; prints the median errors and writes CSV files and figures.",
    )
    parser.add_argument(
        "--out", type=Path, default=Path("nightloc_demo"), help="output folder (default ./nightloc_demo)"
    )
    parser.add_argument("--seed", type=int, default=0, help="seed of the odometry noise (non-negative, default 0)")
    parser.add_argument("--repeats", type=int, default=1, help="odometry noise draws per noise model (default 1)")
    parser.add_argument(
        "--cache",
        type=Path,
        default=None,
        help="folder of the generated dataset (default ~/.cache/nightloc or $XDG_CACHE_HOME/nightloc)",
    )
    parser.add_argument("--no-figures", action="store_true", help="do not draw the figures")
    add_figure_format_option(parser)
    parser.set_defaults(run=run)


def run(args: argparse.Namespace) -> int:
    """Runs the sub-command; returns the exit status (errors raise, the CLI prints one line)."""
    if args.seed < 0:
        raise ValueError(f"--seed must be non-negative, got {args.seed}")
    if not 1 <= args.repeats <= MAX_REPEATS:
        raise ValueError(f"--repeats must be in 1..{MAX_REPEATS} (MAX_REPEATS), got {args.repeats}")
    from ..synth import default_cache_dir, default_dataset

    start = time.perf_counter()
    cache = args.cache if args.cache is not None else default_cache_dir()
    # The whole OUT folder is one set: both worlds appear together at the end, or nothing changes.
    with output_set(args.out, command="demo", inputs=(cache,)) as out:
        print(f"synthetic dataset in {cache} (generated on first use, ~10 s)", flush=True)
        folders = default_dataset(cache_dir=cache)
        settings = EvaluationSettings(repeats=args.repeats, seed=args.seed)
        params = LocalizationParams()
        reports = []
        for world, reference, query in DEMO_PAIRS:
            ref_map = ReferenceMap.build(folders[world][reference])
            evaluation = evaluate(
                ref_map,
                folders[world][query],
                settings,
                params,
                name=f"{world}/{query}",
                progress_desc=f"{world}: evaluating",
            )
            target = make_folder(out / world)
            written = [
                evaluation.write_errors_csv(target / "errors.csv").name,
                evaluation.write_summary_csv(target / "summary.csv").name,
            ]
            if not args.no_figures:
                from ..figures.evaluation import save_evaluation_figures

                written += [
                    p.name
                    for p in save_evaluation_figures(
                        evaluation, ref_map, target, params=params, figure_format=args.figure_format
                    )
                ]
            frames = len(evaluation.matches[0].results)
            print()
            print(
                f"{world}: {frames} night query frames against a day map of {len(ref_map)} images; "
                f"median distance error (m), interpolation on unless noted:"
            )
            print(evaluation.table(off_column=True))
            print(PAPER_RESULTS[world])
            reports.append(f"{args.out / world}/" + ", ".join(written))
    for report in reports:
        print(f"wrote {report}")
    print(f"\ndone in {time.perf_counter() - start:.1f} s")
    return 0
