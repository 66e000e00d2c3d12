"""The route filter's motion models as types: every model's outputs bit for bit as stored in
``tests/route/data/motion_golden.npz`` (``motion_golden.py``), on every SIMD path; the one name
table shared by the core, ``RouteParams.filter_motion`` and ``nightloc route --motion``; the
numpy oracle's models (``tests/route_oracle.py``) against the core's."""

from __future__ import annotations

import copy
import dataclasses
from pathlib import Path

import numpy as np
import pytest

from nightloc import _core, route
from nightloc.route.params import DISTANCE_MOTIONS, MOTION_MODELS

import motion_golden
import route_oracle as ro

pytestmark = pytest.mark.sanitize  # drives the compiled filter: CI reruns it under ASan + UBSan


@pytest.fixture(scope="module")
def golden():
    with np.load(motion_golden.GOLDEN) as stored:
        return {key: stored[key] for key in stored.files}


@pytest.mark.parametrize("case", sorted(motion_golden.CASES))
def test_each_model_gives_its_stored_outputs_bit_for_bit(golden, case, simd_path):
    """Batch and frame by frame (with a state set and a reset): the same bits as stored, on the
    SIMD path the fixture forces."""
    got = motion_golden.outputs(case)
    assert set(got) == {key for key in golden if key.startswith(f"{case}/")}
    for key, value in got.items():
        np.testing.assert_array_equal(value, golden[key], err_msg=key)


def test_golden_cases_cover_every_model():
    assert {motion for motion, _, _ in motion_golden.CASES.values()} == set(MOTION_MODELS)


@pytest.mark.parametrize("motion", MOTION_MODELS)
def test_oracle_model_agrees_with_the_core(motion):
    """The oracle's per-model prediction with the shared floor and off-route step."""
    data = motion_golden.problem(21)
    params = route.RouteParams(filter_motion=motion)
    odometry = motion in DISTANCE_MOTIONS
    advances = data["advances"] if odometry else None
    distances = data["distances"] if odometry else None
    refs, confidence, off_route, speed, ran = route.route_filter_run(
        data["matrix"], params, data["weights"], 1, advances, distances
    )
    assert ran == motion
    o_refs, o_confidence, o_off, o_speed, _ = ro.route_filter_model(
        data["matrix"], params, motion, data["weights"], advances, distances
    )
    np.testing.assert_array_equal(refs, o_refs)
    np.testing.assert_allclose(confidence, o_confidence, rtol=1e-9, atol=1e-13)
    np.testing.assert_allclose(off_route, o_off, rtol=1e-9, atol=1e-13)
    np.testing.assert_allclose(speed, o_speed, rtol=1e-9, atol=1e-12)


def test_one_name_table():
    """The core's names are RouteParams', each reaches the core as itself, the oracle has a model
    for each, and the registry's needs_distances is what the oracle's model needs."""
    assert tuple(_core.route_motion_names()) == MOTION_MODELS
    assert tuple(m["name"] for m in _core.route_motion_models()) == MOTION_MODELS
    assert set(ro.MOTIONS) == set(MOTION_MODELS)
    core = _core.RouteFilterParams()
    for name in MOTION_MODELS:
        core.motion = name
        assert core.motion == name
        assert route.RouteParams(filter_motion=name).core_filter_params().motion == name
        try:  # the oracle's model without the references' distances
            ro.MOTIONS[name](route.RouteParams(filter_motion=name), 5)
            needs = False
        except (TypeError, ValueError, IndexError):  # it reads the distances
            needs = True
        assert (name in DISTANCE_MOTIONS) == needs, name
    assert DISTANCE_MOTIONS  # the odometry model


def test_an_unknown_model_names_the_choices():
    choices = ", ".join(f"'{name}'" for name in MOTION_MODELS)
    with pytest.raises(ValueError, match=f"^filter_motion must be one of {choices}, got 'teleport'$"):
        route.RouteParams(filter_motion="teleport")
    with pytest.raises(_core.SettingError, match=f"^motion must be one of {choices}, got 'teleport'$"):
        _core.RouteFilterParams().motion = "teleport"


def test_odometry_model_needs_distances():
    matrix = motion_golden.problem(3)["matrix"]
    params = route.RouteParams(filter_motion="odometry")
    with pytest.raises(ValueError, match="filter_motion 'odometry' needs odometry"):
        route.route_filter(matrix, params)
    with pytest.raises(ValueError, match="filter_motion 'odometry' needs odometry"):
        route.RouteFilter(matrix.shape[1], params)
    # The core: distances are the odometry model's input, and only its.
    core = params.core_filter_params()
    with pytest.raises(ValueError, match="needs the references' distances"):
        _core.RouteFilter(matrix.shape[1], core)
    core.motion = "speed"
    with pytest.raises(ValueError, match="set motion to odometry"):
        _core.RouteFilter(matrix.shape[1], core, np.arange(float(matrix.shape[1])))


def test_filter_copies_carry_their_model():
    data = motion_golden.problem(4)
    params = dataclasses.replace(route.RouteParams(), filter_motion="odometry")
    core = route.filter.core_params(params, "odometry")
    first = _core.RouteFilter(data["matrix"].shape[1], core, data["distances"])
    first.run(data["matrix"][:30], None, 1, data["advances"][:30])
    second = copy.copy(first)
    rest = data["matrix"][30:]
    a = first.run(rest, None, 1, data["advances"][30:])
    b = second.run(rest, None, 1, data["advances"][30:])
    assert second.motion == "odometry"
    for x, y in zip(a, b):
        np.testing.assert_array_equal(x, y)


def test_every_filter_parameter_has_its_doc_line():
    """Each ``filter_*`` field of RouteParams has its row in route mode's table, and each field
    the core takes is copied by name (no list of fields to keep in step)."""
    docs = (Path(__file__).parents[2] / "docs" / "route_mode.md").read_text(encoding="utf-8")
    rows = [line for line in docs.splitlines() if line.startswith("| `")]
    fields = [f.name for f in dataclasses.fields(route.RouteParams) if f.name.startswith("filter_")]
    for name in fields:
        assert any(f"`{name}`" in row for row in rows), name
    core = route.RouteParams().core_filter_params()
    bound = {name for name in dir(core) if not name.startswith("_") and not callable(getattr(core, name))}
    assert bound == {name.removeprefix("filter_") for name in ("vmin", "vmax", *fields)} - {"min_texture"}
