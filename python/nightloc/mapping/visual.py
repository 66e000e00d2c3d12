"""Relative heading between two panoramas of one place, to a fraction of a column.

Convention (docs/design.md): panorama column ``c`` looks along azimuth ``heading - 2*pi*c/W``; the
best column shift ``k`` of the query against a reference (:func:`nightloc.rotational_sad`) means
``heading_query - heading_ref = 2*pi*k/W``. This module refines ``k`` between columns: the SAD of
a shift grows about linearly on both sides of the true one (a "V", not a parabola), so the
minimum is placed where two lines of equal and opposite slope through the three lowest points
meet (:func:`subcolumn_minimum`).

Between two places apart, near objects move across the panorama (parallax) and pull the
whole-image minimum off the rotation. Parallax vanishes along the line joining the two places,
so when that direction is known (from the odometry), :func:`relative_heading` compares only
the columns that look along it, ahead and behind (``axis_half_width`` either side), searching
a few columns around the relative heading the odometry predicts (or the whole-image minimum):
a narrow strip of columns alone can match well at a wrong turn, the prediction keeps it near.
"""

from __future__ import annotations

import math

import numpy as np

from ..matching.sad import rotational_sad

__all__ = ["axis_columns", "relative_heading", "subcolumn_minimum"]


def subcolumn_minimum(costs: np.ndarray, circular: bool = True) -> float:
    """The position (in columns, fractional) of the minimum of ``costs`` by a symmetric V fit.

    Args:
        costs: ``(n,)`` cost per shift, lowest best.
        circular: the shifts wrap around (a full panorama); else the ends are not refined.

    Returns:
        ``k + delta`` with ``k`` the lowest cost's index and ``|delta| <= 0.5``; in ``[0, n)``
        when circular.
    """
    values = np.asarray(costs, dtype=np.float64)
    n = len(values)
    k = int(np.argmin(values))
    if n < 3 or (not circular and k in (0, n - 1)):
        return float(k)
    low, left, right = values[k], values[(k - 1) % n], values[(k + 1) % n]
    slope = max(left - low, right - low)
    delta = 0.5 * (left - right) / slope if slope > 0 else 0.0
    position = k + delta
    return position % n if circular else position


def axis_columns(width: int, axis: float, half_width: float) -> np.ndarray:
    """``(width,)`` bool: the reference's columns that look within ``half_width`` radians of the
    direction ``axis`` (radians, counter-clockwise from the reference's heading) or of its
    opposite."""
    azimuth = -2.0 * np.pi * np.arange(width) / width
    off = np.abs(np.mod(azimuth - axis + np.pi, 2 * np.pi) - np.pi)
    return np.minimum(off, np.pi - off) <= half_width


def relative_heading(
    query: np.ndarray,
    ref: np.ndarray,
    axis: float | None = None,
    axis_half_width: float = math.radians(30.0),
    window: int = 4,
    prior: float | None = None,
) -> tuple[float, float]:
    """``heading_query - heading_ref`` (radians, in (-pi, pi]) of two prepared panoramas, and
    the whole-image score (mean absolute difference at the best shift).

    Args:
        query, ref: ``(H, W)`` uint8 prepared 360-degree panoramas.
        axis: direction from the reference's place to the query's, radians counter-clockwise
            from the reference's heading; None (or places too close to matter) compares every
            column.
        axis_half_width: radians either side of the axis (and of its opposite) compared.
        window: columns either side of the centre searched with the axis columns.
        prior: the expected relative heading (radians), the centre of that search; None: the
            whole-image minimum.
    """
    table = rotational_sad(query, ref[np.newaxis])[0].astype(np.float64)
    width = ref.shape[1]
    score = float(table.min())
    shift = subcolumn_minimum(table)
    if axis is not None:
        columns = axis_columns(width, axis, axis_half_width)
        if columns.sum() >= 4:
            coarse = int(np.argmin(table)) if prior is None else int(round(prior * width / (2 * math.pi)))
            shifts = np.arange(coarse - window, coarse + window + 1) % width
            # column c of the query rolled left by k is the query's column (c + k) mod W
            picked = (np.flatnonzero(columns)[np.newaxis, :] + shifts[:, np.newaxis]) % width
            q = query.astype(np.int16)[:, picked]  # (H, shifts, columns)
            r = ref[:, columns].astype(np.int16)[:, np.newaxis, :]
            costs = np.abs(q - r).mean(axis=(0, 2))
            local = subcolumn_minimum(costs, circular=False)
            if 0 < local < len(costs) - 1:  # a minimum inside the window; else keep the whole image's
                shift = (coarse - window + local) % width
    angle = 2.0 * math.pi * shift / width
    return (angle - 2.0 * math.pi if angle > math.pi else angle), score
