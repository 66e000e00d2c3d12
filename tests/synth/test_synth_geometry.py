"""nightloc.synth geometry and camera: exact intersections, the column convention, parallax,
occlusion, and agreement with nightloc.match's relative heading."""

from __future__ import annotations

import math

import numpy as np
import pytest

import nightloc
from nightloc.synth import Camera, SynthScene, cast_rays, column_azimuths, row_elevations
from nightloc.synth.geometry import Cylinder, PackedGeometry, Prism, box, horizontal_intervals, panel, slab_hits
from nightloc.synth.render import GROUND, OBJECT, SKY

from synth_support import bare_world

W = 192


def wrap(angle: float) -> float:
    return (angle + math.pi) % (2 * math.pi) - math.pi


def expected_column(heading: float, x: float, y: float, target) -> float:
    """Column (0..W) where the camera at (x, y) with ``heading`` sees the point ``target``."""
    azimuth = math.atan2(target[1] - y, target[0] - x)
    return ((heading - azimuth) * W / (2 * math.pi)) % W


def object_columns(hits, obj: int, row: int) -> np.ndarray:
    """Panorama columns (pixel units) whose ray in ``row`` hits object ``obj``."""
    oversample = hits.kind.shape[1] // W
    cols = np.flatnonzero((hits.kind[row] == OBJECT) & (hits.obj[row] == obj))
    return (cols + 0.5) / oversample - 0.5


def horizon_row(camera: Camera) -> int:
    return int(np.argmin(np.abs(row_elevations(camera))))


# --- exact intersections -----------------------------------------------------------------------


def test_ray_box_and_cylinder_intervals_are_exact():
    geometry = PackedGeometry([box(2.0, -1.0, 3.0, 1.0, 0.0, 1.0, "grey"), Cylinder((5.0, 0.0), 1.0, 0.0, 1.0, "grey")])
    spans = horizontal_intervals(geometry, 0.0, 0.0, np.array([1.0]), np.array([0.0]))
    np.testing.assert_allclose(spans.d_in[0], [2.0, 4.0])
    np.testing.assert_allclose(spans.d_out[0], [3.0, 6.0])
    # Entry through the box's west face (edge 3, which starts at perimeter 1 + 2 + 1 = 4 and
    # runs from (2, 1) down to (2, -1), so y = 0 is 1 m along it) and the cylinder's west point.
    np.testing.assert_allclose(spans.u_in[0], [5.0, math.pi])
    np.testing.assert_allclose(spans.nx[0], [-1.0, -1.0], atol=1e-12)
    np.testing.assert_allclose(spans.ny[0], [0.0, 0.0], atol=1e-12)
    # A diagonal ray misses the box, and from inside the box the entry distance is 0.
    miss = horizontal_intervals(geometry, 0.0, 0.0, np.array([0.0]), np.array([1.0]))
    assert np.all(np.isinf(miss.d_in[0]))
    inside = horizontal_intervals(geometry, 2.5, 0.0, np.array([1.0]), np.array([0.0]))
    assert inside.d_in[0, 0] == 0.0 and inside.d_out[0, 0] == pytest.approx(0.5)
    assert inside.d_in[0, 1] == pytest.approx(1.5)


def test_slab_hits_side_cap_and_miss():
    d_in, d_out = np.array(2.0), np.array(3.0)
    h = 0.3
    # A 1 m tall prism 2..3 m away: a ray rising 0.2 m/m is at 0.7 m at 2 m: hits the side.
    assert slab_hits(d_in, d_out, 0.0, 1.0, np.array(0.2), h) == pytest.approx(2.0)
    # Rising 0.4 m/m it is at 1.1 m at 2 m and 1.5 m at 3 m: passes over.
    assert np.isinf(slab_hits(d_in, d_out, 0.0, 1.0, np.array(0.4), h))
    # A floating slab 1..2 m high: rising 0.3 m/m the ray enters its underside at 0.3 + 0.3 d = 1.
    assert slab_hits(d_in, d_out, 1.0, 2.0, np.array(0.3), h) == pytest.approx(0.7 / 0.3)
    # Level ray at camera height through a prism that spans it; and one below its bottom.
    assert slab_hits(d_in, d_out, 0.0, 1.0, np.array(0.0), h) == pytest.approx(2.0)
    assert np.isinf(slab_hits(d_in, d_out, 0.5, 1.0, np.array(0.0), h))


def test_prism_rejects_bad_footprints():
    with pytest.raises(ValueError, match="convex"):
        Prism(np.array([[0, 0], [0, 1], [1, 1], [1, 0]], float), 0.0, 1.0, "grey")  # clockwise
    with pytest.raises(ValueError, match="above"):
        box(0, 0, 1, 1, 1.0, 1.0, "grey")
    with pytest.raises(ValueError, match="radius"):
        Cylinder((0, 0), 0.0, 0.0, 1.0, "grey")


def test_panel_front_face_is_edge_zero_facing_the_given_way():
    front = panel((0.0, 0.0), 1.0, 0.1, math.pi / 2, 0.0, 1.0, "grey")  # faces +y
    geometry = PackedGeometry([front])
    np.testing.assert_allclose(geometry.edge_normals[0, 0], [0.0, 1.0], atol=1e-12)
    # Seen from the front (looking south), u grows to the viewer's right (west, -x).
    spans = horizontal_intervals(geometry, 0.3, 2.0, np.array([0.0]), np.array([-1.0]))
    spans_w = horizontal_intervals(geometry, -0.3, 2.0, np.array([0.0]), np.array([-1.0]))
    assert spans.u_in[0, 0] == pytest.approx(0.2) and spans_w.u_in[0, 0] == pytest.approx(0.8)


