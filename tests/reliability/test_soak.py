"""Long runs: frames streamed through the localizers for hours-equivalent, with flat memory and
no growth in per-frame time, and answers that do not drift.

The stream is periodic (the robot drives the same loop again and again, with the same sensor
noise), and each localizer's state covers only its last few frames, so the answers of the last
lap must equal those of the first lap exactly.

Size: ``NIGHTLOC_SOAK_FRAMES`` frames per localizer (the bounded CI run, by default: 20 000
through the RouteLocalizer, 10 000 through the Localizer, whose heat maps cost more per frame;
docs/reliability.md reports a 100 000-frame run of each). Measured: Python heap growth with tracemalloc (numpy
buffers included), resident set size from /proc (C++ allocations included), and the mean time
per frame in windows of 1000 frames, first windows against last windows. Time is the process's
CPU time, not wall time, and the bound is generous: the machine is shared, so only a real
trend, not another process's load, should fail it.
"""

from __future__ import annotations

import os
import time
import tracemalloc
from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np
import pytest

import nightloc
from nightloc import route

pytestmark = pytest.mark.slow


def soak_frames(default: int) -> int:
    """Frames to stream: ``NIGHTLOC_SOAK_FRAMES`` when set, else ``default``."""
    return int(os.environ.get("NIGHTLOC_SOAK_FRAMES", default))


WINDOW = 1000
WARM_UP = 1000
#: Bounds (generous; see the module docstring).
MAX_HEAP_GROWTH = 512 * 1024  # bytes over the whole run
MAX_RSS_GROWTH = 16 * 1024 * 1024
MAX_SLOWDOWN = 2.0  # median per-frame time of the last 3 windows / the first 3


def _rss_bytes() -> int:
    try:
        with open("/proc/self/statm") as stream:
            return int(stream.read().split()[1]) * os.sysconf("SC_PAGE_SIZE")
    except (OSError, ValueError, AttributeError):  # not Linux: fall back to the peak
        import resource

        return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss * 1024


@dataclass
class SoakReport:
    frames: int
    heap_growth: int = 0
    rss_growth: int = 0
    window_times: list[float] = field(default_factory=list)  # mean CPU seconds per frame, per window
    first_lap: list = field(default_factory=list)
    last_lap: list = field(default_factory=list)

    @property
    def slowdown(self) -> float:
        first = float(np.median(self.window_times[:3]))
        last = float(np.median(self.window_times[-3:]))
        return last / first

    def summary(self, name: str) -> str:
        parts = np.array_split(self.window_times, min(10, len(self.window_times)))  # tenths of the run
        deciles = [f"{1e6 * float(np.median(part)):.0f}" for part in parts]
        return (
            f"{name}: {self.frames} frames, "
            f"{1e6 * float(np.median(self.window_times)):.1f} us CPU/frame (median window), "
            f"last/first windows {self.slowdown:.2f}, heap growth {self.heap_growth / 1024:.1f} KiB, "
            f"RSS growth {self.rss_growth / 2**20:.2f} MiB; us/frame by tenth of the run: {' '.join(deciles)}"
        )


