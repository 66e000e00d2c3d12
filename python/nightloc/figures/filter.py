"""Figures of the grid Bayes filter.

:func:`comparison_figure` (``nightloc demo``): distance-error box plots per odometry noise model,
the paper's n-frame sum beside the filter, one panel per kind of odometry (map-frame
displacements, wheel odometry). :func:`confidence_figure` (``tools/filter_targets.py``): the
filter's confidence against its error, frame by frame, and how often each confidence was right.
The trajectory of ``nightloc localize`` is :func:`nightloc.figures.trajectory.trajectory_figure`.
"""

from __future__ import annotations

import os
from collections.abc import Mapping, Sequence
from typing import Union

import numpy as np
from matplotlib.figure import Figure

from ._common import new_figure, save_figure, styled

__all__ = ["comparison_figure", "confidence_figure"]

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


@styled
def confidence_figure(
    runs: Mapping[str, tuple[np.ndarray, np.ndarray]],
    title: str,
    path: PathLike | None = None,
    figure_format: str | None = None,
    radius: float = 1.0,
    trusted: float = 0.9,
) -> Figure:
    """The filter's confidence against its distance error, and its calibration.

    Left: every frame (confidence, error), one colour per run label, the lines ``error = radius``
    and ``confidence = trusted``: the upper right corner holds the confidently wrong frames.
    Right: per tenth of confidence, the share of its frames within ``radius`` of the truth (a
    calibrated confidence lies on the diagonal: the belief within ``radius``, as reported),
    with the frames in each tenth.

    Args:
        runs: ``{label: (errors (n,) metres, confidences (n,) in [0, 1])}``.
        title: the figure's title.
        path: where to write it (PNG, PDF or SVG).
        radius: metres (the localizer's ``confidence_radius``); trusted: the confidence a robot
            would act on.
    """
    fig, (scatter, calibration) = new_figure(10.0, 4.2, 1, 2)
    every_error, every_confidence = [], []
    for label, (errors, confidence) in runs.items():
        errors, confidence = np.asarray(errors, dtype=float), np.asarray(confidence, dtype=float)
        wrong = int(((errors > radius) & (confidence > trusted)).sum())
        scatter.scatter(confidence, errors, s=6, alpha=0.5, label=f"{label} ({wrong} of {errors.size})")
        every_error.append(errors)
        every_confidence.append(confidence)
    errors, confidence = np.concatenate(every_error), np.concatenate(every_confidence)
    scatter.axhline(radius, color="k", lw=0.8, ls="--")
    scatter.axvline(trusted, color="k", lw=0.8, ls="--")
    scatter.set_yscale("log")
    scatter.set_xlim(0, 1)
    scatter.set_xlabel(f"confidence (belief within {radius:.1f} m of the estimate)")
    scatter.set_ylabel("distance error (m)")
    share = float(((errors > radius) & (confidence > trusted)).mean()) if errors.size else 0.0
    scatter.set_title(f"error > {radius:g} m with confidence > {trusted:g}: {share:.2%} of {errors.size} frames")
    scatter.legend(loc="lower left", fontsize="small", markerscale=2)
    edges = np.linspace(0, 1, 11)
    tenth = np.clip(np.digitize(confidence, edges) - 1, 0, 9)
    centres, right, counts = [], [], []
    for k in range(10):
        inside = tenth == k
        if inside.any():
            centres.append(0.5 * (edges[k] + edges[k + 1]))
            right.append(float((errors[inside] <= radius).mean()))
            counts.append(int(inside.sum()))
    calibration.plot([0, 1], [0, 1], color="0.6", lw=0.8, ls=":", label="calibrated")
    calibration.plot(centres, right, "o-", color="tab:blue", label="share within the radius")
    for x, y, n in zip(centres, right, counts):
        calibration.annotate(str(n), (x, y), textcoords="offset points", xytext=(0, -12), ha="center", fontsize=7)
    calibration.set_xlim(0, 1)
    calibration.set_ylim(0, 1.05)
    calibration.set_xlabel("confidence (tenths; frames per tenth below the points)")
    calibration.set_ylabel(f"frames within {radius:g} m of the truth")
    calibration.legend(loc="upper left", fontsize="small")
    fig.suptitle(title)
    if path is not None:
        save_figure(fig, path, figure_format)
    return fig
