"""The rendered routes' vertical viewpoint (camera height, pitch offset, per-frame and slow pitch
wobble) and route mode's default window against it: the renderer's geometry and a street walked
at night from a higher, tilted, hand-held camera. The shared real pairs with the default window:
test_route_window.py."""

from __future__ import annotations

import numpy as np
import pytest

from nightloc import route
from nightloc.route import RouteParams
from nightloc.route.params import DEFAULT_SHIFT_WINDOWS
from nightloc.synth.routes import FORWARD_CAMERA, Drive, RouteScene, build_street, render_drive, street_drive

import route_oracle as ro


@pytest.fixture(scope="module")
def street():
    world = build_street(2, 60.0)
    return world, RouteScene(world, 2)


def _one_frame(drive: Drive, i: int, pitch: float = 0.0, height: float | None = None) -> Drive:
    heights = drive.heights[i : i + 1] if height is None else np.array([height])
    return Drive(drive.positions[i : i + 1], drive.headings[i : i + 1], np.array([pitch]), "day", 0.0, 5, heights)


def test_street_drive_vertical_viewpoint(street):
    world, _scene = street
    plain = street_drive(world, "night", 1.0, seed=4)
    assert np.all(plain.heights == world.camera_height) and np.all(plain.pitches == 0.0)
    moved = street_drive(world, "night", 1.0, seed=4, height=1.0, pitch=-2.0, pitch_wobble=1.5)
    # The vertical viewpoint draws from its own stream: the walk's path is the same walk.
    np.testing.assert_array_equal(moved.positions, plain.positions)
    np.testing.assert_array_equal(moved.headings, plain.headings)
    assert np.all(moved.heights == 1.0)
    # A slow wobble: smooth along the route (frames 0.8 m apart, correlation length 4 m) ...
    long_world = build_street(0, 400.0)
    slow = street_drive(long_world, "night", seed=7, pitch=1.0, pitch_wobble=1.5).pitches - 1.0
    fast = street_drive(long_world, "night", seed=7, pitch=1.0, pitch_jitter=1.5).pitches - 1.0
    lag1 = lambda v: float(np.corrcoef(v[:-1], v[1:])[0, 1])  # noqa: E731
    assert lag1(slow) > 0.95 and abs(lag1(fast)) < 0.1, (lag1(slow), lag1(fast))
    # ... with the standard deviation asked for (about 24 independent stretches of 16 m here).
    assert 1.0 < slow.std() < 2.0 and abs(slow.mean()) < 0.6, (slow.std(), slow.mean())
    assert 1.35 < fast.std() < 1.65
    with pytest.raises(ValueError, match="height must be"):
        street_drive(world, "night", height=0.05)
    with pytest.raises(ValueError, match="pitch_wobble must be"):
        street_drive(world, "night", pitch_wobble=-1.0)
    with pytest.raises(ValueError, match="beyond 20 degrees"):
        street_drive(world, "night", pitch=15.0, pitch_wobble=3.0)
    with pytest.raises(ValueError, match="wobble_length"):
        street_drive(world, "night", pitch_wobble=1.0, wobble_length=0.0)


def test_render_drive_pitch_moves_rows_and_height_moves_the_near_scene(street):
    world, scene = street
    drive = street_drive(world, "day", 0.0, seed=5)
    i = len(drive.positions) // 2
    row_angle = (FORWARD_CAMERA.elevation_top_deg - FORWARD_CAMERA.elevation_bottom_deg) / FORWARD_CAMERA.height
    level = render_drive(scene, _one_frame(drive, i))[0].astype(np.float64)
    # Tilted up by exactly four rendered rows: the scene moves down by four rows.
    up = render_drive(scene, _one_frame(drive, i, pitch=4 * row_angle))[0].astype(np.float64)
    apart = [np.abs(up[k:] - level[: len(level) - k]).mean() for k in range(8)]
    assert int(np.argmin(apart)) == 4 and apart[4] < 0.2 * apart[0], apart  # the rest: sensor noise
    # The default height is the street's camera height.
    same = render_drive(scene, _one_frame(drive, i, height=world.camera_height))[0]
    np.testing.assert_array_equal(same, level.astype(np.uint8))
    # A camera 0.5 m lower: the near ground and fences (bottom rows) move, the far scene and the
    # sky (top rows) hardly do.
    low = render_drive(scene, _one_frame(drive, i, height=world.camera_height - 0.5))[0].astype(np.float64)
    change = np.abs(low - level).mean(axis=(1, 2))
    third = len(change) // 3
    assert change[-third:].mean() > 2 * change[:third].mean(), change


def test_default_window():
    assert DEFAULT_SHIFT_WINDOWS == {"forward": (8, 2), "panoramic": (0, 0)}
    assert RouteParams().effective_shift_window == (8, 2)
    assert RouteParams(circular_shifts=True).effective_shift_window == (0, 0)


@pytest.mark.slow
def test_rendered_walk_from_another_height_and_pitch():
    """A street walked by day at 1.4 m, then at night 1 m to the side with the camera 0.3 m higher,
    tilted 3 degrees up and wobbling slowly (1 degree) as if carried by hand (the sweep's street 2,
    walk lateral1_high_up_handheld; about a minute: 252 frames rendered). The former default
    window (+-8 columns, +-1 row) loses most of the walk both ways round; the default keeps it."""
    world = build_street(2, 120.0)
    scene = RouteScene(world, 2)
    preparer = route.RoutePreparer(RouteParams())
    day = preparer(render_drive(scene, street_drive(world, "day", 0.0, 200), "forward"))
    night_walk = street_drive(world, "night", 1.0, 210, height=1.7, pitch=3.0, pitch_wobble=1.0)
    night = preparer(render_drive(scene, night_walk, "forward"))
    for refs, queries in ((day, night), (night, day)):
        former = ro.evaluate_route(refs, queries, RouteParams(shift_window=(8, 1)))
        default = ro.evaluate_route(refs, queries, RouteParams())
        assert default.best_f1 >= 0.7 and default.recall_at_100 >= 0.45, default.summary()
        assert default.best_f1 >= former.best_f1 + 0.2, (former.summary(), default.summary())
        assert default.recall_at_100 >= former.recall_at_100 + 0.3, (former.summary(), default.summary())
