"""Figures of an evaluation, in the style of the paper, drawn with :mod:`nightloc.figures.plotting`.

* :func:`seq_len_figure`: distance error box plots against sequence length (Figures 10, 16, 21);
* :func:`noise_figure`: against the odometry noise model at one sequence length (11, 17, 22);
* :func:`interpolation_figure`: interpolation on against off, per sequence length (12, 18);
* :func:`heatmap_figure`: one query frame's heat maps, single frame beside the sequence (Figure 9):
  reference positions as green circles sized by how well they match, a red cross at the truth,
  a green cross at the best-matching reference and a black cross at the interpolated estimate.

Every function returns the :class:`~nightloc.figures.plotting.Figure` and saves it when given a path.
"""

from __future__ import annotations

import os
from pathlib import Path
from typing import Union

import numpy as np

from ..io.reference_map import ReferenceMap
from ..localization.evaluation import Evaluation, QueryMatches, replay
from ..localization.heatmap import HeatGrid, invert_scores
from ..localization.localizer import Estimate, LocalizationParams
from .plotting import Figure

__all__ = [
    "headline_seq_len",
    "heatmap_figure",
    "interpolation_figure",
    "noise_figure",
    "pick_heatmap_frame",
    "save_evaluation_figures",
    "seq_len_figure",
]

PathLike = Union[str, "os.PathLike[str]"]
#: The paper's sequence length for its noise and interpolation figures.
PAPER_SEQ_LEN = 7


def headline_seq_len(evaluation: Evaluation) -> int:
    """The sequence length of the noise and interpolation figures: 7 (the paper's) when it was
    evaluated, else the longest evaluated."""
    lengths = evaluation.settings.seq_lengths
    return PAPER_SEQ_LEN if PAPER_SEQ_LEN in lengths else max(lengths)


def _label(query: str | None) -> str:
    return f" - {query}" if query else ""


def _preferred(values, wanted):
    return wanted if wanted in values else values[0]


def seq_len_figure(
    evaluation: Evaluation,
    query: str | None = None,
    noise_model: int = 0,
    interpolation: bool = True,
    path: PathLike | None = None,
) -> Figure:
    """Box plots of the distance error for each sequence length (one noise model)."""
    settings = evaluation.settings
    noise_model = _preferred(settings.noise_models, noise_model)
    interpolation = _preferred(settings.interpolation, interpolation)
    lengths = [
        n
        for n in settings.seq_lengths
        if evaluation.errors(seq_len=n, noise_model=noise_model, interpolation=interpolation, query=query).size
    ]
    return _error_boxes(
        evaluation,
        query,
        [
            evaluation.errors(seq_len=n, noise_model=noise_model, interpolation=interpolation, query=query)
            for n in lengths
        ],
        [str(n) for n in lengths],
        width=max(420, 60 * len(lengths) + 160),
        title=f"Distance error vs sequence length{_label(query)}",
        xlabel=f"sequence length (frames); noise model {noise_model}, interpolation {'on' if interpolation else 'off'}",
        path=path,
    )


def noise_figure(
    evaluation: Evaluation,
    query: str | None = None,
    seq_len: int | None = None,
    interpolation: bool = True,
    path: PathLike | None = None,
) -> Figure:
    """Box plots of the distance error for each odometry noise model (one sequence length)."""
    settings = evaluation.settings
    seq_len = headline_seq_len(evaluation) if seq_len is None else seq_len
    interpolation = _preferred(settings.interpolation, interpolation)
    models = list(settings.noise_models)
    return _error_boxes(
        evaluation,
        query,
        [evaluation.errors(seq_len=seq_len, noise_model=m, interpolation=interpolation, query=query) for m in models],
        [str(m) for m in models],
        width=max(420, 80 * len(models) + 160),
        title=f"Distance error vs odometry noise{_label(query)}",
        xlabel=f"noise model (Table III); {seq_len}-frame sequences, interpolation {'on' if interpolation else 'off'}",
        path=path,
    )


def interpolation_figure(
    evaluation: Evaluation,
    query: str | None = None,
    noise_model: int = 0,
    path: PathLike | None = None,
) -> Figure:
    """Box plots with interpolation on beside off, for each sequence length."""
    settings = evaluation.settings
    noise_model = _preferred(settings.noise_models, noise_model)
    lengths = list(settings.seq_lengths)
    series = {}
    for interp in settings.interpolation:
        series["interpolation on" if interp else "interpolation off"] = [
            evaluation.errors(seq_len=n, noise_model=noise_model, interpolation=interp, query=query) for n in lengths
        ]
    fig = Figure(
        max(480, 90 * len(lengths) + 160), 420, title=f"Distance error with and without interpolation{_label(query)}"
    )
    ax = fig.axes()
    ax.grouped_boxplot(series, [str(n) for n in lengths], colors=["blue", "orange"][: len(series)])
    ax.set_xlabel(f"sequence length (frames); noise model {noise_model}")
    ax.set_ylabel("distance error (m)")
    ax.set_ylim(0, _top(evaluation, query))
    if len(series) > 1:
        ax.legend("upper right")
    if path is not None:
        fig.save(path)
    return fig


def _error_boxes(
    evaluation: Evaluation,
    query: str | None,
    groups: list[np.ndarray],
    labels: list[str],
    width: int,
    title: str,
    xlabel: str,
    path: PathLike | None,
) -> Figure:
    """One box per group of distance errors (m), on the evaluation's common error scale."""
    fig = Figure(width, 420, title=title)
    ax = fig.axes()
    ax.boxplot(groups, labels=labels)
    ax.set_xlabel(xlabel)
    ax.set_ylabel("distance error (m)")
    ax.set_ylim(0, _top(evaluation, query))
    if path is not None:
        fig.save(path)
    return fig


