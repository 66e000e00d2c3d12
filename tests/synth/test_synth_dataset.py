"""nightloc.synth datasets on disk: layout, determinism, the cached default, the command line,
and the night-vs-day matching signal (informative but hard)."""

from __future__ import annotations

import itertools
import json
import math
from pathlib import Path

import numpy as np
import pytest

import nightloc
from nightloc.cli import main
from nightloc.synth import (
    TRAVERSE_NAMES,
    Camera,
    default_cache_dir,
    default_dataset,
    make_dataset,
    plan_traverses,
)
from nightloc.synth.dataset import GENERATOR_VERSION

from synth_support import default_synth_data

SMALL = Camera(width=96, height=48)  # quarter-size frames keep these tests fast
TINY = Camera(width=48, height=24)


def images_of(folder: Path) -> list:
    return [p.read_bytes() for p in sorted((folder / "images").iterdir())]


def test_make_dataset_layout_and_poses(tmp_path):
    folders = make_dataset("living_room", tmp_path / "room", seed=3, camera=SMALL)
    assert list(folders) == ["day_reference", "night_query"]
    plans = {p.name: p for p in plan_traverses("living_room", 3)}
    for name, folder in folders.items():
        traverse = nightloc.load_traverse(folder)
        assert len(traverse) == {"day_reference": 52, "night_query": 32}[name]
        assert (folder / "poses.csv").read_text().splitlines()[0] == "image,x,y,heading,timestamp"
        assert (folder / "odometry.csv").read_text().splitlines()[0] == "image,forward,left,turn,timestamp"
        np.testing.assert_allclose(traverse.positions, plans[name].positions)
        np.testing.assert_allclose(traverse.headings, plans[name].headings)
        image = traverse.read(0)
        assert image.shape == (48, 96, 3) and image.dtype == np.uint8
    description = json.loads((tmp_path / "room" / "dataset.json").read_text())
    assert description["generator_version"] == GENERATOR_VERSION and description["seed"] == 3
    assert description["mapped_area"] == {"x0": 0.0, "y0": 0.0, "x1": 6.0, "y1": 3.0}
    assert description["traverses"]["night_query"] == {"condition": "night", "frames": 32}
    hidden = [p.name for p in (tmp_path / "room").iterdir() if p.name.startswith(".")]
    assert hidden == [".nightloc-output.json"]  # the set's record of its files; no leftovers


def _drive_times(positions: np.ndarray) -> list[float]:
    """Oracle of the frames' times: 1 s, then each straight step driven at 0.4 m/s, never less than
    a 10 Hz camera's period; milliseconds."""
    times = [1.0]
    for (x0, y0), (x1, y1) in itertools.pairwise(positions):
        times.append(times[-1] + max(math.hypot(x1 - x0, y1 - y0) / 0.4, 0.1))
    return [round(t, 3) for t in times]


def test_synthetic_traverses_carry_their_frames_times(tmp_path):
    """poses.csv and odometry.csv end with each frame's time, from the documented drive speed and
    camera rate, so a bag or a TUM trajectory can be made from them without inventing a frame rate."""
    folders = make_dataset("living_room", tmp_path / "room", seed=3, camera=TINY)
    plans = {p.name: p for p in plan_traverses("living_room", 3)}
    description = json.loads((tmp_path / "room" / "dataset.json").read_text())
    assert description["timing"] == {"drive_speed_m_s": 0.4, "camera_rate_hz": 10.0, "first_frame_s": 1.0}
    for name, folder in folders.items():
        expected = _drive_times(plans[name].positions)
        traverse = nightloc.load_traverse(folder)
        np.testing.assert_allclose(traverse.timestamps, expected, rtol=0, atol=1e-9)
        assert (np.diff(traverse.timestamps) >= 0.1 - 1e-9).all()
        (folder / "poses.csv").unlink()  # the times are in odometry.csv too
        np.testing.assert_allclose(nightloc.load_traverse(folder).timestamps, expected, rtol=0, atol=1e-9)


