"""The streaming Localizer: known answers, sequence fusion against the oracle, heading, odometry forms."""

from __future__ import annotations

import math

import numpy as np
import pytest

import nightloc
from nightloc.config import load_params, save_params
from nightloc.localization.heatmap import HeatMapper
from nightloc.localization.localizer import LocalizationParams, Localizer
from nightloc.localization.sequence import cumulative_offsets
from nightloc.matching.sad import MatchResult, shifts_to_headings
from nightloc.motion.odometry import MapDisplacement, RobotMotion, true_robot_motions, wrap_angle

from heat_oracle import fuse


def _lattice_map(rng, with_headings=True):
    """30 random prepared panoramas on integer metres of a 6 x 4 m area (corners included)."""
    xs, ys = np.meshgrid(np.arange(7.0), np.arange(5.0))
    lattice = np.column_stack([xs.ravel(), ys.ravel()])
    keep = np.unique(np.r_[[0, 6, 28, 34], rng.choice(35, 26, replace=False)])
    positions = lattice[keep]
    images = nightloc.patch_normalize(rng.integers(0, 256, (len(positions), 24, 48), dtype=np.uint8))
    headings = rng.uniform(-np.pi, np.pi, len(positions)) if with_headings else None
    return nightloc.ReferenceMap(images, positions, headings)


def _result(scores, headings, width=48):
    """A MatchResult with given scores and relative headings."""
    scores = np.asarray(scores, dtype=np.float32)
    shifts = np.zeros(len(scores), dtype=np.int32)
    return MatchResult(int(np.argmin(scores)), scores, shifts, np.asarray(headings, dtype=np.float64), width)


def test_single_frame_finds_the_place_and_heading_of_a_turned_reference():
    rng = np.random.default_rng(0)
    ref_map = _lattice_map(rng)
    loc = Localizer(ref_map, method="paper", seq_len=1, grid_width=61, grid_height=41, margin=0.0)
    for k in rng.choice(len(ref_map), 8, replace=False):
        turn = int(rng.integers(48))
        query = np.ascontiguousarray(np.roll(ref_map.images[k], turn, axis=1))
        est = loc.update(query)
        assert est.ref_index == k and est.best_ref == k and est.score == 0.0
        assert (est.x, est.y) == pytest.approx(tuple(ref_map.positions[k]), abs=1e-9)
        # DESIGN convention: a query rolled right by `turn` columns looks 2*pi*turn/48 further left
        assert est.heading == pytest.approx(wrap_angle(ref_map.headings[k] + 2 * np.pi * turn / 48), abs=1e-12)
        assert est.frames == 1 and 0.0 <= est.confidence <= 1.0


def test_interpolation_off_reports_the_best_reference_position():
    rng = np.random.default_rng(1)
    ref_map = _lattice_map(rng)
    loc = Localizer(ref_map, method="paper", seq_len=1, interpolation=False)
    scores = rng.uniform(20, 40, len(ref_map))
    scores[5] = 2.0
    est = loc.update_match(_result(scores, np.zeros(len(ref_map))))
    assert est.ref_index == 5 and (est.x, est.y) == tuple(ref_map.positions[5])


def test_sequence_heat_map_equals_the_fusion_oracle():
    rng = np.random.default_rng(2)
    ref_map = _lattice_map(rng)
    n = 4
    loc = Localizer(ref_map, method="paper", seq_len=n)
    mapper = HeatMapper(ref_map.positions)  # independent, float64 path
    frames, steps = [], []
    for t in range(9):
        scores = rng.uniform(5, 40, len(ref_map))
        step = rng.normal(0, 0.4, 2) if t else None
        est = loc.update_match(_result(scores, np.zeros(len(ref_map))), step, return_heatmap=True)
        frames.append(mapper.heat_map(scores))
        steps.append(step)
        window = frames[-n:]
        window_steps = np.array(steps[len(steps) - len(window) + 1 :]).reshape(-1, 2)
        offsets = np.vstack([cumulative_offsets(window_steps), [0.0, 0.0]])
        expected = fuse([h for h, _ in window], mapper.grid.to_cells(offsets), [f for _, f in window])
        assert est.frames == len(window)
        np.testing.assert_allclose(est.heatmap, expected, atol=2e-5)
        np.testing.assert_allclose(est.frame_heatmap, window[-1][0], atol=2e-6)
        i = round((est.x - mapper.grid.x0) / mapper.grid.dx)
        j = round((est.y - mapper.grid.y0) / mapper.grid.dy)
        assert expected[j, i] >= expected.max() - 1e-4  # the estimate is the oracle's hottest cell


