"""Route-mode figures.

Drawn with :mod:`nightloc.figures.plotting` (OpenCV):

* :func:`difference_matrix_figure`: the (enhanced) difference matrix with the matches on it;
* :func:`pr_curve_figure`: precision against recall, with recall at 100 % precision and the best
  F1 point marked;
* :func:`correspondence_figure`: the paper's Figure 23, matched reference frame against query
  frame, with the true positives accepted at 100 % precision highlighted.

Drawn with matplotlib (Agg backend, imported when called; ImportError when it is missing):

* :func:`filter_confidence_figure`: the route filter's confidence and off-route probability per
  query frame, correct and wrong matches marked;
* :func:`pr_comparison_figure`: the precision-recall curves of several methods on one plot.

Each function returns the :class:`~nightloc.figures.plotting.Figure`; ``path`` saves it as a PNG
(atomically).
"""

from __future__ import annotations

import math
import os
from typing import Union

import cv2
import numpy as np

from ..route.evaluation import RouteEvaluation
from ..route.pipeline import RouteResult

__all__ = [
    "correspondence_figure",
    "difference_matrix_figure",
    "filter_confidence_figure",
    "pr_comparison_figure",
    "pr_curve_figure",
    "save_route_figures",
]

PathLike = Union[str, "os.PathLike[str]"]

#: Largest side, in cells, of the matrix image drawn (bigger matrices are area-averaged).
MAX_IMAGE_CELLS = 900


def _figure(width: int, height: int, title: str):
    from .plotting import Figure  # deferred: figures are optional output

    return Figure(width=width, height=height, title=title)


def _reduced(matrix: np.ndarray, limit: int = MAX_IMAGE_CELLS) -> np.ndarray:
    """``matrix`` area-averaged to at most ``limit`` cells per side (NaN and inf replaced by the
    finite maximum first, so one bad cell does not blank its neighbourhood)."""
    values = np.asarray(matrix, dtype=np.float32)
    finite = np.isfinite(values)
    if not finite.all():
        fill = float(values[finite].max()) if finite.any() else 0.0
        values = np.where(finite, values, np.float32(fill))
    rows, cols = values.shape
    if rows <= limit and cols <= limit:
        return values
    size = (min(cols, limit), min(rows, limit))  # cv2: (width, height)
    return cv2.resize(values, size, interpolation=cv2.INTER_AREA)


def difference_matrix_figure(
    result: RouteResult,
    evaluation: RouteEvaluation | None = None,
    path: PathLike | None = None,
    enhanced: bool = True,
    width: int = 900,
    height: int = 820,
):
    """The difference matrix (x = query frame, y = reference frame) with the matches.

    Matches are dots: green where correct, red where wrong (white when there is no ground truth).

    Args:
        result: a :class:`RouteResult`.
        evaluation: optional ground-truth evaluation for the colours.
        enhanced: draw the contrast-enhanced matrix (else the raw one, if it was kept).
    """
    matrix = result.enhanced if enhanced or result.difference is None else result.difference
    which = "contrast-enhanced difference matrix" if matrix is result.enhanced else "difference matrix"
    fig = _figure(width, height, f"Route: {which} and matches")
    ax = fig.axes()
    n_query, n_ref = matrix.shape
    values = _reduced(matrix.T)  # rows = references (y), columns = queries (x)
    finite = values[np.isfinite(values)]
    hi = float(np.percentile(finite, 99)) if finite.size else 1.0
    lo = float(finite.min()) if finite.size else 0.0
    ax.image(
        values,
        extent=(0, n_query, 0, n_ref),
        cmap="viridis",
        vmin=lo,
        vmax=max(hi, lo + 1e-6),
        colorbar=True,
        colorbar_label="lower = more similar",
    )
    defined = np.flatnonzero(result.refs >= 0)
    x = defined + 0.5
    y = result.refs[defined] + 0.5
    dot = 2.0 if len(defined) > 300 else 3.0
    if evaluation is None:
        ax.scatter(x, y, size=dot, color="white", label="match")
    else:
        good = evaluation.correct[defined]
        ax.scatter(x[good], y[good], size=dot, color="lime", label="correct")
        ax.scatter(x[~good], y[~good], size=dot, color="red", label="wrong")
        ax.legend("upper left")
    ax.set_xlabel("query frame")
    ax.set_ylabel("reference frame")
    ax.set_xlim(0, n_query)
    ax.set_ylim(0, n_ref)
    if path is not None:
        fig.save(path)
    return fig


