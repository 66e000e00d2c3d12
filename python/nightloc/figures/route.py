"""Route-mode figures (``nightloc route``).

* :func:`difference_matrix_figure`: the (enhanced) difference matrix with the matches on it;
* :func:`pr_curve_figure`: precision against recall, with recall at 100 % precision and the best
  F1 point marked;
* :func:`correspondence_figure`: the paper's Figure 23, matched reference frame against query
  frame, with the true positives accepted at 100 % precision highlighted;
* :func:`filter_confidence_figure`: the route filter's confidence and off-route probability per
  query frame, correct and wrong matches marked;
* :func:`pr_comparison_figure`: the precision-recall curves of several methods on one plot
  (``nightloc route --method seqslam,filter``).

Each names its data and parameters under the title (:func:`route_caption`: the two traverses,
their sizes, the preset and what was changed from it, the ground truth), returns the matplotlib
:class:`~matplotlib.figure.Figure` and, given ``path``, writes it (PNG, PDF or SVG by the suffix
or ``figure_format``; atomically).
"""

from __future__ import annotations

import dataclasses
import math
import os
from pathlib import Path
from typing import Union

import numpy as np
from matplotlib.figure import Figure

from ..route.evaluation import RouteEvaluation
from ..route.params import PRESETS, RouteParams
from ..route.pipeline import RouteResult
from ..route.preview import matrix_preview
from ._common import figure_path, new_figure, save_figure, styled

__all__ = [
    "correspondence_figure",
    "difference_matrix_figure",
    "filter_confidence_figure",
    "pr_comparison_figure",
    "pr_curve_figure",
    "route_caption",
    "save_route_figures",
]

PathLike = Union[str, "os.PathLike[str]"]


def _changes(params: RouteParams, preset: str) -> list[str]:
    base = PRESETS[preset]
    return [
        f"{f.name}={getattr(params, f.name)}"
        for f in dataclasses.fields(RouteParams)
        if getattr(params, f.name) != getattr(base, f.name)
    ]


def _name(source: str | os.PathLike[str] | None) -> str:
    """A traverse's name: a string as it is, a path by its last two parts (``nordland/summer``)."""
    if source is None:
        return "traverse"
    if isinstance(source, str):
        return source
    parts = Path(os.path.abspath(source)).parts[-2:]
    return "/".join(p for p in parts if p != os.sep)


def route_caption(
    result: RouteResult,
    reference: str | os.PathLike[str] | None = None,
    query: str | os.PathLike[str] | None = None,
    preset: str | None = None,
    ground_truth: str | None = None,
) -> str:
    """What a route figure shows, in two lines: the traverses (names and frame counts), the
    preset with any parameter changed from it, the search (the filter's motion model as it ran,
    with its speeds, and sharpness; or SeqSLAM's ds, speeds and mode) and the ground truth.

    ``reference`` and ``query`` are names, or paths (shown by their last two parts); ``preset``
    defaults to the preset closest to ``result.params`` (fewest fields changed).
    """
    params = result.params
    if preset is None or preset not in PRESETS:
        preset = min(sorted(PRESETS), key=lambda name: len(_changes(params, name)))
    changed = _changes(params, preset)
    data = f"reference {_name(reference)} ({result.n_refs} frames) vs query {_name(query)} ({result.n_queries} frames)"
    setting = f"preset {preset}" + (f" with {', '.join(changed)}" if changed else "")
    if params.method == "filter":
        search = f"route filter, {result.motion_words()}, sharpness {params.filter_sharpness:g}"
    else:
        search = f"SeqSLAM ds {params.effective_ds}, speeds {params.vmin:g}-{params.vmax:g}, {params.mode}"
    lines = [data, f"{setting}; {search}" + (f"; ground truth: {ground_truth}" if ground_truth else "")]
    return "\n".join(lines)


