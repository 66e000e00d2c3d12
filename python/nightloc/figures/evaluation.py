"""Figures of an evaluation (``nightloc evaluate`` / ``demo``), in the style of the paper.

* :func:`seq_len_figure`: distance error box plots against sequence length (Figures 10, 16, 21);
* :func:`noise_figure`: against the odometry noise model at one sequence length (11, 17, 22),
  each model named by its Table III standard deviations;
* :func:`interpolation_figure`: interpolation on beside off, per sequence length (12, 18);
* :func:`heatmap_figure`: one query frame's heat maps, single frame beside the sequence (Figure 9):
  reference positions as green circles sized by how well they match, a red cross at the truth
  (drawn large, with a white edge, so it stays visible over the hot peak), a green cross at the
  best-matching reference and a black cross at the interpolated estimate; a caption says why the
  frame was chosen (:func:`explain_heatmap_frame`).

Box plots are Tukey's (box = quartiles, red line = median, whiskers = 1.5 IQR, + = outliers)
with the number of errors ``n`` under each box. Every function returns the matplotlib
:class:`~matplotlib.figure.Figure` and, given ``path``, also writes it (PNG, PDF or SVG by the
suffix or ``figure_format``; atomically).
"""

from __future__ import annotations

import os
import textwrap
from collections.abc import Sequence
from pathlib import Path
from typing import Any, Union

import numpy as np
from matplotlib import patheffects
from matplotlib.figure import Figure
from matplotlib.lines import Line2D
from matplotlib.patches import Patch

from ..localization.evaluation import Evaluation, QueryMatches, replay
from ..localization.heatmap import HeatGrid, invert_scores
from ..localization.localizer import Estimate, LocalizationParams
from ..mapping.reference_map import ReferenceMap
from ..motion.odometry import NOISE_MODELS
from ._common import figure_path, new_figure, save_figure, styled

__all__ = [
    "explain_heatmap_frame",
    "headline_seq_len",
    "heatmap_figure",
    "interpolation_figure",
    "noise_figure",
    "noise_label",
    "pick_heatmap_frame",
    "save_evaluation_figures",
    "seq_len_figure",
]

PathLike = Union[str, "os.PathLike[str]"]
#: The paper's sequence length for its noise and interpolation figures.
PAPER_SEQ_LEN = 7
#: Colours of interpolation on / off (box edges).
INTERPOLATION_COLOURS = {True: "tab:blue", False: "tab:orange"}


def headline_seq_len(evaluation: Evaluation) -> int:
    """The sequence length of the noise and interpolation figures: 7 (the paper's) when it was
    evaluated, else the longest evaluated."""
    lengths = evaluation.settings.seq_lengths
    return PAPER_SEQ_LEN if PAPER_SEQ_LEN in lengths else max(lengths)


def noise_label(model: int) -> str:
    """Table III in words: ``"none"`` for model 0, else e.g. ``"std 0.1 m, 0.02 rad"`` (per step)."""
    noise = NOISE_MODELS[int(model)]
    if noise.distance_std == 0 and noise.heading_std == 0:
        return "none"
    return f"std {noise.distance_std:g} m, {noise.heading_std:g} rad"


def _preferred(values, wanted):
    return wanted if wanted in values else values[0]


def _data_name(evaluation: Evaluation, query: str | None) -> str:
    """What the figure shows, for its title: the query's name, or all of them."""
    if query is not None:
        return query
    names = [m.name for m in evaluation.matches]
    return names[0] if len(names) == 1 else f"{len(names)} queries"


def _on_off(interpolation: bool) -> str:
    return "on" if interpolation else "off"


def _top(evaluation: Evaluation, query: str | None) -> float:
    """The common error scale (metres) of an evaluation's box plots."""
    errors = evaluation.errors(query=query)
    return float(max(errors.max() * 1.05, 0.1)) if errors.size else 1.0