def test_robot_frame_odometry_gives_the_same_result_as_map_displacements():
    rng = np.random.default_rng(3)
    ref_map = _lattice_map(rng)
    t = np.linspace(0, 2, 10)
    positions = np.column_stack([1 + 2 * t, 2 + np.sin(2 * t)])
    headings = wrap_angle(np.arctan2(2 * np.cos(2 * t), 2.0) + 0.3)  # camera not along the path
    motions = true_robot_motions(positions, headings)
    by_map = Localizer(ref_map, method="paper", seq_len=6)
    by_robot = Localizer(ref_map, method="paper", seq_len=6)
    for k in range(len(positions)):
        scores = rng.uniform(5, 40, len(ref_map))
        # every reference agrees on the true heading, so the visual heading estimate is exact
        relative = wrap_angle(headings[k] - ref_map.headings)
        step = positions[k] - positions[k - 1] if k else None
        a = by_map.update_match(_result(scores, relative), step, return_heatmap=True)
        b = by_robot.update_match(_result(scores, relative), motions[k] if k else None, return_heatmap=True)
        np.testing.assert_allclose(b.heatmap, a.heatmap, atol=2e-5)
        assert (a.x, a.y, a.ref_index) == (b.x, b.y, b.ref_index)
        assert b.heading == pytest.approx(headings[k], abs=1e-9)


def test_unknown_motion_restarts_the_sequence_and_reset_forgets():
    rng = np.random.default_rng(4)
    ref_map = _lattice_map(rng)
    loc = Localizer(ref_map, method="paper", seq_len=3)
    r = _result(rng.uniform(5, 40, len(ref_map)), np.zeros(len(ref_map)))
    assert [loc.update_match(r, (0.1, 0)).frames for _ in range(4)] == [1, 2, 3, 3]
    assert loc.update_match(r, None).frames == 1
    assert loc.update_match(r, MapDisplacement(0.0, 0.1)).frames == 2
    loc.reset()
    assert math.isnan(loc.heading)
    assert loc.update_match(r, (0.0, 0.1)).frames == 1


def test_robot_motion_without_map_headings_is_a_clear_error():
    rng = np.random.default_rng(5)
    ref_map = _lattice_map(rng, with_headings=False)
    loc = Localizer(ref_map, method="paper")
    r = _result(rng.uniform(5, 40, len(ref_map)), np.zeros(len(ref_map)))
    est = loc.update_match(r)
    assert math.isnan(est.heading)
    with pytest.raises(ValueError, match="heading"):
        loc.update_match(r, RobotMotion(0.3, 0.0, 0.1))
    # the failed update changed nothing: the next one continues the same sequence
    assert loc.update_match(r, (0.3, 0.0)).frames == 2
    with pytest.raises(ValueError, match="NaN"):
        loc.update_match(_result(np.full(len(ref_map), np.nan), np.zeros(len(ref_map))), (0.1, 0.0))
    assert loc.update_match(r, (0.3, 0.0)).frames == 3


