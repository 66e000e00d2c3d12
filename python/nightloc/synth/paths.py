"""The traverses of the paper's Table I, laid out in the synthetic worlds.

=====================  ==========  ======  ==============================================
traverse               lighting    frames  path
=====================  ==========  ======  ==============================================
garden/day_reference   day         24      lawn-mower path: 4 rows x 6 stops, 1.2 m apart
garden/night_reference night       53      the same path, sampled evenly along its length
garden/night_query     night       41      an alternative path, partly overlapping
living_room/day_reference  day     52      grid points 0.5 m x 1 m (13 x 4), row by row
living_room/night_query    night   32      random positions and headings
large_garden/day_reference day     901     a perimeter pass, then a lawn-mower drive, 0.5 m apart
large_garden/night_query   night   98      across the lawn, along it, back down the middle
=====================  ==========  ======  ==============================================

Another night (:func:`plan_night_drives`) drives both ways in every world: ``night_reference``
re-drives the day path (the living room's grid, 55 frames; the large garden's whole day drive,
as many frames as by day) and ``night_query`` drives the world's other path (the living room:
32 random poses), each night with its own wobble and sideways error.

Headings follow the direction of travel with a random wobble (std 8 degrees); the night
traverses also wander sideways off the nominal path (std 5-8 cm), as a driven robot does. The
seed draws the wobble, the sideways error and the living room's random query poses.

Times (:meth:`TraversePlan.timestamps`): the robot drives from frame to frame in a straight line
at :data:`DRIVE_SPEED_M_S`, and its camera (:data:`CAMERA_RATE_HZ`) takes frames at least one
period apart; the first frame is at :data:`FIRST_FRAME_S` (a ROS header stamp of 0 reads as
"unset", so a bag made from a traverse keeps its times).
"""

from __future__ import annotations

import itertools
from dataclasses import dataclass

import numpy as np

__all__ = [
    "CAMERA_RATE_HZ",
    "DRIVE_SPEED_M_S",
    "FIRST_FRAME_S",
    "NIGHT_DRIVES",
    "TRAVERSE_NAMES",
    "TraversePlan",
    "plan_night_drives",
    "plan_traverses",
]

TRAVERSE_NAMES: dict[str, tuple[str, ...]] = {
    "garden": ("day_reference", "night_reference", "night_query"),
    "living_room": ("day_reference", "night_query"),
    "large_garden": ("day_reference", "night_query"),
}

HEADING_WOBBLE = np.radians(8.0)
#: The synthetic robot's speed between frames (m/s), which gives the frames their times.
DRIVE_SPEED_M_S = 0.4
#: The synthetic camera's frame rate (Hz): two frames are at least one period apart.
CAMERA_RATE_HZ = 10.0
#: Time of each traverse's first frame (s).
FIRST_FRAME_S = 1.0


@dataclass(frozen=True)
class TraversePlan:
    """Where the frames of one traverse are taken.

    Attributes:
        name: traverse folder name, e.g. ``"night_query"``.
        condition: ``"day"`` or ``"night"``.
        positions: ``(N, 2)`` metres.
        headings: ``(N,)`` radians in (-pi, pi].
        carried: the frames the robot reached by being carried from the previous one (a
            kidnapped robot): its wheel odometry shows no motion for those steps.
    """

    name: str
    condition: str
    positions: np.ndarray
    headings: np.ndarray
    carried: tuple[int, ...] = ()

    def timestamps(self) -> np.ndarray:
        """``(N,)`` seconds of the frames: :data:`FIRST_FRAME_S`, then for each step the straight
        distance from the previous frame at :data:`DRIVE_SPEED_M_S`, at least one camera period
        (``1 / CAMERA_RATE_HZ``); rounded to milliseconds."""
        steps = np.hypot(*np.diff(np.asarray(self.positions, dtype=np.float64), axis=0).T)
        gaps = np.maximum(steps / DRIVE_SPEED_M_S, 1.0 / CAMERA_RATE_HZ)
        return np.round(FIRST_FRAME_S + np.concatenate([[0.0], np.cumsum(gaps)]), 3)