def _titled(fig: Figure, ax, title: str, caption: str | None) -> None:
    fig.suptitle(title)
    if caption:
        ax.set_title(caption, fontsize=8)


@styled
def difference_matrix_figure(
    result: RouteResult,
    evaluation: RouteEvaluation | None = None,
    path: PathLike | None = None,
    enhanced: bool = True,
    caption: str | None = None,
    figure_format: str | None = None,
) -> Figure:
    """The difference matrix (x = query frame, y = reference frame) with the matches.

    Matches are dots at the cell centres ``(query + 0.5, ref + 0.5)``: green where correct, red
    where wrong (white when there is no ground truth). Matrices larger than
    :data:`~nightloc.route.preview.MAX_IMAGE_CELLS` per side are area-averaged for the image
    (:mod:`nightloc.route.preview`; a run on a Dask cluster brings the picture it built band by
    band, ``result.matrix_image``); the dots are exact.

    Args:
        result: a :class:`RouteResult`.
        evaluation: optional ground-truth evaluation for the colours.
        enhanced: draw the contrast-enhanced matrix (else the raw one, if it was kept).
        caption: the data and parameters (default :func:`route_caption` without names).
    """
    matrix = result.enhanced if enhanced or result.difference is None else result.difference
    which = "contrast-enhanced difference matrix" if matrix is result.enhanced else "difference matrix"
    fig, ax = new_figure(8.0, 7.2)
    n_query, n_ref = matrix.shape
    picture = result.matrix_image if matrix is result.enhanced and result.matrix_image is not None else None
    if picture is None:
        picture = matrix_preview(matrix)
    values = picture.T  # rows = references (y), columns = queries (x)
    finite = values[np.isfinite(values)]
    hi = float(np.percentile(finite, 99)) if finite.size else 1.0
    lo = float(finite.min()) if finite.size else 0.0
    image = ax.imshow(
        values,
        extent=(0, n_query, 0, n_ref),
        origin="lower",
        aspect="auto",
        cmap="viridis",
        vmin=lo,
        vmax=max(hi, lo + 1e-6),
        interpolation="nearest",
    )
    fig.colorbar(image, ax=ax, label="difference (lower = more similar)")
    defined = np.flatnonzero(result.refs >= 0)
    x = defined + 0.5
    y = result.refs[defined] + 0.5
    size = 4.0 if len(defined) > 300 else 9.0
    if evaluation is None:
        ax.scatter(x, y, s=size, color="white", linewidths=0, label=f"match ({len(defined)})")
    else:
        good = evaluation.correct[defined]
        ax.scatter(x[good], y[good], s=size, color="lime", linewidths=0, label=f"correct ({int(good.sum())})")
        ax.scatter(x[~good], y[~good], s=size, color="red", linewidths=0, label=f"wrong ({int((~good).sum())})")
    if len(defined):
        ax.legend(loc="upper left", markerscale=2.0)
    ax.set_xlabel("query frame")
    ax.set_ylabel("reference frame")
    ax.set_xlim(0, n_query)
    ax.set_ylim(0, n_ref)
    ax.grid(False)
    _titled(fig, ax, f"Route: {which} and matches", caption if caption is not None else route_caption(result))
    if path is not None:
        save_figure(fig, path, figure_format)
    return fig


