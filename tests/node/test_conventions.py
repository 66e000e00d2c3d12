"""The node's numbers without a middleware: REP 105's transforms against a known geometric
answer, the belief as an occupancy grid, odometry matched to frames by stamp (as the bag reader
matches a log), a log's odometry chained into poses, and setting the belief from an initial pose."""

from __future__ import annotations

import math

import numpy as np
import pytest

import nightloc
from nightloc.io.bag import interpolate_poses, robot_motions
from nightloc.localization.heatmap import HeatGrid
from nightloc.motion.odometry import MapDisplacement, NoiseModel, RobotMotion
from nightloc.node.conventions import BeliefRaster, compose, invert, map_to_odom, quaternion, stamp_of
from nightloc.node.record import odometry_poses
from nightloc.node.sync import MAX_SAMPLES, OdometrySync


def _matrix(pose):
    c, s = math.cos(pose[2]), math.sin(pose[2])
    return np.array([[c, -s, pose[0]], [s, c, pose[1]], [0, 0, 1.0]])


def test_map_to_odom_carries_the_odometry_pose_onto_the_localizer_s():
    rng = np.random.default_rng(0)
    for _ in range(20):
        in_map, in_odom = tuple(rng.uniform(-5, 5, 3)), tuple(rng.uniform(-5, 5, 3))
        correction = map_to_odom(in_map, in_odom)
        # homogeneous matrices: map_T_odom @ odom_T_base == map_T_base
        np.testing.assert_allclose(_matrix(correction) @ _matrix(in_odom), _matrix(in_map), atol=1e-12)
        np.testing.assert_allclose(_matrix(compose(in_map, invert(in_map))), np.eye(3), atol=1e-12)
    x, y, z, w = quaternion(math.pi / 2)
    assert (x, y) == (0.0, 0.0) and z == pytest.approx(math.sqrt(0.5)) and w == pytest.approx(math.sqrt(0.5))
    assert stamp_of(1.5) == (1, 500_000_000) and stamp_of(2.0000000004) == (2, 0)


def test_belief_raster_square_cells_and_peak_scaling():
    grid = HeatGrid(x0=0.25, y0=1.0, dx=0.5, dy=1.0, width=4, height=3)  # oblong cells
    raster = BeliefRaster(grid)
    assert raster.resolution == 0.5 and (raster.width, raster.height) == (4, 6)
    assert raster.origin == (0.0, 0.5)
    belief = np.zeros((3, 4))
    belief[2, 1] = 0.6  # the top row, second column
    belief[0, 3] = 0.3
    values = raster.values(belief).reshape(6, 4)
    assert values.dtype == np.int8
    # each grid row covers two raster rows; row 0 is the lowest y
    np.testing.assert_array_equal(values[4:, 1], [100, 100])
    np.testing.assert_array_equal(values[:2, 3], [50, 50])
    assert values.sum() == 2 * 100 + 2 * 50


def test_odometry_sync_matches_the_bag_reader_and_stays_bounded():
    rng = np.random.default_rng(1)
    times = np.cumsum(rng.uniform(0.01, 0.05, 400))
    samples = np.column_stack([np.cumsum(rng.normal(0, 0.05, 400)), np.cumsum(rng.normal(0, 0.05, 400)),
                               np.cumsum(rng.normal(0, 0.3, 400))])  # fmt: skip
    frames = np.sort(rng.uniform(times[5], times[-5], 30))
    whole = interpolate_poses(times, samples, frames, 0.25, "odometry", "frames")  # the bag reader, at once
    expected = robot_motions(whole)
    sync = OdometrySync(0.25)
    fed = 0
    for k, stamp in enumerate(frames):
        while fed < len(times) and times[fed] < stamp + 0.06:  # the stream arrives as it goes
            assert sync.add(times[fed], tuple(samples[fed])) == ""
            fed += 1
        assert sync.covers(stamp)
        pose = sync.pose_at(stamp)
        np.testing.assert_allclose(pose[:2], whole[k, :2], atol=1e-12)
        assert math.remainder(pose[2] - whole[k, 2], 2 * math.pi) == pytest.approx(0, abs=1e-9)
        motion = sync.motion(stamp, pose)
        if k == 0:
            assert motion is None
        else:
            np.testing.assert_allclose((motion.forward, motion.left), expected[k, :2], atol=1e-9)
            assert math.remainder(motion.turn - expected[k, 2], 2 * math.pi) == pytest.approx(0, abs=1e-9)
    assert len(sync._samples) < 40  # only the window the next frames need
    for k in range(MAX_SAMPLES + 10):  # whatever the stamps do, bounded
        sync.add(1000.0 + k, (0.0, 0.0, 0.0))
    assert len(sync._samples) == MAX_SAMPLES


