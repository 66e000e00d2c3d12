"""Generation time of the synthetic world (nightloc.synth).

Groups: one 192x96 panorama (ray casting + shading + sensor) per world and lighting; a whole
traverse (41 night frames of the garden query, 1 and 2 threads); the full default dataset
(202 frames, both worlds, all cores: slow marker). ``extra_info["ms_per_frame"]`` is the
minimum time per frame.

    python -m pytest benchmarks/test_bench_synth.py --benchmark-only --benchmark-columns=min,median
"""

from __future__ import annotations

import shutil
import tempfile
from pathlib import Path

import numpy as np
import pytest

from nightloc.synth import SynthScene, default_dataset, plan_traverses


def record(benchmark, frames: int) -> None:
    stats = getattr(benchmark, "stats", None)
    if stats is not None and stats.stats.min > 0:
        benchmark.extra_info["ms_per_frame"] = round(1e3 * stats.stats.min / frames, 2)


@pytest.mark.parametrize("condition", ["day", "night"])
@pytest.mark.parametrize("world", ["garden", "living_room"])
def test_one_panorama(benchmark, world, condition):
    scene = SynthScene(world, seed=0)
    benchmark.group = "synth: one 192x96 panorama"
    x0, y0, x1, y1 = scene.world.mapped_area
    rng = np.random.default_rng(0)
    image = benchmark(scene.frame, condition, (x0 + x1) / 2 + 0.3, (y0 + y1) / 2 - 0.2, 0.7, rng)
    record(benchmark, 1)
    assert image.shape == (96, 192, 3) and image.dtype == np.uint8 and image.std() > 2


@pytest.mark.parametrize("threads", [1, 2])
def test_garden_night_query_traverse(benchmark, threads):
    scene = SynthScene("garden", seed=0)
    plan = {p.name: p for p in plan_traverses("garden", 0)}["night_query"]
    benchmark.group = "synth: garden night query, 41 frames"
    frames = benchmark.pedantic(lambda: list(scene.render_plan(plan, threads=threads)), rounds=2)
    record(benchmark, len(frames))
    assert len(frames) == 41


@pytest.mark.slow
def test_default_dataset_from_scratch(benchmark):
    benchmark.group = "synth: default dataset, 202 frames"

    def generate():
        cache = Path(tempfile.mkdtemp(prefix="nightloc-bench-"))
        try:
            return default_dataset(cache_dir=cache)
        finally:
            shutil.rmtree(cache, ignore_errors=True)

    paths = benchmark.pedantic(generate, rounds=1)
    record(benchmark, 202)
    assert set(paths) == {"garden", "living_room"}
