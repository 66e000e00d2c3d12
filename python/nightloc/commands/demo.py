"""``nightloc demo``: the whole method on the embedded default data (the README's main command).

    nightloc demo [--out nightloc_demo] [--seed 0] [--repeats 1] [--cache DIR] [--no-figures]
                  [--figure-format png|pdf|svg]

The embedded default is the synthetic world of :mod:`nightloc.synth` (generated once into the
user cache): a garden and a living room, each with a day-time reference
traverse and a night-time query traverse along another path (the paper's Table I). For each
world the demo builds the reference map from the day traverse, localizes every night query
frame for sequence lengths 1-10, odometry noise models 0-3 and interpolation on/off
(:func:`nightloc.localization.evaluation.evaluate`), prints the median distance errors and writes
``OUT/<world>/errors.csv``, ``summary.csv`` and the figures, as ``nightloc evaluate`` does.

Beside the paper's method it runs the grid Bayes filter (``Localizer``'s default) with map-frame
odometry (rows ``method=filter`` of ``errors.csv``) and with wheel odometry
(``errors_wheel.csv``: the paper's 10-frame sequences and the filter), prints both methods' median
errors over the query frames from the 10th on per noise model, and draws
``filter_vs_paper.png``.

Then the **teach run**: the day map built again from the day drive's own wheel
odometry (``odometry.csv``, no survey; :func:`nightloc.mapping.teach_run`), its ATE beside the
dead reckoning's, and the filter's night error on it (the query's truth moved into the map's
frame by the rigid fit) beside the surveyed map's; ``teach_run.png`` draws the paths. It needs
GTSAM (``pip install "nightloc[mapping]"``); without it the demo says so in one line and goes on.
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path
from typing import TYPE_CHECKING

from ..figures import add_figure_format_option
from ..io.atomic import make_folder, output_set
from ..localization.evaluation import (
    Evaluation,
    EvaluationSettings,
    align_to_map,
    evaluate,
    map_alignment,
    match_traverse,
)
from ..localization.localizer import LocalizationParams
from ..mapping.reference_map import ReferenceMap
from .options import check_draw_options

if TYPE_CHECKING:
    import numpy as np

#: (world, reference traverse, query traverse) pairs the demo evaluates.
DEMO_PAIRS = (("garden", "day_reference", "night_query"), ("living_room", "day_reference", "night_query"))

#: The paper's headline results, printed beside ours.
PAPER_RESULTS = {
    "garden": "paper (real garden, night query): median ~0.5 m with 10-frame sequences",
    "living_room": "paper (real living room, night query): median up to ~0.25 m with 7-frame sequences under noise",
}


#: The paper's sequence length the filter is compared with, and the first query frame counted
#: (1-based: a 10-frame sequence is full from the 10th frame on).
COMPARE_SEQ_LEN = 10
COMPARE_FROM = 10


def comparison_errors(
    map_evaluation: Evaluation, wheel_evaluation: Evaluation
) -> dict[str, dict[str, list[np.ndarray]]]:
    """``{odometry: {"paper": [errors per noise model], "filter": [...]}}`` over the frames from
    :data:`COMPARE_FROM` on (interpolation on)."""
    out = {}
    for label, ev in (("map-frame odometry", map_evaluation), ("wheel odometry (RobotMotion)", wheel_evaluation)):
        later = ev.frame_index() >= COMPARE_FROM - 1
        by_method: dict[str, list[np.ndarray]] = {"paper": [], "filter": []}
        for model in ev.settings.noise_models:
            for method in by_method:
                mask = ev.select(noise_model=model, interpolation=True, method=method) & later
                if method == "paper":
                    mask &= ev.columns["seq_len"] == COMPARE_SEQ_LEN
                by_method[method].append(ev.columns["error_m"][mask])
        out[label] = by_method
    return out


def comparison_table(errors: dict[str, dict[str, list[np.ndarray]]], models: tuple[int, ...]) -> str:
    """The medians of :func:`comparison_errors` as text: rows odometry x method, columns noise models."""
    import numpy as np

    header = f"{'odometry':<30}{'method':<16}" + "".join(f"noise {m:<4}" for m in models)
    lines = [header, "-" * len(header)]
    for label, by_method in errors.items():
        for method, name in (("paper", f"paper, n={COMPARE_SEQ_LEN}"), ("filter", "Bayes filter")):
            cells = "".join(f"{np.median(e):<10.2f}" if e.size else f"{'-':<10}" for e in by_method[method])
            lines.append(f"{label:<30}{name:<16}{cells}")
    return "\n".join(lines)


def _median_m(errors: np.ndarray) -> str:
    import numpy as np

    return f"{np.median(errors):.2f} m" if len(errors) else "-"


def teach_comparison(
    surveyed_map: ReferenceMap,
    day: Path,
    query: Path,
    surveyed_errors: np.ndarray,
    settings: EvaluationSettings,
    params: LocalizationParams,
    figure: Path | None = None,
    progress_desc: str | None = None,
) -> list[str]:
    """The demo's teach-run lines: the map from the day drive's wheel odometry, its ATE beside
    the dead reckoning's, the filter's night error on it beside ``surveyed_errors`` (the same
    query frames on the surveyed map); draws the paths to ``figure``. One line when GTSAM is
    missing."""
    import warnings

    import numpy as np

    from ..errors import MissingDependencyError
    from ..io.traverse import load_traverse
    from ..mapping import TeachWarning, absolute_trajectory_error, teach_run

    traverse = load_traverse(day)
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", TeachWarning)
            teach_map, report = teach_run(traverse, surveyed_map.params)
    except MissingDependencyError:
        return ['teach run: skipped, it needs GTSAM: pip install "nightloc[mapping]"']
    truth = np.asarray(traverse.positions)
    alignment = map_alignment(teach_map, traverse)
    if alignment is None:  # a teach run's map is never surveyed
        raise AssertionError("a teach-run map needs aligning")
    matches = align_to_map(match_traverse(teach_map, query, tables=True), alignment[0])
    evaluation = evaluate(teach_map, matches, settings, params, progress_desc=progress_desc)
    later = evaluation.frame_index() >= COMPARE_FROM - 1
    teach_errors = evaluation.columns["error_m"][evaluation.select(method="filter") & later]
    if figure is not None:
        from ..figures.teach import teach_figure

        fit = alignment[0]
        teach_figure(
            report.dead_reckoning,
            teach_map.positions,
            fit.inverse().apply(truth),
            title=f"Teach run: {traverse.root.parent.name} day drive from its wheel odometry",
            path=figure,
        )
    reckoned_ate = absolute_trajectory_error(report.dead_reckoning[:, :2], truth)
    map_ate = absolute_trajectory_error(teach_map.positions, truth)
    first = (
        f"teach run (the day drive's wheel odometry, no survey): {report.accepted} visual constraints accepted, "
        f"{report.rejected} rejected; map ATE {map_ate:.2f} m (dead reckoning {reckoned_ate:.2f} m)"
    )
    second = (
        f"night median error, Bayes filter with wheel odometry (noise model {settings.noise_models[0]}), frames "
        f"{COMPARE_FROM} on: "
        f"surveyed map {_median_m(surveyed_errors)}, teach-run map {_median_m(teach_errors)}"
    )
    return [first, second]


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
        "--out",
        type=Path,
        default=Path("nightloc_demo"),
        help="output folder (default ./nightloc_demo; created with its parents if missing)",
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


def _draw_world(
    evaluation: Evaluation,
    errors: dict[str, dict[str, list[np.ndarray]]],
    ref_map: ReferenceMap,
    target: Path,
    params: LocalizationParams,
    world: str,
    frames: int,
    args: argparse.Namespace,
) -> list[str]:
    """One world's evaluation figures and the filter beside the paper's method: their names."""
    from ..figures._common import figure_path
    from ..figures.evaluation import save_evaluation_figures
    from ..figures.filter import comparison_figure

    written = [
        p.name
        for p in save_evaluation_figures(evaluation, ref_map, target, params=params, figure_format=args.figure_format)
    ]
    figure = figure_path(target, "filter_vs_paper", args.figure_format)
    comparison_figure(
        errors,
        f"{world}: night query frames {COMPARE_FROM}-{frames}, {args.repeats} noise draw(s) per model",
        figure,
        args.figure_format,
    )
    written.append(figure.name)
    return written


def _print_world(
    evaluation: Evaluation,
    errors: dict[str, dict[str, list[np.ndarray]]],
    ref_map: ReferenceMap,
    world: str,
    frames: int,
    repeats: int,
) -> None:
    """One world's tables: the paper's method against the paper's figures, then the filter beside it."""
    print()
    print(
        f"{world}: {frames} night query frames against a day map of {len(ref_map)} images; "
        f"median distance error (m), interpolation on unless noted:"
    )
    print(evaluation.table(off_column=True))
    print(PAPER_RESULTS[world])
    print()
    print(
        f"{world}: the Bayes filter beside the paper's method (n = {COMPARE_SEQ_LEN}), median distance "
        f"error (m) over frames {COMPARE_FROM}-{frames}, {repeats} noise draw(s):"
    )
    print(comparison_table(errors, evaluation.settings.noise_models))