def test_odometry_sync_complaints_and_covariance_noise():
    sync = OdometrySync(0.1)
    assert "non-finite" in sync.add(1.0, (math.nan, 0.0, 0.0))
    assert sync.add(1.0, (0.0, 0.0, 0.0), (0.04, 0.0, 0.01)) == ""
    assert sync.add(2.0, (1.0, 0.0, 0.0)) == ""
    assert sync.step_noise(1.05, 0.5) == NoiseModel(0.2 * 0.5, 0.1 * 0.5)
    assert sync.step_noise(1.9, 0.5) is None  # all zeros: unknown
    with pytest.raises(nightloc.DatasetError, match=r"lie more than 0.1 s"):
        sync.pose_at(1.5)  # in a gap of the stream
    assert "back in time" in sync.add(1.5, (0.0, 0.0, 0.0))
    assert sync.newest == 1.5 and sync.pose_at(1.5) == (0.0, 0.0, 0.0)


def test_odometry_poses_chain_a_log_s_motions():
    motions = [None, RobotMotion(1.0, 0.0, math.pi / 2), RobotMotion(1.0, 0.0, 0.0), None, MapDisplacement(0.5, 0.0)]
    poses = odometry_poses(motions)
    np.testing.assert_allclose(poses, [(0, 0, 0), (1, 0, math.pi / 2), (1, 1, math.pi / 2), (1, 1, math.pi / 2),
                                       (1.5, 1, math.pi / 2)], atol=1e-12)  # fmt: skip


@pytest.fixture(scope="module")
def small_map():
    rng = np.random.default_rng(2)
    images = nightloc.patch_normalize(rng.integers(0, 256, (30, 24, 48), dtype=np.uint8))
    return nightloc.ReferenceMap(images, rng.uniform(0, 6, (30, 2)), rng.uniform(-np.pi, np.pi, 30))


def test_set_pose_makes_the_belief_that_gaussian(small_map):
    loc = nightloc.Localizer(small_map)
    loc.set_pose(2.0, 3.0, 1.0, np.diag([0.09, 0.04, 0.01]))
    belief = loc.pose_belief
    grid = loc.grid
    marginal = belief.sum(axis=0)
    gx, gy = np.meshgrid(grid.xs, grid.ys)
    mean = ((marginal * gx).sum(), (marginal * gy).sum())
    assert mean == pytest.approx((2.0, 3.0), abs=0.01)
    variance_x = (marginal * (gx - mean[0]) ** 2).sum()
    assert variance_x == pytest.approx(0.09 + grid.dx**2 / 4, rel=0.05)  # widened by half a cell
    bins = belief.shape[0]
    headings = 2 * np.pi * np.arange(bins) / bins
    per_bin = belief.sum(axis=(1, 2))
    assert headings[np.argmax(per_bin)] == pytest.approx(1.0, abs=np.pi / bins)
    with pytest.raises(ValueError, match="off the map's grid"):
        loc.set_pose(500.0, 500.0, 0.0, np.diag([0.01, 0.01, 0.01]))


def test_heading_variance_uniform_and_settled(small_map):
    loc = nightloc.Localizer(small_map)
    image = small_map.images[3]
    first = loc.update(image)
    assert first.heading_variance <= math.pi**2 / 3 + 1e-9
    loc.set_pose(*small_map.positions[3], float(small_map.headings[3]), np.diag([0.01, 0.01, 0.001]))
    settled = loc.update(image, RobotMotion(0.0, 0.0, 0.0))
    assert settled.heading_variance < 0.05  # concentrated: about the bin width squared
    loc.reset()
    uniform = loc.predict(RobotMotion(0.0, 0.0, 0.0))
    assert uniform.heading_variance == pytest.approx(math.pi**2 / 3, rel=0.01)  # (2 pi)^2 / 12, bins centred
    paper = nightloc.Localizer(small_map, method="paper").update(image)
    assert math.isnan(paper.heading_variance)