def _boxes(
    ax, groups: Sequence[np.ndarray], positions: Sequence[float] | np.ndarray, colour: str = "black", width: float = 0.5
):
    """Tukey box plots of the non-empty ``groups`` at ``positions``; returns matplotlib's dict."""
    drawn = [(np.asarray(g, dtype=np.float64), p) for g, p in zip(groups, positions) if np.asarray(g).size]
    if not drawn:
        return {}
    parts = ax.boxplot(
        [g for g, _ in drawn],
        positions=[p for _, p in drawn],
        widths=width,
        whis=1.5,
        manage_ticks=False,
        boxprops={"color": colour, "linewidth": 1.2},
        whiskerprops={"color": colour},
        capprops={"color": colour},
        medianprops={"color": "tab:red", "linewidth": 2},
        flierprops={"marker": "+", "markeredgecolor": "tab:red", "markersize": 6},
    )
    for line in parts["medians"]:
        line.set_label("_median")  # found by tests; a leading underscore keeps it out of legends
    return parts


def _box_figure(
    evaluation: Evaluation,
    query: str | None,
    groups: list[np.ndarray],
    labels: list[str],
    title: str,
    xlabel: str,
    path: PathLike | None,
    figure_format: str | None,
    inches_per_box: float = 0.62,
) -> Figure:
    """One box per group of distance errors (m), ``n`` under each, on the evaluation's error scale."""
    fig, ax = new_figure(max(4.8, inches_per_box * len(groups) + 1.4), 4.4)
    positions = np.arange(1, len(groups) + 1, dtype=np.float64)
    _boxes(ax, groups, positions)
    ax.set_xticks(positions, [f"{label}\nn={np.asarray(g).size}" for label, g in zip(labels, groups)])
    ax.set_xlim(0.4, len(groups) + 0.6)
    ax.set_ylim(0, _top(evaluation, query))
    ax.set_title(title)
    ax.set_xlabel(xlabel)
    ax.set_ylabel("distance error (m)")
    ax.grid(False, axis="x")
    if path is not None:
        save_figure(fig, path, figure_format)
    return fig


@styled
def seq_len_figure(
    evaluation: Evaluation,
    query: str | None = None,
    noise_model: int = 0,
    interpolation: bool = True,
    path: PathLike | None = None,
    figure_format: str | None = None,
) -> Figure:
    """Box plots of the distance error for each sequence length (one noise model)."""
    settings = evaluation.settings
    noise_model = _preferred(settings.noise_models, noise_model)
    interpolation = _preferred(settings.interpolation, interpolation)
    selection = {"noise_model": noise_model, "interpolation": interpolation, "query": query}
    lengths = [n for n in settings.seq_lengths if evaluation.errors(seq_len=n, **selection).size]
    return _box_figure(
        evaluation,
        query,
        [evaluation.errors(seq_len=n, **selection) for n in lengths],
        [str(n) for n in lengths],
        title=f"Distance error vs sequence length: {_data_name(evaluation, query)}",
        xlabel=f"sequence length (frames); odometry noise model {noise_model} ({noise_label(noise_model)}), "
        f"interpolation {_on_off(interpolation)}",
        path=path,
        figure_format=figure_format,
    )


@styled
def noise_figure(
    evaluation: Evaluation,
    query: str | None = None,
    seq_len: int | None = None,
    interpolation: bool = True,
    path: PathLike | None = None,
    figure_format: str | None = None,
) -> Figure:
    """Box plots of the distance error for each odometry noise model (one sequence length); each
    tick names the model's Table III standard deviations per step (distance, heading)."""
    settings = evaluation.settings
    seq_len = headline_seq_len(evaluation) if seq_len is None else seq_len
    interpolation = _preferred(settings.interpolation, interpolation)
    models = list(settings.noise_models)
    return _box_figure(
        evaluation,
        query,
        [evaluation.errors(seq_len=seq_len, noise_model=m, interpolation=interpolation, query=query) for m in models],
        [f"model {m}\n{noise_label(m)}" for m in models],
        title=f"Distance error vs odometry noise: {_data_name(evaluation, query)}",
        xlabel=f"odometry noise model (Table III: std of distance and heading per step)\n"
        f"{seq_len}-frame sequences, interpolation {_on_off(interpolation)}",
        path=path,
        figure_format=figure_format,
        inches_per_box=1.35,
    )


