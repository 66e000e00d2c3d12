"""``nightloc evaluate``: the paper's 2D localization experiments on any pair of traverses.

    nightloc evaluate REFERENCE QUERY --out OUT [--method paper,filter] [--seq-lengths 1-10]
                      [--noise-models 0,1,2,3] [--interpolation on,off] [--repeats 1] [--seed 0]
                      [--odometry map|robot|log] [--odometry-noise wheel|1|DIST,HEADING]
                      [--params FILE.toml] [--shift-window COLUMNS,ROWS] [--heatmap-frames 12,30] [--no-figures]
                      [--figure-format png|pdf|svg]

REFERENCE is a traverse folder with poses (``images/`` + ``poses.csv``) or a map file written
by ``nightloc build-map``; QUERY is a traverse folder with poses (the ground truth). Writes the
folder OUT as one set (:func:`nightloc.io.atomic.output_set`: complete or unchanged; a second run
into OUT at the same time refuses; files in OUT that nightloc did not write are kept):

* ``OUT/errors.csv``: one row per query frame and configuration, the columns of
  :data:`~nightloc.localization.evaluation.ERRORS_COLUMNS` (``method`` paper or filter; the
  filter's ``seq_len`` is the number of frames seen so far; ``noise_model`` -1 with ``--odometry
  log``);
* ``OUT/summary.csv``: the columns of :data:`~nightloc.localization.evaluation.SUMMARY_COLUMNS`
  (the filter's rows summarize all its frames, seq_len 0; n, median, mean and p90 over every frame,
  the tail -- p95, the share of frames over 1 m, the longest run of such frames in one draw -- over
  the frames from the 10th on);

``--method`` picks the paper's sequence matching (default: the paper's experiments), the grid
Bayes filter, or both; ``--odometry`` simulated map-frame displacements (the paper), simulated
wheel odometry, or ``log``: the query's own ``odometry.csv`` (a robot's real odometry evaluated
against its poses; ``--odometry-noise`` is then the noise the filter assumes: by default ``wheel``,
the step-scaled model, for wheel odometry and Table III model 1 for map-frame steps).

A map built by a teach run (``build-map`` from wheel odometry) lives in its day drive's odometry
frame: the query's true poses are moved into it by the best rigid 2D fit of the map onto the day
drive's survey (``--survey DAY``, default the map's source traverse, whose ``poses.csv`` must list
the map's frames) before any error is computed, and the command says so.
* figures (unless ``--no-figures``): ``error_vs_seq_len.png``, ``error_vs_noise.png``,
  ``error_vs_interpolation.png`` (the paper's Figures 10-12) and ``heatmap_frame<i>.png``
  (Figure 9); ``.pdf`` or ``.svg`` with ``--figure-format``.
"""

from __future__ import annotations

import argparse
import re
import time
from pathlib import Path

from ..figures import add_figure_format_option
from ..io.atomic import check_output_path, output_set
from ..io.traverse import Traverse, load_traverse
from ..localization.evaluation import (
    EVALUATION_METHODS,
    Evaluation,
    EvaluationSettings,
    align_to_map,
    evaluate,
    map_alignment,
    match_traverse,
)
from ..localization.grid_filter import FilterParams
from ..localization.localizer import MAX_SEQ_LEN, LocalizationParams
from ..preparation.params import PreparationParams
from .options import (
    add_bag_options,
    add_camera_option,
    add_params_options,
    add_shift_window_option,
    bag_options,
    check_draw_options,
    filter_params_with_window,
    load_reference,
    parse_noise,
    parse_shift_window,
    read_settings,
)
from .wording import refuse_map_as_traverse


