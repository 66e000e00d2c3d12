"""The figure of a teach run: the dead-reckoned, the optimised and (when known) the surveyed path.

The teach run's map lives in its odometry frame; the survey, when there is one, is brought into
it by the best rigid 2D fit of the optimised positions (:func:`nightloc.mapping.rigid_fit`), so
the three paths overlay as the ATE compares them.
"""

from __future__ import annotations

import os
from typing import Union

import numpy as np
from matplotlib.figure import Figure

from ._common import new_figure, save_figure, styled

__all__ = ["teach_figure"]

PathLike = Union[str, "os.PathLike[str]"]


@styled
def teach_figure(
    dead_reckoning: np.ndarray,
    optimised: np.ndarray,
    surveyed: np.ndarray | None = None,
    accepted_pairs: np.ndarray | None = None,
    title: str = "Teach run",
    path: PathLike | None = None,
    figure_format: str | None = None,
) -> Figure:
    """Draws the three paths (``(N, 2)`` metres each, map frame; ``surveyed`` already aligned)
    and the accepted visual constraints (``(K, 2)`` frame index pairs) as faint lines."""
    optimised = np.asarray(optimised, dtype=np.float64)[:, :2]
    dead = np.asarray(dead_reckoning, dtype=np.float64)[:, :2]
    fig, ax = new_figure(7.0, 5.2)
    if accepted_pairs is not None and len(accepted_pairs):
        pairs = np.asarray(accepted_pairs, dtype=int)
        for i, j in pairs:
            ax.plot(*optimised[[i, j]].T, color="#9ecae1", linewidth=0.5, zorder=1)
        ax.plot([], [], color="#9ecae1", linewidth=0.5, label=f"visual constraints ({len(pairs)})")
    if surveyed is not None:
        ax.plot(*np.asarray(surveyed, dtype=np.float64)[:, :2].T, "-", color="black", linewidth=1.2, label="surveyed")
    ax.plot(*dead.T, "--", color="#d62728", linewidth=1.0, label="dead reckoning")
    ax.plot(*optimised.T, "-", color="#1f77b4", linewidth=1.2, marker=".", markersize=3, label="optimised (map)")
    ax.plot(*optimised[0], "o", color="black", markersize=5, label="start (map origin)")
    ax.set_aspect("equal", adjustable="datalim")
    ax.set_xlabel("x (m, map frame)")
    ax.set_ylabel("y (m)")
    ax.set_title(title)
    ax.legend(loc="best", fontsize="small")
    if path is not None:
        save_figure(fig, path, figure_format)
    return fig
