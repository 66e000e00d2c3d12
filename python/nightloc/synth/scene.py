"""What a synthetic world is made of: :class:`World` (solids, textures, ground, lights, the mapped
area), its :class:`GroundMap` and its :class:`LightSource` lamps. The worlds themselves are built
in :mod:`nightloc.synth.world` and :mod:`nightloc.synth.large_garden`.

World frame: metres, x right (east), y up (north), z up.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from .geometry import Cylinder, PackedGeometry, Prism, Solid, check_free
from .textures import Texture

__all__ = ["RGB", "GroundMap", "LightSource", "World"]

RGB = tuple[float, float, float]


@dataclass(frozen=True)
class LightSource:
    """A small lamp: position ``(x, y, z)`` in metres and RGB power.

    ``power`` is the irradiance (in the worlds' radiance units, where direct noon sun on a
    facing surface is about 3) that the lamp gives a surface facing it 1 m away; it falls off
    with the squared distance. ``conditions`` lists when it is on (``"day"``, ``"night"``).
    Objects whose ``emission`` tag equals the light's name glow while it is on.
    """

    position: tuple[float, float, float]
    power: RGB
    conditions: tuple[str, ...]
    glow: float = 4.0  # radiance gain of the glowing object (lamp shade, lit window)


@dataclass(frozen=True)
class GroundMap:
    """A map of the ground plane: ``values[row, col]`` is the cell at ``x = x0 + (col + 0.5) / ppm``,
    ``y = y0 + (row + 0.5) / ppm`` (rows go north). ``values`` is ``(rows, cols, 3)`` float32.

    A world's albedo map may say where its lawn is: ``lawn`` ``(rows, cols)`` bool, the grass cells,
    and ``stripes`` ``(rows, cols)`` float32, the mowing stripes' brightness factor the builder
    applied there (1 elsewhere); a season of nights (:mod:`nightloc.synth.season`) regrows and
    mows the lawn from them. None: no lawn (a room, an irradiance map)."""

    values: np.ndarray
    x0: float
    y0: float
    pixels_per_metre: float
    lawn: np.ndarray | None = None
    stripes: np.ndarray | None = None

    def sample(self, x: np.ndarray, y: np.ndarray) -> np.ndarray:
        """Nearest-cell values at ground points (clamped to the map), ``x.shape + (3,)``."""
        rows, cols = self.values.shape[:2]
        c = np.clip(((x - self.x0) * self.pixels_per_metre).astype(np.int64), 0, cols - 1)
        r = np.clip(((y - self.y0) * self.pixels_per_metre).astype(np.int64), 0, rows - 1)
        return self.values[r, c]

    def cell_centres(self) -> tuple[np.ndarray, np.ndarray]:
        """``(x, y)`` of every cell, each ``(rows, cols)``."""
        rows, cols = self.values.shape[:2]
        xs = self.x0 + (np.arange(cols) + 0.5) / self.pixels_per_metre
        ys = self.y0 + (np.arange(rows) + 0.5) / self.pixels_per_metre
        return np.meshgrid(xs, ys)


@dataclass
class World:
    """Everything needed to render a world.

    Attributes:
        name: ``"garden"`` or ``"living_room"``.
        objects: prisms then cylinders.
        materials: texture of every material name used by ``objects``.
        ground: albedo of the ground plane (linear RGB in [0, 1]).
        mapped_area: ``(x0, y0, x1, y1)`` metres: where the robot drives and maps.
        indoor: True for rooms (no sun on walls; sunlight enters through windows only).
        camera_height: height of the panoramic camera above the ground, metres.
        lights: light sources by name.
    """

    name: str
    objects: list[Solid]
    materials: dict[str, Texture]
    ground: GroundMap
    mapped_area: tuple[float, float, float, float]
    indoor: bool
    camera_height: float
    lights: dict[str, LightSource]
    seed: int
    geometry: PackedGeometry = field(init=False)
    material_index: np.ndarray = field(init=False)  # (O,) index into material_names
    material_names: list[str] = field(init=False)

    def __post_init__(self) -> None:
        self.objects = [o for o in self.objects if isinstance(o, Prism)] + [
            o for o in self.objects if isinstance(o, Cylinder)
        ]
        self.geometry = PackedGeometry(self.objects)
        missing = sorted({o.material for o in self.objects} - set(self.materials))
        if missing:
            raise ValueError(f"world {self.name!r} uses materials without textures: {missing}")
        self.material_names = sorted(self.materials)
        lookup = {name: i for i, name in enumerate(self.material_names)}
        self.material_index = np.array([lookup[o.material] for o in self.objects], dtype=np.int64)

    def check_camera_positions(self, positions: np.ndarray) -> None:
        """Raises ValueError for a camera position inside a solid object (0.12 m clearance)."""
        check_free(self.geometry, positions, self.camera_height, clearance=0.12)