@styled
def pr_curve_figure(
    evaluation: RouteEvaluation,
    path: PathLike | None = None,
    caption: str | None = None,
    figure_format: str | None = None,
) -> Figure:
    """Precision (y) against recall (x) over the score threshold, from (recall 0, precision 1)."""
    fig, ax = new_figure(6.4, 5.4)
    curve = evaluation.curve
    if curve.thresholds.size:
        ax.plot(
            np.concatenate([[0.0], curve.recall]),
            np.concatenate([[1.0], curve.precision]),
            color="tab:blue",
            label="precision-recall",
        )
    ax.plot(
        [evaluation.recall_at_100],
        [1.0],
        linestyle="none",
        marker="o",
        color="tab:green",
        label=f"recall at 100% precision: {evaluation.recall_at_100:.3f}",
    )
    ax.plot(
        [evaluation.best_f1_recall],
        [evaluation.best_f1_precision],
        linestyle="none",
        marker="s",
        color="tab:red",
        label=f"best F1 {evaluation.best_f1:.3f} (P {evaluation.best_f1_precision:.3f}, "
        f"R {evaluation.best_f1_recall:.3f})",
    )
    ax.set_xlim(0.0, 1.0)
    ax.set_ylim(0.0, 1.02)
    ax.set_xlabel("recall")
    ax.set_ylabel("precision")
    ax.legend(loc="lower left")
    _titled(fig, ax, "Route: precision-recall", caption)
    if path is not None:
        save_figure(fig, path, figure_format)
    return fig


@styled
def correspondence_figure(
    result: RouteResult,
    evaluation: RouteEvaluation,
    path: PathLike | None = None,
    caption: str | None = None,
    figure_format: str | None = None,
) -> Figure:
    """The paper's Figure 23: frame correspondences between the two traverses.

    Grey dots are every match; blue dots the true positives accepted at 100 % precision (the
    largest score threshold with no false positive); the orange line is the ground truth where it
    is a frame correspondence or a nearest reference.
    """
    fig, ax = new_figure(7.6, 6.4)
    defined = np.flatnonzero(result.refs >= 0)
    ax.scatter(defined, result.refs[defined], s=3, color="lightgrey", linewidths=0, label="all matches")
    threshold = evaluation.threshold_at_100
    if math.isfinite(threshold):
        accepted = defined[(result.scores[defined] <= threshold) & evaluation.correct[defined]]
        label = f"true positives at 100% precision ({len(accepted)})"
        ax.scatter(accepted, result.refs[accepted], s=6, color="tab:blue", linewidths=0, label=label)
    queries, refs = _truth_line(evaluation, result)
    if np.isfinite(refs).any():
        ax.plot(queries, refs, color="tab:orange", linewidth=1, label="ground truth")
    ax.set_xlabel("query frame (second traverse)")
    ax.set_ylabel("reference frame (first traverse)")
    ax.set_xlim(0, result.n_queries)
    ax.set_ylim(0, result.n_refs)
    ax.legend(loc="upper left", markerscale=2.0)
    _titled(fig, ax, "Route: frame correspondences", caption)
    if path is not None:
        save_figure(fig, path, figure_format)
    return fig


def _truth_line(evaluation: RouteEvaluation, result: RouteResult) -> tuple[np.ndarray, np.ndarray]:
    truth = evaluation.true_refs
    queries = np.arange(result.n_queries, dtype=np.float64)
    refs = truth.astype(np.float64)
    refs[truth < 0] = np.nan  # breaks the line
    return queries, refs


def save_route_figures(
    result: RouteResult,
    evaluation: RouteEvaluation | None,
    folder: PathLike,
    figure_format: str = "png",
    reference: str | os.PathLike[str] | None = None,
    query: str | os.PathLike[str] | None = None,
    preset: str | None = None,
    ground_truth: str | None = None,
) -> list[Path]:
    """Writes the figures that apply into ``folder``; returns their paths.

    ``difference_matrix.<fmt>`` always; ``pr_curve.<fmt>`` and ``correspondence.<fmt>`` with
    ground truth; ``filter_confidence.<fmt>`` for the route filter (``fmt`` = ``figure_format``:
    png, pdf or svg). ``reference``, ``query``, ``preset`` and ``ground_truth`` go into each
    figure's caption (:func:`route_caption`).
    """
    caption = route_caption(result, reference, query, preset, ground_truth)
    paths = [figure_path(folder, "difference_matrix", figure_format)]
    difference_matrix_figure(result, evaluation, paths[0], caption=caption, figure_format=figure_format)
    if evaluation is not None:
        paths.append(figure_path(folder, "pr_curve", figure_format))
        pr_curve_figure(evaluation, paths[-1], caption=caption, figure_format=figure_format)
        paths.append(figure_path(folder, "correspondence", figure_format))
        correspondence_figure(result, evaluation, paths[-1], caption=caption, figure_format=figure_format)
    if result.confidence is not None:
        paths.append(figure_path(folder, "filter_confidence", figure_format))
        filter_confidence_figure(result, evaluation, paths[-1], caption=caption, figure_format=figure_format)
    return paths


