"""The route filter's speed and odometry models: the core against the numpy
oracle written from their definitions (tests/route_oracle.py) on every SIMD path, batch =
streaming bit for bit, and the behaviours they promise: a query whose speed swings 0.5-1.5x the
reference's stays locked, a stop or a reverse does not derail it, odometry in both traverses
predicts by the distance travelled, odometry on one side runs the speed model and says so."""

from __future__ import annotations

import dataclasses
import json
import math

import numpy as np
import pytest

import nightloc
from nightloc import _core, route
from nightloc.cli import main
from nightloc.route.odometry import motion_plan, route_odometry
from nightloc.route.params import DISTANCE_MOTIONS, ODOMETRY_MOTION

import route_oracle as ro

pytestmark = pytest.mark.sanitize  # drives the compiled filter: CI reruns it under ASan + UBSan

SPEED = route.RouteParams(filter_motion="speed")
SPEED_PARAMS = [
    SPEED,
    dataclasses.replace(SPEED, filter_speed_cells=3, filter_speed_tau=math.inf, filter_backward=0.02),
    dataclasses.replace(
        SPEED, filter_speed_min=-0.5, filter_speed_max=2.0, filter_speed_step=0.25, filter_speed_jitter=0.0
    ),
    dataclasses.replace(SPEED, filter_speed_change=0.3, filter_floor=0.0, filter_clip=math.inf, filter_speed_cells=2),
    dataclasses.replace(SPEED, filter_speed_change=0.0, filter_leave=0.0, filter_window=0),
    dataclasses.replace(SPEED, filter_speed_min=1.0, filter_speed_max=1.0),
]
ODOMETRY_PARAMS = [
    route.RouteParams(),
    route.RouteParams(filter_odometry_cells=1, filter_odometry_noise=0.3, filter_odometry_jitter=0.0),
    route.RouteParams(filter_odometry_cells=5, filter_odometry_novelty=0.0, filter_floor=0.0),
    route.RouteParams(filter_odometry_noise=4.0, filter_odometry_jitter=3.0),  # the spread's cap of 256 passes
]


def _odometry(seed: int, n_query: int, n_ref: int):
    rng = np.random.default_rng(seed)
    distances = np.cumsum(rng.uniform(0.2, 2.0, n_ref))
    distances[10:14] = distances[10]  # the reference stood still for four frames
    advances = rng.uniform(-0.5, 2.5, n_query)
    advances[[3, 4]] = 0.0  # the query stops
    advances[30] = 50.0  # a jump far along the route
    return advances, distances


def _stream(filt, matrix, weights, advances=None):
    steps = [filt.step(matrix[q], weights[q], 0.0 if advances is None else advances[q]) for q in range(len(matrix))]
    return (
        np.array([s.ref for s in steps]),
        np.array([s.confidence for s in steps]),
        np.array([s.off_route for s in steps]),
        np.array([s.speed for s in steps]),
    )


@pytest.mark.parametrize("index", range(len(SPEED_PARAMS)))
def test_speed_model_equals_oracle_and_streams_bit_for_bit(index):
    p = SPEED_PARAMS[index]
    matrix, weights = ro.noisy_matrix(index)
    refs, confidence, off_route, speed, motion = route.route_filter_run(matrix, p, weights)
    assert motion == "speed"
    o_refs, o_confidence, o_off, o_speed, o_belief = ro.route_filter_planes(matrix, p, weights)
    np.testing.assert_array_equal(refs, o_refs)
    np.testing.assert_allclose(confidence, o_confidence, rtol=1e-9, atol=1e-13)
    np.testing.assert_allclose(off_route, o_off, rtol=1e-9, atol=1e-13)
    np.testing.assert_allclose(speed, o_speed, rtol=1e-9, atol=1e-12)
    filt = route.RouteFilter(matrix.shape[1], p)
    assert filt.motion == "speed"
    streamed = _stream(filt, matrix, weights)
    for got, batch in zip(streamed, (refs, confidence, off_route, speed)):
        np.testing.assert_array_equal(got, batch)
    np.testing.assert_allclose(filt.belief, o_belief, rtol=1e-9, atol=1e-15)
    assert filt.belief.sum() + filt.off_route == pytest.approx(1.0, abs=1e-12)


