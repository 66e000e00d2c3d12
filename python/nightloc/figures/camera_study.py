"""The camera study's figure (``nightloc camera-study``): error against pixels, one line per light
level, and error against darkness, one line per sensor; one row of panels per method."""

from __future__ import annotations

import os
from typing import TYPE_CHECKING, Union

import numpy as np
from matplotlib.figure import Figure

from ._common import new_figure, save_figure, styled

if TYPE_CHECKING:
    from ..studies.camera import CameraStudy, Sensor

__all__ = ["camera_study_figure"]

PathLike = Union[str, "os.PathLike[str]"]


_COLOURS = ("#1b9e77", "#d95f02", "#7570b3", "#e7298a", "#66a61e", "#e6ab02", "#a6761d", "#666666")
_MARKERS = ("o", "s", "^", "D", "v", "P", "X", "<")
#: Side-by-side offset of the lines: a fraction of the x step (darkness), a factor (pixels, log axis).
_DODGE = 0.06
_LOG_DODGE = 1.06


def _line_style(k: int) -> dict:
    """The k-th line's colour and marker (hollow, so a line under another still shows)."""
    return {
        "color": _COLOURS[k % len(_COLOURS)],
        "marker": _MARKERS[k % len(_MARKERS)],
        "markerfacecolor": "none",
        "markersize": 6,
    }


@styled
def camera_study_figure(
    study: CameraStudy,
    sensor: Sensor | None = None,
    size: tuple[int, int] | None = None,
    path: PathLike | None = None,
) -> Figure:
    """Median error (m, with p95 dotted) against matching pixels at ``sensor`` (default the study's
    sensor nearest the synthetic camera's 4000 e- well), one line per darkness; and against
    darkness at ``size`` (default the size nearest 48 x 24), one line per sensor. Lines are set a
    little apart sideways, each with its own hollow marker, so that equal results stay visible.
    Saved to ``path`` when given."""
    settings = study.settings
    if sensor is None:
        sensor = min(settings.sensors, key=lambda s: (abs(s.full_well - 4000.0), s.read_noise))
    if size is None:
        size = min(settings.sizes, key=lambda s: (abs(s[0] * s[1] - 48 * 24), s))
    methods = settings.methods
    fig, panels = new_figure(10.0, 3.6 * len(methods), len(methods), 2)
    axes = np.asarray(panels).reshape(len(methods), 2)
    for row, method in enumerate(methods):
        left, right = axes[row, 0], axes[row, 1]
        pixels = np.array([w * h for w, h in settings.sizes], dtype=float)
        for k, darkness in enumerate(settings.darkness):
            cells = [study.row(w, h, darkness, sensor, method) for w, h in settings.sizes]
            # lines of equal values (darkness 0 and 1 in enough light) stay visible side by side
            shifted = pixels * _LOG_DODGE ** (k - (len(settings.darkness) - 1) / 2)
            style = _line_style(k)
            left.plot(shifted, [c.median_m for c in cells], "-", **style, label=f"darkness {darkness:g}")
            left.plot(shifted, [c.p95_m for c in cells], ":", color=style["color"], linewidth=0.9)
        left.set_xscale("log")
        left.set_xticks(pixels, [f"{w}x{h}\n{w * h}" for w, h in settings.sizes])
        left.minorticks_off()
        left.set_xlabel("matching resolution (pixels)")
        left.set_ylabel("error (m): median, p95 dotted")
        left.set_title(f"{method}: error vs resolution, {sensor.label}")
        left.legend(loc="upper right")
        levels = np.array(settings.darkness, dtype=float)
        step = float(np.min(np.diff(levels))) if len(levels) > 1 else 1.0
        for k, s in enumerate(settings.sensors):
            cells = [study.row(size[0], size[1], d, s, method) for d in settings.darkness]
            shifted = levels + _DODGE * step * (k - (len(settings.sensors) - 1) / 2)
            style = _line_style(k)
            right.plot(shifted, [c.median_m for c in cells], "-", **style, label=s.label)
            right.plot(shifted, [c.p95_m for c in cells], ":", color=style["color"], linewidth=0.9)
        right.set_xlabel("darkness (each step of 1: 100x fewer photons)")
        right.set_ylabel("error (m): median, p95 dotted")
        right.set_title(f"{method}: error vs light at {size[0]}x{size[1]}")
        right.legend(loc="upper left")
    draws = f"{settings.draws} noise draw{'s' if settings.draws != 1 else ''}"
    fig.suptitle(f"camera study, {study.world}: {draws}, sequence length {settings.seq_len}")
    if path is not None:
        save_figure(fig, path)
    return fig