def pr_curve_figure(evaluation: RouteEvaluation, path: PathLike | None = None, width: int = 640, height: int = 520):
    """Precision (y) against recall (x) over the score threshold."""
    fig = _figure(width, height, "Route: precision-recall")
    ax = fig.axes()
    curve = evaluation.curve
    if curve.thresholds.size:
        ax.plot(
            np.concatenate([[0.0], curve.recall]),
            np.concatenate([[1.0], curve.precision]),
            color="blue",
            label="precision-recall",
        )
    ax.scatter(
        [evaluation.recall_at_100],
        [1.0],
        size=6,
        color="green",
        label=f"recall at 100% precision {evaluation.recall_at_100:.3f}",
    )
    ax.scatter(
        [evaluation.best_f1_recall],
        [evaluation.best_f1_precision],
        size=6,
        color="red",
        marker="s",
        label=f"best F1 {evaluation.best_f1:.3f}",
    )
    ax.set_xlim(0.0, 1.0)
    ax.set_ylim(0.0, 1.02)
    ax.set_xlabel("recall")
    ax.set_ylabel("precision")
    ax.set_grid(True)
    ax.legend("lower left")
    if path is not None:
        fig.save(path)
    return fig


def correspondence_figure(
    result: RouteResult,
    evaluation: RouteEvaluation,
    path: PathLike | None = None,
    width: int = 760,
    height: int = 640,
):
    """The paper's Figure 23: frame correspondences between the two traverses.

    Grey dots are every match; blue dots the true positives accepted at 100 % precision (the
    largest score threshold with no false positive); the thin line is the ground truth where it
    is a frame correspondence or a nearest reference.
    """
    fig = _figure(width, height, "Route: frame correspondences")
    ax = fig.axes()
    defined = np.flatnonzero(result.refs >= 0)
    ax.scatter(defined, result.refs[defined], size=1.5, color="lightgrey", label="all matches")
    threshold = evaluation.threshold_at_100
    if math.isfinite(threshold):
        accepted = defined[(result.scores[defined] <= threshold) & evaluation.correct[defined]]
        label = f"true positives at 100% precision ({len(accepted)})"
        ax.scatter(accepted, result.refs[accepted], size=2.5, color="blue", label=label)
    queries, refs = _truth_line(evaluation, result)
    if np.isfinite(refs).any():
        ax.plot(queries, refs, color="orange", thickness=1, label="ground truth")
    ax.set_xlabel("query frame (second traverse)")
    ax.set_ylabel("reference frame (first traverse)")
    ax.set_xlim(0, result.n_queries)
    ax.set_ylim(0, result.n_refs)
    ax.legend("upper left")
    if path is not None:
        fig.save(path)
    return fig


def _truth_line(evaluation: RouteEvaluation, result: RouteResult):
    truth = evaluation.true_refs
    queries = np.arange(result.n_queries, dtype=np.float64)
    refs = truth.astype(np.float64)
    refs[truth < 0] = np.nan  # breaks the line
    return queries, refs


def save_route_figures(result: RouteResult, evaluation: RouteEvaluation | None, folder: PathLike) -> list:
    """Writes the figures that apply into ``folder``; returns their paths.

    ``difference_matrix.png`` always; ``pr_curve.png`` and ``correspondence.png`` with ground truth;
    ``filter_confidence.png`` for the route filter when matplotlib is installed.
    """
    out = os.fspath(folder)
    paths = [os.path.join(out, "difference_matrix.png")]
    difference_matrix_figure(result, evaluation, paths[0])
    if evaluation is not None:
        paths.append(os.path.join(out, "pr_curve.png"))
        pr_curve_figure(evaluation, paths[-1])
        paths.append(os.path.join(out, "correspondence.png"))
        correspondence_figure(result, evaluation, paths[-1])
    if result.confidence is not None and _matplotlib_available():
        paths.append(os.path.join(out, "filter_confidence.png"))
        filter_confidence_figure(result, evaluation, paths[-1])
    return paths


