"""nightloc.synth seasons: the nights' schedule, each night's world (lamps, lawn, leaves, wet
ground, furniture, objects), the bad nights, their record in dataset.json, bad input."""

from __future__ import annotations

import json
import math
from dataclasses import replace

import numpy as np
import pytest

import nightloc
from nightloc.cli import main
from nightloc.synth import Camera, make_dataset
from nightloc.synth.geometry import Cylinder
from nightloc.synth.season import (
    LANTERN_NIGHTS,
    MOWING_INTERVAL,
    PLAYHOUSE_NIGHTS,
    REMOVAL_NIGHTS,
    STRIPE_CONTRAST,
    SYNODIC_MONTH,
    WET_ALBEDO,
    other_garden,
    parse_bad_nights,
    plan_season,
    season_drives,
    season_world,
)
from nightloc.synth.world import build_world

TINY = Camera(width=48, height=24)


def test_a_longer_season_begins_with_the_nights_of_a_shorter_one():
    assert plan_season("garden", 12, 3) == plan_season("garden", 30, 3)[:12]
    assert plan_season("garden", 12, 3) != plan_season("garden", 12, 4)


def test_the_lawn_is_mowed_every_interval_and_the_stripes_turn_each_time():
    season = plan_season("large_garden", 40, 1)
    mowings = sorted({n.mowed_night for n in season} - {0})
    assert 1 <= mowings[0] <= MOWING_INTERVAL and np.all(np.diff(mowings) == MOWING_INTERVAL)
    for night in season:
        assert night.grass_cm == pytest.approx(3.0 + 0.4 * (night.night - night.mowed_night))
        assert (
            night.stripes_along == ("y" if mowings.index(night.mowed_night) % 2 == 0 else "x") or not night.mowed_night
        )
        if night.night == night.mowed_night:
            assert night.stripe_contrast == pytest.approx(STRIPE_CONTRAST)
    before = [n for n in season if n.mowed_night == 0]
    assert all(n.stripes_along == "x" for n in before)  # the day map's stripes, fading


def test_the_moon_waxes_and_wanes_with_the_lunar_cycle():
    season = plan_season("garden", 60, 2)
    phases = np.array([n.moon_phase for n in season])
    steps = np.mod(np.diff(phases), 1.0)
    np.testing.assert_allclose(steps, 1.0 / SYNODIC_MONTH, atol=1e-12)
    for night in season:
        up = 0.1 <= night.moon_phase <= 0.8
        assert (night.moon_direction is not None) == up
        assert 0.0 <= night.moon <= 0.5 * (1 - math.cos(2 * math.pi * night.moon_phase)) + 1e-12
        if up:
            assert night.moon_direction[2] > 0 and math.isclose(np.linalg.norm(night.moon_direction), 1.0)
    assert max(n.moon for n in season) > 0.8 and min(n.moon for n in season) == 0.0
    assert all(n.wet for n in season if n.rain)


def test_the_seasons_events_fall_in_their_windows_and_last():
    for seed in range(4):
        season = plan_season("garden", 30, seed)
        first = {
            what: next(n.night for n in season if getattr(n, what)) for what in ("lanterns", "playhouse", "removed")
        }
        assert LANTERN_NIGHTS[0] <= first["lanterns"] <= LANTERN_NIGHTS[1]
        assert PLAYHOUSE_NIGHTS[0] <= first["playhouse"] <= PLAYHOUSE_NIGHTS[1]
        assert REMOVAL_NIGHTS[0] <= first["removed"] <= REMOVAL_NIGHTS[1]
        for what, night in first.items():
            assert all(getattr(n, what) for n in season[night - 1 :])
        away = [n.night for n in season if not n.house_lamps]
        assert len(away) == 3 and np.all(np.diff(away) == 1)


def test_test_drives_every_k_nights_and_never_on_a_bad_night():
    season = plan_season("garden", 12, 0, test_every=4, bad="8:covered,3:kidnapped")
    assert [n.night for n in season if n.test_drive] == [4, 12]
    assert {n.night: n.bad for n in season if n.bad} == {3: "kidnapped", 8: "covered"}
    names = [[p.name for p in season_drives("garden", 0, n)] for n in season[3:4]]
    assert names == [["season_004", "season_004_query"]]