@pytest.mark.parametrize("index", range(len(ODOMETRY_PARAMS)))
def test_odometry_model_equals_oracle_and_streams_bit_for_bit(index):
    p = ODOMETRY_PARAMS[index]
    matrix, weights = ro.noisy_matrix(10 + index)
    advances, distances = _odometry(index, *matrix.shape)
    refs, confidence, off_route, speed, motion = route.route_filter_run(
        matrix, p, weights, advances=advances, reference_distances=distances
    )
    assert motion == "odometry"
    o_refs, o_confidence, o_off, o_speed, o_belief = ro.route_filter_planes(matrix, p, weights, advances, distances)
    np.testing.assert_array_equal(refs, o_refs)
    np.testing.assert_allclose(confidence, o_confidence, rtol=1e-9, atol=1e-13)
    np.testing.assert_allclose(off_route, o_off, rtol=1e-9, atol=1e-13)
    np.testing.assert_allclose(speed, o_speed, rtol=1e-9, atol=1e-12)
    filt = route.RouteFilter(matrix.shape[1], p, reference_distances=distances)
    assert filt.motion == "odometry"
    streamed = _stream(filt, matrix, weights, advances)
    for got, batch in zip(streamed, (refs, confidence, off_route, speed)):
        np.testing.assert_array_equal(got, batch)
    np.testing.assert_allclose(filt.belief, o_belief, rtol=1e-9, atol=1e-15)
    # In pieces (the first frame after a reset has no motion; later pieces continue).
    pieces = route.RouteFilter(matrix.shape[1], p, reference_distances=distances)
    parts = [pieces.run(matrix[a:b], weights[a:b], advances[a:b]) for a, b in ((0, 1), (1, 37), (37, len(matrix)))]
    np.testing.assert_array_equal(np.concatenate([part[1] for part in parts]), confidence)


@pytest.mark.parametrize("index", [0, 1, 3])
def test_speed_chain_and_spread_equal_oracle(index):
    p = SPEED_PARAMS[index]
    speeds, up, down, prior, passes = _core.speed_chain(p.core_filter_params())
    o_speeds, o_up, o_down, o_prior, o_passes = ro.speed_chain(p)
    np.testing.assert_allclose(speeds, o_speeds, rtol=0, atol=1e-12)
    np.testing.assert_allclose(up, o_up, rtol=1e-12, atol=1e-15)
    np.testing.assert_allclose(down, o_down, rtol=1e-12, atol=1e-15)
    np.testing.assert_allclose(prior, o_prior, rtol=1e-9, atol=1e-12)
    assert passes == o_passes
    assert prior.sum() == pytest.approx(1.0, abs=1e-12)
    for q in ODOMETRY_PARAMS:
        for advance, spacing in ((0.0, 1.0), (1.3, 0.7), (-4.0, 2.0)):
            taps = _core.odometry_spread(advance, spacing, q.core_filter_params())
            np.testing.assert_allclose(taps, ro.odometry_spread(advance, spacing, q), rtol=1e-12, atol=1e-15)
            assert taps.sum() == pytest.approx(1.0, abs=1e-12)
            assert len(taps) % 2 == 1 and np.allclose(taps, taps[::-1])  # centred: the mean advance is kept


def test_identical_on_every_simd_path(simd_path):
    """The speed and odometry models on this path give the scalar path's bits."""
    matrix, weights = ro.noisy_matrix(31, 60, 150)
    advances, distances = _odometry(31, 60, 150)
    runs = (
        lambda: route.route_filter_run(matrix, SPEED_PARAMS[1], weights),
        lambda: route.route_filter_run(
            matrix, ODOMETRY_PARAMS[0], weights, advances=advances, reference_distances=distances
        ),
    )
    with nightloc.use_simd_backend("scalar"):
        expected = [run()[:4] for run in runs]
    for run, want in zip(runs, expected):
        for got, ref in zip(run()[:4], want):
            np.testing.assert_array_equal(got, ref)


def test_threads_do_not_change_the_result():
    matrix, weights = ro.noisy_matrix(4, 150, 80)
    advances, distances = _odometry(4, 150, 80)
    for kwargs in ({}, {"advances": advances, "reference_distances": distances}):
        params = SPEED if not kwargs else route.RouteParams()
        one = route.route_filter_run(matrix, params, weights, 1, **kwargs)
        for threads in (2, 3):
            for got, want in zip(route.route_filter_run(matrix, params, weights, threads, **kwargs)[:4], one[:4]):
                np.testing.assert_array_equal(got, want)


# --------------------------------------------------------------------------------------------
# behaviour on routes


def _positions(speeds: np.ndarray, start: float = 2.0) -> np.ndarray:
    return start + np.r_[0.0, np.cumsum(speeds)][: len(speeds)]