@styled
def filter_confidence_figure(
    result: RouteResult,
    evaluation: RouteEvaluation | None = None,
    path: PathLike | None = None,
    caption: str | None = None,
    figure_format: str | None = None,
) -> Figure:
    """The route filter's confidence (belief within ``filter_window`` of the match) and off-route
    probability per query frame; with ground truth, correct matches in blue and wrong ones in red,
    and the level above which every match is right (100 % precision) as a dashed line."""
    if result.confidence is None:
        raise ValueError("filter_confidence_figure needs a route filter result (params.method == 'filter')")
    fig, ax = new_figure(12.0, 3.8)
    queries = np.arange(result.n_queries)
    if evaluation is not None:
        good = evaluation.correct
        ax.scatter(
            queries[good],
            result.confidence[good],
            s=4,
            color="tab:blue",
            linewidths=0,
            label=f"confidence, correct match ({int(good.sum())})",
        )
        ax.scatter(
            queries[~good],
            result.confidence[~good],
            s=7,
            color="tab:red",
            linewidths=0,
            label=f"confidence, wrong match ({int((~good).sum())})",
        )
        level = result.confidence_at(evaluation.threshold_at_100)
        if level is not None:
            ax.axhline(
                level,
                color="tab:blue",
                lw=0.8,
                ls="--",
                label=f"100% precision: confidence >= {level:.4f}\n(score = 1 - confidence <= "
                f"{evaluation.threshold_at_100:.4f})",
            )
    else:
        ax.scatter(queries, result.confidence, s=4, color="tab:blue", linewidths=0, label="confidence")
    ax.plot(queries, result.off_route, color="tab:orange", lw=0.8, label="off-route probability")
    ax.set_xlim(0, max(1, result.n_queries))
    ax.set_ylim(-0.02, 1.02)
    ax.set_xlabel("query frame")
    ax.set_ylabel("probability")
    ax.legend(loc="upper left", bbox_to_anchor=(1.01, 1.0), markerscale=2.0)
    _titled(
        fig,
        ax,
        "Route filter: confidence of each match, off-route probability",
        caption if caption is not None else route_caption(result),
    )
    if path is not None:
        save_figure(fig, path, figure_format)
    return fig


@styled
def pr_comparison_figure(
    evaluations: dict,
    path: PathLike | None = None,
    caption: str | None = None,
    figure_format: str | None = None,
) -> Figure:
    """Precision against recall of several methods on the same data (``{name: RouteEvaluation}``),
    each labelled with its best F1 and recall at 100 % precision."""
    fig, ax = new_figure(6.4, 5.4)
    for name, evaluation in evaluations.items():
        curve = evaluation.curve
        ax.plot(
            np.concatenate([[0.0], curve.recall]),
            np.concatenate([[1.0], curve.precision]),
            lw=1.5,
            label=f"{name}: best F1 {evaluation.best_f1:.3f}, R@100P {evaluation.recall_at_100:.3f}",
        )
    ax.set_xlim(0.0, 1.0)
    ax.set_ylim(0.0, 1.02)
    ax.set_xlabel("recall")
    ax.set_ylabel("precision")
    ax.legend(loc="lower left")
    _titled(fig, ax, "Route: precision-recall by method", caption)
    if path is not None:
        save_figure(fig, path, figure_format)
    return fig