def wrap_angle(angles: np.ndarray) -> np.ndarray:
    """Angles wrapped to (-pi, pi]."""
    wrapped = np.mod(np.asarray(angles, float) + np.pi, 2 * np.pi) - np.pi
    return np.where(wrapped == -np.pi, np.pi, wrapped)


def _polyline_samples(waypoints: np.ndarray, count: int) -> tuple[np.ndarray, np.ndarray]:
    """``count`` points evenly spaced along a polyline (ends included) and the travel direction there."""
    segments = np.diff(waypoints, axis=0)
    lengths = np.hypot(segments[:, 0], segments[:, 1])
    cumulative = np.concatenate([[0.0], np.cumsum(lengths)])
    s = np.linspace(0.0, cumulative[-1], count)
    index = np.clip(np.searchsorted(cumulative, s, side="right") - 1, 0, len(segments) - 1)
    t = (s - cumulative[index]) / lengths[index]
    points = waypoints[index] + segments[index] * t[:, None]
    direction = np.arctan2(segments[index, 1], segments[index, 0])
    return points, direction


def _lawnmower_rows(xs: np.ndarray, ys: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Stops of a boustrophedon over the grid ``xs x ys`` and the direction of travel at each."""
    points, directions = [], []
    for row, y in enumerate(ys):
        order = xs if row % 2 == 0 else xs[::-1]
        for x in order:
            points.append((x, y))
            directions.append(0.0 if row % 2 == 0 else np.pi)
    return np.array(points), np.array(directions)


def _lawnmower_polyline(xs: np.ndarray, ys: np.ndarray) -> np.ndarray:
    corners = []
    for row, y in enumerate(ys):
        ends = (xs[0], xs[-1]) if row % 2 == 0 else (xs[-1], xs[0])
        corners += [(ends[0], y), (ends[1], y)]
    return np.array(corners)


def _wobble(rng: np.random.Generator, directions: np.ndarray) -> np.ndarray:
    return wrap_angle(directions + rng.normal(0.0, HEADING_WOBBLE, len(directions)))


def _sideways(rng: np.random.Generator, points: np.ndarray, directions: np.ndarray, std: float) -> np.ndarray:
    offset = rng.normal(0.0, std, len(points))
    return points + offset[:, None] * np.stack([-np.sin(directions), np.cos(directions)], axis=1)


GARDEN_ROW_X = np.linspace(0.5, 6.5, 6)
GARDEN_ROW_Y = np.linspace(0.5, 4.5, 4)
GARDEN_QUERY_WAYPOINTS = np.array([[0.5, 2.5], [6.5, 2.5], [6.5, 4.5], [3.5, 4.5], [0.5, 0.5]])
#: The large garden's day drive: a perimeter pass, then mowing rows 1 m apart, images every
#: LARGE_STEP metres; its night drive crosses the lawn.
LARGE_PERIMETER = np.array([[0.5, 0.5], [24.5, 0.5], [24.5, 14.5], [0.5, 14.5], [0.5, 0.5]])
LARGE_ROWS_X = np.array([0.5, 24.5])
LARGE_ROWS_Y = np.arange(0.5, 15.0, 1.0)
LARGE_STEP = 0.5
LARGE_NIGHT_WAYPOINTS = np.array([[1.0, 7.2], [24.0, 7.8], [13.0, 14.0], [13.0, 1.0]])
#: The large garden mowed in columns (``pattern="columns"``): columns 1 m apart along y (on the
#: quarter-metre marks, clear of the feeder and the trees), and a night drive along the diagonals.
LARGE_COLUMNS_X = np.arange(0.75, 24.8, 1.0)
LARGE_COLUMNS_Y = np.array([0.5, 14.5])
LARGE_COLUMNS_NIGHT_WAYPOINTS = np.array([[2.0, 2.0], [22.5, 12.8], [22.5, 2.5], [3.0, 11.5], [8.0, 7.5]])
#: Mowing patterns of the large garden's day drive.
LARGE_PATTERNS = ("rows", "columns")
LARGE_HEADING_WOBBLE = np.radians(4.0)
ROOM_GRID_X = np.linspace(0.0, 6.0, 13)
ROOM_GRID_Y = np.linspace(0.0, 3.0, 4)


def _spaced_polyline(waypoints: np.ndarray, step: float) -> tuple[np.ndarray, np.ndarray]:
    """Points every ``step`` metres along each segment of a polyline (its corners included, not
    repeated) and the travel direction at each; the first point is the polyline's start."""
    points, directions = [waypoints[:1]], [np.zeros(1)]
    for a, b in itertools.pairwise(waypoints):
        length = float(np.hypot(*(b - a)))
        count = max(1, int(round(length / step)))
        t = np.arange(1, count + 1) / count
        points.append(a + (b - a) * t[:, None])
        directions.append(np.full(count, np.arctan2(b[1] - a[1], b[0] - a[0])))
    direction = np.concatenate(directions)
    direction[0] = direction[1]
    return np.concatenate(points), direction


def _large_garden_plans(rng: np.random.Generator, pattern: str = "rows") -> list[TraversePlan]:
    if pattern not in LARGE_PATTERNS:
        raise ValueError(f"pattern must be one of {', '.join(LARGE_PATTERNS)}, got {pattern!r}")
    if pattern == "columns":  # the boustrophedon along y: rows of the transposed lawn, swapped back
        mowing = _lawnmower_polyline(LARGE_COLUMNS_Y, LARGE_COLUMNS_X)[:, ::-1]
        night_waypoints = LARGE_COLUMNS_NIGHT_WAYPOINTS
    else:
        mowing = _lawnmower_polyline(LARGE_ROWS_X, LARGE_ROWS_Y)
        night_waypoints = LARGE_NIGHT_WAYPOINTS
    day_path = np.concatenate([LARGE_PERIMETER, mowing[1:]])  # the mowing starts where the pass ended
    points, directions = _spaced_polyline(day_path, LARGE_STEP)
    headings = wrap_angle(directions + rng.normal(0.0, LARGE_HEADING_WOBBLE, len(directions)))
    day = TraversePlan("day_reference", "day", _sideways(rng, points, directions, 0.03), headings)
    points, directions = _spaced_polyline(night_waypoints, LARGE_STEP)
    night = TraversePlan("night_query", "night", _sideways(rng, points, directions, 0.08), _wobble(rng, directions))
    return [day, night]


def plan_traverses(world: str, seed: int = 0, pattern: str = "rows") -> list[TraversePlan]:
    """The traverses of ``world`` (``"garden"``, ``"living_room"`` or ``"large_garden"``), in
    Table I order; ``pattern`` is the large garden's mowing pattern (:data:`LARGE_PATTERNS`:
    ``"rows"`` along x, the default, or ``"columns"`` along y with another night drive)."""
    rng = np.random.default_rng([int(seed), 4, {"garden": 0, "living_room": 1}.get(world, 2)])
    if world == "large_garden":
        return _large_garden_plans(rng, pattern)
    if pattern != "rows":
        raise ValueError(f"pattern applies to the large garden only (got {pattern!r} for {world!r})")
    if world == "garden":
        stops, directions = _lawnmower_rows(GARDEN_ROW_X, GARDEN_ROW_Y)
        day = TraversePlan("day_reference", "day", stops, _wobble(rng, directions))
        points, directions = _polyline_samples(_lawnmower_polyline(GARDEN_ROW_X, GARDEN_ROW_Y), 53)
        night_ref = TraversePlan(
            "night_reference", "night", _sideways(rng, points, directions, 0.05), _wobble(rng, directions)
        )
        points, directions = _polyline_samples(GARDEN_QUERY_WAYPOINTS, 41)
        query = TraversePlan("night_query", "night", _sideways(rng, points, directions, 0.08), _wobble(rng, directions))
        return [day, night_ref, query]
    if world == "living_room":
        stops, directions = _lawnmower_rows(ROOM_GRID_X, ROOM_GRID_Y)
        day = TraversePlan("day_reference", "day", stops, _wobble(rng, directions))
        positions = np.stack([rng.uniform(0.1, 5.9, 32), rng.uniform(0.1, 2.9, 32)], axis=1)
        query = TraversePlan("night_query", "night", positions, wrap_angle(rng.uniform(-np.pi, np.pi, 32)))
        return [day, query]
    raise ValueError(f"unknown world {world!r}; choose one of {', '.join(TRAVERSE_NAMES)}")


#: The two drives of every night of :func:`plan_night_drives`: a re-drive of the day path and another path.
NIGHT_DRIVES: tuple[str, ...] = ("night_reference", "night_query")
#: Frames of the living room's night re-drive of its day grid (about 0.5 m apart).
ROOM_REDRIVE_FRAMES = 55


def plan_night_drives(world: str, seed: int = 0, night: int = 0, pattern: str = "rows") -> list[TraversePlan]:
    """A night's two drives of ``world``, named :data:`NIGHT_DRIVES`: ``night_reference`` along the
    day path and ``night_query`` along the world's other path, both ``"night"``.

    ``night`` numbers the nights of one dataset: night 0 is the usual one, whose drives are those
    of :func:`plan_traverses` (for the living room and the large garden, which have no night
    re-drive there, it is drawn here); night ``k > 0`` draws its own wobble, sideways error and
    (living room) query poses from ``(seed, k)``, along the same nominal paths.
    """
    if isinstance(night, bool) or not isinstance(night, (int, np.integer)) or night < 0:
        raise ValueError(f"night must be an int >= 0, got {night!r}")
    usual = {p.name: p for p in plan_traverses(world, seed, pattern)}
    world_id = {"garden": 0, "living_room": 1}.get(world, 2)
    rng = np.random.default_rng([int(seed), 4, world_id, 100 + int(night)])
    if night == 0 and "night_reference" in usual:
        return [usual[name] for name in NIGHT_DRIVES]
    if world == "garden":
        points, directions = _polyline_samples(_lawnmower_polyline(GARDEN_ROW_X, GARDEN_ROW_Y), 53)
        redrive = TraversePlan(
            "night_reference", "night", _sideways(rng, points, directions, 0.05), _wobble(rng, directions)
        )
        points, directions = _polyline_samples(GARDEN_QUERY_WAYPOINTS, 41)
        query = TraversePlan("night_query", "night", _sideways(rng, points, directions, 0.08), _wobble(rng, directions))
    elif world == "living_room":
        points, directions = _polyline_samples(_lawnmower_polyline(ROOM_GRID_X, ROOM_GRID_Y), ROOM_REDRIVE_FRAMES)
        points = np.clip(_sideways(rng, points, directions, 0.05), (-0.15, -0.15), (6.15, 3.15))
        redrive = TraversePlan("night_reference", "night", points, _wobble(rng, directions))
        if night == 0:
            query = usual["night_query"]
        else:
            positions = np.stack([rng.uniform(0.1, 5.9, 32), rng.uniform(0.1, 2.9, 32)], axis=1)
            query = TraversePlan("night_query", "night", positions, wrap_angle(rng.uniform(-np.pi, np.pi, 32)))
    else:  # the large garden: the day drive again, as many frames evenly along it
        day = usual["day_reference"]
        mowing = (
            _lawnmower_polyline(LARGE_COLUMNS_Y, LARGE_COLUMNS_X)[:, ::-1]
            if pattern == "columns"
            else _lawnmower_polyline(LARGE_ROWS_X, LARGE_ROWS_Y)
        )
        points, directions = _polyline_samples(np.concatenate([LARGE_PERIMETER, mowing[1:]]), len(day.positions))
        headings = wrap_angle(directions + rng.normal(0.0, LARGE_HEADING_WOBBLE, len(directions)))
        redrive = TraversePlan("night_reference", "night", _sideways(rng, points, directions, 0.05), headings)
        if night == 0:
            query = usual["night_query"]
        else:
            waypoints = LARGE_COLUMNS_NIGHT_WAYPOINTS if pattern == "columns" else LARGE_NIGHT_WAYPOINTS
            points, directions = _spaced_polyline(waypoints, LARGE_STEP)
            query = TraversePlan(
                "night_query", "night", _sideways(rng, points, directions, 0.08), _wobble(rng, directions)
            )
    return [redrive, query]