# The behaviour tests' routes (route_oracle.synthetic_route_at) are random textures seen from the
# same viewpoint: the translation window has nothing to absorb there and only dilutes their weak
# evidence, so they compare one alignment (the window's own route tests: test_route_window.py).
ONE_ALIGNMENT = route.RouteParams(shift_window=(0, 0))


def _correct(result, truth, skip: int = 20) -> float:
    return float(np.mean(np.abs(result.refs[skip:] - truth[skip:]) <= 2))


def test_speed_model_stays_locked_when_the_speed_swings():
    # 0.5-1.5x the reference's speed, a full swing every 50 frames, on weak evidence (a quarter
    # of each query frame is the place): a speed model with a loose prior follows it (every
    # frame), the window model lags behind at both ends of the swing; the default prior, tuned
    # not to lose precision on constant-speed pairs, sits in between (docs/route_mode.md).
    speeds = 1.0 + 0.5 * np.sin(2 * np.pi * np.arange(300) / 50)
    refs, queries, truth = ro.synthetic_route_at(330, _positions(speeds), seed=3, likeness=0.25)
    loose = dataclasses.replace(SPEED, filter_speed_change=0.1, filter_speed_tau=6.0, shift_window=(0, 0))
    window = route.match_prepared(refs, queries, route.RouteParams(filter_motion="window", shift_window=(0, 0)))
    speed = route.match_prepared(refs, queries, loose)
    assert speed.motion == "speed" and window.motion == "window"
    assert _correct(speed, truth) > 0.98
    assert _correct(window, truth) < 0.9
    # The speed it reports follows the true one (a few frames behind).
    assert np.corrcoef(speed.speed[30:], np.roll(speeds, 3)[30:])[0, 1] > 0.8
    assert np.isnan(window.speed).all()


@pytest.mark.parametrize("kind", ["stop", "reverse"])
def test_a_stop_or_a_reverse_does_not_derail_the_filter(kind):
    speeds = np.ones(260)
    if kind == "stop":
        speeds[100:125] = 0.0
    else:
        speeds[100:108] = -0.75
    positions = _positions(speeds)
    refs, queries, truth = ro.synthetic_route_at(280, positions, seed=5, likeness=0.25)
    for params in (ONE_ALIGNMENT, dataclasses.replace(SPEED, shift_window=(0, 0))):
        result = route.match_prepared(refs, queries, params)
        assert np.all(np.isfinite(result.confidence)) and np.all((result.confidence >= 0) & (result.confidence <= 1))
        # Locked before, and again within 25 frames of moving on.
        assert _correct(result, truth, 20) > 0.7
        after = 125 if kind == "stop" else 108
        assert np.all(np.abs(result.refs[after + 25 :] - truth[after + 25 :]) <= 2)
    # With odometry the stop is held and the reverse followed, frame by frame.
    advances = np.diff(positions, prepend=positions[0])
    result = route.match_prepared(
        refs, queries, ONE_ALIGNMENT, advances=advances * 1.03, reference_distances=np.arange(280.0)
    )
    assert result.motion == "odometry"
    assert np.all(np.abs(result.refs[20:] - truth[20:]) <= 2)
    assert np.nanmin(result.speed[101:108]) < -0.5 if kind == "reverse" else abs(result.speed[110]) < 1e-9


def test_odometry_predicts_by_distance_travelled():
    # 0.55-1.45x with odometry noisy by 5 %, the references unevenly spaced (their distances
    # are what places them): locked from the first frames, far beyond the speed window.
    rng = np.random.default_rng(8)
    speeds = 1.0 + 0.45 * np.sin(2 * np.pi * np.arange(280) / 50 + 1.0)
    positions = _positions(speeds)
    refs, queries, truth = ro.synthetic_route_at(300, positions, seed=8, likeness=0.15)
    spacing = rng.uniform(0.5, 1.5, 300)  # metres between consecutive reference frames
    distances = np.r_[0.0, np.cumsum(spacing[:-1])]
    metres = np.interp(positions, np.arange(300), distances)
    advances = np.diff(metres, prepend=metres[0]) * (1 + rng.normal(0, 0.05, len(positions)))
    odometry = route.match_prepared(refs, queries, ONE_ALIGNMENT, advances=advances, reference_distances=distances)
    window = route.match_prepared(refs, queries, ONE_ALIGNMENT)
    assert _correct(odometry, truth, 10) > 0.97
    assert _correct(window, truth, 10) < 0.8
    # The mean advance it reports is in references per frame: the query's speed.
    assert np.median(np.abs(odometry.speed[10:] - speeds[9:-1])) < 0.2
    with pytest.raises(ValueError, match="both advances"):
        route.match_prepared(refs, queries, advances=advances)