# --- the camera --------------------------------------------------------------------------------


def test_column_azimuth_convention():
    azimuths = column_azimuths(0.7, W)
    np.testing.assert_allclose(azimuths, 0.7 - 2 * np.pi * np.arange(W) / W)
    elevations = row_elevations(Camera(height=96))
    assert elevations[0] == pytest.approx(math.radians(50 - 80 / 96 / 2))
    assert elevations[-1] == pytest.approx(math.radians(-30 + 80 / 96 / 2))
    with pytest.raises(ValueError, match="width"):
        Camera(width=0)
    with pytest.raises(ValueError, match="elevations"):
        Camera(elevation_top_deg=-40.0)


@pytest.mark.parametrize("heading", [0.5, -2.0, 3.0])
def test_landmark_column_follows_heading_and_moves_right_when_turning_left(heading):
    post = (3.0, 1.0)
    world = bare_world([Cylinder(post, 0.05, 0.0, 2.0, "grey")])
    camera = Camera()
    row = horizon_row(camera)
    seen = []
    for turn in (0.0, 0.3):  # 0.3 rad counter-clockwise = a left turn
        cols = object_columns(cast_rays(world, 0.0, 0.0, heading + turn, camera), 0, row)
        assert len(cols) > 0
        expected = expected_column(heading + turn, 0.0, 0.0, post)
        centre = expected + wrap(2 * math.pi * (cols.mean() - expected) / W) * W / (2 * math.pi)
        assert centre == pytest.approx(expected, abs=0.5)
        seen.append(centre)
    assert seen[1] - seen[0] == pytest.approx(0.3 * W / (2 * math.pi), abs=0.5)  # moved right


def test_parallax_near_objects_move_more_and_occlude_far_ones():
    near, far = (1.0, 1.0), (5.0, 5.0)  # same azimuth (45 degrees) from the origin
    world = bare_world([Cylinder(near, 0.1, 0.0, 0.6, "grey"), Cylinder(far, 0.3, 0.0, 4.0, "grey")])
    camera = Camera(height=192)  # fine rows for the occlusion edge
    heading = math.pi / 4 + 1.0
    start = cast_rays(world, 0.0, 0.0, heading, camera)
    column = int(round(expected_column(heading, 0.0, 0.0, near) * 2))  # oversampled column
    # Occlusion along that column: the near post's top edge hides the far tree below it.
    elevations = row_elevations(camera)
    near_front = math.hypot(*near) - 0.1
    near_top = math.atan((0.6 - 0.3) / near_front)
    near_foot = -math.atan(0.3 / near_front)  # below it the ground is nearer than the post
    far_top = math.atan((4.0 - 0.3) / (math.hypot(*far) - 0.3))
    for r, elevation in enumerate(elevations):
        kind, obj = start.kind[r, column], start.obj[r, column]
        if near_foot + 0.01 < elevation < near_top - 0.01:
            assert (kind, obj) == (OBJECT, 0)
        elif near_top + 0.01 < elevation < far_top - 0.01:
            assert (kind, obj) == (OBJECT, 1)
        elif elevation > far_top + 0.01:
            assert kind == SKY
        elif elevation < near_foot - 0.01:
            assert kind == GROUND
    # Moving 0.5 m along +x: both shift left in the image, the near post much more.
    row = horizon_row(camera) - 2
    moved = cast_rays(world, 0.5, 0.0, heading, camera)
    shifts = []
    for obj, target in ((0, near), (1, far)):
        after = object_columns(moved, obj, row).mean()
        assert after == pytest.approx(expected_column(heading, 0.5, 0.0, target), abs=0.6)
        shifts.append(after - expected_column(heading, 0.0, 0.0, target))
    assert shifts[0] < shifts[1] < 0 and abs(shifts[0]) > 3 * abs(shifts[1])


def test_ground_below_and_undersides_of_floating_objects():
    world = bare_world([box(-1.0, -1.0, 1.0, 1.0, 1.5, 1.7, "grey")])  # a slab overhead
    hits = cast_rays(world, 0.0, 0.0, 0.0, Camera())
    up = hits.elevation > math.atan(1.2 / 1.0) + 0.02  # sees the slab's underside everywhere
    assert np.all(hits.kind[up] == OBJECT) and np.all(hits.nz[up] == -1.0)
    np.testing.assert_allclose(hits.z[up], 1.5)
    down = hits.elevation < -0.01
    assert np.all(hits.kind[down] == GROUND)
    np.testing.assert_allclose(
        hits.distance[down], (0.3 / -np.tan(hits.elevation[down]))[:, None] * np.ones((1, hits.kind.shape[1]))
    )


# --- agreement with the matcher ----------------------------------------------------------------


@pytest.mark.parametrize(("h_ref", "h_query"), [(0.4, 1.1), (0.4, -2.3), (-3.0, 3.0), (2.0, 2.0)])
def test_relative_heading_matches_nightloc_match(h_ref, h_query):
    scene = SynthScene("garden", seed=0)
    refs = np.stack([scene.frame("day", x, y, h_ref) for x, y in [(1.0, 1.0), (3.5, 2.5), (6.0, 4.0)]])
    query = scene.frame("day", 3.5, 2.5, h_query)
    result = nightloc.match(nightloc.prepare(query), nightloc.prepare(refs))
    assert result.index == 1
    assert abs(wrap(result.heading - (h_query - h_ref))) <= 2 * math.pi / 48 * 0.75


def test_camera_inside_an_object_is_refused():
    scene = SynthScene("living_room", seed=0)
    with pytest.raises(ValueError, match="inside an object"):
        scene.world.check_camera_positions(np.array([[1.0, 1.0], [2.5, 3.5]]))  # the sofa
