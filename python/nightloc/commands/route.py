"""``nightloc route``: 1D localization of a query traverse along a reference traverse of the same
route, with the route filter (default) or SeqSLAM.

    nightloc route REFERENCE QUERY --out OUT [--method filter|seqslam|seqslam,filter]
                   [--preset openseqslam] [--ds 10] [--vmin 0.8 --vmax 1.2] [--mode centred|causal]
                   [--tolerance 2] [--ground-truth auto|names|frames|positions|none]

REFERENCE and QUERY are traverse folders (``images/`` with an optional ``poses.csv``, or a
folder of images; order = sorted file names) or videos (``--frame-step``). Writes the folder OUT
as one set (:func:`nightloc.io.atomic.output_set`: complete or unchanged; a second run into OUT
at the same time refuses; files in OUT that nightloc did not write are kept):

* ``OUT/matches.csv``: ``query,ref,score,query_image,ref_image`` (0-based positions in the
  traverse order and the frames' names; ``ref`` -1, ``score`` nan and ``ref_image`` empty where a
  query has no match; lower score = more confident), and for the filter ``confidence,off_route``;
* ``OUT/pr.csv``: ``threshold,precision,recall`` when ground truth is available;
* ``OUT/summary.json``: the method and its parameters, the filter's motion model and why
  (``motion_model``, ``motion_model_because``), the preparation, sizes, timings, recall at
  100 % precision with its threshold (``threshold_at_100_precision`` on the score scale named by
  ``score_scale``; for the filter also ``confidence_at_100_precision``, the level the confidence
  figure draws), best F1, the fraction of queries matched correctly at any score, and why there
  is no ground truth when there is none;
* figures ``difference_matrix.png`` and, with ground truth, ``pr_curve.png`` and
  ``correspondence.png`` (the paper's Figure 23), and for the filter ``filter_confidence.png``,
  unless ``--no-figures``; ``--figure-format pdf|svg`` writes them as PDF or SVG instead.

The filter's motion model (``--odometry auto``): when both traverses carry odometry
(``odometry.csv``, a bag's odometry, or poses) it predicts by the distance travelled
(:mod:`nightloc.route.odometry`); otherwise, or with ``--odometry none``, it runs the
parameters' ``filter_motion`` (the speed window or the speed model), and the printed line and
``summary.json`` say which ran and why (e.g. odometry in one traverse only).

Several methods (``--method seqslam,filter``) share the prepared images and the difference
matrix; each writes its set into ``OUT/<method>/``, and ``OUT/summary.json`` holds the
comparison (also printed as a table) with ``OUT/pr_comparison.png``.

A run that can match no query frame (e.g. ``--ds`` longer than the query traverse) fails with
the reason, writing nothing.

Ground truth (``--ground-truth auto``): positions when both traverses have poses (tolerance in
metres, default 3 as in the paper's creek experiment); otherwise, when the two traverses share
distinctive file names (e.g. Nordland's ``images-NNNNN.png``, every 10th frame of one video, in
both seasons), the reference with the query's file name (tolerance in frames, default 2). Names
that are just each frame's position number in both traverses (``000000.png`` ... in two robot
logs) say nothing about the place: then there is no ground truth, and the run says so; pass
``names`` or ``frames`` to use them anyway. ``frames`` pairs query i with reference i.
"""

from __future__ import annotations

import argparse
import csv
import io
import json
import math
import re
import time
from collections.abc import Sequence
from pathlib import Path

import numpy as np

