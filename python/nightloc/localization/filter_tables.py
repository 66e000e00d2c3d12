"""The map's localizer's map-only tables, as a map file stores them for firmware.

A robot without Python (``nightloc_replay``, the C++ ``nightloc::Localizer``; docs/cpp_core.md)
runs the map's localizer, ``nightloc.Localizer(ref_map)``: the grid Bayes filter with the
:class:`~nightloc.localization.grid_filter.FilterParams` and
:class:`~nightloc.localization.localizer.LocalizationParams` the map keeps
(:attr:`nightloc.ReferenceMap.settings`: ``nightloc build-map --params``; the defaults for a map
without) and the odometry noise of Table III model 1. What that localizer computes once per map
with scipy (the grid, the Delaunay interpolation weights, the nearest reference of each cell)
cannot be reproduced bit for bit without scipy, and the filter's settings must be the ones Python
gives its core, not a second copy: :func:`filter_tables` takes all of it from that localizer, and
:meth:`nightloc.ReferenceMap.save` stores it beside the images (map format 3).

Header (``header["localizer"]``, JSON): ``method`` ("filter"), ``grid`` (``x0, y0, dx, dy``
metres: the centre of cell (0, 0) and the spacing; ``width, height`` cells), ``columns`` (of the
prepared images), ``shifts`` (the table's column shifts), ``field_of_view`` (radians; 0 for a
panorama), ``window`` (``[columns, rows]`` of the translation window), ``settings`` (what
:class:`~nightloc.localization.grid_filter.GridFilter` gives the core, key for key), the
``localization`` and ``filter`` parameters they came from (what
:meth:`nightloc.ReferenceMap.load` reads back as the map's settings) and ``odometry_noise``
(``[distance_std, heading_std]``, then ``distance_per_metre, heading_per_radian`` for a
step-scaled model).

Arrays (the grid has ``C = width x height`` cells, row-major from the lowest y; ``P`` places):
``filter_weights_indptr`` ``(C + 1,)`` int32, ``filter_weights_indices`` int32 and
``filter_weights_data`` float32 (the CSR interpolation weights, cells x places, as the core takes
them), ``filter_place_of_ref`` ``(N,)`` int32 (the place of each reference) and
``filter_closest_ref`` ``(C,)`` int32 (the reference nearest to each cell centre, the lowest
index where several share its place).
"""

from __future__ import annotations

from typing import Any

import numpy as np

from ..config import params_to_dict
from ..mapping.reference_map import ReferenceMap
from .localizer import Localizer

__all__ = ["FILTER_ARRAYS", "filter_tables"]

#: The arrays :func:`filter_tables` adds to a map file.
FILTER_ARRAYS = (
    "filter_weights_indptr",
    "filter_weights_indices",
    "filter_weights_data",
    "filter_place_of_ref",
    "filter_closest_ref",
)


def filter_tables(ref_map: ReferenceMap) -> tuple[dict[str, Any], dict[str, np.ndarray]]:
    """The map's localizer's header section and arrays for ``ref_map`` (see the module docstring)."""
    localizer = Localizer(ref_map)
    flt = localizer.grid_filter
    mapper = localizer.mapper
    grid = mapper.grid
    weights = mapper.weights
    closest = np.array([mapper.closest_ref(cell) for cell in range(grid.width * grid.height)], dtype=np.int32)
    header = {
        "method": localizer.method,
        "grid": {
            "x0": grid.x0,
            "y0": grid.y0,
            "dx": grid.dx,
            "dy": grid.dy,
            "width": grid.width,
            "height": grid.height,
        },
        "columns": int(ref_map.params.width),
        "shifts": [int(s) for s in flt.shifts],
        "field_of_view": float(flt.field_of_view),
        "window": [int(flt.window[0]), int(flt.window[1])],
        "settings": flt.settings.to_dict(),
        "localization": params_to_dict(localizer.params),
        "filter": params_to_dict(localizer.filter_params),
        "odometry_noise": [float(flt.noise.distance_std), float(flt.noise.heading_std)]
        + ([float(flt.noise.distance_per_metre), float(flt.noise.heading_per_radian)] if flt.noise.step_scaled else []),
    }
    arrays = {
        "filter_weights_indptr": weights.indptr.astype(np.int32),
        "filter_weights_indices": weights.indices.astype(np.int32),
        "filter_weights_data": weights.data.astype(np.float32),
        "filter_place_of_ref": np.asarray(mapper.place_of_ref, dtype=np.int32),
        "filter_closest_ref": closest,
    }
    return header, arrays