def _top(evaluation: Evaluation, query: str | None) -> float:
    errors = evaluation.errors(query=query)
    return float(max(errors.max() * 1.05, 0.1)) if errors.size else 1.0


def pick_heatmap_frame(evaluation: Evaluation, query: str | None = None, seq_len: int | None = None) -> int:
    """The query frame where the sequence helps most (noise model 0, interpolation on): the
    largest drop from the single-frame error to the ``seq_len``-frame error, among frames with
    ``seq_len - 1`` frames before them (when the traverse is that long)."""
    seq_len = headline_seq_len(evaluation) if seq_len is None else seq_len
    noise = _preferred(evaluation.settings.noise_models, 0)
    interp = _preferred(evaluation.settings.interpolation, True)
    first = min(evaluation.settings.seq_lengths)
    single = evaluation.errors(seq_len=first, noise_model=noise, interpolation=interp, query=query)
    multi = evaluation.errors(seq_len=seq_len, noise_model=noise, interpolation=interp, query=query)
    n = min(single.size, multi.size)
    if n == 0:
        raise ValueError("no rows for the heat-map figure")
    gain = single[:n] - multi[:n]
    full = min(seq_len - 1, n - 1)  # prefer frames with a whole sequence behind them
    return full + int(np.argmax(gain[full:]))


def heatmap_figure(
    ref_map: ReferenceMap,
    matches: QueryMatches,
    frame: int,
    seq_len: int = PAPER_SEQ_LEN,
    params: LocalizationParams | None = None,
    path: PathLike | None = None,
    estimates: list[Estimate] | None = None,
) -> Figure:
    """The paper's Figure 9 for one query frame: single-frame heat map beside the sequence's.

    Noise-free odometry, interpolation on. ``estimates`` may pass the two estimates (with heat
    maps) instead of replaying the localizer.
    """
    if estimates is None:
        estimates = [
            replay(ref_map, matches, frame, 1, params=params),
            replay(ref_map, matches, frame, seq_len, params=params),
        ]
    result = matches.results[frame]
    truth = matches.positions[frame]
    inverted = invert_scores(result.scores)  # 1 = best match, 0 = worst
    radii = 2.0 + 10.0 * inverted
    best = ref_map.positions[result.index]
    grid = HeatGrid.spanning(
        ref_map.positions, *(estimates[0].heatmap.shape[::-1]), margin=(params or LocalizationParams()).margin
    )
    fig = Figure(
        1100, 500, cols=2, title=f"Heat maps of query frame {frame} ({matches.images[frame]}) of {matches.name}"
    )
    for col, (est, label) in enumerate(zip(estimates, ["single frame", f"{int(estimates[1].frames)}-frame sequence"])):
        ax = fig.axes(0, col)
        ax.image(est.heatmap, grid.extent, cmap="jet", colorbar=True, colorbar_label="heat (inverted score)")
        ax.scatter(
            ref_map.positions[:, 0],
            ref_map.positions[:, 1],
            size=radii,
            color="lime",
            filled=False,
            thickness=2,
            label="references (size = match)",
        )
        ax.scatter([truth[0]], [truth[1]], size=7, color="red", marker="x", thickness=3, label="truth")
        ax.scatter([best[0]], [best[1]], size=7, color="green", marker="x", thickness=3, label="best reference")
        ax.scatter([est.x], [est.y], size=7, color="black", marker="x", thickness=3, label="estimate")
        error = float(np.hypot(est.x - truth[0], est.y - truth[1]))
        ax.set_title(f"{label}: error {error:.2f} m")
        ax.set_xlabel("x (m)")
        ax.set_ylabel("y (m)")
        ax.set_aspect_equal()
        ax.legend("below")
    if path is not None:
        fig.save(path)
    return fig


def save_evaluation_figures(
    evaluation: Evaluation,
    ref_map: ReferenceMap,
    folder: PathLike,
    prefix: str = "",
    query: str | None = None,
    params: LocalizationParams | None = None,
    heatmap_frames: list[int] | None = None,
) -> list[Path]:
    """Writes the figures of one query into ``folder``; returns their paths.

    ``<prefix>error_vs_seq_len.png``, ``<prefix>error_vs_noise.png``,
    ``<prefix>error_vs_interpolation.png`` (when both settings ran) and
    ``<prefix>heatmap_frame<i>.png`` for each heat-map frame (default: :func:`pick_heatmap_frame`).
    """
    out = Path(folder)
    matches = next((m for m in evaluation.matches if query is None or m.name == query), None)
    if matches is None:
        raise ValueError(f"no query named {query!r} in the evaluation")
    query = matches.name if len(evaluation.matches) > 1 else query
    paths = [out / f"{prefix}error_vs_seq_len.png", out / f"{prefix}error_vs_noise.png"]
    seq_len_figure(evaluation, query, path=paths[0])
    noise_figure(evaluation, query, path=paths[1])
    if len(evaluation.settings.interpolation) > 1:
        paths.append(out / f"{prefix}error_vs_interpolation.png")
        interpolation_figure(evaluation, query, path=paths[-1])
    seq_len = headline_seq_len(evaluation)
    frames = heatmap_frames if heatmap_frames is not None else [pick_heatmap_frame(evaluation, query, seq_len)]
    for frame in frames:
        paths.append(out / f"{prefix}heatmap_frame{frame}.png")
        heatmap_figure(ref_map, matches, frame, seq_len, params, path=paths[-1])
    return paths