def test_a_bag_made_from_a_synthetic_traverse_keeps_its_times(tmp_path):
    from bag_support import stamp_ns, write_bag

    night = nightloc.load_traverse(default_synth_data()["garden"]["night_query"])
    frames = [night.read(i) for i in range(len(night))]
    stamps = [stamp_ns(t) for t in night.timestamps]
    poses = np.column_stack([night.positions, night.headings])
    bag = nightloc.load_traverse(write_bag(tmp_path / "night", frames, stamps, odometry=poses))
    np.testing.assert_allclose(bag.timestamps, night.timestamps, rtol=0, atol=1e-6)
    assert night.timestamps[0] == 1.0 and len(bag) == len(night)


def test_traverses_mirror_table_one():
    counts = {w: {p.name: len(p.positions) for p in plan_traverses(w, 0)} for w in ("garden", "living_room")}
    assert counts == {
        "garden": {"day_reference": 24, "night_reference": 53, "night_query": 41},
        "living_room": {"day_reference": 52, "night_query": 32},
    }
    for world in ("garden", "living_room"):  # the names the cache check and default_dataset use
        for seed in (0, 7):
            assert tuple(p.name for p in plan_traverses(world, seed)) == TRAVERSE_NAMES[world]
    for world, area in (("garden", (0, 0, 7, 5)), ("living_room", (0, 0, 6, 3))):
        for plan in plan_traverses(world, 0):
            x, y = plan.positions.T
            assert np.all((x >= area[0] - 0.3) & (x <= area[2] + 0.3) & (y >= area[1] - 0.3) & (y <= area[3] + 0.3))
            assert np.all((plan.headings > -math.pi) & (plan.headings <= math.pi))
            assert np.ptp(np.cos(plan.headings)) > 1.0  # headings vary along the path
    garden = {p.name: p for p in plan_traverses("garden", 0)}
    # The night reference follows the day path; the query only partly overlaps it.
    gap = lambda a, b: np.linalg.norm(a[:, None] - b[None], axis=2).min(axis=1)  # noqa: E731
    assert np.median(gap(garden["night_reference"].positions, garden["day_reference"].positions)) < 0.7
    query_gap = gap(garden["night_query"].positions, garden["night_reference"].positions)
    assert np.mean(query_gap < 0.2) > 0.15 and np.mean(query_gap > 0.4) > 0.3


def test_the_large_garden_mowed_in_columns_runs_along_y_clear_of_the_objects():
    from nightloc.synth.world import build_world

    rows = {p.name: p for p in plan_traverses("large_garden", 0)}
    columns = {p.name: p for p in plan_traverses("large_garden", 0, "columns")}
    world = build_world("large_garden", 0)
    for plan in columns.values():
        world.check_camera_positions(plan.positions)  # raises for a position inside an object
        x, y = plan.positions.T
        assert np.all((x > 0.2) & (x < 24.9) & (y > 0.2) & (y < 14.8))  # on the lawn
    day = columns["day_reference"]
    mowing = day.positions[157:]  # after the perimeter pass (78 m at 0.5 m)
    # the mowing drives along y: most steps move in y, and the day headings point along +-y
    steps = np.diff(mowing, axis=0)
    assert np.mean(np.abs(steps[:, 1]) > np.abs(steps[:, 0])) > 0.85  # the rest: 1 m between columns
    assert np.median(np.abs(np.sin(day.headings[157:]))) > 0.95
    assert np.median(np.abs(np.cos(rows["day_reference"].headings[157:]))) > 0.95
    # and the night drive is another route
    assert not np.allclose(columns["night_query"].positions[:50], rows["night_query"].positions[:50], atol=1.0)
    with pytest.raises(ValueError, match="pattern"):
        plan_traverses("large_garden", 0, "spiral")
    with pytest.raises(ValueError, match="large garden only"):
        plan_traverses("garden", 0, "columns")