@styled
def interpolation_figure(
    evaluation: Evaluation,
    query: str | None = None,
    noise_model: int = 0,
    path: PathLike | None = None,
    figure_format: str | None = None,
) -> Figure:
    """Box plots with interpolation on beside off, for each sequence length."""
    settings = evaluation.settings
    noise_model = _preferred(settings.noise_models, noise_model)
    lengths = list(settings.seq_lengths)
    modes = list(settings.interpolation)
    fig, ax = new_figure(max(5.2, 0.9 * len(lengths) + 1.6), 4.4)
    centres = np.arange(1, len(lengths) + 1, dtype=np.float64)
    offsets = {mode: (i - (len(modes) - 1) / 2) * 0.38 for i, mode in enumerate(modes)}
    counts: dict[bool, list[int]] = {}
    for mode in modes:
        groups = [
            evaluation.errors(seq_len=n, noise_model=noise_model, interpolation=mode, query=query) for n in lengths
        ]
        counts[mode] = [g.size for g in groups]
        _boxes(ax, groups, centres + offsets[mode], colour=INTERPOLATION_COLOURS[mode], width=0.32)
    ticks = []
    for i, n in enumerate(lengths):
        sizes = sorted({counts[mode][i] for mode in modes})
        ticks.append(f"{n}\nn={'/'.join(str(s) for s in sizes)}")
    ax.set_xticks(centres, ticks)
    ax.set_xlim(0.4, len(lengths) + 0.6)
    ax.set_ylim(0, _top(evaluation, query))
    ax.set_title(f"Distance error with and without interpolation: {_data_name(evaluation, query)}")
    ax.set_xlabel(f"sequence length (frames); odometry noise model {noise_model} ({noise_label(noise_model)})")
    ax.set_ylabel("distance error (m)")
    ax.grid(False, axis="x")
    ax.legend(
        handles=[
            Patch(facecolor="none", edgecolor=INTERPOLATION_COLOURS[m], label=f"interpolation {_on_off(m)}")
            for m in modes
        ],
        loc="upper right",
    )
    if path is not None:
        save_figure(fig, path, figure_format)
    return fig


def _gain(evaluation: Evaluation, query: str | None, seq_len: int) -> tuple[np.ndarray, np.ndarray, int]:
    """Per-frame errors (noise-free odometry, interpolation on) with the shortest evaluated
    sequence and with ``seq_len`` frames, and that shortest length."""
    noise = _preferred(evaluation.settings.noise_models, 0)
    interp = _preferred(evaluation.settings.interpolation, True)
    first = min(evaluation.settings.seq_lengths)
    single = evaluation.errors(seq_len=first, noise_model=noise, interpolation=interp, query=query)
    multi = evaluation.errors(seq_len=seq_len, noise_model=noise, interpolation=interp, query=query)
    n = min(single.size, multi.size)
    if n == 0:
        raise ValueError("no rows for the heat-map figure")
    return single[:n], multi[:n], first


def pick_heatmap_frame(evaluation: Evaluation, query: str | None = None, seq_len: int | None = None) -> int:
    """The query frame where the sequence helps most (noise model 0, interpolation on): the
    largest drop from the single-frame error to the ``seq_len``-frame error, among frames with
    ``seq_len - 1`` frames before them (when the traverse is that long)."""
    seq_len = headline_seq_len(evaluation) if seq_len is None else seq_len
    single, multi, _ = _gain(evaluation, query, seq_len)
    return _largest_drop(single, multi, seq_len)[0]


def _largest_drop(single: np.ndarray, multi: np.ndarray, seq_len: int) -> tuple[int, int]:
    """(frame, full): the frame from ``full`` on (the first with a whole sequence behind it, when
    the traverse is that long) with the largest drop from ``single`` to ``multi``."""
    full = min(seq_len - 1, single.size - 1)
    return full + int(np.argmax((single - multi)[full:])), full