from .._validate import thread_count
from ..config import load_params_file
from ..figures import add_figure_format_option
from ..io.atomic import check_output_path, output_set, write_text
from ..io.traverse import Traverse, load_traverse
from ..preparation.camera import check_frames_fit
from ..preparation.params import PreparationParams
from ..route.evaluation import GroundTruth, RouteEvaluation, evaluate_matches
from ..route.filter import texture_weights
from ..route.odometry import motion_plan
from ..route.params import PRESETS, RouteParams, resolve_params
from ..route.pipeline import RouteResult, match_difference, route_difference_matrix
from ..route.preparation import RoutePreparer
from .options import (
    add_bag_options,
    add_camera_option,
    add_shift_window_option,
    bag_options,
    parse_shift_window,
    preparation_for_camera,
)
from .wording import duration, in_option_words, refuse_map_as_traverse

#: Default tolerances: frames for frame correspondence, metres for positions.
DEFAULT_FRAME_TOLERANCE = 2
DEFAULT_METRE_TOLERANCE = 3.0
#: Largest frame tolerance (a tolerance as long as any traverse makes every match correct).
MAX_FRAME_TOLERANCE = 1_000_000


def register(subparsers: argparse._SubParsersAction[argparse.ArgumentParser]) -> None:
    parser = subparsers.add_parser(
        "route",
        help="1D route localization between two traverses: route filter (default) or SeqSLAM",
        description="Matches every frame of QUERY to a frame of REFERENCE (difference matrix, contrast "
        "enhancement, then the causal route filter or SeqSLAM's trajectory search) and writes OUT/matches.csv, "
        "OUT/pr.csv (with ground truth), OUT/summary.json and figures.",
    )
    parser.add_argument("reference", help="reference traverse: folder, video or ROS bag")
    parser.add_argument("query", help="query traverse: folder, video or ROS bag")
    parser.add_argument("--out", required=True, help="output folder (created with its parents if missing)")
    parser.add_argument(
        "--preset",
        choices=sorted(PRESETS),
        default=None,
        help="parameter preset (default nightloc; openseqslam reproduces OpenSeqSLAM exactly)",
    )
    parser.add_argument(
        "--method",
        help="filter (causal Bayes filter, the nightloc preset's default), seqslam (the openseqslam preset's), "
        "or a comma-separated list such as seqslam,filter to compare them in one run",
    )
    parser.add_argument("--params", help="TOML file with [route] and/or [preparation] tables")
    parser.add_argument("--ds", type=int, help="sequence length in frames (OpenSeqSLAM default 10)")
    parser.add_argument("--vmin", type=float, help="slowest speed, reference frames per query frame (0.8)")
    parser.add_argument("--vmax", type=float, help="fastest speed (1.2)")
    parser.add_argument("--mode", choices=["centred", "causal"], help="centred (OpenSeqSLAM) or causal (online)")
    parser.add_argument(
        "--circular-shifts", action="store_true", default=None, help="360-degree panoramas: search every column shift"
    )
    add_camera_option(parser, "Default forward (--camera panoramic is --circular-shifts).")
    add_shift_window_option(
        parser,
        "viewpoint tolerance: compare each pair at its best alignment within +-COLUMNS columns (forward "
        "cameras) and +-ROWS rows, over the overlap; 0,0 compares one alignment",
    )
    parser.add_argument(
        "--tolerance",
        type=float,
        help=f"ground-truth tolerance: frames (default {DEFAULT_FRAME_TOLERANCE}) or metres "
        f"with positions (default {DEFAULT_METRE_TOLERANCE:g})",
    )
    parser.add_argument(
        "--ground-truth",
        choices=["auto", "names", "frames", "positions", "none"],
        default="auto",
        help="how correct matches are known (default auto)",
    )
    parser.add_argument("--frame-step", type=int, default=1, help="keep every k-th frame of a video (default 1)")
    parser.add_argument(
        "--odometry",
        choices=["auto", "none"],
        default="auto",
        help="auto (default): when both traverses carry odometry (odometry.csv, a bag's odometry, or poses) the "
        "filter predicts by the distance travelled; none: never (the speed model runs)",
    )
    parser.add_argument("--threads", type=int, help="worker threads (default all cores)")
    parser.add_argument("--no-figures", action="store_true", help="do not draw the figures")
    add_figure_format_option(parser)
    add_bag_options(parser)
    parser.set_defaults(run=run)