@pytest.mark.parametrize(
    ("spec", "message"),
    [
        ("3:lost", "unknown bad night 'lost'"),
        ("13:covered", r"in 1\.\.12"),
        ("covered", "NIGHT:KIND"),
        ("3:covered,3:kidnapped", "two bad kinds"),
    ],
)
def test_bad_nights_are_checked(spec, message):
    with pytest.raises(ValueError, match=message):
        parse_bad_nights(spec, 12)


def test_a_season_is_drawn_for_the_outdoor_worlds_only():
    with pytest.raises(ValueError, match="garden, large_garden"):
        plan_season("living_room", 3)
    with pytest.raises(ValueError, match=r"1\.\.999 nights"):
        plan_season("garden", 0)


def _night(**changes):
    """Night 10 of a plain season night: nothing but the given changes."""
    plain = replace(
        plan_season("garden", 10, 0)[-1],
        wet=False,
        rain=False,
        leaf_cover=0.0,
        lanterns=False,
        house_lamps=True,
        playhouse=False,
        wheelbarrow=False,
        removed="",
        mowed_night=0,
        stripes_along="x",
        grass_cm=3.0,
    )
    return replace(plain, **changes)


def test_a_mowing_along_y_turns_the_lawns_stripes_and_leaves_the_rest():
    world = build_world("garden", 0)
    ground = world.ground
    night = _night(night=7, mowed_night=7, stripes_along="y")
    values = season_world(world, night, 0).ground.values
    ratio = (values / ground.values)[..., 1]
    lawn = ground.lawn
    np.testing.assert_allclose(ratio[~lawn], 1.0, rtol=1e-6)  # beds, patio, stones: as by day
    # on the lawn: the new stripes (1 +- contrast, varying along x) over the day's (along y)
    cols = (ground.x0 + (np.arange(lawn.shape[1]) + 0.5) / ground.pixels_per_metre)[None, :]
    band = np.floor((cols - ground.x0) / 0.55) % 2 == 0
    expected = np.where(band, 1 + STRIPE_CONTRAST, 1 - STRIPE_CONTRAST) / ground.stripes
    np.testing.assert_allclose(ratio[lawn], np.broadcast_to(expected, lawn.shape)[lawn], rtol=1e-5)


def test_wet_ground_and_leaves():
    world = build_world("garden", 0)
    day_like = season_world(world, _night(night=1, mowed_night=0), 0).ground.values
    wet = season_world(world, _night(night=1, wet=True), 0).ground.values
    np.testing.assert_allclose(wet, day_like * WET_ALBEDO, rtol=1e-6)
    leaves = season_world(world, _night(night=1, leaf_cover=0.2), 0).ground.values
    changed = np.any(leaves != day_like, axis=-1).mean()
    assert 0.17 < changed <= 0.2 + 1e-9


def test_lanterns_house_lamps_furniture_playhouse_and_the_removed_bench():
    world = build_world("garden", 0)
    plain = season_world(world, _night(), 0)
    assert set(plain.lights) == set(world.lights) and len(plain.objects) == len(world.objects) + 6  # 2 chairs, a table
    away = season_world(world, _night(house_lamps=False), 0)
    on = {name for name, light in away.lights.items() if "night" in light.conditions}
    assert on == {"street_lamp"}
    lit = season_world(world, _night(lanterns=True), 0)
    assert sum(name.startswith("moved_lamp_") for name in lit.lights) >= 2
    changed = season_world(world, _night(playhouse=True, wheelbarrow=True, removed="bench"), 0)
    # the bench (two boxes along the west fence) gone, a playhouse (two solids) and a wheelbarrow added
    assert len(changed.objects) == len(plain.objects) - 2 + 3
    moved = season_world(world, _night(furniture_layout=7), 0)
    assert not np.allclose(moved.objects[-1].center, plain.objects[-1].center)  # the table moved
    for w in (plain, changed, moved):  # nothing stands in the robot's way
        for n in (1, 2):
            for plan in season_drives("garden", 0, replace(_night(), night=n, test_drive=True)):
                w.check_camera_positions(plan.positions)


