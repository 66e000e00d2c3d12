"""``nightloc route``: 1D localization of a query traverse along a reference traverse of the same
route, with the route filter (default) or SeqSLAM.

    nightloc route REFERENCE QUERY --out OUT [--method filter|seqslam|seqslam,filter]
                   [--preset openseqslam] [--ds 10] [--vmin 0.8 --vmax 1.2] [--mode centred|causal]
                   [--motion MODEL]
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

The filter's motion model: ``--motion NAME`` names the one that runs (a name of
:data:`nightloc.route.params.MOTION_MODELS`; a model that moves by the distance travelled,
:data:`~nightloc.route.params.DISTANCE_MOTIONS`, needs odometry in both traverses). Without it
(``--odometry auto``): when both traverses carry odometry (``odometry.csv``, a bag's odometry, or
poses) the filter predicts by the distance travelled
(:mod:`nightloc.route.odometry`); otherwise, or with ``--odometry none``, it runs the
parameters' ``filter_motion`` (TOML ``[route] filter_motion``, default the speed model). The
printed line and ``summary.json`` say which ran and why (e.g. odometry in one traverse only).

``--dask SCHEDULER`` (an address such as ``tcp://10.0.0.5:8786``, or ``local`` for a
``LocalCluster`` of worker processes on loopback) computes the difference matrix on a Dask
cluster in bands of query rows (:func:`nightloc.route.dask_backend.dask_stream_match`): the
filter receives the enhanced bands in order, SeqSLAM searches each band on its worker, and no
process holds the whole matrix; the outputs are those of the run without it (the figure of the
matrix is built band by band). The workers need nightloc installed. Without dask it fails in one
line naming ``pip install "nightloc[dask]"``.

Several methods (``--method seqslam,filter``) share the prepared images and the difference
matrix (with ``--dask`` each method computes its own bands); each writes its set into
``OUT/<method>/``, and ``OUT/summary.json`` holds the
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
import contextlib
import math
import time
from pathlib import Path

from .._validate import thread_count
from ..errors import NightlocError
from ..figures import add_figure_format_option
from ..io.atomic import check_output_path, output_set, write_text
from ..io.route_csv import matches_csv, pr_csv
from ..io.traverse import Traverse, load_traverse
from ..preparation.camera import check_frames_fit
from ..preparation.params import PreparationParams
from ..route.dask_backend import dask_stream_match, local_client, require_distributed
from ..route.evaluation import evaluate_matches
from ..route.filter import texture_weights
from ..route.ground_truth import (
    DEFAULT_FRAME_TOLERANCE,
    DEFAULT_METRE_TOLERANCE,
    GROUND_TRUTH_KINDS,
    ground_truth_for,
)
from ..route.odometry import carried_odometry, motion_plan
from ..route.params import DISTANCE_MOTIONS, MOTION_MODELS, PRESETS, RouteParams, resolve_params
from ..route.pipeline import RouteResult, match_difference, route_difference_matrix
from ..route.preparation import RoutePreparer
from ..route.report import COMPARED, comparison_summary, method_summary, motion_line, summary_json
from .options import (
    add_bag_options,
    add_camera_option,
    add_params_options,
    add_shift_window_option,
    bag_options,
    parse_shift_window,
    preparation_for_camera,
    read_settings,
)
from .wording import duration, in_option_words, refuse_map_as_traverse


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
    add_params_options(parser, "[route] and/or [preparation] tables")
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
        choices=GROUND_TRUTH_KINDS,
        default="auto",
        help="how correct matches are known (default auto)",
    )
    parser.add_argument("--frame-step", type=int, default=1, help="keep every k-th frame of a video (default 1)")
    parser.add_argument(
        "--motion",
        type=motion_model,
        metavar="{" + ",".join(MOTION_MODELS) + "}",
        help="the filter's motion model: "
        + ", ".join(MOTION_MODELS)
        + f" ({', '.join(sorted(DISTANCE_MOTIONS))}: by the distance travelled, which needs odometry in both "
        "traverses); default: that when both traverses carry odometry, else the parameters' filter_motion",
    )
    parser.add_argument(
        "--odometry",
        choices=["auto", "none"],
        help="auto (default): when both traverses carry odometry (odometry.csv, a bag's odometry, or poses) the "
        "filter predicts by the distance travelled; none: never (the parameters' filter_motion runs)",
    )
    parser.add_argument("--threads", type=int, help="worker threads (default all cores)")
    parser.add_argument(
        "--dask",
        metavar="SCHEDULER",
        help="compute the difference matrix on a Dask cluster: the scheduler's address (tcp://HOST:8786) or local (a "
        "LocalCluster of worker processes on this machine's loopback, one per --threads); bands of query rows stream "
        'to the search, so memory is bounded by bands, not by the matrix (pip install "nightloc[dask]")',
    )
    parser.add_argument("--no-figures", action="store_true", help="do not draw the figures")
    add_figure_format_option(parser)
    add_bag_options(parser)
    parser.set_defaults(run=run)


# --------------------------------------------------------------------------------------------
# parameters


def motion_model(name: str) -> str:
    """``--motion``'s value: one of :data:`MOTION_MODELS`, else an error naming them."""
    if name not in MOTION_MODELS:
        raise argparse.ArgumentTypeError(f"unknown motion model {name!r}; choose one of {', '.join(MOTION_MODELS)}")
    return name