# --------------------------------------------------------------------------------------------
# parameters


def methods_from_args(args: argparse.Namespace, params: RouteParams) -> list:
    """The methods to run: ``--method`` (comma-separated, each once) or the parameters' own."""
    if args.method is None:
        return [params.method]
    methods = [name.strip() for name in str(args.method).split(",")]
    for name in methods:
        if name not in ("filter", "seqslam"):
            raise ValueError(f"--method {args.method!r}: unknown method {name!r}; choose filter, seqslam or both")
    if len(set(methods)) != len(methods):
        raise ValueError(f"--method {args.method!r} names a method twice")
    return methods


def route_params_from_args(args: argparse.Namespace) -> tuple:
    """(RouteParams, PreparationParams or None) from --params, --preset and the overrides."""
    route_params: RouteParams | None = None
    preparation: PreparationParams | None = None
    if args.params:
        tables = load_params_file(args.params)
        route_params = tables.get("route")
        preparation = tables.get("preparation")
    if args.camera is not None:
        if args.circular_shifts and args.camera == "forward":
            raise ValueError("--circular-shifts (a panoramic camera's search) contradicts --camera forward")
        args.circular_shifts = args.camera == "panoramic"
        preparation = preparation_for_camera(preparation, args.camera, args.params)
    if args.preset is not None:
        if route_params is not None:
            raise ValueError(f"give --preset or a [route] table in {args.params}, not both")
        route_params = PRESETS[args.preset]
    params = resolve_params(
        route_params,
        ds=args.ds,
        vmin=args.vmin,
        vmax=args.vmax,
        mode=args.mode,
        circular_shifts=args.circular_shifts,
        shift_window=parse_shift_window(args.shift_window),
    )
    return params, preparation


# --------------------------------------------------------------------------------------------
# ground truth


def ground_truth_for(kind: str, reference: Traverse, query: Traverse, tolerance: float | None) -> tuple:
    """(GroundTruth or None, the kind used, why there is none or "") for the two traverses.

    ``auto``: positions when both traverses have poses; names when the two traverses share file
    names that are *distinctive* (:func:`names_are_positional`: not merely each frame's position
    number in both); otherwise none, with the reason.
    """
    same_names = _name_correspondence(reference, query)
    if kind == "auto":
        if reference.has_poses and query.has_poses:
            kind = "positions"
        elif same_names is None or not (same_names >= 0).any():
            return None, "none", "the traverses share no file names and have no poses"
        elif names_are_positional(reference.names) and names_are_positional(query.names):
            return (
                None,
                "none",
                (
                    f"both traverses name their frames by position ({query.names[0]}, {query.names[-1]}, ...), "
                    f"which says nothing about where they were taken; pass --ground-truth names or frames if "
                    f"frame i of one is frame i of the other, or add poses.csv"
                ),
            )
        else:
            kind = "names"
    if kind == "none":
        return None, "none", "--ground-truth none"
    if kind == "positions":
        if reference.positions is None or query.positions is None:
            raise ValueError("--ground-truth positions needs poses in both traverses (poses.csv or a video's CSV)")
        metres = DEFAULT_METRE_TOLERANCE if tolerance is None else tolerance
        return GroundTruth.from_positions(query.positions, reference.positions, metres), "positions", ""
    frames = DEFAULT_FRAME_TOLERANCE if tolerance is None else tolerance
    if not math.isfinite(frames) or float(frames) != int(frames) or not 0 <= frames <= MAX_FRAME_TOLERANCE:
        raise ValueError(
            f"--tolerance must be a whole number of frames in 0..{MAX_FRAME_TOLERANCE} for frame ground truth, "
            f"got {frames}"
        )
    if kind == "names":
        if same_names is None or not (same_names >= 0).any():
            raise ValueError("--ground-truth names: no query frame has the file name of a reference frame")
        return GroundTruth.from_frames(len(query), len(reference), int(frames), same_names), "names", ""
    return GroundTruth.from_frames(len(query), len(reference), int(frames)), "frames", ""