def test_the_other_garden_is_this_one_mirrored_about_the_mapped_area():
    world = build_world("garden", 0)
    other = other_garden("garden", 0)
    x0, _, x1, _ = world.mapped_area
    assert other.mapped_area == world.mapped_area
    birdbath = next(o for o in other.objects if isinstance(o, Cylinder) and o.radius == 0.3)
    assert birdbath.center == pytest.approx((x0 + x1 - 2.3, 3.85))
    assert other.lights["porch_lamp"].position[:2] == pytest.approx((x0 + x1 - 5.2, 6.5))
    shed = [o for o in other.objects if o.material == "shed"]  # the shed: now in the south-west corner
    assert shed and shed[0].footprint[:, 0].max() < 0.0
    assert not np.array_equal(other.ground.values, world.ground.values)
    for plan in season_drives("garden", 0, replace(_night(), night=1, test_drive=True)):
        other.check_camera_positions(plan.positions)


def test_a_rendered_season_records_every_night_and_its_bad_nights(tmp_path):
    out = tmp_path / "season"
    folders = make_dataset(
        "garden", out, seed=1, camera=TINY, threads=1, season=4, test_every=2, bad_nights="3:kidnapped"
    )
    assert list(folders) == [
        "day_reference",
        "season_001",
        "season_002",
        "season_002_query",
        "season_003",
        "season_004",
        "season_004_query",
    ]
    description = json.loads((out / "dataset.json").read_text())
    season = description["season"]
    assert season["nights"] == 4 and season["test_every"] == 2
    planned = plan_season("garden", 4, 1, test_every=2, bad="3:kidnapped")
    for record, night in zip(season["schedule"], planned, strict=True):
        assert record["night"] == night.night and record["bad"] == night.bad
        assert record["grass_cm"] == pytest.approx(night.grass_cm, abs=1e-4)
        assert {lamp["name"] for lamp in record["lamps_on"]} >= {"street_lamp"}
    assert description["traverses"]["season_003"]["carried"] == [26]
    kidnapped = nightloc.load_traverse(out / "season_003")
    odometry = (out / "season_003" / "odometry.csv").read_text().splitlines()
    assert odometry[27].split(",")[1:4] == ["0.0", "0.0", "0.0"]  # frame 26: carried, the wheels still
    jump = np.hypot(*(kidnapped.positions[26] - kidnapped.positions[25]))
    assert jump > 2.0
    day = nightloc.load_traverse(out / "day_reference")
    assert len(day) == 24 and (out / "season_004_query" / "poses.csv").exists()


def test_a_covered_lens_sees_almost_nothing(tmp_path):
    make_dataset("garden", tmp_path / "s", seed=1, camera=TINY, threads=1, season=2, bad_nights="2:covered")
    covered, usual = (nightloc.load_traverse(tmp_path / "s" / n) for n in ("season_002", "season_001"))
    dark = np.mean([covered.read(i).mean() for i in range(0, len(covered), 10)])
    lit = np.mean([usual.read(i).mean() for i in range(0, len(usual), 10)])
    assert dark < 0.4 * lit


def test_season_command_line(tmp_path, capsys):
    assert main(["synth", "--world", "garden", "--season", "2", "--size", "48x24", "--out", str(tmp_path / "s")]) == 0
    assert "season_002" in capsys.readouterr().out
    for args, message in (
        (["--world", "living_room", "--season", "2"], "--season applies to --world garden or large_garden"),
        (["--world", "garden", "--bad-nights", "1:covered"], "give --season N too"),
        (["--world", "garden", "--season", "2", "--nights", "all"], "not with --nights"),
    ):
        assert main(["synth", *args, "--out", str(tmp_path / "x")]) == 2
        assert message in capsys.readouterr().err
    assert not (tmp_path / "x").exists()