def test_raw_frames_are_prepared_with_the_map_parameters():
    rng = np.random.default_rng(6)
    raw = [np.clip(rng.normal(128, 40, (96, 192)), 0, 255).astype(np.uint8) for _ in range(12)]
    raw = [np.ascontiguousarray(np.repeat(np.repeat(r[::4, ::4], 4, 0), 4, 1)) for r in raw]  # smooth-ish
    positions = rng.uniform(0, 5, (12, 2))
    ref_map = nightloc.ReferenceMap(nightloc.prepare(np.stack(raw)), positions)
    a = Localizer(ref_map, method="paper", seq_len=2)
    b = Localizer(ref_map, method="paper", seq_len=2)
    for k in (3, 7):
        frame = np.ascontiguousarray(np.roll(raw[k], 8, axis=1))
        ea, eb = a.update(frame, (0.1, 0.0)), b.update(ref_map.preparer.prepare(frame), (0.1, 0.0))
        assert (ea.x, ea.y, ea.ref_index, ea.heading) == (eb.x, eb.y, eb.ref_index, eb.heading)
        assert ea.best_ref == k
    colour = np.dstack([raw[3]] * 3)
    assert a.update(colour).best_ref == 3
    with pytest.raises(ValueError, match="one frame"):
        a.update(np.stack(raw[:2]), prepared=True)


def test_matches_match_results_from_the_difference_matrix():
    rng = np.random.default_rng(7)
    ref_map = _lattice_map(rng)
    queries = np.ascontiguousarray(np.roll(ref_map.images[[2, 9, 11]], 5, axis=2))
    scores, shifts = nightloc.difference_matrix(queries, ref_map.images)
    loc1, loc2 = Localizer(ref_map, method="paper"), Localizer(ref_map, method="paper")
    for i, query in enumerate(queries):
        direct = loc1.update(query, (0.2, 0.1) if i else None)
        row = MatchResult(int(np.argmin(scores[i])), scores[i], shifts[i], shifts_to_headings(shifts[i], 48), 48)
        batch = loc2.update_match(row, (0.2, 0.1) if i else None)
        assert (direct.x, direct.y, direct.heading) == (batch.x, batch.y, batch.heading)


def test_params_overrides_and_toml(tmp_path):
    rng = np.random.default_rng(8)
    ref_map = _lattice_map(rng)
    loc = Localizer(ref_map, LocalizationParams(seq_len=3), method="paper", grid_width=40)
    assert loc.params.seq_len == 3 and loc.params.grid_width == 40 and loc.grid.width == 40
    assert LocalizationParams().seq_len == 7 and LocalizationParams().grid_width == 100
    save_params(tmp_path / "p.toml", LocalizationParams(seq_len=10, interpolation=False))
    loaded = load_params(tmp_path / "p.toml", LocalizationParams)
    assert loaded == LocalizationParams(seq_len=10, interpolation=False)
    with pytest.raises(TypeError, match="unknown localization parameter"):
        Localizer(ref_map, seq_length=3)
    with pytest.raises(ValueError, match="seq_len"):
        Localizer(ref_map, method="paper", seq_len=0)
    with pytest.raises(TypeError, match="ReferenceMap"):
        Localizer(ref_map.images)
    with pytest.raises(TypeError, match="MatchResult"):
        loc.update_match(np.zeros(len(ref_map)))
    with pytest.raises(ValueError, match="references"):
        loc.update_match(_result(np.zeros(3), np.zeros(3)))
    with pytest.raises(ValueError, match="dx, dy"):
        loc.update(ref_map.images[0], (1.0, 2.0, 3.0))


@pytest.mark.parametrize("method", ["filter", "paper"])
def test_the_revision_changes_with_the_state_and_only_with_it(method):
    rng = np.random.default_rng(5)
    ref_map = _lattice_map(rng)
    loc = Localizer(ref_map, method=method)
    frame = ref_map.images[3]
    seen = [loc.revision]

    def changed() -> bool:
        seen.append(loc.revision)
        return seen[-1] != seen[-2]

    loc.update(frame, prepared=True)
    assert changed()
    _ = (loc.heading, loc.grid)
    if method == "filter":
        loc.score_table(frame, prepared=True)
    assert not changed()  # reading is not changing
    loc.update(frame, (0.1, 0.0), prepared=True)
    assert changed()
    loc.reset()
    assert changed()
    if method == "filter":
        loc.noise = 3  # a setting, not the state
        _ = loc.belief
        assert not changed()
        loc.predict((0.2, 0.0))
        assert changed()
        loc.set_pose(2.0, 1.0)
        assert changed()
        loc.estimate_belief(loc.belief)
        assert changed()
