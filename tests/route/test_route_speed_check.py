"""The speed check: the query's speed ratio from odometry or from the matches, beside the range
the search assumes (the motion registry's), and what the command says when it lies outside."""

from __future__ import annotations

import itertools
import json
import math

import numpy as np
import pytest

import nightloc
from nightloc import route
from nightloc.cli import main
from nightloc.route.params import MOTION_MODELS, motion_speeds
from nightloc.route.speed_check import (
    STRETCH_ROWS,
    STRETCHES,
    MatchesRatio,
    StretchSampler,
    check_speed,
    ratio_from_odometry,
    ratio_from_rows,
    sample_stretches,
)

import route_oracle as ro


def _enhanced(ratio: float, n_refs: int = 260, seed: int = 3, likeness: float = 0.5) -> np.ndarray:
    """The enhanced matrix of a synthetic query driving the route at ``ratio`` references per frame."""
    positions = np.arange(0.0, n_refs - 1, ratio)
    refs, queries, _ = ro.synthetic_route_at(n_refs, positions, seed=seed, likeness=likeness)
    params = route.RouteParams()
    difference = route.route_difference_matrix(queries, refs, params)
    return route.enhance_contrast(difference, params, offset=params.search_offset)


def _stretches(matrix: np.ndarray) -> list[np.ndarray]:
    sampler = StretchSampler(matrix.shape[0])
    sampler.take(0, matrix)
    return sampler.rows()


def _central_planes(p: route.RouteParams) -> tuple[float, float]:
    """The oracle's speed planes holding the central 80 % of the speed prior."""
    speeds, _, _, prior, _ = ro.speed_chain(p)
    below = np.cumsum(prior)
    return speeds[int(np.argmax(below > 0.1))], speeds[int(np.argmax(below >= 0.9 - 1e-9))]


def test_each_motion_model_reads_its_range_from_its_own_fields():
    params = route.RouteParams(vmin=0.6, vmax=1.7, filter_speed_change=0.1, filter_speed_tau=6.0)
    for name in MOTION_MODELS:
        speeds = motion_speeds(params, name)
        assert speeds.search == f"{name} motion model"
        if speeds.fields is None:  # moves by the distance travelled: any speed
            assert not speeds.bounded and speeds.covers(0.01) and speeds.covers(100.0)
            continue
        assert all(hasattr(params, field) for field in speeds.fields)
        assert speeds.covers(speeds.lowest) and not speeds.covers(speeds.highest + 0.01)
    window = motion_speeds(params, "window")  # the central 80 % of a speed uniform in vmin .. vmax
    assert (window.lowest, window.highest) == pytest.approx((0.71, 1.59)) and window.fields == ("vmin", "vmax")
    for prior in (params, route.RouteParams(), route.RouteParams(filter_speed_tau=math.inf)):
        speed = motion_speeds(prior, "speed")
        assert (speed.lowest, speed.highest) == pytest.approx(_central_planes(prior))
        assert "filter_speed_tau" in speed.fields and "filter_speed_change" in speed.fields
    # the default prior keeps 80 % of its mass on 0.9 .. 1.1 although its planes span 0.5 .. 1.5
    default = motion_speeds(route.RouteParams(), "speed")
    assert (default.lowest, default.highest) == pytest.approx((0.9, 1.1))
    assert default.covers(0.9) and default.covers(1.1000001) and not default.covers(1.11)  # its ends, rounded
    free = motion_speeds(route.RouteParams(filter_speed_tau=math.inf), "speed")  # no pull: a uniform prior
    assert (free.lowest, free.highest) == pytest.approx((0.6, 1.4))
    seqslam = motion_speeds(params, None)
    assert (seqslam.lowest, seqslam.highest, seqslam.fields) == (0.6, 1.7, ("vmin", "vmax"))