def test_streaming_localizer_with_odometry_equals_the_batch(tmp_path):
    speeds = 1.0 + 0.4 * np.sin(np.arange(80) / 6)
    positions = _positions(speeds)
    refs, queries, _ = ro.synthetic_route_at(100, positions, seed=9, likeness=0.4)
    advances = np.diff(positions, prepend=positions[0])
    distances = np.arange(100.0) * 0.5
    batch = route.match_prepared(refs, queries, advances=advances * 0.5, reference_distances=distances)
    localizer = nightloc.RouteLocalizer(refs, prepared=True, reference_distances=distances)
    assert localizer.motion == "odometry"
    updates = [
        localizer.update(q, prepared=True, advance=None if k == 0 else a * 0.5)
        for k, (q, a) in enumerate(zip(queries, advances))
    ]
    np.testing.assert_array_equal([u.ref for u in updates], batch.refs)
    np.testing.assert_array_equal([u.confidence for u in updates], batch.confidence)
    np.testing.assert_array_equal([u.speed for u in updates], batch.speed)
    window_model = route.RouteParams(filter_motion="window")
    assert nightloc.RouteLocalizer(refs, window_model, prepared=True).update(queries[0], prepared=True).speed is None
    with pytest.raises(ValueError, match="pass advance="):
        localizer.update(queries[0], prepared=True)
    plain = nightloc.RouteLocalizer(refs, prepared=True)
    with pytest.raises(ValueError, match="odometry=True"):
        plain.update(queries[0], prepared=True, advance=1.0)
    with pytest.raises(ValueError, match="finite"):
        localizer.update(queries[0], prepared=True, advance=math.nan)
    # From a traverse's own records: odometry=True reads the reference's odometry.csv.
    traverse = nightloc.save_traverse(
        tmp_path / "ref", list(refs), odometry=[None] + [nightloc.MapDisplacement(0.5, 0.0)] * 99
    )
    from_log = nightloc.RouteLocalizer(traverse, odometry=True)
    assert from_log.motion == "odometry"
    with pytest.raises(ValueError, match="odometry=True needs the reference as a traverse"):
        nightloc.RouteLocalizer(refs, prepared=True, odometry=True)
    bare = nightloc.save_traverse(tmp_path / "bare", list(refs))
    with pytest.raises(ValueError, match=r"has no odometry\.csv or poses"):
        nightloc.RouteLocalizer(bare, odometry=True)
    with pytest.raises(ValueError, match="filter"):
        nightloc.RouteLocalizer(refs, "openseqslam", prepared=True, reference_distances=distances)


# --------------------------------------------------------------------------------------------
# traverses' odometry and the command


def _write_pair(tmp_path, ref_odometry: bool, query_odometry: bool, query_poses: bool = False):
    speeds = 1.0 + 0.45 * np.sin(2 * np.pi * np.arange(120) / 50)
    positions = _positions(speeds, 1.0)
    refs, queries, truth = ro.synthetic_route_at(130, positions, seed=11, likeness=0.5, height=24, width=48)
    advances = np.diff(positions, prepend=positions[0])
    reference = nightloc.save_traverse(
        tmp_path / "ref",
        list(refs),
        odometry=[None] + [nightloc.RobotMotion(0.3, 0.0, 0.0)] * 129 if ref_odometry else None,
    )
    query_motion = [None] + [nightloc.RobotMotion(0.3 * a, 0.0, 0.0) for a in advances[1:]] if query_odometry else None
    xy = np.c_[0.3 * positions, np.zeros(len(positions))] if query_poses else None
    query = nightloc.save_traverse(tmp_path / "qry", list(queries), xy, odometry=query_motion)
    return reference, query, truth


