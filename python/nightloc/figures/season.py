"""The season study's figure (``tools/season_study.py``): an experience map night after night
beside the day map alone: the test drives' median and p95, the learning drives' median, the map's
references and places, the time per frame."""

from __future__ import annotations

import os
from collections.abc import Sequence
from typing import TYPE_CHECKING, Union

import numpy as np
from matplotlib.figure import Figure

from ._common import new_figure, save_figure, styled

if TYPE_CHECKING:
    from ..studies.season import NightRecord

__all__ = ["season_figure"]

PathLike = Union[str, "os.PathLike[str]"]
_COLOURS = {"wheel": "#1b9e77", "robot0": "#66a61e", "robot1": "#d95f02", "robot2": "#e6ab02", "robot3": "#7570b3"}


def _curve(
    records: Sequence[NightRecord], kind: str, drive: str, ref_map: str, field: str
) -> tuple[list[int], list[float]]:
    """Nights and the median over the chain's draws of ``field`` (NaN nights left out)."""
    rows = [r for r in records if r.odometry == kind and r.drive == drive and r.map == ref_map]
    nights = sorted({r.night for r in rows})
    out: tuple[list[int], list[float]] = ([], [])
    for night in nights:
        values = [float(getattr(r, field)) for r in rows if r.night == night]
        finite = [v for v in values if np.isfinite(v)]
        if finite:
            out[0].append(night)
            out[1].append(float(np.median(finite)))
    return out


@styled
def season_figure(records: Sequence[NightRecord], title: str = "", path: PathLike | None = None) -> Figure:
    """Four panels over the season's nights, one colour per odometry kind (the median over its
    draws), the learned map solid and the day map dashed: the test drives' median and p95 error,
    the learning drives' median, the map's references (places dotted) and the time per frame;
    bad nights marked grey. Saved to ``path`` when given."""
    fig, panels = new_figure(11.0, 7.0, 2, 2)
    (tests, learns), (size, timing) = panels
    kinds = sorted({r.odometry for r in records}, key=lambda k: (k != "wheel", k))
    for kind in kinds:
        colour = _COLOURS.get(kind, "#666666")
        for ref_map, style in (("learned", "-"), ("day", "--")):
            label = f"{kind}, {'experience map' if ref_map == 'learned' else 'day map'}"
            nights, medians = _curve(records, kind, "test", ref_map, "median_m")
            tests.plot(nights, medians, style, marker="o", markersize=3, color=colour, label=label)
            nights, p95 = _curve(records, kind, "test", ref_map, "p95_m")
            tests.plot(nights, p95, style, color=colour, linewidth=0.7, alpha=0.6)
            nights, medians = _curve(records, kind, "learn", ref_map, "median_m")
            learns.plot(nights, medians, style, color=colour, linewidth=1.0)
            nights, ms = _curve(records, kind, "learn", ref_map, "ms_per_frame")
            timing.plot(nights, ms, style, color=colour, linewidth=1.0)
        nights, refs = _curve(records, kind, "learn", "learned", "references")
        size.plot(nights, refs, "-", color=colour, label=f"{kind}: references")
        nights, places = _curve(records, kind, "learn", "learned", "places")
        size.plot(nights, places, ":", color=colour, label=f"{kind}: places")
    day_refs = next((r.references for r in records if r.map == "day"), 0)
    size.axhline(day_refs, color="k", linestyle="--", linewidth=0.8, label="day map")
    size.axhline(4 * day_refs, color="k", linestyle=":", linewidth=0.8, label="4x the day map")
    for bad in sorted({r.night for r in records if r.bad}):
        for axes in (tests, learns, size, timing):
            axes.axvline(bad, color="0.6", linewidth=4, alpha=0.3)
    tests.set_title("test drives (other path): median, p95 thin")
    tests.set_ylabel("error (m)")
    tests.legend(loc="upper right", fontsize=7)
    learns.set_title("learning drives (day path) before learning: median")
    learns.set_ylabel("error (m)")
    size.set_title("the map before each night")
    size.set_ylabel("count")
    size.legend(loc="upper left", fontsize=7)
    timing.set_title("time per frame (prepare, match, update; one thread)")
    timing.set_ylabel("ms")
    for axes in (tests, learns, size, timing):
        axes.set_xlabel("night")
    if title:
        fig.suptitle(title)
    if path is not None:
        save_figure(fig, path)
    return fig