def test_ratio_from_odometry_is_the_advance_over_the_mean_spacing():
    rng = np.random.default_rng(4)
    distances = np.cumsum(rng.uniform(0.8, 1.6, 50))  # mean spacing about 1.2
    advances = np.r_[0.0, rng.uniform(0.4, 0.7, 80)]
    advances[10] = -0.5  # reversing counts by its length
    ratio = ratio_from_odometry(advances, distances)
    per_frame = np.abs(advances[1:]) / ((distances[-1] - distances[0]) / 49)
    assert ratio is not None and ratio.source == "odometry" and ratio.samples == 80
    np.testing.assert_allclose([ratio.low, ratio.median, ratio.high], np.percentile(per_frame, [10, 50, 90]))
    assert ratio_from_odometry(advances, np.zeros(5)) is None  # the reference never moved


def test_stretches_cover_short_routes_and_sample_long_ones():
    assert sample_stretches(0) == []
    assert sample_stretches(53) == [(0, 53)]
    short = sample_stretches(STRETCH_ROWS * 2 + 10)
    assert short[0][0] == 0 and short[-1][1] == STRETCH_ROWS * 2 + 10 and len(short) == 3
    assert all(b == c for (_, b), (c, _) in itertools.pairwise(short))
    long = sample_stretches(10_000)
    assert len(long) == STRETCHES and long[0][0] == 0 and long[-1][1] == 10_000
    assert all(stop - start == STRETCH_ROWS for start, stop in long)


def test_sampler_takes_bands_in_any_order():
    matrix = np.arange(40_000 * 3, dtype=np.float32).reshape(40_000, 3)
    whole = _stretches(matrix)
    sampler = StretchSampler(40_000)
    for start in reversed(range(0, 40_000, 777)):
        sampler.take(start, matrix[start : start + 777])
    for got, expected in zip(sampler.rows(), whole):
        np.testing.assert_array_equal(got, expected)
    partial = StretchSampler(40_000)
    partial.take(0, matrix[:100])
    with pytest.raises(ValueError, match="not given whole"):
        partial.rows()
    # a stream hands each stretch over once it is whole, and holds it no longer
    stream = StretchSampler(40_000)
    handed = []
    for start in range(0, 40_000, 777):
        stream.take(start, matrix[start : start + 777])
        handed += stream.complete()
        assert sum(len(part) for parts in stream._parts for part in parts.values()) < 2 * STRETCH_ROWS
    assert len(handed) == len(whole)
    for got, expected in zip(handed, whole):
        np.testing.assert_array_equal(got, expected)
    with pytest.raises(ValueError, match="handed over"):
        stream.rows()


@pytest.mark.parametrize("ratio", [0.45, 1.0, 2.2])
def test_the_matches_show_the_ratio(ratio):
    stretches = _stretches(_enhanced(ratio))
    measured = ratio_from_rows(stretches)
    assert measured is not None and measured.source == "matches"
    assert measured.median == pytest.approx(ratio, abs=0.08)
    one_at_a_time = MatchesRatio()
    for stretch in stretches:
        one_at_a_time.add(stretch)
    assert one_at_a_time.ratio() == measured


def test_a_query_off_the_route_shows_no_ratio():
    refs, _, _ = ro.synthetic_route(200, 10, speed=1.0, seed=5)
    _, elsewhere, _ = ro.synthetic_route(200, 120, speed=1.0, seed=6)  # another route's frames
    params = route.RouteParams()
    matrix = route.enhance_contrast(route.route_difference_matrix(elsewhere, refs, params), params, offset="bound")
    assert ratio_from_rows(_stretches(matrix)) is None
    assert ratio_from_rows([matrix[:10]]) is None  # too short to judge