def uses_odometry(args: argparse.Namespace) -> bool:
    """Whether the filter may run its odometry model: ``--motion`` names the model that runs
    (odometry or not); without it, ``--odometry`` (auto: when both traverses carry odometry)."""
    if args.motion is None:
        return args.odometry != "none"
    wanted = args.motion in DISTANCE_MOTIONS
    if args.odometry is not None and (args.odometry == "auto") != wanted:
        raise ValueError(
            f"--motion {args.motion} contradicts --odometry {args.odometry}; give --motion alone (it names the model "
            "that runs)"
        )
    return wanted


def option_name(field: str) -> str:
    """How the command sets a :class:`RouteParams` field: its option (``--vmin``, ``--motion``),
    else the field itself (a key of the ``--params`` file's ``[route]`` table)."""
    options = {"filter_motion": "--motion", "vmin": "--vmin", "vmax": "--vmax", "ds": "--ds", "mode": "--mode"}
    return options.get(field, field)


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
    settings = read_settings(args)
    route_params = settings.section(RouteParams)
    preparation = settings.section(PreparationParams)
    if args.camera is not None:
        if args.circular_shifts and args.camera == "forward":
            raise ValueError("--circular-shifts (a panoramic camera's search) contradicts --camera forward")
        args.circular_shifts = args.camera == "panoramic"
        preparation = preparation_for_camera(preparation, args.camera, settings)
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
        filter_motion=args.motion,
    )
    return params, preparation


# --------------------------------------------------------------------------------------------
# the Dask cluster


def require_cluster(scheduler: str) -> None:
    """Fails before the work when ``--dask`` cannot run: dask.distributed missing (one line naming
    the install command) or an empty address."""
    if not scheduler.strip():
        raise ValueError("--dask needs a scheduler address (tcp://HOST:8786) or local")
    require_distributed()


@contextlib.contextmanager
def cluster_client(scheduler: str, threads: int | None):
    """A client of the scheduler ``--dask`` names (``local``: a LocalCluster of ``threads`` worker
    processes on loopback, one thread each), closed on exit."""
    if scheduler == "local":
        with local_client(thread_count(threads)) as client:
            yield client
        return
    distributed = require_distributed()
    with distributed.Client(scheduler, timeout=20) as client:
        yield client


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


def _checked_params(args: argparse.Namespace) -> tuple[RouteParams, PreparationParams | None, list, list[RouteParams]]:
    """The route and preparation parameters, the methods and each method's parameters, checked
    (errors in the options' words)."""
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
        if isinstance(error, NightlocError):
            raise  # about the keys of --params or --set, in their words
        raise in_option_words(error, _OPTIONS) from None
    return params, preparation, methods, per_method


def _load_traverses(args: argparse.Namespace, params: RouteParams) -> tuple[Traverse, Traverse]:
    """The reference and query traverses (names, times and poses; frames read when prepared),
    checked to come from one camera."""
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
    return reference, query


def _check_defined(result: RouteResult, p: RouteParams) -> None:
    """A ValueError when no query frame could be matched (every trajectory left the references)."""
    if not result.defined.any():
        raise ValueError(
            f"no query frame could be matched by {p.method} ({result.n_queries} queries, {result.n_refs} "
            f"references, {p.mode} sequences of ds {p.effective_ds}, speeds {p.vmin:g}..{p.vmax:g}): every "
            f"trajectory left the reference traverse or had no defined score; shorten --ds or widen the speeds"
        )