def test_same_seed_gives_byte_identical_images_whatever_the_threads(tmp_path):
    a = make_dataset("garden", tmp_path / "a", seed=5, camera=TINY, threads=1)
    b = make_dataset("garden", tmp_path / "b", seed=5, camera=TINY, threads=2)
    c = make_dataset("garden", tmp_path / "c", seed=6, camera=TINY)
    for name in a:
        assert images_of(a[name]) == images_of(b[name])
        assert (a[name] / "poses.csv").read_bytes() == (b[name] / "poses.csv").read_bytes()
        assert images_of(a[name]) != images_of(c[name])


def test_existing_output_is_kept_unless_overwrite(tmp_path):
    make_dataset("living_room", tmp_path, seed=0, camera=TINY)
    before = images_of(tmp_path / "night_query")
    with pytest.raises(FileExistsError, match="overwrite"):
        make_dataset("living_room", tmp_path, seed=1, camera=TINY)
    assert images_of(tmp_path / "night_query") == before
    make_dataset("living_room", tmp_path, seed=1, camera=TINY, overwrite=True)
    assert images_of(tmp_path / "night_query") != before


@pytest.mark.parametrize(
    ("kwargs", "error", "message"),
    [
        ({"world": "moon"}, ValueError, "unknown world"),
        ({"seed": -1}, ValueError, "seed"),
        ({"seed": 1.5}, ValueError, "seed"),
        ({"darkness": -0.5}, ValueError, "darkness"),
        ({"darkness": float("nan")}, ValueError, "darkness"),
    ],
)
def test_bad_arguments_are_clear_errors_and_write_nothing(tmp_path, kwargs, error, message):
    arguments = {"world": "garden", "out_dir": tmp_path / "out", "seed": 0, **kwargs}
    with pytest.raises(error, match=message):
        make_dataset(camera=SMALL, **arguments)
    assert not (tmp_path / "out").exists()


def test_default_dataset_is_generated_once_into_the_cache(tmp_path, monkeypatch):
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path / "xdg"))
    assert default_cache_dir() == tmp_path / "xdg" / "nightloc"
    monkeypatch.delenv("XDG_CACHE_HOME")
    monkeypatch.setenv("HOME", str(tmp_path / "home"))
    assert default_cache_dir() == tmp_path / "home" / ".cache" / "nightloc"

    paths = default_synth_data()
    assert set(paths) == {"garden", "living_room"}
    assert set(paths["garden"]) == {"day_reference", "night_reference", "night_query"}
    folder = paths["garden"]["day_reference"].parents[1]
    assert folder.name == f"synth-v{GENERATOR_VERSION}-seed0"
    stamp = (paths["garden"]["night_query"] / "poses.csv").stat().st_mtime_ns
    again = default_dataset(cache_dir=folder.parent)  # already there: nothing is regenerated
    assert again == paths and (paths["garden"]["night_query"] / "poses.csv").stat().st_mtime_ns == stamp
    assert nightloc.load_traverse(paths["living_room"]["night_query"]).read(0).shape == (96, 192, 3)


def test_incomplete_cache_is_regenerated(tmp_path, monkeypatch):
    import nightloc.synth.dataset as dataset

    real = dataset.make_dataset
    monkeypatch.setattr(dataset, "make_dataset", lambda *a, **k: real(*a, camera=TINY, **k))
    first = default_dataset(cache_dir=tmp_path)
    folder = first["garden"]["day_reference"].parents[1]
    sorted((folder / "living_room" / "night_query" / "images").iterdir())[-1].unlink()  # a damaged copy
    (folder / "stray.txt").write_text("left over")
    again = default_dataset(cache_dir=tmp_path)
    assert again == first and not (folder / "stray.txt").exists()
    assert len(list((again["living_room"]["night_query"] / "images").iterdir())) == 32
    assert not [p for p in tmp_path.iterdir() if p.name.endswith(".partial")]


# --- the command line ----------------------------------------------------------------------------