def register(subparsers: argparse._SubParsersAction[argparse.ArgumentParser]) -> None:
    """Adds the sub-command's parser to ``subparsers``."""
    parser = subparsers.add_parser(
        "evaluate",
        help="2D localization errors of a query traverse against a reference (the paper's experiments)",
        description="Localizes every frame of QUERY against REFERENCE for each sequence length, odometry "
        "noise model and interpolation setting, and writes OUT/errors.csv, OUT/summary.csv and figures.",
    )
    parser.add_argument("reference", type=Path, help="reference traverse (folder or bag, with poses) or map file")
    parser.add_argument("query", type=Path, help="query traverse (folder, video or bag) with poses (ground truth)")
    parser.add_argument("--out", type=Path, required=True, help="output folder (created with its parents if missing)")
    parser.add_argument("--seq-lengths", default="1-10", help="sequence lengths, e.g. 1-10 or 1,3,7 (default 1-10)")
    parser.add_argument("--noise-models", default="0,1,2,3", help="Table III noise models (default 0,1,2,3)")
    parser.add_argument("--interpolation", default="on,off", help="on, off or on,off (default on,off)")
    parser.add_argument("--repeats", type=int, default=1, help="noise draws per noise model (default 1)")
    parser.add_argument("--seed", type=int, default=0, help="seed of the noise draws (default 0)")
    parser.add_argument(
        "--method",
        default="paper",
        help="paper (the paper's sequence matching, default), filter (the grid Bayes filter) or paper,filter",
    )
    parser.add_argument(
        "--odometry",
        choices=["map", "robot", "log"],
        default="map",
        help="simulated map-frame displacements (the paper, default), simulated wheel odometry (robot), or the "
        "query's own odometry.csv (log)",
    )
    parser.add_argument(
        "--odometry-noise",
        default=None,
        help="with --odometry log: the odometry noise the filter assumes, a Table III model (0-3), DIST,HEADING "
        "standard deviations per frame in metres and radians, or 'wheel' (4 %% of each step's length, 0.02 rad per "
        "step; default: 'wheel' for wheel odometry (forward,left,turn), 1 for map-frame steps)",
    )
    add_params_options(
        parser, "[localization], [filter] (over a map file's own: build-map --params) and/or [preparation]"
    )
    add_camera_option(
        parser, "The query's camera: it must be the map's (a reference folder is prepared for it; default panoramic)."
    )
    add_shift_window_option(
        parser,
        "the filter's translation window: +-ROWS rows searched in every comparison (a tilting robot) and, for a "
        "forward camera, +-COLUMNS column offsets over which its headings are told apart (default: [filter] "
        "forward_window and row_window: a quarter of the width, 0 rows); a panoramic map takes 0,ROWS",
    )
    parser.add_argument("--heatmap-frames", help="query frames (0-based) for heat-map figures (default: one, chosen)")
    parser.add_argument(
        "--survey",
        type=Path,
        help="a teach-run map (no survey of its own): the day traverse whose poses.csv aligns the map's frame with "
        "the query's (default the map's source traverse)",
    )
    parser.add_argument("--threads", type=int, help="matching threads (default all cores)")
    parser.add_argument("--no-figures", action="store_true", help="do not draw the figures")
    add_figure_format_option(parser)
    add_bag_options(parser)
    parser.set_defaults(run=run)


def parse_int_list(text: str, option: str) -> tuple[int, ...]:
    """``"1-3,7"`` -> ``(1, 2, 3, 7)``; raises ValueError naming ``option``."""
    values: list[int] = []
    for part in str(text).split(","):
        part = part.strip()
        if not part:
            raise ValueError(f"{option}: empty item in {text!r}; write e.g. 1-10 or 1,3,7")
        span = re.fullmatch(r"(\d+)\s*-\s*(\d+)", part)
        if span:
            lo, hi = int(span.group(1)), int(span.group(2))
            if hi < lo:
                raise ValueError(f"{option}: range {part!r} runs backwards; write e.g. 1-10")
            if hi - lo > 10_000:
                raise ValueError(f"{option}: range {part!r} is too long")
            values.extend(range(lo, hi + 1))
            continue
        try:
            values.append(int(part))
        except ValueError:
            raise ValueError(f"{option}: {part!r} is not an integer or a range like 1-10") from None
    return tuple(dict.fromkeys(values))


def parse_interpolation(text: str) -> tuple[bool, ...]:
    """``"on,off"`` -> ``(True, False)``."""
    out = []
    for part in str(text).split(","):
        word = part.strip().lower()
        if word not in ("on", "off"):
            raise ValueError(f"--interpolation: {part!r} must be on or off (e.g. on,off)")
        out.append(word == "on")
    return tuple(dict.fromkeys(out))


def parse_methods(text: str) -> tuple[str, ...]:
    """``"paper,filter"`` -> ``("paper", "filter")``; raises ValueError naming --method."""
    methods = tuple(dict.fromkeys(part.strip().lower() for part in str(text).split(",")))
    bad = [m for m in methods if m not in EVALUATION_METHODS]
    if bad or not methods:
        raise ValueError(f"--method: {bad[0] if bad else text!r} is not paper or filter (e.g. --method paper,filter)")
    return methods


def settings_from_args(args: argparse.Namespace) -> EvaluationSettings:
    """The :class:`EvaluationSettings` of the command-line options (checked)."""
    check_draw_options(args)
    seq_lengths = parse_int_list(args.seq_lengths, "--seq-lengths")
    if min(seq_lengths) < 1 or max(seq_lengths) > MAX_SEQ_LEN:
        raise ValueError(f"--seq-lengths must be in 1..{MAX_SEQ_LEN}, got {min(seq_lengths)}..{max(seq_lengths)}")
    noise_models = parse_int_list(args.noise_models, "--noise-models")
    bad = [m for m in noise_models if m not in (0, 1, 2, 3)]
    if bad:
        raise ValueError(f"--noise-models must be among 0,1,2,3 (the paper's Table III), got {bad[0]}")
    return EvaluationSettings(
        seq_lengths,
        noise_models,
        parse_interpolation(args.interpolation),
        args.repeats,
        args.seed,
        args.odometry,
        parse_methods(args.method),
        None if args.odometry_noise is None else parse_noise(args.odometry_noise),
    )