_LAST_NUMBER = re.compile(r"(\d+)(?!.*\d)")


def names_are_positional(names: Sequence[str]) -> bool:
    """True when every name's last number is its frame's position in the list, counted from 0
    or from 1 (``000000.png``, ``frame0001.jpg``, ``Image000.jpg`` ...): such names number the
    frames of any log alike and say nothing about the place. Nordland's ``images-00010.png``
    (every 10th frame of one video) is not positional."""
    for start in (0, 1):
        ok = True
        for index, name in enumerate(names):
            found = _LAST_NUMBER.search(Path(name).stem)
            if found is None or int(found.group(1)) != index + start:
                ok = False
                break
        if ok:
            return True
    return False


def _name_correspondence(reference: Traverse, query: Traverse) -> np.ndarray | None:
    if reference.is_video or query.is_video:
        return None
    index = {Path(name).name: i for i, name in enumerate(reference.names)}
    return np.array([index.get(Path(name).name, -1) for name in query.names], dtype=np.int64)


# --------------------------------------------------------------------------------------------
# output files


def _number(value: float) -> str:
    return "nan" if math.isnan(value) else repr(float(value))


def matches_csv(
    result: RouteResult,
    query_names: Sequence[str],
    ref_names: Sequence[str],
    query_times: Sequence[float] | np.ndarray | None = None,
) -> str:
    """``query,ref,score,query_image,ref_image`` rows (and ``confidence,off_route`` for the
    filter), then ``timestamp``, the query frame's time in seconds (``nan`` when the traverse
    carries none): ``ref`` -1, ``score`` nan and ``ref_image`` empty where a query has no match
    (so ``numpy.loadtxt(..., usecols=(0, 1, 2))`` reads the numbers)."""
    buffer = io.StringIO()
    writer = csv.writer(buffer, lineterminator="\n")
    confidence, off_route = result.confidence, result.off_route
    filtered = confidence is not None and off_route is not None
    writer.writerow(
        [
            "query",
            "ref",
            "score",
            "query_image",
            "ref_image",
            *(["confidence", "off_route"] if filtered else []),
            "timestamp",
        ]
    )
    for q in range(result.n_queries):
        ref = int(result.refs[q])
        matched = ref >= 0
        row: list = [
            q,
            ref if matched else -1,
            _number(result.scores[q]) if matched else "nan",
            query_names[q],
            ref_names[ref] if matched else "",
        ]
        if confidence is not None and off_route is not None:
            row += [_number(confidence[q]), _number(off_route[q])]
        row.append("nan" if query_times is None else _number(query_times[q]))
        writer.writerow(row)
    return buffer.getvalue()


def pr_csv(evaluation: RouteEvaluation) -> str:
    """``threshold,precision,recall`` rows, thresholds ascending."""
    buffer = io.StringIO()
    writer = csv.writer(buffer, lineterminator="\n")
    writer.writerow(["threshold", "precision", "recall"])
    curve = evaluation.curve
    for t, p, r in zip(curve.thresholds, curve.precision, curve.recall):
        writer.writerow([repr(float(t)), repr(float(p)), repr(float(r))])
    return buffer.getvalue()


# --------------------------------------------------------------------------------------------


