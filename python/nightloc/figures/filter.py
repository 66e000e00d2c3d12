"""Figures of the grid Bayes filter, drawn with matplotlib (Agg canvas, no pyplot, no display).

* :func:`comparison_figure` — ``nightloc demo``: the filter beside the paper's method, distance
  error per odometry noise model, for map-frame and wheel odometry;
* :func:`localized_trajectory_figure` — ``nightloc localize``: the references, the estimated path
  with its credible radius, and the true path when the log has one.

matplotlib is imported here only: nothing on the robot's path imports this module. Figures are
written atomically (PNG, or PDF/SVG by the path's suffix).
"""

from __future__ import annotations

import io
import os
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Union

import numpy as np

from ..io.atomic import write_bytes

__all__ = ["comparison_figure", "localized_trajectory_figure"]

PathLike = Union[str, "os.PathLike[str]"]

_PAPER_COLOUR, _FILTER_COLOUR = "#d62728", "#1f77b4"


def _new_figure(width: float, height: float):
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    fig = Figure(figsize=(width, height), dpi=110)
    FigureCanvasAgg(fig)
    return fig


def _save(fig, path: PathLike) -> Path:
    target = Path(path)
    fmt = target.suffix.lower().lstrip(".") or "png"
    buffer = io.BytesIO()
    metadata = {"Software": None} if fmt == "png" else None  # reproducible bytes
    fig.savefig(buffer, format=fmt, metadata=metadata)
    return write_bytes(target, buffer.getvalue())


def comparison_figure(
    errors: Mapping[str, Mapping[str, Sequence[np.ndarray]]],
    title: str,
    path: PathLike | None = None,
    paper_label: str = "paper, n = 10",
):
    """Distance-error box plots per noise model, the paper's method beside the filter.

    Args:
        errors: ``{odometry label: {"paper": [errors per noise model], "filter": [...]}}``, e.g.
            ``{"map-frame odometry": {...}, "wheel odometry": {...}}``; each list holds one array of
            errors (metres) per noise model 0, 1, ...
        title: the figure's title (e.g. the world and the frames counted).
        path: where to write it (PNG unless the suffix says pdf or svg).

    Returns:
        The matplotlib Figure.
    """
    fig = _new_figure(5.0 * len(errors), 4.2)
    axes = fig.subplots(1, len(errors), squeeze=False)[0]
    top = 0.0
    for ax, (label, by_method) in zip(axes, errors.items()):
        models = len(by_method["paper"])
        for offset, method, colour, name in (
            (-0.18, "paper", _PAPER_COLOUR, paper_label),
            (0.18, "filter", _FILTER_COLOUR, "Bayes filter"),
        ):
            data = [np.asarray(e, dtype=float) for e in by_method[method]]
            parts = ax.boxplot(
                data,
                positions=np.arange(models) + offset,
                widths=0.3,
                patch_artist=True,
                showfliers=True,
                flierprops={"markersize": 2, "markeredgecolor": colour},
                medianprops={"color": "black"},
            )
            for box in parts["boxes"]:
                box.set_facecolor(colour)
                box.set_alpha(0.6)
            medians = [float(np.median(d)) if d.size else np.nan for d in data]
            ax.plot(np.arange(models) + offset, medians, "o", color=colour, markersize=3, label=name)
            top = max(top, *[float(np.percentile(d, 95)) for d in data if d.size])
        ax.set_xticks(np.arange(models))
        ax.set_xticklabels([f"{m}" for m in range(models)])
        ax.set_xlabel("odometry noise model (Table III)")
        ax.set_ylabel("distance error (m)")
        ax.set_title(label)
        ax.grid(axis="y", alpha=0.3)
        ax.legend(loc="upper left", fontsize=8)
    for ax in axes:
        ax.set_ylim(0, max(top * 1.1, 0.5))
    fig.suptitle(title)
    fig.tight_layout()
    if path is not None:
        _save(fig, path)
    return fig