def test_route_odometry_from_logs_and_poses(tmp_path):
    reference, query, _ = _write_pair(tmp_path, True, False, query_poses=True)
    log = route_odometry(reference)
    assert log is not None and log.source == "odometry.csv"
    np.testing.assert_allclose(log.steps[1:], 0.3)
    np.testing.assert_allclose(log.distances, 0.3 * np.arange(130))
    from_poses = route_odometry(query)
    assert from_poses is not None and from_poses.source == "poses"
    plan = motion_plan(reference, query, "speed")
    assert plan.motion == "odometry" and plan.note == "reference odometry.csv, query poses"
    # Wheel odometry backwards is a negative step; map-frame displacements have no direction.
    motions = [None, nightloc.RobotMotion(-0.2, 0.0, 0.0), nightloc.RobotMotion(0.1, 0.0, 0.0)]
    back = nightloc.save_traverse(tmp_path / "back", list(np.zeros((3, 8, 8), np.uint8)), odometry=motions)
    np.testing.assert_allclose(route_odometry(back).steps, [0.0, -0.2, 0.1])
    np.testing.assert_allclose(route_odometry(back).distances, [0.0, 0.2, 0.3])
    bare = nightloc.save_traverse(tmp_path / "bare", list(np.zeros((3, 8, 8), np.uint8)))
    assert route_odometry(bare) is None
    assert motion_plan(reference, bare, "speed").note == "odometry in the reference only (the query has none)"
    assert motion_plan(reference, query, "window", use_odometry=False).motion == "window"


@pytest.mark.parametrize(
    ("ref_odometry", "query_odometry", "motion", "because"),
    [
        (True, True, "odometry", "reference odometry.csv, query odometry.csv"),
        (False, True, "speed", "odometry in the query only (the reference has none)"),
        (False, False, "speed", "neither traverse has odometry.csv or poses"),
    ],
)
def test_command_names_the_motion_model(tmp_path, capsys, ref_odometry, query_odometry, motion, because):
    reference, query, truth = _write_pair(tmp_path, ref_odometry, query_odometry)
    config = tmp_path / "route.toml"
    config.write_text('[route]\nfilter_motion = "speed"\n')
    out = tmp_path / "out"
    code = main(
        [
            "route",
            str(reference.root),
            str(query.root),
            "--out",
            str(out),
            "--no-figures",
            "--ground-truth",
            "none",
            "--params",
            str(config),
        ]
    )
    assert code == 0
    summary = json.loads((out / "summary.json").read_text())
    assert summary["motion_model"] == motion
    assert summary["motion_model_because"] == because
    printed = capsys.readouterr().out
    assert f"{motion} motion model" in printed
    if motion != "odometry" and query_odometry:
        assert "odometry in the query only" in printed
    matches = np.loadtxt(out / "matches.csv", delimiter=",", skiprows=1, usecols=(0, 1))
    assert np.mean(np.abs(matches[20:, 1] - truth[20:]) <= 2) > 0.9
    if ref_odometry and query_odometry:
        code = main(
            [
                "route",
                str(reference.root),
                str(query.root),
                "--out",
                str(tmp_path / "none"),
                "--no-figures",
                "--ground-truth",
                "none",
                "--odometry",
                "none",
            ]
        )
        assert (
            json.loads((tmp_path / "none" / "summary.json").read_text())["motion_model_because"] == "odometry not used"
        )


def _route_run(tmp_path, reference, query, name: str, *options: str) -> tuple[dict, np.ndarray]:
    out = tmp_path / name
    args = ["route", str(reference.root), str(query.root), "--out", str(out), "--no-figures", "--ground-truth", "none"]
    code = main([*args, *options])
    assert code == 0
    matches = np.loadtxt(out / "matches.csv", delimiter=",", skiprows=1, usecols=(1, 5, 6))
    return json.loads((out / "summary.json").read_text()), matches


@pytest.mark.parametrize("motion", route.MOTION_MODELS)
def test_motion_option_chooses_the_model_and_the_toml_key_agrees(tmp_path, motion):
    """On traverses that both carry odometry, ``--motion NAME`` runs that model: its matches are
    the library's with ``filter_motion = NAME`` (odometry: with the traverses' odometry), and
    the TOML key gives the same files (a model that does not move by the distance travelled: with
    ``--odometry none``, as without it odometry in both traverses runs the odometry model)."""
    reference, query, _ = _write_pair(tmp_path, True, True)
    summary, matches = _route_run(tmp_path, reference, query, "option", "--motion", motion)
    assert summary["motion_model"] == motion
    expected = route.match_route(
        reference, query, route.RouteParams(filter_motion=motion), threads=1, odometry=motion in DISTANCE_MOTIONS
    )
    assert expected.motion == motion
    np.testing.assert_array_equal(matches[:, 0], expected.refs)
    np.testing.assert_array_equal(matches[:, 1], expected.confidence)
    np.testing.assert_array_equal(matches[:, 2], expected.off_route)
    config = tmp_path / f"{motion}.toml"
    config.write_text(f'[route]\nfilter_motion = "{motion}"\n')
    odometry = [] if motion in DISTANCE_MOTIONS else ["--odometry", "none"]
    by_key, key_matches = _route_run(tmp_path, reference, query, "key", "--params", str(config), *odometry)
    assert by_key["motion_model"] == motion
    np.testing.assert_array_equal(key_matches, matches)
    # The models differ on this pair: each name ran its own.
    if motion not in DISTANCE_MOTIONS:
        _, by_odometry = _route_run(tmp_path, reference, query, "odometry", "--motion", ODOMETRY_MOTION)
        assert not np.array_equal(by_odometry, matches)