def _check_can_match(p: RouteParams, n_refs: int, n_queries: int) -> None:
    """Fails before the work when a traverse is too short for the method to match anything."""
    if n_refs < 2:
        raise ValueError(f"the reference traverse has {n_refs} frame; route matching needs at least 2")
    if p.method != "seqslam":
        return  # the filter answers from the first frame on
    ds = p.effective_ds
    needed = ds + 1 if p.mode == "centred" else ds
    if n_queries < needed:
        raise ValueError(
            f"the query traverse has {n_queries} frames, but a {p.mode} sequence of --ds {p.ds} needs at "
            f"least {needed} to match any frame; shorten --ds (or use a longer traverse, or --method filter)"
        )
    needed = 2 * p.uniqueness_radius + 2
    if n_refs < needed:
        raise ValueError(
            f"the reference route has {n_refs} frames; SeqSLAM's uniqueness window of +-{p.uniqueness_radius} "
            f"needs at least {needed} (or use --method filter)"
        )


#: Route parameters that are options of the command (their names in errors become --ds, ...).
_OPTIONS = ("threads", "ds", "vmin", "vmax", "mode")


def run(args: argparse.Namespace) -> int:
    if args.frame_step < 1:
        raise ValueError(f"--frame-step must be >= 1, got {args.frame_step}")
    if args.tolerance is not None and not (math.isfinite(args.tolerance) and args.tolerance >= 0):
        raise ValueError(f"--tolerance must be a finite number >= 0, got {args.tolerance}")
    try:
        thread_count(args.threads)
        params, preparation = route_params_from_args(args)
        methods = methods_from_args(args, params)
        per_method = [resolve_params(params, method=method) for method in methods]
    except ValueError as error:  # raised by the parameter classes in their field names
        if args.params is not None and str(error).startswith(str(args.params)):
            raise  # about the file's keys, in its words
        raise in_option_words(error, _OPTIONS) from None
    inputs = (args.reference, args.query, args.params)
    check_output_path(args.out, folder=True, inputs=inputs, parents=True)  # a file in the way fails now
    usage = "nightloc route compares two traverses: nightloc route REFERENCE QUERY --out OUT"
    refuse_map_as_traverse(args.reference, "REFERENCE", usage)
    refuse_map_as_traverse(args.query, "QUERY", usage)
    bag = bag_options(args)
    reference = load_traverse(args.reference, frame_step=args.frame_step, **bag)  # names, times and poses only
    query = load_traverse(args.query, frame_step=args.frame_step, **bag)
    reference_shape = reference.read(0).shape
    check_frames_fit(
        query.read(0).shape,
        (reference_shape[1], reference_shape[0]),
        "panoramic" if params.circular_shifts else "forward",
        f"the query {query.root}",
        f"the reference {reference.root}",
        args.camera,
        remedy="route mode matches two traverses of one camera",
        exact_size=False,
    )
    truth, truth_kind, no_truth = ground_truth_for(args.ground_truth, reference, query, args.tolerance)
    for p in per_method:
        _check_can_match(p, len(reference), len(query))
    plan = motion_plan(reference, query, params.filter_motion, args.odometry == "auto") if "filter" in methods else None

    # Checked and locked before the work; the files appear together at the end, or not at all.
    with output_set(args.out, command="route", inputs=inputs, parents=True) as out:
        preparer = RoutePreparer(params, preparation)
        start = time.perf_counter()
        refs = preparer(reference)
        queries = preparer(query)
        preparation_s = time.perf_counter() - start
        start = time.perf_counter()
        difference = route_difference_matrix(queries, refs, params, threads=args.threads)
        difference_s = time.perf_counter() - start
        weights = texture_weights(queries, params.filter_min_texture) if "filter" in methods else None

        summaries = {}
        evaluations = {}
        for index, p in enumerate(per_method):
            last = index == len(per_method) - 1
            used = plan if p.method == "filter" else None
            result = match_difference(
                difference,
                p,
                args.threads,
                keep_difference=not last,
                weights=weights if p.method == "filter" else None,
                advances=None if used is None else used.advances,
                reference_distances=None if used is None else used.reference_distances,
            )
            if used is not None:
                result.motion_note = used.note
            result.timings = {"preparation": preparation_s, "difference": difference_s, **result.timings}
            if not result.defined.any():
                raise ValueError(
                    f"no query frame could be matched by {p.method} ({result.n_queries} queries, {result.n_refs} "
                    f"references, {p.mode} sequences of ds {p.effective_ds}, speeds {p.vmin:g}..{p.vmax:g}): every "
                    f"trajectory left the reference traverse or had no defined score; shorten --ds or widen the speeds"
                )
            folder = out.path if len(methods) == 1 else out.path / p.method
            evaluation = evaluate_matches(result.refs, result.scores, truth) if truth is not None else None
            evaluations[p.method] = (result, evaluation)
            summaries[p.method] = _write_method(
                folder, result, evaluation, args, reference, query, preparer, truth, truth_kind, no_truth
            )
        if len(methods) > 1:
            comparison_figures = _write_comparison(out.path, summaries, evaluations, args, truth)

    for method, (result, evaluation) in evaluations.items():
        folder = Path(args.out) if len(methods) == 1 else Path(args.out) / method
        _print_method(result, evaluation, truth, truth_kind, no_truth, folder, summaries[method]["figures"])
    if len(methods) > 1:
        _print_comparison(Path(args.out), summaries, comparison_figures)
    return 0


