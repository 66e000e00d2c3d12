"""The figure of a localized traverse (for ``nightloc localize``): the estimated trajectory on the
map, beside the distance error per frame when the truth is known.

:func:`trajectory_figure` returns the matplotlib :class:`~matplotlib.figure.Figure` and, given
``path``, writes it (PNG, PDF or SVG by the suffix or ``figure_format``; atomically).
"""

from __future__ import annotations

import os
import textwrap
from typing import Union

import numpy as np
from matplotlib.figure import Figure

from ._common import new_figure, save_figure, styled

__all__ = ["trajectory_figure"]

PathLike = Union[str, "os.PathLike[str]"]


def _points(values: object, name: str, rows: int | None = None) -> np.ndarray:
    array = np.asarray(values, dtype=np.float64)
    if array.ndim != 2 or array.shape[1] != 2 or (rows is not None and array.shape[0] != rows):
        want = f"({rows}, 2)" if rows is not None else "(N, 2)"
        raise ValueError(f"{name} must be {want} x, y in metres, got shape {array.shape}")
    return array


@styled
def trajectory_figure(
    references: object,
    estimates: object,
    truth: object | None = None,
    credible_radius: object | None = None,
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
    fig, axes = new_figure(11.0, 5.2, 1, 2, width_ratios=[1.3, 1.0]) if true is not None else new_figure(7.0, 5.6)
    ax = axes[0] if true is not None else axes
    ax.scatter(refs[:, 0], refs[:, 1], s=12, color="0.6", linewidths=0, label=f"references ({len(refs)})", zorder=1)
    if radius is not None:
        from matplotlib.patches import Circle

        for (x, y), r in zip(est, radius):
            if np.isfinite([x, y, r]).all():
                # an artist, not a patch: large early disks must not widen the axes
                ax.add_artist(Circle((x, y), r, facecolor="tab:blue", edgecolor="none", alpha=0.06, zorder=0))
        ax.plot([], [], "o", color="tab:blue", alpha=0.25, markersize=10, label="credible radius")
    if true is not None:
        ax.plot(true[:, 0], true[:, 1], color="black", linewidth=1.5, label="truth", zorder=2)
        segments = np.full((3 * len(est), 2), np.nan)
        segments[0::3], segments[1::3] = est, true
        ax.plot(segments[:, 0], segments[:, 1], color="tab:red", linewidth=0.6, alpha=0.7, zorder=2, label="error")
    ax.plot(est[:, 0], est[:, 1], color="tab:blue", linewidth=1.0, marker="o", markersize=3, label="estimate", zorder=3)
    ax.set_aspect("equal", adjustable="datalim")
    ax.set_xlabel("x (m)")
    ax.set_ylabel("y (m)")
    ax.legend(loc="best")
    if true is not None:
        errors = np.hypot(*(est - true).T)
        panel = axes[1]
        panel.plot(np.arange(len(errors)), errors, color="tab:red", linewidth=1.0, marker=".", markersize=4)
        if radius is not None:
            panel.plot(np.arange(len(radius)), radius, color="tab:blue", linestyle="--", linewidth=1.0,
                       label="credible radius")  # fmt: skip
        finite = errors[np.isfinite(errors)]
        if finite.size:
            median = float(np.median(finite))
            panel.axhline(median, color="black", linestyle="--", linewidth=1, label=f"median {median:.2f} m")
            panel.legend(loc="upper right")
        panel.set_xlabel("frame")
        panel.set_ylabel("distance error (m)")
        panel.set_ylim(bottom=0)
        panel.set_title(f"distance error per frame (n={finite.size})")
    fig.suptitle(title if not caption else f"{title}\n{textwrap.fill(caption, 140)}")
    if path is not None:
        save_figure(fig, path, figure_format)
    return fig