def run(args: argparse.Namespace) -> int:
    """Runs the sub-command; returns the exit status (errors raise, the CLI prints one line)."""
    check_draw_options(args)
    from ..synth import default_cache_dir, default_dataset

    start = time.perf_counter()
    cache = args.cache if args.cache is not None else default_cache_dir()
    # The whole OUT folder is one set: both worlds appear together at the end, or nothing changes.
    with output_set(args.out, command="demo", inputs=(cache,), parents=True) as out:
        print(f"synthetic dataset in {cache} (generated on first use, ~10 s)", flush=True)
        folders = default_dataset(cache_dir=cache)
        settings = EvaluationSettings(repeats=args.repeats, seed=args.seed, methods=("paper", "filter"))
        wheel = EvaluationSettings(
            seq_lengths=(COMPARE_SEQ_LEN,),
            interpolation=(True,),
            repeats=args.repeats,
            seed=args.seed,
            odometry="robot",
            methods=("paper", "filter"),
        )
        params = LocalizationParams()
        reports = []
        for world, reference, query in DEMO_PAIRS:
            ref_map = ReferenceMap.build(folders[world][reference])
            matches = match_traverse(ref_map, folders[world][query], f"{world}/{query}", tables=True)
            evaluation = evaluate(ref_map, matches, settings, params, progress_desc=f"{world}: evaluating")
            wheel_evaluation = evaluate(ref_map, matches, wheel, params, progress_desc=f"{world}: wheel odometry")
            errors = comparison_errors(evaluation, wheel_evaluation)
            frames = len(matches.results)
            target = make_folder(out / world)
            written = [
                evaluation.write_errors_csv(target / "errors.csv").name,
                evaluation.write_summary_csv(target / "summary.csv").name,
                wheel_evaluation.write_errors_csv(target / "errors_wheel.csv").name,
            ]
            if not args.no_figures:
                written += _draw_world(evaluation, errors, ref_map, target, params, world, frames, args)
            _print_world(evaluation, errors, ref_map, world, frames, args.repeats)
            models = list(evaluation.settings.noise_models)
            model = 1 if 1 in models else models[0]  # the robot's wheel odometry noise, as the demo's
            wheel_filter = EvaluationSettings(
                seq_lengths=(1,), noise_models=(model,), interpolation=(True,), odometry="robot", methods=("filter",)
            )
            surveyed_errors = errors["wheel odometry (RobotMotion)"]["filter"][models.index(model)]
            teach_figure = None if args.no_figures else target / f"teach_run.{args.figure_format}"
            lines = teach_comparison(
                ref_map,
                folders[world][reference],
                folders[world][query],
                surveyed_errors,
                wheel_filter,
                params,
                teach_figure,
                progress_desc=f"{world}: teach-run map",
            )
            print()
            print("\n".join(lines))
            if teach_figure is not None and len(lines) > 1:
                written.append(teach_figure.name)
            reports.append(f"{args.out / world}/" + ", ".join(written))
    for report in reports:
        print(f"wrote {report}")
    print(f"\ndone in {time.perf_counter() - start:.1f} s")
    return 0