def localized_trajectory_figure(
    references: np.ndarray,
    estimates: np.ndarray,
    credible_radius: np.ndarray,
    truth: np.ndarray | None = None,
    title: str = "Localized trajectory",
    caption: str | None = None,
    path: PathLike | None = None,
):
    """The references (grey), the estimated path (blue) with its credible radius per frame (light
    circles), and with ``truth`` the true path (black), a line from each estimate to its truth and
    a second panel of the distance error and credible radius per frame.

    Args:
        references: ``(R, 2)`` reference positions, metres.
        estimates: ``(N, 2)`` estimated positions in frame order, metres.
        credible_radius: ``(N,)`` metres.
        truth: optional ``(N, 2)`` true positions.
    """
    from matplotlib.patches import Circle

    refs = np.asarray(references, dtype=float).reshape(-1, 2)
    est = np.asarray(estimates, dtype=float).reshape(-1, 2)
    radius = np.asarray(credible_radius, dtype=float).reshape(-1)
    if radius.shape[0] != est.shape[0]:
        raise ValueError(f"credible_radius must have one value per estimate ({est.shape[0]}), got {radius.shape[0]}")
    true = None if truth is None else np.asarray(truth, dtype=float).reshape(-1, 2)
    if true is not None and true.shape != est.shape:
        raise ValueError(f"truth must be {est.shape} like the estimates, got {true.shape}")
    fig = _new_figure(11.0 if true is not None else 7.0, 5.2)
    axes = fig.subplots(1, 2 if true is not None else 1, squeeze=False)[0]
    ax = axes[0]
    ax.scatter(refs[:, 0], refs[:, 1], s=12, color="0.6", linewidths=0, label=f"references ({len(refs)})", zorder=1)
    for (x, y), r in zip(est, radius):
        if np.isfinite(r):
            ax.add_patch(Circle((x, y), r, facecolor=_FILTER_COLOUR, edgecolor="none", alpha=0.06, zorder=0))
    if true is not None:
        ax.plot(true[:, 0], true[:, 1], color="black", linewidth=1.5, label="truth", zorder=2)
        segments = np.full((3 * len(est), 2), np.nan)
        segments[0::3], segments[1::3] = est, true
        ax.plot(segments[:, 0], segments[:, 1], color=_PAPER_COLOUR, linewidth=0.6, alpha=0.7, zorder=2, label="error")
    ax.plot(
        est[:, 0], est[:, 1], color=_FILTER_COLOUR, linewidth=1.0, marker="o", markersize=3, label="estimate", zorder=3
    )
    ax.plot([], [], "o", color=_FILTER_COLOUR, alpha=0.25, markersize=10, label="credible radius")
    span = np.vstack([refs, est] + ([true] if true is not None else []))
    lo, hi = np.nanmin(span, axis=0), np.nanmax(span, axis=0)
    pad = 0.05 * max(float(np.max(hi - lo)), 1.0)
    ax.set_xlim(lo[0] - pad, hi[0] + pad)
    ax.set_ylim(lo[1] - pad, hi[1] + pad)
    ax.set_aspect("equal", adjustable="box")
    ax.set_xlabel("x (m)")
    ax.set_ylabel("y (m)")
    ax.legend(loc="best", fontsize=8)
    if true is not None:
        errors = np.hypot(*(est - true).T)
        panel = axes[1]
        frames = np.arange(len(errors))
        panel.plot(frames, errors, color=_PAPER_COLOUR, linewidth=1.0, marker=".", markersize=4, label="distance error")
        panel.plot(frames, radius, color=_FILTER_COLOUR, linewidth=1.0, linestyle="--", label="credible radius")
        finite = errors[np.isfinite(errors)]
        if finite.size:
            median = float(np.median(finite))
            panel.axhline(median, color="black", linestyle=":", linewidth=1, label=f"median error {median:.2f} m")
        panel.set_xlabel("frame")
        panel.set_ylabel("metres")
        panel.set_ylim(bottom=0)
        panel.legend(loc="upper right", fontsize=8)
        panel.set_title(f"error and uncertainty per frame (n={finite.size})")
    fig.suptitle(title if caption is None else f"{title}\n{caption}", fontsize=10)
    fig.tight_layout()
    if path is not None:
        _save(fig, path)
    return fig
