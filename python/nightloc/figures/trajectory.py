"""The figure of a localized traverse (for ``nightloc localize``): the estimated trajectory on the
map, beside the distance error (and the localizer's confidence) per frame when the truth is known.

:func:`trajectory_figure` returns the matplotlib :class:`~matplotlib.figure.Figure` and, given
``path``, writes it (PNG, PDF or SVG by the suffix or ``figure_format``; atomically).
"""

from __future__ import annotations

import os
import textwrap
from typing import Union

import matplotlib as mpl
import numpy as np
from matplotlib.axes import Axes
from matplotlib.figure import Figure

from ..localization.tail import FIRST_FRAME, LOST_M, tail_metrics
from ._common import new_figure, save_figure, styled

__all__ = ["MAX_DRAWN_RADIUS_SHARE", "trajectory_figure"]

#: Credible-radius disks are drawn at most this share of the view's larger side.
MAX_DRAWN_RADIUS_SHARE = 0.15


def _view(track: np.ndarray, references: np.ndarray) -> tuple[float, float, float, float]:
    """``(x0, x1, y0, y1)`` metres around the trajectory ``track`` (its finite points; the
    references when it has none), with a margin of 8 % and at least 0.5 m."""
    points = track[np.isfinite(track).all(axis=1)]
    if points.size == 0:
        points = references[np.isfinite(references).all(axis=1)]
    if points.size == 0:
        return (-1.0, 1.0, -1.0, 1.0)
    low, high = points.min(axis=0), points.max(axis=0)
    margin = np.maximum(0.08 * (high - low).max(), 0.5)
    return (float(low[0] - margin), float(high[0] + margin), float(low[1] - margin), float(high[1] + margin))


PathLike = Union[str, "os.PathLike[str]"]


def _points(values: object, name: str, rows: int | None = None) -> np.ndarray:
    array = np.asarray(values, dtype=np.float64)
    if array.ndim != 2 or array.shape[1] != 2 or (rows is not None and array.shape[0] != rows):
        want = f"({rows}, 2)" if rows is not None else "(N, 2)"
        raise ValueError(f"{name} must be {want} x, y in metres, got shape {array.shape}")
    return array


def _draw_map_panel(
    ax: Axes,
    refs: np.ndarray,
    est: np.ndarray,
    true: np.ndarray | None,
    radius: np.ndarray | None,
    view: tuple[float, float, float, float],
) -> None:
    """The map panel: references, credible disks, the true path and the errors, the estimates;
    ``view`` ``(x0, x1, y0, y1)`` metres, the trajectory's extent."""
    cap = MAX_DRAWN_RADIUS_SHARE * max(view[1] - view[0], view[3] - view[2])
    ax.scatter(refs[:, 0], refs[:, 1], s=12, color="0.6", linewidths=0, label=f"references ({len(refs)})", zorder=1)
    if radius is not None:
        from matplotlib.patches import Circle

        for (x, y), r in zip(est, radius):
            if np.isfinite([x, y, r]).all():
                # an artist, not a patch: large early disks must not widen the axes; radii beyond a
                # share of the view are drawn at that share (a lost filter's 100 m would hide the plot)
                ax.add_artist(Circle((x, y), min(r, cap), facecolor="tab:blue", edgecolor="none", alpha=0.06, zorder=0))
        capped = bool(np.nanmax(radius, initial=0.0) > cap)
        label = f"credible radius (drawn up to {cap:.2g} m)" if capped else "credible radius"
        ax.plot([], [], "o", color="tab:blue", alpha=0.25, markersize=10, label=label)
    if true is not None:
        ax.plot(true[:, 0], true[:, 1], color="black", linewidth=1.5, label="truth", zorder=2)
        segments = np.full((3 * len(est), 2), np.nan)
        segments[0::3], segments[1::3] = est, true
        ax.plot(segments[:, 0], segments[:, 1], color="tab:red", linewidth=0.6, alpha=0.7, zorder=2, label="error")
    ax.plot(est[:, 0], est[:, 1], color="tab:blue", linewidth=1.0, marker="o", markersize=3, label="estimate", zorder=3)
    # the view fits the trajectory (not the references, not the disks); matplotlib widens it for
    # equal axes when drawing (the limits stay automatic, so it may)
    ax.dataLim.set_points(np.array([[view[0], view[2]], [view[1], view[3]]]))
    ax.autoscale_view(tight=True)
    ax.set_aspect("equal", adjustable="datalim")
    ax.set_xlabel("x (m)")
    ax.set_ylabel("y (m)")
    ax.legend(loc="best")