def _write_method(
    folder: Path, result: RouteResult, evaluation, args, reference, query, preparer, truth, truth_kind, no_truth
) -> dict:
    """Writes one method's files into ``folder`` (inside the output set); returns its summary."""
    folder.mkdir(exist_ok=True)
    write_text(folder / "matches.csv", matches_csv(result, query.names, reference.names, query.timestamps), newline="")
    if evaluation is not None:
        write_text(folder / "pr.csv", pr_csv(evaluation), newline="")
    figures = []
    if not args.no_figures:
        from ..figures.route import save_route_figures

        truth_text = None
        if truth is not None:
            truth_text = f"{truth_kind}, ±{truth.tolerance:g} {'m' if truth.kind == 'positions' else 'frames'}"
        saved = save_route_figures(
            result,
            evaluation,
            folder,
            args.figure_format,
            reference=reference.root,
            query=query.root,
            preset=args.preset,
            ground_truth=truth_text,
        )
        figures = [p.name for p in saved]
    p = result.params
    summary = {
        "method": p.method,
        "reference": str(reference.root),
        "query": str(query.root),
        "n_refs": result.n_refs,
        "n_queries": result.n_queries,
        "n_matched": int(result.defined.sum()),
        "method_params": p.method_params(),  # the settings this method uses (no other method's)
        "motion_model": result.motion,
        "motion_model_because": result.motion_note or None,
        "preparation": None
        if preparer.preparation is None
        else {field: getattr(preparer.preparation, field) for field in preparer.preparation.__dataclass_fields__},
        "timings_s": {key: round(value, 4) for key, value in result.timings.items()},
        "ground_truth": truth_kind,
        "no_ground_truth_because": no_truth or None,
        "tolerance": None if truth is None else truth.tolerance,
        "figures": figures,
    }
    if evaluation is not None:
        summary.update(route_metrics(result, evaluation))
    write_text(folder / "summary.json", json.dumps(summary, indent=1, default=_json_default) + "\n")
    return summary


def route_metrics(result: RouteResult, evaluation: RouteEvaluation) -> dict:
    """summary.json's precision-recall figures. Thresholds are on the score scale (a match is
    accepted when its score is at most the threshold; the filter's score is ``1 - confidence``);
    ``confidence_at_100_precision`` is the same threshold on the filter's confidence scale
    (:meth:`RouteResult.confidence_at`, as the confidence figure draws it; None for SeqSLAM)."""
    positives = int(evaluation.positives.sum())
    return {
        "recall_at_100_precision": evaluation.recall_at_100,
        "score_scale": "1 - confidence" if result.method == "filter" else "uniqueness ratio",
        "threshold_at_100_precision": _finite_or_none(evaluation.threshold_at_100),
        "confidence_at_100_precision": result.confidence_at(evaluation.threshold_at_100),
        "best_f1": evaluation.best_f1,
        "best_f1_precision": evaluation.best_f1_precision,
        "best_f1_recall": evaluation.best_f1_recall,
        "best_f1_threshold": _finite_or_none(evaluation.best_f1_threshold),
        "correct_any_score": int(evaluation.correct.sum()) / positives if positives else None,
    }


