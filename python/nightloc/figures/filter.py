"""The figure of ``nightloc demo`` comparing the grid Bayes filter with the paper's method.

:func:`comparison_figure`: distance-error box plots per odometry noise model, the paper's
n-frame sum beside the filter, one panel per kind of odometry (map-frame displacements, wheel
odometry). The trajectory of ``nightloc localize`` is :func:`nightloc.figures.trajectory.trajectory_figure`.
"""

from __future__ import annotations

import os
from collections.abc import Mapping, Sequence
from typing import Union

import numpy as np
from matplotlib.figure import Figure

from ._common import new_figure, save_figure, styled

__all__ = ["comparison_figure"]

PathLike = Union[str, "os.PathLike[str]"]

_COLOURS = {"paper": "tab:red", "filter": "tab:blue"}


@styled
def comparison_figure(
    errors: Mapping[str, Mapping[str, Sequence[np.ndarray]]],
    title: str,
    path: PathLike | None = None,
    figure_format: str | None = None,
    labels: Mapping[str, str] | None = None,
) -> Figure:
    """Distance-error box plots per noise model, the paper's method beside the filter.

    Args:
        errors: ``{odometry label: {"paper": [errors per noise model], "filter": [...]}}``, e.g.
            ``{"map-frame odometry": {...}, "wheel odometry": {...}}``; each list holds one array
            of distance errors (metres) per noise model 0, 1, ...
        title: the figure's title (e.g. the world and the frames counted).
        path: where to write it (PNG, PDF or SVG by ``figure_format`` or the suffix).
        labels: the legend's names of ``"paper"`` and ``"filter"``.

    Returns:
        The matplotlib Figure.
    """
    names = {"paper": "paper, n = 10", "filter": "Bayes filter", **(labels or {})}
    fig, axes = new_figure(5.0 * len(errors), 4.0, 1, len(errors))
    axes = np.atleast_1d(axes)
    top = 0.5
    for ax, (label, by_method) in zip(axes, errors.items()):
        models = len(by_method["paper"])
        for offset, method in ((-0.18, "paper"), (0.18, "filter")):
            data = [np.asarray(e, dtype=float) for e in by_method[method]]
            colour = _COLOURS[method]
            parts = ax.boxplot(
                data,
                positions=np.arange(models) + offset,
                widths=0.3,
                patch_artist=True,
                flierprops={"markersize": 2, "markeredgecolor": colour},
                medianprops={"color": "black"},
            )
            for box in parts["boxes"]:
                box.set_facecolor(colour)
                box.set_alpha(0.6)
            medians = [float(np.median(d)) if d.size else np.nan for d in data]
            ax.plot(np.arange(models) + offset, medians, "o", color=colour, markersize=3, label=names[method])
            top = max(top, *(float(np.percentile(d, 95)) for d in data if d.size))
        ax.set_xticks(np.arange(models), [str(m) for m in range(models)])
        ax.set_xlabel("odometry noise model (Table III)")
        ax.set_ylabel("distance error (m)")
        ax.set_title(label)
        ax.legend(loc="upper left")
    for ax in axes:
        ax.set_ylim(0, top * 1.1)
    fig.suptitle(title)
    if path is not None:
        save_figure(fig, path, figure_format)
    return fig