def explain_heatmap_frame(
    evaluation: Evaluation,
    frame: int,
    query: str | None = None,
    seq_len: int | None = None,
    requested: bool = False,
) -> str:
    """Why the heat-map figure shows ``frame``, with its errors: one line for the caption.

    ``"Frame requested: ..."`` when the user asked for it (``requested``), ``"Frame chosen where
    the sequence helps most: ..."`` when it is :func:`pick_heatmap_frame`'s choice, else
    ``"Frame <i>: ..."``.
    """
    seq_len = headline_seq_len(evaluation) if seq_len is None else seq_len
    single, multi, first = _gain(evaluation, query, seq_len)
    if not 0 <= frame < single.size:
        raise ValueError(f"frame {frame} is outside the evaluated query frames 0..{single.size - 1}")
    errors = (
        f"error {single[frame]:.2f} m with {first} frame{'s' if first > 1 else ''}, "
        f"{multi[frame]:.2f} m with {seq_len} frames"
    )
    detail = "noise-free odometry, interpolation on"
    if requested:
        return f"Frame requested: {errors} ({detail})"
    chosen, full = _largest_drop(single, multi, seq_len)
    if frame == chosen:
        return (
            f"Frame chosen where the sequence helps most: {errors}, the largest drop among frames "
            f"{full}-{single.size - 1} ({detail})"
        )
    return f"Frame {frame}: {errors} ({detail})"


_WHITE_EDGE = 2.5  # points of white stroke around each cross


def _cross(ax, x: float, y: float, colour: str, size: float, width: float, label: str, zorder: int) -> Line2D:
    """A cross marker with a white edge, so it reads over any colour of the heat map."""
    (line,) = ax.plot(
        [x],
        [y],
        linestyle="none",
        marker="x",
        markersize=size,
        markeredgewidth=width,
        color=colour,
        label=label,
        zorder=zorder,
        path_effects=[patheffects.withStroke(linewidth=width + _WHITE_EDGE, foreground="white")],
    )
    return line


@styled
def heatmap_figure(
    ref_map: ReferenceMap,
    matches: QueryMatches,
    frame: int,
    seq_len: int = PAPER_SEQ_LEN,
    params: LocalizationParams | None = None,
    path: PathLike | None = None,
    estimates: list[Estimate] | None = None,
    caption: str | None = None,
    figure_format: str | None = None,
) -> Figure:
    """The paper's Figure 9 for one query frame: single-frame heat map beside the sequence's.

    Noise-free odometry, interpolation on. ``estimates`` may pass the two estimates (with heat
    maps) instead of replaying the localizer; ``caption`` (e.g. :func:`explain_heatmap_frame`)
    is written under the panels. Draw order, bottom to top: heat map, reference circles, truth
    (large red cross), best reference (green: the frame's best match on the single-frame panel,
    the reference the sequence reports, closest to its estimate, on the sequence's panel),
    estimate (black, smaller, so a correct estimate shows inside the truth's cross).
    """
    params = params or LocalizationParams()
    if estimates is None:
        estimates = [
            replay(ref_map, matches, frame, 1, params=params),
            replay(ref_map, matches, frame, seq_len, params=params),
        ]
    result = matches.results[frame]
    truth = matches.positions[frame]
    inverted = invert_scores(result.scores)  # 1 = best match, 0 = worst
    shown = estimates[0].heatmap
    if shown is None:
        raise ValueError("estimates must carry heat maps: Localizer.update(..., return_heatmap=True)")
    height, width = shown.shape
    grid = HeatGrid.spanning(ref_map.positions, width, height, margin=params.margin)

    x0, x1, y0, y1 = grid.extent
    panels = float(np.clip(4.2 * (y1 - y0) / (x1 - x0), 2.0, 6.0)) + 1.0  # height that fits the map's aspect
    fig, _ = new_figure(11.0, panels + 0.8, 0, 0)
    top, bottom = fig.subfigures(2, 1, squeeze=False, height_ratios=[panels, 0.8])[:, 0]
    axes = top.subplots(1, 2)
    for ax, est in zip(axes, estimates):
        label = "single frame" if est.frames == 1 else f"{int(est.frames)}-frame sequence"
        image = ax.imshow(
            est.heatmap, extent=grid.extent, origin="lower", cmap="jet", interpolation="nearest", zorder=0
        )
        top.colorbar(image, ax=ax, shrink=0.9, label="heat (inverted score)")
        ax.scatter(
            ref_map.positions[:, 0],
            ref_map.positions[:, 1],
            s=(3.0 + 14.0 * inverted) ** 2,
            facecolors="none",
            edgecolors="lime",
            linewidths=1.5,
            zorder=2,
            label="references (size = match)",
        )
        _cross(ax, truth[0], truth[1], "red", 17, 3.5, "truth", zorder=3)
        best = ref_map.positions[result.index if est.frames == 1 else est.ref_index]
        _cross(ax, best[0], best[1], "green", 12, 3.0, "best reference", zorder=4)
        _cross(ax, est.x, est.y, "black", 10, 2.5, "estimate", zorder=5)
        error = float(np.hypot(est.x - truth[0], est.y - truth[1]))
        ax.set_title(f"{label}: error {error:.2f} m")
        ax.set_xlabel("x (m)")
        ax.set_ylabel("y (m)")
        ax.set_aspect("equal")
        ax.grid(False)
    top.suptitle(
        f"Heat maps of query frame {frame} ({matches.images[frame]}) of {matches.name} "
        f"against a map of {len(ref_map)} references"
    )
    handles, labels = axes[0].get_legend_handles_labels()
    bottom.legend(handles, labels, loc="upper center", ncols=len(handles), frameon=False)
    if caption:
        bottom.text(0.5, 0.05, textwrap.fill(caption, 150), ha="center", va="bottom", style="italic")
    if path is not None:
        save_figure(fig, path, figure_format)
    return fig