def _print_method(result: RouteResult, evaluation, truth, truth_kind, no_truth, folder: Path, figures: list) -> None:
    p = result.params
    compute = sum(result.timings[k] for k in ("difference", "enhancement", "search"))
    how = (
        f"filter, {_motion_words(result)}, sharpness {p.filter_sharpness:g}"
        if p.method == "filter"
        else f"seqslam {p.mode}, ds {p.effective_ds}"
    )
    print(
        f"{result.n_queries} query frames against {result.n_refs} reference frames: {int(result.defined.sum())} "
        f"matched ({how}); matching {duration(compute)} (search {duration(result.timings['search'])}), "
        f"reading and preparing {duration(result.timings['preparation'])}"
    )
    if evaluation is not None:
        unit = "m" if truth.kind == "positions" else "frames"
        print(f"ground truth from {truth_kind} (+-{truth.tolerance:g} {unit}): {evaluation.summary()}")
    else:
        print(f"no ground truth ({no_truth}): pr.csv not written")
    print(
        f"wrote {folder}/matches.csv"
        + (", pr.csv" if evaluation is not None else "")
        + ", summary.json"
        + ("".join(f", {name}" for name in figures))
    )


def _motion_words(result: RouteResult) -> str:
    """The filter's motion model for the printed line, with the reason when odometry was not used."""
    words = result.motion_words()
    if result.motion == "odometry":
        return f"{words} ({result.motion_note})"
    if result.motion_note and "neither" not in result.motion_note:
        return f"{words}: {result.motion_note}"
    return words


def _write_comparison(out: Path, summaries: dict, evaluations: dict, args, truth) -> list:
    """``out/summary.json`` with every method's results and ``out/pr_comparison.<format>``;
    returns the figure names."""
    figures = []
    if truth is not None and not args.no_figures:
        from ..figures.route import pr_comparison_figure

        name = f"pr_comparison.{args.figure_format}"
        pr_comparison_figure(
            {method: evaluation for method, (_, evaluation) in evaluations.items()},
            out / name,
            figure_format=args.figure_format,
        )
        figures.append(name)
    comparison = {
        "methods": list(summaries),
        "figures": figures,
        "results": {
            method: {
                "folder": method,
                **{key: summary.get(key) for key in _COMPARED},
                "search_s": summary["timings_s"].get("search"),
                "method_params": summary["method_params"],
            }
            for method, summary in summaries.items()
        },
    }
    write_text(out / "summary.json", json.dumps(comparison, indent=1, default=_json_default) + "\n")
    return figures


_COMPARED = ("best_f1", "recall_at_100_precision", "correct_any_score")


def _print_comparison(out: Path, summaries: dict, figures: list) -> None:
    print()
    print(f"{'method':<10} {'best F1':>8} {'R@100P':>8} {'correct':>8} {'search s':>9}")
    for method, summary in summaries.items():
        cells = [summary.get(key) for key in _COMPARED]
        text = " ".join(f"{'-' if v is None else format(v, '.3f'):>8}" for v in cells)
        print(f"{method:<10} {text} {summary['timings_s'].get('search', float('nan')):>9.3f}")
    print(f"wrote {out}/summary.json" + "".join(f", {name}" for name in figures))


def _finite_or_none(value: float) -> float | None:
    return float(value) if math.isfinite(value) else None


def _json_default(value: object) -> object:
    if isinstance(value, (np.integer, np.floating)):
        return value.item()
    return str(value)
