"""Helpers of the nightloc.synth tests: a bare test world and the default dataset, made once."""

from __future__ import annotations

import atexit
import functools
import shutil
import tempfile
from pathlib import Path

import numpy as np

from nightloc.synth.textures import Texture
from nightloc.synth.world import GroundMap, LightSource, World


def bare_world(objects: list[object], lights: dict[str, LightSource] | None = None, indoor: bool = False) -> World:
    """A world of ``objects`` (material ``"grey"``) on a uniform ground, mapped from -10 to 10 m
    in 2 cm cells (farther ground points take the colour of the map's edge)."""
    materials = {"grey": Texture(np.full((8, 8, 3), 128, np.uint8), 100.0)}
    ground = GroundMap(np.full((1000, 1000, 3), 0.25, np.float32), -10.0, -10.0, 50.0)
    return World("bare", objects, materials, ground, (0.0, 0.0, 1.0, 1.0), indoor, 0.3, dict(lights or {}), 0)


@functools.cache
def default_synth_data() -> dict[str, dict[str, Path]]:
    """``nightloc.synth.default_dataset`` generated once per test run into a temporary cache."""
    from nightloc.synth import default_dataset

    cache = Path(tempfile.mkdtemp(prefix="nightloc-synth-test-"))
    atexit.register(shutil.rmtree, cache, True)
    return default_dataset(cache_dir=cache)