def test_check_names_what_fits():
    slow = _stretches(_enhanced(0.45))
    speed_model = check_speed(None, "speed", slow)
    assert not speed_model.fits
    low, high = speed_model.advice["vmin"], speed_model.advice["vmax"]
    assert speed_model.advice["filter_motion"] == "window"
    assert low == pytest.approx(0.8 * speed_model.ratio.median, abs=0.006)
    assert high == pytest.approx(1.2 * speed_model.ratio.median, abs=0.006)
    message = speed_model.message()
    assert "outside the speed motion model's 0.9..1.1 (set by filter_speed_min, filter_speed_max, " in message
    assert f"filter_motion = 'window', vmin = {low!r}, vmax = {high!r} fits" in message
    assert f"--motion window --vmin {low} --vmax {high} fits" in speed_model.message(
        lambda field: {"filter_motion": "--motion"}.get(field, "--" + field)
    )
    seqslam = check_speed("openseqslam", None, slow)
    assert set(seqslam.advice) == {"vmin", "vmax"} and "SeqSLAM's speeds 0.8..1.2" in seqslam.message()
    # with odometry in both traverses the ratio is the odometry's and the odometry model fits
    odometry = (np.r_[0.0, np.full(60, 0.3)], np.arange(100.0))
    carried = check_speed(None, "window", None, odometry)
    assert carried.ratio.source == "odometry" and carried.advice == {"filter_motion": "odometry"}
    assert check_speed(None, "odometry", None, odometry).fits  # any speed
    on_time = check_speed(None, "speed", _stretches(_enhanced(1.0)))
    assert on_time.fits and on_time.advice == {} and on_time.message() == ""
    assert on_time.as_dict()["range"] == pytest.approx([0.9, 1.1]) and on_time.as_dict()["fits"]


def _write_route(tmp_path, ratio: float, odometry: bool):
    positions = np.arange(0.0, 199.0, ratio)
    refs, queries, _ = ro.synthetic_route_at(200, positions, seed=12, likeness=0.5, height=24, width=48)
    step = 0.4  # metres between reference frames
    reference = nightloc.save_traverse(
        tmp_path / "ref",
        list(refs),
        odometry=[None] + [nightloc.RobotMotion(step, 0.0, 0.0)] * 199 if odometry else None,
    )
    query = nightloc.save_traverse(
        tmp_path / "qry",
        list(queries),
        odometry=[None] + [nightloc.RobotMotion(step * ratio, 0.0, 0.0)] * (len(positions) - 1) if odometry else None,
    )
    return reference, query


@pytest.mark.parametrize(
    ("odometry", "options", "advice"),
    [
        (False, [], "--motion window --vmin 0.3"),  # 0.8 x 0.4: the speed model by default
        (True, ["--motion", "speed"], "--motion odometry fits"),
        (False, ["--method", "seqslam"], "--vmin 0.3"),
    ],
)
def test_command_warns_once_with_the_option_that_fits(tmp_path, capsys, odometry, options, advice):
    reference, query = _write_route(tmp_path, 0.4, odometry)
    out = tmp_path / "out"
    code = main(["route", str(reference.root), str(query.root), "--out", str(out), "--no-figures", *options])
    printed = capsys.readouterr().out
    assert code == 0
    warnings = [line for line in printed.splitlines() if line.startswith("warning:")]
    assert len(warnings) == 1, printed
    assert "the query advances 0.4" in warnings[0] and advice in warnings[0]
    check = json.loads((out / "summary.json").read_text())["speed_check"]
    assert not check["fits"] and check["ratio"]["source"] == ("odometry" if odometry else "matches")
    assert math.isclose(check["ratio"]["median"], 0.4, abs_tol=0.05)


def test_command_says_nothing_when_the_speed_fits(tmp_path, capsys):
    reference, query = _write_route(tmp_path, 1.0, odometry=False)
    out = tmp_path / "out"
    assert main(["route", str(reference.root), str(query.root), "--out", str(out), "--no-figures"]) == 0
    assert "warning" not in capsys.readouterr().out
    check = json.loads((out / "summary.json").read_text())["speed_check"]
    assert check["fits"] and check["advice"] is None and check["search"] == "speed motion model"
