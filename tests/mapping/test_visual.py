"""The heading factor's measurement: relative heading of two panoramas against known rotations.

Convention (docs/design.md): column c looks along heading - 2*pi*c/W; the best shift k of the
query against a reference means heading_query - heading_ref = 2*pi*k/W.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

import nightloc
from nightloc.mapping.visual import axis_columns, relative_heading, subcolumn_minimum
from nightloc.synth import SynthScene


def test_subcolumn_minimum_of_a_v():
    shifts = np.arange(48)
    for true in (10.3, 10.0, 0.2, 47.6):
        off = np.abs(np.mod(shifts - true + 24, 48) - 24)  # a V around `true`, wrapping round
        assert subcolumn_minimum(3.0 + 2.0 * off) == pytest.approx(true, abs=1e-9)
    assert subcolumn_minimum(np.array([5.0, 1.0, 3.0]), circular=False) == pytest.approx(1.25)
    assert subcolumn_minimum(np.array([0.0, 1.0, 3.0]), circular=False) == 0.0  # an end is not refined


def test_axis_columns_look_along_the_axis_and_back():
    columns = axis_columns(48, 0.0, math.radians(10))  # ahead: column 0; behind: column 24
    assert set(np.flatnonzero(columns)) == {0, 1, 47, 23, 24, 25}
    left = axis_columns(48, math.pi / 2, math.radians(5))  # +90 deg (left) is column 36 (= -12)
    assert set(np.flatnonzero(left)) == {12, 36}


@pytest.fixture(scope="module")
def scene():
    return SynthScene("garden", seed=0)


@pytest.mark.parametrize("turn_deg", [0.0, 3.0, -20.0, 97.5, 181.0, -123.4])
def test_relative_heading_of_known_rotations(scene, turn_deg):
    """One place rendered at two headings: the measured relative heading is the turn, to a
    fraction of a 7.5-degree column, with the design's sign."""
    heading = 0.4
    turn = math.radians(turn_deg)
    ref = nightloc.prepare(scene.frame("day", 3.0, 2.5, heading, scene.frame_rng("ref", 0)))
    query = nightloc.prepare(scene.frame("day", 3.0, 2.5, heading + turn, scene.frame_rng("query", 0)))
    measured, score = relative_heading(query, ref)
    assert abs(math.remainder(measured - turn, 2 * math.pi)) < math.radians(1.5)  # 0.2 columns
    assert score < 8.0


def test_parallax_free_columns_near_the_axis(scene):
    """Two places 1 m apart along +x: comparing the columns that look along the axis (the axis
    given in the reference's frame) and searching around the predicted turn keeps the heading."""
    turn = math.radians(35.0)
    ref = nightloc.prepare(scene.frame("day", 2.0, 2.5, 0.3, scene.frame_rng("ref", 1)))
    query = nightloc.prepare(scene.frame("day", 3.0, 2.5, 0.3 + turn, scene.frame_rng("query", 1)))
    measured, _ = relative_heading(query, ref, axis=-0.3, prior=turn + 0.05)
    assert abs(math.remainder(measured - turn, 2 * math.pi)) < math.radians(3.0)