def test_cli_writes_a_world(tmp_path, capsys):
    out_dir = tmp_path / "room"
    assert (
        main(
            [
                "synth",
                "--world",
                "living_room",
                "--out",
                str(out_dir),
                "--seed",
                "2",
                "--darkness",
                "0.5",
                "--size",
                "48x24",
            ]
        )
        == 0
    )
    out = capsys.readouterr().out
    assert "living_room/night_query: 32 frames" in out
    assert nightloc.load_traverse(out_dir / "night_query").read(0).shape == (24, 48, 3)
    description = json.loads((tmp_path / "room" / "dataset.json").read_text())
    assert description["darkness"] == 0.5 and description["seed"] == 2


def test_forward_camera_world_cuts_the_forward_quarter_and_maps_four_ways(tmp_path):
    from nightloc.synth.dataset import SynthScene, forward_view

    folders = make_dataset("living_room", tmp_path / "fwd", camera=TINY, view="forward", threads=1)
    plans = {p.name: p for p in plan_traverses("living_room")}
    day = nightloc.load_traverse(folders["day_reference"])
    n = len(plans["day_reference"].positions)
    assert len(day.names) == 4 * n and day.read(0).shape == (24, 12, 3)
    turned = np.angle(np.exp(1j * (day.headings[n : 2 * n] - day.headings[:n])))
    np.testing.assert_allclose(turned, np.pi / 2, atol=1e-5)  # the second drive looks 90 degrees left
    np.testing.assert_allclose(day.positions[n : 2 * n], day.positions[:n], atol=1e-5)
    # a frame is its panorama's forward quarter: columns -W/8 .. W/8 around the heading, left to right
    scene = SynthScene("living_room", camera=TINY)
    x, y = day.positions[n + 3]
    panorama = scene.frame(
        "day", float(x), float(y), float(day.headings[n + 3]), scene.frame_rng("day_reference", n + 3)
    )
    assert np.array_equal(day.read(n + 3), forward_view(panorama))
    assert np.array_equal(forward_view(panorama), np.concatenate([panorama[:, -6:], panorama[:, :6]], axis=1))
    assert json.loads((tmp_path / "fwd" / "dataset.json").read_text())["view"] == "forward"