def _print_results(
    evaluation: Evaluation,
    settings: EvaluationSettings,
    frames: int,
    query: Traverse,
    references: int,
    total_s: float,
    matching_s: float,
) -> None:
    """The run's size and time, then each method's table of distance errors."""
    configs = len(evaluation) // max(frames, 1)
    print(
        f"{frames} query frames of {query.root} against {references} references: "
        f"{configs} configurations in {total_s:.1f} s (matching and preparation {matching_s:.1f} s)"
    )
    if "paper" in settings.methods:
        for interp in settings.interpolation:
            print(f"the paper's method: median distance error (m), interpolation {'on' if interp else 'off'}:")
            print(evaluation.table(interpolation=interp))
    if "filter" in settings.methods:
        first = min(10, frames)
        print(
            f"the Bayes filter beside the paper's method over frames {first} on: median and p95 distance error (m), "
            f"share of frames over 1 m, longest run of them:"
        )
        print(evaluation.compare_table(first_frame=first))


def run(args: argparse.Namespace) -> int:
    """Runs the sub-command; returns the exit status (errors raise, the CLI prints one line)."""
    settings = settings_from_args(args)
    if args.threads is not None and args.threads < 1:
        raise ValueError(f"--threads must be >= 1, got {args.threads}")
    heatmap_frames = (
        None if args.heatmap_frames is None else list(parse_int_list(args.heatmap_frames, "--heatmap-frames"))
    )
    window = parse_shift_window(args.shift_window)
    params = read_settings(args)
    preparation = params.section(PreparationParams)
    inputs = (args.reference, args.query, args.params, args.survey)
    check_output_path(args.out, folder=True, inputs=inputs, parents=True)  # a file in the way fails now
    refuse_map_as_traverse(args.query, "QUERY", "the reference comes first: nightloc evaluate REFERENCE QUERY")
    bag = bag_options(args)
    query = load_traverse(args.query, **bag)  # names, times and poses only
    if query.positions is None:
        raise ValueError(
            f"query {args.query} has no poses: evaluation needs poses.csv with columns image,x,y[,heading]"
        )
    if heatmap_frames is not None and (min(heatmap_frames) < 0 or max(heatmap_frames) >= len(query)):
        raise ValueError(f"--heatmap-frames must be in 0..{len(query) - 1} for {len(query)} query frames")
    # Checked and locked before the work; the files appear together at the end, or not at all.
    with output_set(args.out, command="evaluate", inputs=inputs, parents=True) as out:
        start = time.perf_counter()
        ref_map = load_reference(args.reference, preparation, args.camera, params, bag)
        ref_map.check_frames(query.read(0).shape, f"the query {query.root}", args.camera)
        params.add(f"the map {args.reference}", ref_map.settings, below=True)  # a map file keeps its settings
        localization = params.get(LocalizationParams)
        filter_params = filter_params_with_window(
            params.get(FilterParams), window, ref_map.camera, ref_map.images.shape[1:]
        )
        matches = match_traverse(
            ref_map,
            query,
            threads=args.threads,
            tables="filter" in settings.methods,
            odometry=settings.odometry == "log",
            filter_params=filter_params,
        )
        matching_s = time.perf_counter() - start
        alignment = map_alignment(ref_map, args.survey)
        if alignment is not None:
            matches = align_to_map(matches, alignment[0])
        evaluation = evaluate(ref_map, matches, settings, localization, filter_params=filter_params)
        total_s = time.perf_counter() - start

        written = [
            evaluation.write_errors_csv(out / "errors.csv").name,
            evaluation.write_summary_csv(out / "summary.csv").name,
        ]
        if not args.no_figures:
            from ..figures.evaluation import save_evaluation_figures

            written += [
                p.name
                for p in save_evaluation_figures(
                    evaluation,
                    ref_map,
                    out.path,
                    params=localization,
                    heatmap_frames=heatmap_frames,
                    figure_format=args.figure_format,
                )
            ]

    if alignment is not None:
        print(alignment[1])
    _print_results(evaluation, settings, len(matches.results), query, len(ref_map), total_s, matching_s)
    print(f"wrote {args.out}/" + ", ".join(written))
    return 0