def run(args: argparse.Namespace) -> int:
    """Runs the sub-command; returns the exit status (errors raise, the CLI prints one line)."""
    params, preparation, methods, per_method = _checked_params(args)
    if args.dask is not None:
        require_cluster(args.dask)
    inputs = (args.reference, args.query, args.params)
    check_output_path(args.out, folder=True, inputs=inputs, parents=True)  # a file in the way fails now
    reference, query = _load_traverses(args, params)
    truth, truth_kind, no_truth = ground_truth_for(args.ground_truth, reference, query, args.tolerance)
    for p in per_method:
        _check_can_match(p, len(reference), len(query))
    plan = motion_plan(reference, query, params.filter_motion, uses_odometry(args)) if "filter" in methods else None
    carried = carried_odometry(reference, query)  # for the speed check, used by the search or not

    # Checked and locked before the work; the files appear together at the end, or not at all.
    with contextlib.ExitStack() as stack:
        client = None if args.dask is None else stack.enter_context(cluster_client(args.dask, args.threads))
        out = stack.enter_context(output_set(args.out, command="route", inputs=inputs, parents=True))
        preparer = RoutePreparer(params, preparation)
        start = time.perf_counter()
        refs = preparer(reference)
        queries = preparer(query)
        preparation_s = time.perf_counter() - start
        if client is None:
            start = time.perf_counter()
            difference = route_difference_matrix(queries, refs, params, threads=args.threads)
            difference_s = time.perf_counter() - start
            weights = texture_weights(queries, params.filter_min_texture) if "filter" in methods else None

        summaries = {}
        evaluations = {}
        for index, p in enumerate(per_method):
            last = index == len(per_method) - 1
            used = plan if p.method == "filter" else None
            advances = None if used is None else used.advances
            distances = None if used is None else used.reference_distances
            if client is not None:
                result = dask_stream_match(
                    client,
                    refs,
                    queries,
                    p,
                    advances=advances,
                    reference_distances=distances,
                    carried_odometry=carried,
                )
                result.timings = {"preparation": preparation_s, "matching": result.timings["total"]}
            else:
                result = match_difference(
                    difference,
                    p,
                    args.threads,
                    keep_difference=not last,
                    weights=weights if p.method == "filter" else None,
                    advances=advances,
                    reference_distances=distances,
                    carried_odometry=carried,
                )
                result.timings = {"preparation": preparation_s, "difference": difference_s, **result.timings}
            if used is not None:
                result.motion_note = used.note
            _check_defined(result, p)
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
    matches = matches_csv(
        result.refs,
        result.scores,
        query.names,
        reference.names,
        result.confidence,
        result.off_route,
        query.timestamps,
    )
    write_text(folder / "matches.csv", matches, newline="")
    if evaluation is not None:
        curve = evaluation.curve
        write_text(folder / "pr.csv", pr_csv(curve.thresholds, curve.precision, curve.recall), newline="")
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
    summary = method_summary(
        result, evaluation, reference.root, query.root, preparer.preparation, truth, truth_kind, no_truth, figures
    )
    write_text(folder / "summary.json", summary_json(summary))
    return summary


def _print_method(result: RouteResult, evaluation, truth, truth_kind, no_truth, folder: Path, figures: list) -> None:
    p = result.params
    timings = result.timings
    stages = ("difference", "enhancement", "search", "speed_check")
    compute = timings.get("matching", sum(timings.get(k, 0.0) for k in stages))
    search = f" (search {duration(timings['search'])})" if "search" in timings else " (on the Dask cluster)"
    how = (
        f"filter, {motion_line(result)}, sharpness {p.filter_sharpness:g}"
        if p.method == "filter"
        else f"seqslam {p.mode}, ds {p.effective_ds}"
    )
    print(
        f"{result.n_queries} query frames against {result.n_refs} reference frames: {int(result.defined.sum())} "
        f"matched ({how}); matching {duration(compute)}{search}, "
        f"reading and preparing {duration(timings['preparation'])}"
    )
    if evaluation is not None:
        unit = "m" if truth.kind == "positions" else "frames"
        print(f"ground truth from {truth_kind} (+-{truth.tolerance:g} {unit}): {evaluation.summary()}")
    else:
        print(f"no ground truth ({no_truth}): pr.csv not written")
    if result.speed_check is not None and not result.speed_check.fits:
        print(f"warning: {result.speed_check.message(option_name)}")
    print(
        f"wrote {folder}/matches.csv"
        + (", pr.csv" if evaluation is not None else "")
        + ", summary.json"
        + ("".join(f", {name}" for name in figures))
    )


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
    write_text(out / "summary.json", summary_json(comparison_summary(summaries, figures)))
    return figures


def _print_comparison(out: Path, summaries: dict, figures: list) -> None:
    print()
    print(f"{'method':<10} {'best F1':>8} {'R@100P':>8} {'correct':>8} {'search s':>9}")
    for method, summary in summaries.items():
        cells = [summary.get(key) for key in COMPARED]
        text = " ".join(f"{'-' if v is None else format(v, '.3f'):>8}" for v in cells)
        print(f"{method:<10} {text} {summary['timings_s'].get('search', float('nan')):>9.3f}")
    print(f"wrote {out}/summary.json" + "".join(f", {name}" for name in figures))