def soak(step: Callable[[int], object], frames: int, lap: int) -> SoakReport:
    """Calls ``step(i)`` for i in 0..frames-1 and measures memory, time and the answers of the
    first and last complete laps after the warm-up."""
    assert frames >= WARM_UP + 4 * WINDOW and frames >= WARM_UP + 2 * lap
    report = SoakReport(frames)
    first_lap_start = -(-WARM_UP // lap) * lap
    last_lap_start = (frames // lap - 1) * lap
    # Tracing starts before the warm-up: the state a localizer keeps (its last frames) is then
    # allocated under tracing, and its steady replacement does not read as growth.
    tracemalloc.start()
    try:
        for i in range(WARM_UP):
            answer = step(i)
            if first_lap_start <= i < first_lap_start + lap:
                report.first_lap.append(answer)
        heap_start = tracemalloc.get_traced_memory()[0]
        rss_start = _rss_bytes()
        window_start = time.process_time()
        for i in range(WARM_UP, frames):
            answer = step(i)
            if first_lap_start <= i < first_lap_start + lap:
                report.first_lap.append(answer)
            if last_lap_start <= i < last_lap_start + lap:
                report.last_lap.append(answer)
            if (i - WARM_UP + 1) % WINDOW == 0:
                now = time.process_time()
                report.window_times.append((now - window_start) / WINDOW)
                window_start = now
        report.heap_growth = tracemalloc.get_traced_memory()[0] - heap_start
        report.rss_growth = _rss_bytes() - rss_start
    finally:
        tracemalloc.stop()
    return report


def check(report: SoakReport, name: str) -> None:
    print(report.summary(name))
    assert report.heap_growth < MAX_HEAP_GROWTH, report.summary(name)
    assert report.rss_growth < MAX_RSS_GROWTH, report.summary(name)
    assert report.slowdown < MAX_SLOWDOWN, report.summary(name)
    assert len(report.first_lap) == len(report.last_lap) > 0
    assert report.first_lap == report.last_lap, f"{name}: answers drift between the first and the last lap"


def test_route_localizer_soak():
    lap = 250
    rng = np.random.default_rng(0)
    refs = nightloc.patch_normalize(rng.integers(0, 256, (lap, 24, 48), dtype=np.uint8), wrap=False)
    noise = rng.integers(-25, 26, (lap, 24, 48))
    stream = np.clip(refs.astype(np.int16) + noise, 0, 255).astype(np.uint8)  # the night laps
    localizer = route.RouteLocalizer(refs, prepared=True, threads=1)

    def step(i: int):
        update = localizer.update(stream[i % lap], prepared=True)
        return update.ref, round(update.score, 9)

    frames = soak_frames(20000)
    report = soak(step, frames, lap)
    check(report, "RouteLocalizer")
    correct = sum(ref == i % lap for i, (ref, _) in enumerate(report.last_lap, start=(frames // lap - 1) * lap))
    assert correct > 0.9 * lap  # and it localizes


def test_localizer_soak():
    """The 2D localizer on a loop of 200 places (a lawn-mower pattern), with noisy map-frame
    odometry that repeats every lap, seq_len 7 (the paper's headline setting)."""
    lap = 200
    rng = np.random.default_rng(1)
    xs, ys = np.meshgrid(np.arange(20) * 0.5, np.arange(10) * 0.5)
    xs[1::2] = xs[1::2, ::-1]  # boustrophedon: the mower's path
    positions = np.column_stack([xs.ravel(), ys.ravel()])
    images = nightloc.patch_normalize(rng.integers(0, 256, (lap, 24, 48), dtype=np.uint8))
    ref_map = nightloc.ReferenceMap(images, positions, rng.uniform(-np.pi, np.pi, lap))
    noise = rng.integers(-25, 26, (lap, 24, 48))
    night = np.clip(np.roll(images, 11, axis=2).astype(np.int16) + noise, 0, 255).astype(np.uint8)
    steps = np.diff(positions, axis=0, append=positions[:1])  # the step that leads to place i + 1
    odometry = [tuple(step + rng.normal(0, 0.05, 2)) for step in np.roll(steps, 1, axis=0)]
    localizer = nightloc.Localizer(ref_map, method="paper", seq_len=7, grid_width=50, grid_height=50)  # 50x50: CI time

    def step(i: int):
        estimate = localizer.update(night[i % lap], odometry[i % lap] if i else None, prepared=True)
        return round(estimate.x, 9), round(estimate.y, 9), estimate.ref_index

    frames = soak_frames(10000)
    report = soak(step, frames, lap)
    check(report, "Localizer")
    start = (frames // lap - 1) * lap
    correct = sum(ref == i % lap for i, (_, _, ref) in enumerate(report.last_lap, start=start))
    assert correct > 0.9 * lap  # and it localizes
