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


@styled
def camera_study_figure(
    study: CameraStudy,
    sensor: Sensor | None = None,
    size: tuple[int, int] | None = None,
    path: PathLike | None = None,
) -> Figure:
    """Median error (m, with p95 dotted) against matching pixels at ``sensor`` (default the study's
    sensor nearest the synthetic camera's 4000 e- well), one line per darkness; and against
    darkness at ``size`` (default the size nearest 48 x 24), one line per sensor. Saved to ``path``
    when given."""
    settings = study.settings
    if sensor is None:
        sensor = min(settings.sensors, key=lambda s: (abs(s.full_well - 4000.0), s.read_noise))
    if size is None:
        size = min(settings.sizes, key=lambda s: (abs(s[0] * s[1] - 48 * 24), s))
    methods = settings.methods
    fig, panels = new_figure(10.0, 3.6 * len(methods), len(methods), 2)
    axes = np.asarray(panels).reshape(len(methods), 2)
    colours = ["#1b9e77", "#d95f02", "#7570b3", "#e7298a", "#66a61e", "#e6ab02", "#a6761d", "#666666"]
    for row, method in enumerate(methods):
        left, right = axes[row, 0], axes[row, 1]
        pixels = [w * h for w, h in settings.sizes]
        for k, darkness in enumerate(settings.darkness):
            cells = [study.row(w, h, darkness, sensor, method) for w, h in settings.sizes]
            colour = colours[k % len(colours)]
            left.plot(pixels, [c.median_m for c in cells], "o-", color=colour, label=f"darkness {darkness:g}")
            left.plot(pixels, [c.p95_m for c in cells], ":", color=colour, linewidth=0.9)
        left.set_xscale("log")
        left.set_xticks(pixels, [f"{w}x{h}\n{w * h}" for w, h in settings.sizes])
        left.minorticks_off()
        left.set_xlabel("matching resolution (pixels)")
        left.set_ylabel("error (m): median, p95 dotted")
        left.set_title(f"{method}: error vs resolution, {sensor.label}")
        left.legend(loc="upper right")
        for k, s in enumerate(settings.sensors):
            cells = [study.row(size[0], size[1], d, s, method) for d in settings.darkness]
            colour = colours[k % len(colours)]
            right.plot(settings.darkness, [c.median_m for c in cells], "o-", color=colour, label=s.label)
            right.plot(settings.darkness, [c.p95_m for c in cells], ":", color=colour, linewidth=0.9)
        right.set_xlabel("darkness (each step of 1: 100x fewer photons)")
        right.set_ylabel("error (m): median, p95 dotted")
        right.set_title(f"{method}: error vs light at {size[0]}x{size[1]}")
        right.legend(loc="upper left")
    draws = f"{settings.draws} noise draw{'s' if settings.draws != 1 else ''}"
    fig.suptitle(f"camera study, {study.world}: {draws}, sequence length {settings.seq_len}")
    if path is not None:
        save_figure(fig, path)
    return fig