def save_evaluation_figures(
    evaluation: Evaluation,
    ref_map: ReferenceMap,
    folder: PathLike,
    prefix: str = "",
    query: str | None = None,
    params: LocalizationParams | None = None,
    heatmap_frames: list[int] | None = None,
    figure_format: str = "png",
) -> list[Path]:
    """Writes the figures of one query into ``folder``; returns their paths.

    ``<prefix>error_vs_seq_len.<fmt>``, ``<prefix>error_vs_noise.<fmt>``,
    ``<prefix>error_vs_interpolation.<fmt>`` (when both settings ran) and
    ``<prefix>heatmap_frame<i>.<fmt>`` for each heat-map frame (default: :func:`pick_heatmap_frame`),
    where ``fmt`` is ``figure_format`` (png, pdf or svg); from the paper's method's rows (none
    when only the filter ran: it has its own figures).
    """
    evaluation = evaluation.subset("paper")
    if len(evaluation) == 0:
        return []
    matches = next((m for m in evaluation.matches if query is None or m.name == query), None)
    if matches is None:
        raise ValueError(f"no query named {query!r} in the evaluation")
    query = matches.name if len(evaluation.matches) > 1 else query

    def target(stem: str) -> Path:
        return figure_path(folder, f"{prefix}{stem}", figure_format)

    common: dict[str, Any] = {"figure_format": figure_format}
    paths = [target("error_vs_seq_len"), target("error_vs_noise")]
    seq_len_figure(evaluation, query, path=paths[0], **common)
    noise_figure(evaluation, query, path=paths[1], **common)
    if len(evaluation.settings.interpolation) > 1:
        paths.append(target("error_vs_interpolation"))
        interpolation_figure(evaluation, query, path=paths[-1], **common)
    seq_len = headline_seq_len(evaluation)
    frames = heatmap_frames if heatmap_frames is not None else [pick_heatmap_frame(evaluation, query, seq_len)]
    for frame in frames:
        paths.append(target(f"heatmap_frame{frame}"))
        caption = explain_heatmap_frame(evaluation, frame, query, seq_len, requested=heatmap_frames is not None)
        heatmap_figure(ref_map, matches, frame, seq_len, params, path=paths[-1], caption=caption, **common)
    return paths
