"""Per-frame cost of an experience map beside its day map (target: at most 2x the day map's).

A lawn of 1 421 places 0.5 m apart (25 x 15 m; the day map), and the same map after a season of
nights at its bound: two learned appearances at every place (4 263 references, the most the
retention rule keeps, ``LearningParams.max_learned``; docs/experience_maps.md), of which the
localizer matches per frame those nearest its belief, as many as the day references. One thread,
the 100 x 100 grid, 48 heading bins, wheel odometry with noise model 1, a prepared frame per
update (matching against every reference and the filter's update: one call into the core), the
belief settled on the robot's track. The garden's size (24 places, 96 references) in a second
group (72 references). Each benchmark checks that the experience map's learned looks are evidence
about their day images: a frame equal to a learned look localizes at its place.

    python -m pytest benchmarks/test_bench_experience.py --benchmark-only --benchmark-columns=min,median
"""

from __future__ import annotations

import numpy as np
import pytest

import nightloc
from nightloc.io.appearances import Appearances, LearnedNight

MOTION = nightloc.RobotMotion(0.5, 0.0, 0.0)
LEARNED_PER_PLACE = 2
LAWNS = {"lawn": (25.0, 15.0, 0.5), "garden": (7.0, 5.0, 1.2)}


def _maps(name: str) -> tuple[nightloc.ReferenceMap, nightloc.ReferenceMap]:
    """The day map and the experience map of a lawn (random prepared images, learned looks at the
    places' positions, headings turned a little)."""
    width, height, step = LAWNS[name]
    rng = np.random.default_rng(0)
    xs, ys = np.meshgrid(np.arange(0.5, width, step), np.arange(0.5, height, step))
    positions = np.column_stack([xs.ravel(), ys.ravel()])
    n = len(positions)
    images = nightloc.patch_normalize(rng.integers(0, 256, (n * (1 + LEARNED_PER_PLACE), 24, 48), dtype=np.uint8))
    headings = rng.uniform(-np.pi, np.pi, n)
    day = nightloc.ReferenceMap(images[:n], positions, headings)
    night = np.repeat(np.arange(1 + LEARNED_PER_PLACE, dtype=np.int32), n)
    nights = tuple(
        LearnedNight(k, f"night{k}", "2026-01-01T00:00:00Z", n, n, n, 0, 0) for k in range(1, LEARNED_PER_PLACE + 1)
    )
    appearances = Appearances(
        night, np.where(night > 0, 0.9, 0.0), np.zeros(len(night)), np.zeros(len(night), np.int64), nights,
        day.fingerprint,
    )  # fmt: skip
    experience = nightloc.ReferenceMap(
        images,
        np.tile(positions, (1 + LEARNED_PER_PLACE, 1)),
        np.concatenate([headings] + [headings + rng.normal(0, 0.05, n) for _ in range(LEARNED_PER_PLACE)]),
        appearances=appearances,
    )
    return day, experience


@pytest.fixture(scope="module", params=list(LAWNS))
def lawn(request):
    return request.param, *_maps(request.param)


def _tracking(ref_map: nightloc.ReferenceMap, look: np.ndarray) -> nightloc.Localizer:
    loc = nightloc.Localizer(ref_map, odometry_noise=1, threads=1)
    for _ in range(6):  # the belief settled at the look's place
        loc.update(look, MOTION)
    return loc


@pytest.mark.parametrize("which", ["day map", "experience map"])
def test_update_per_frame(benchmark, lawn, which):
    name, day, experience = lawn
    ref_map = day if which == "day map" else experience
    place = len(day) // 2
    look = experience.images[len(day) * 2 + place]  # a learned look of the middle place
    loc = _tracking(ref_map, look)
    benchmark.group = f"experience map, {name}: {len(day)} places, {len(experience)} references after the season"
    estimate = benchmark(loc.update, look, nightloc.RobotMotion(0.0, 0.0, 0.0))
    if which == "experience map":  # the learned look is evidence for its own place
        assert np.hypot(estimate.x - day.positions[place, 0], estimate.y - day.positions[place, 1]) < LAWNS[name][2]