def _draw_error_panel(
    panel: Axes, est: np.ndarray, true: np.ndarray, radius: np.ndarray | None, trust: np.ndarray | None
) -> None:
    """The error panel: the distance error per frame (metres) with its median and the tail, the
    credible radius beside it and the confidence on the right axis."""
    errors = np.hypot(*(est - true).T)
    panel.plot(np.arange(len(errors)), errors, color="tab:red", linewidth=1.0, marker=".", markersize=4)
    if radius is not None:
        panel.plot(np.arange(len(radius)), radius, color="tab:blue", linestyle="--", linewidth=1.0,
                   label="credible radius")  # fmt: skip
    finite = errors[np.isfinite(errors)]
    if finite.size:
        tail = tail_metrics(errors)
        median = float(np.median(finite))
        panel.axhline(median, color="black", linestyle="--", linewidth=1, label=f"median {median:.2f} m")
        if tail.n:
            panel.axhline(
                LOST_M,
                color="tab:red",
                linestyle=":",
                linewidth=1,
                label=f"{LOST_M:g} m: {100 * tail.share_over_1m:.1f} % over, longest run "
                f"{tail.longest_run_over_1m} (p95 {tail.p95_m:.2f} m, from frame {FIRST_FRAME})",
            )
    handles, labels = panel.get_legend_handles_labels()
    if trust is not None:
        right = panel.twinx()
        right.plot(np.arange(len(trust)), trust, color="tab:green", linewidth=1.0, label="confidence")
        right.set_ylim(0, 1.05)
        right.set_ylabel("confidence", color="tab:green")
        right.tick_params(axis="y", colors="tab:green")
        more = right.get_legend_handles_labels()
        # one legend for both axes, on the right axis (drawn above the errors)
        right.legend(handles + more[0], labels + more[1], loc="upper right", fontsize="small")
    elif handles:
        panel.legend(loc="upper right")
    panel.set_xlabel("frame")
    panel.set_ylabel("distance error (m)")
    # a lost filter's first radii (100+ m) must not flatten the errors: the scale fits the
    # errors and most radii, what lies above is cut off
    tallest = [finite.max()] if finite.size else []
    if radius is not None and np.isfinite(radius).any():
        tallest.append(float(np.nanpercentile(radius, 90)))
    panel.set_ylim(bottom=0, top=1.15 * max(tallest) if tallest and max(tallest) > 0 else None)
    panel.set_title(f"distance error per frame (n={finite.size})")


@styled
def trajectory_figure(
    references: object,
    estimates: object,
    truth: object | None = None,
    credible_radius: object | None = None,
    confidence: object | None = None,
    title: str = "Localized trajectory",
    caption: str | None = None,
    path: PathLike | None = None,
    figure_format: str | None = None,
) -> Figure:
    """The estimated positions on the map; with ``truth``, the true path, a thin line from each
    estimate to its truth, and a second panel of the distance error per frame.

    Args:
        references: ``(R, 2)`` reference positions, metres (grey dots).
        estimates: ``(N, 2)`` estimated positions in frame order, metres (blue line and dots;
            rows with NaN break the line).
        truth: optional ``(N, 2)`` true positions, metres (black line).
        credible_radius: optional ``(N,)`` metres, the localizer's uncertainty per frame (the Bayes
            filter's ``Estimate.credible_radius``): a light disk around each estimate, and a
            dashed line beside the error per frame.
        confidence: optional ``(N,)`` 0..1, the localizer's confidence per frame (the Bayes
            filter's ``Estimate.confidence``): a green line on the error panel's right axis.
        title, caption: the figure's title, and a line under it (e.g. the data and parameters).
    """
    refs = _points(references, "references")
    est = _points(estimates, "estimates")
    true = None if truth is None else _points(truth, "truth", est.shape[0])
    radius = None
    if credible_radius is not None:
        radius = np.asarray(credible_radius, dtype=np.float64).reshape(-1)
        if radius.shape[0] != est.shape[0]:
            raise ValueError(f"credible_radius must have one value per estimate ({est.shape[0]}), got {radius.shape}")
    trust = None
    if confidence is not None:
        trust = np.asarray(confidence, dtype=np.float64).reshape(-1)
        if trust.shape[0] != est.shape[0]:
            raise ValueError(f"confidence must have one value per estimate ({est.shape[0]}), got {trust.shape}")
    width = 11.0 if true is not None else 7.0
    fig, axes = new_figure(width, 5.2, 1, 2, width_ratios=[1.3, 1.0]) if true is not None else new_figure(width, 5.6)
    ax = axes[0] if true is not None else axes
    view = _view(est if true is None else np.vstack([est, true]), refs)
    _draw_map_panel(ax, refs, est, true, radius, view)
    if true is not None:
        _draw_error_panel(axes[1], est, true, radius, trust)
    # wrapped to the figure's width (about 0.6 em a character), so no line runs off the page
    characters = int(width * 72 / (0.6 * float(mpl.rcParams["figure.titlesize"])))
    fig.suptitle("\n".join(textwrap.wrap(title, characters) + (textwrap.wrap(caption, characters) if caption else [])))
    if path is not None:
        save_figure(fig, path, figure_format)
    return fig