# --------------------------------------------------------------------------------------------
# matplotlib figures


def _matplotlib_available() -> bool:
    try:
        import matplotlib as mpl  # noqa: F401
    except ImportError:
        return False
    return True


def _pyplot():
    """matplotlib's pyplot on the Agg backend (no display needed)."""
    import matplotlib as mpl

    mpl.use("Agg")
    import matplotlib.pyplot as plt

    return plt


def _save(fig, path: PathLike | None) -> None:
    if path is None:
        return
    import io

    from ..io.atomic import write_bytes

    buffer = io.BytesIO()
    fig.savefig(buffer, format="png", dpi=100)
    write_bytes(path, buffer.getvalue())


def filter_confidence_figure(
    result: RouteResult, evaluation: RouteEvaluation | None = None, path: PathLike | None = None
):
    """The route filter's confidence (belief within ``filter_window`` of the match) and off-route
    probability per query frame; with ground truth, correct matches in blue and wrong ones in red,
    and the 100 %-precision threshold as a line. Returns the matplotlib Figure (closed after
    saving when ``path`` is given)."""
    if result.confidence is None:
        raise ValueError("filter_confidence_figure needs a route filter result (params.method == 'filter')")
    plt = _pyplot()
    fig, ax = plt.subplots(figsize=(12, 3.6), layout="constrained")
    queries = np.arange(result.n_queries)
    if evaluation is not None:
        good = evaluation.correct
        ax.scatter(queries[good], result.confidence[good], s=3, color="tab:blue", label="confidence, correct match")
        ax.scatter(queries[~good], result.confidence[~good], s=5, color="tab:red", label="confidence, wrong match")
        if math.isfinite(evaluation.threshold_at_100):
            level = 1.0 - evaluation.threshold_at_100
            ax.axhline(level, color="tab:blue", lw=0.8, ls="--", label=f"100% precision above {level:.3f}")
    else:
        ax.scatter(queries, result.confidence, s=3, color="tab:blue", label="confidence")
    ax.plot(queries, result.off_route, color="tab:orange", lw=0.8, label="off-route probability")
    ax.set_xlim(0, max(1, result.n_queries))
    ax.set_ylim(-0.02, 1.02)
    ax.set_xlabel("query frame")
    ax.set_ylabel("probability")
    ax.set_title("route filter: confidence of each match and off-route probability")
    ax.legend(loc="upper left", bbox_to_anchor=(1.01, 1.0), fontsize=8, markerscale=2)
    _save(fig, path)
    if path is not None:
        plt.close(fig)
    return fig


def pr_comparison_figure(evaluations: dict, path: PathLike | None = None):
    """Precision against recall of several methods (``{name: RouteEvaluation}``), each labelled
    with its best F1 and recall at 100 % precision. Returns the matplotlib Figure (closed after
    saving when ``path`` is given)."""
    plt = _pyplot()
    fig, ax = plt.subplots(figsize=(6, 5), layout="constrained")
    for name, evaluation in evaluations.items():
        curve = evaluation.curve
        ax.plot(
            np.concatenate([[0.0], curve.recall]),
            np.concatenate([[1.0], curve.precision]),
            lw=1.5,
            label=f"{name}: best F1 {evaluation.best_f1:.3f}, R@100P {evaluation.recall_at_100:.3f}",
        )
    ax.set_xlim(0, 1.0)
    ax.set_ylim(0, 1.02)
    ax.set_xlabel("recall")
    ax.set_ylabel("precision")
    ax.set_title("precision-recall by method")
    ax.legend(loc="lower left", fontsize=8)
    _save(fig, path)
    if path is not None:
        plt.close(fig)
    return fig