def test_a_tilted_camera_looks_up_by_its_pitch_along_the_heading_and_by_its_roll_to_the_side():
    from dataclasses import replace

    from nightloc.synth.dataset import SynthScene

    scene = SynthScene("garden", camera=SMALL)
    x, y, heading = 3.0, 2.0, 0.4
    assert np.array_equal(scene.tilted_frame("day", x, y, heading, 0.0, 0.0), scene.frame("day", x, y, heading))
    # pitched 5 degrees up: the column along the heading sees what a camera aimed 5 degrees higher
    # sees (an independent render: the elevation range moved up), the opposite column 5 lower
    up = replace(
        SMALL, elevation_top_deg=SMALL.elevation_top_deg + 5, elevation_bottom_deg=SMALL.elevation_bottom_deg + 5
    )
    down = replace(
        SMALL, elevation_top_deg=SMALL.elevation_top_deg - 5, elevation_bottom_deg=SMALL.elevation_bottom_deg - 5
    )
    plain = scene.frame("day", x, y, heading).astype(int)
    aimed = {
        name: SynthScene("garden", camera=camera).frame("day", x, y, heading).astype(int)
        for name, camera in (("up", up), ("down", down))
    }

    def distance(a, b, column):  # mean grey-level difference of one column (its own exposure aside)
        return np.abs(a[:, column] - b[:, column]).mean()

    tilted = scene.tilted_frame("day", x, y, heading, 5.0, 0.0).astype(int)
    for near, far, column in (("up", "down", 0), ("down", "up", SMALL.width // 2)):
        closest = distance(tilted, aimed[near], column)
        assert closest < 0.7 * distance(tilted, plain, column) and closest < 0.5 * distance(tilted, aimed[far], column)
    # rolled (left side up): the column 90 degrees left looks higher, as a pitch there would
    rolled = scene.tilted_frame("day", x, y, heading, 0.0, 5.0).astype(int)
    left = 3 * SMALL.width // 4  # columns turn right: 90 degrees left is three quarters round
    assert distance(rolled, aimed["up"], left) < 0.5 * distance(rolled, aimed["down"], left)


@pytest.mark.parametrize(
    "argument",
    [
        ["--darkness", "4"],
        ["--seed", "-3"],
        ["--size", "big"],
        ["--size", "4x2"],
        ["--tilt", "-1"],
        ["--pattern", "columns"],
    ],
)
def test_cli_bad_values_are_one_line_errors(tmp_path, capsys, argument):
    assert main(["synth", "--world", "garden", "--out", str(tmp_path / "g"), *argument]) == 2
    err = capsys.readouterr().err
    assert err.startswith("nightloc synth: error:") and err.count("\n") == 1
    assert not (tmp_path / "g").exists()


# --- informative but hard ------------------------------------------------------------------------

PAIRS = [("garden", "night_reference"), ("garden", "night_query"), ("living_room", "night_query")]


def single_frame_errors(world: str, query_name: str) -> dict:
    """Position errors (m) of single-frame best-reference matching against the day map."""
    paths = default_synth_data()[world]
    refs = nightloc.load_traverse(paths["day_reference"])
    queries = nightloc.load_traverse(paths[query_name])
    scores, shifts = nightloc.difference_matrix(nightloc.prepare(queries), nightloc.prepare(refs))
    distances = np.linalg.norm(queries.positions[:, None] - refs.positions[None], axis=2)
    best = scores.argmin(axis=1)
    rows = np.arange(len(best))
    relative = nightloc.shifts_to_headings(shifts[rows, best], 48)
    heading_error = np.abs((queries.headings - refs.headings[best] - relative + np.pi) % (2 * np.pi) - np.pi)
    return {
        "best": distances[rows, best],
        "random": distances.ravel(),  # every reference equally likely
        "oracle": distances.min(axis=1),
        "hit_nearest": best == distances.argmin(axis=1),
        "heading_error": heading_error,
    }


@pytest.mark.parametrize(("world", "query_name"), PAIRS)
def test_night_matching_beats_random_clearly_but_is_not_perfect(world, query_name):
    e = single_frame_errors(world, query_name)
    best, random, oracle = (float(np.median(e[k])) for k in ("best", "random", "oracle"))
    print(
        f"{world}/{query_name}: median error best {best:.2f} m, random {random:.2f} m, oracle {oracle:.2f} m, "
        f"nearest found {e['hit_nearest'].mean():.0%}"
    )
    assert best < 0.65 * random  # informative
    assert best > oracle and e["hit_nearest"].mean() < 0.9  # but not perfect
    # Where the match is right, its relative heading is right too (rotation invariance).
    close = e["best"] < 0.6
    assert close.sum() >= 5 and np.median(e["heading_error"][close]) < math.radians(10)


@pytest.mark.slow
def test_darker_nights_match_worse():
    """Garden night queries at three darkness levels against one day map: errors grow with darkness."""
    from nightloc.synth import SynthScene

    plans = {p.name: p for p in plan_traverses("garden", 0)}
    day, query = plans["day_reference"], plans["night_query"]
    distances = np.linalg.norm(query.positions[:, None] - day.positions[None], axis=2)
    refs = None
    medians = []
    for darkness in (0.0, 1.0, 1.6):
        scene = SynthScene("garden", seed=0, darkness=darkness)
        if refs is None:
            refs = nightloc.prepare(np.stack(list(scene.render_plan(day))))
        scores, _ = nightloc.difference_matrix(nightloc.prepare(np.stack(list(scene.render_plan(query)))), refs)
        medians.append(float(np.median(distances[np.arange(len(scores)), scores.argmin(axis=1)])))
    print("median error by darkness 0, 1, 1.6:", medians)
    assert medians[0] <= medians[1] < medians[2]