def test_motion_option_errors(tmp_path, capsys):
    reference, query, _ = _write_pair(tmp_path, False, True)
    args = ["route", str(reference.root), str(query.root), "--out", str(tmp_path / "out"), "--no-figures"]
    with pytest.raises(SystemExit):
        main([*args, "--motion", "teleport"])
    assert f"unknown motion model 'teleport'; choose one of {', '.join(route.MOTION_MODELS)}" in capsys.readouterr().err
    assert main([*args, "--motion", "odometry"]) == 2
    err = capsys.readouterr().err
    assert "the odometry motion model needs odometry in both traverses" in err
    assert "odometry in the query only (the reference has none)" in err
    assert main([*args, "--motion", "speed", "--odometry", "auto"]) == 2
    assert "--motion speed contradicts --odometry auto" in capsys.readouterr().err
    assert not (tmp_path / "out").exists()


def test_bad_motion_inputs_are_named():
    matrix, _ = ro.noisy_matrix(1, 30, 20)
    with pytest.raises(ValueError, match="advances must be a 1-D array of 30"):
        route.route_filter(matrix, advances=np.ones(29), reference_distances=np.arange(20.0))
    with pytest.raises(ValueError, match="advances must be finite"):
        route.route_filter(matrix, advances=np.r_[np.ones(29), np.nan], reference_distances=np.arange(20.0))
    with pytest.raises(ValueError, match="must not decrease"):
        route.route_filter(matrix, advances=np.ones(30), reference_distances=np.r_[np.arange(19.0), 3.0])
    with pytest.raises(ValueError, match="positive, finite length"):
        route.route_filter(matrix, advances=np.ones(30), reference_distances=np.zeros(20))
    with pytest.raises(ValueError, match="finite"):
        route.route_filter(matrix, advances=np.ones(30), reference_distances=np.r_[np.arange(19.0), np.inf])
    with pytest.raises(ValueError, match="reference_distances must be a 1-D array of 20"):
        route.RouteFilter(20, reference_distances=np.arange(5.0))
    for change, words in (
        ({"filter_speed_step": 0.0}, "filter_speed_step"),
        ({"filter_speed_min": 2.0}, "filter_speed_max"),
        ({"filter_speed_step": 0.0001}, "speed planes"),
        ({"filter_speed_tau": 0.0}, "filter_speed_tau"),
        ({"filter_speed_change": -1.0}, "filter_speed_change"),
        ({"filter_speed_cells": 0}, "filter_speed_cells"),
        ({"filter_speed_cells": 64, "filter_speed_jitter": 100.0}, "filter_speed_jitter x speed_cells"),
        ({"filter_odometry_cells": 65}, "filter_odometry_cells"),
        ({"filter_odometry_noise": math.nan}, "filter_odometry_noise"),
        ({"filter_odometry_novelty": -1.0}, "filter_odometry_novelty"),
    ):
        with pytest.raises(ValueError, match=words):
            route.RouteParams(**change)
    with pytest.raises(ValueError, match=f"filter_motion must be one of '{route.MOTION_MODELS[0]}', "):
        route.RouteParams(filter_motion="teleport")
    with pytest.raises(ValueError, match="use fewer speed planes or cells"):
        route.RouteFilter(2_000_000, dataclasses.replace(SPEED, filter_speed_cells=64, filter_speed_step=0.01))


def test_route_params_defaults_are_the_cores():
    """RouteParams' filter defaults and the C++ RouteFilterParams' defaults are the same model."""
    ours, core = route.RouteParams().core_filter_params(), _core.RouteFilterParams()
    fields = [name for name in dir(core) if not name.startswith("_") and not callable(getattr(core, name))]
    for field in fields:
        assert getattr(ours, field) == getattr(core, field), field
        assert hasattr(route.RouteParams, field) or hasattr(route.RouteParams, f"filter_{field}"), field
