"""nightloc.synth nights that differ: the named night conditions, their drives, their light and
sensor noise, their record in dataset.json, the default output kept byte-identical, bad input."""

from __future__ import annotations

import hashlib
import json
import math
from dataclasses import replace
from pathlib import Path

import cv2
import numpy as np
import pytest

import nightloc
from nightloc.cli import main
from nightloc.synth import Camera, SynthScene, make_dataset, plan_traverses
from nightloc.synth.geometry import box
from nightloc.synth.lighting import MOON_IRRADIANCE, make_lighting, make_night_lighting
from nightloc.synth.nights import NIGHT_NAMES, lamp_layout, night_traverse_name, parse_nights
from nightloc.synth.paths import plan_night_drives
from nightloc.synth.render import render_radiance
from nightloc.synth.world import build_world

from synth_support import bare_world

TINY = Camera(width=48, height=24)
SMALL = Camera(width=96, height=48)
POSES = {"garden": (3.5, 2.5, 0.3), "living_room": (2.0, 1.5, 1.0), "large_garden": (12.5, 7.2, 0.3)}
#: sha256 of ``make_dataset(world, out, seed=1, camera=TINY, threads=1)`` (every file but the set's
#: hidden record, by relative path), as rendered before the nights existed.
TODAY = {
    "garden": "a270e7121374c7708d0ce846d9585ed84288d443b480aede81af8a3043683acf",
    "living_room": "bf8c0a71bfe241681dd5295b69993ef64d2897a5e155d33d727770e81639345f",
}


def digest(folder: Path) -> str:
    h = hashlib.sha256()
    for path in sorted(folder.rglob("*")):
        if path.is_file() and not path.name.startswith("."):
            h.update(str(path.relative_to(folder)).encode())
            h.update(path.read_bytes())
    return h.hexdigest()


def images_of(folder: Path) -> list[bytes]:
    return [p.read_bytes() for p in sorted((folder / "images").iterdir())]


def grey(image: np.ndarray) -> np.ndarray:
    return cv2.cvtColor(image, cv2.COLOR_BGR2GRAY).astype(np.float64)


def brightness_and_snr(scene: SynthScene, pose) -> tuple[float, float]:
    """Mean grey level of the noiseless night frame and its ratio to the rms sensor noise (3 draws)."""
    clean = grey(scene.frame("night", *pose))
    noise = [grey(scene.frame("night", *pose, rng=np.random.default_rng(k))) - clean for k in range(3)]
    return float(clean.mean()), float(clean.mean()) / math.sqrt(float(np.mean(np.square(noise))))


@pytest.fixture(scope="module")
def garden_nights(tmp_path_factory) -> Path:
    """The garden with every night, tiny frames, seed 1."""
    out = tmp_path_factory.mktemp("nights") / "garden"
    make_dataset("garden", out, seed=1, camera=TINY, nights="all", threads=1)
    return out


# --- the default stays today's ------------------------------------------------------------------


@pytest.mark.parametrize("world", ["garden", "living_room"])
def test_without_nights_the_dataset_is_byte_identical_to_before(tmp_path, world):
    make_dataset(world, tmp_path / world, seed=1, camera=TINY, threads=1)
    assert digest(tmp_path / world) == TODAY[world]


def test_the_usual_night_keeps_table_ones_traverses_byte_for_byte(tmp_path, garden_nights):
    usual = make_dataset("garden", tmp_path / "usual", seed=1, camera=TINY, threads=1)
    for name in ("day_reference", "night_reference", "night_query"):
        for file in ("poses.csv", "odometry.csv"):
            assert (garden_nights / name / file).read_bytes() == (usual[name] / file).read_bytes()
        assert images_of(garden_nights / name) == images_of(usual[name])


# --- layout, record, times ----------------------------------------------------------------------


def test_every_night_is_two_traverses_with_poses_odometry_and_times(garden_nights):
    description = json.loads((garden_nights / "dataset.json").read_text())
    assert list(description["nights"]) == list(NIGHT_NAMES)
    expected = ["day_reference"] + [
        name if night == "lamps" else f"{name}_{night}"
        for night in NIGHT_NAMES
        for name in ("night_reference", "night_query")
    ]
    assert list(description["traverses"]) == expected
    for night in NIGHT_NAMES:
        plans = plan_night_drives("garden", 1, NIGHT_NAMES.index(night))
        for plan, name in zip(plans, description["nights"][night]["traverses"], strict=True):
            assert description["traverses"][name] == {
                "condition": "night",
                "frames": len(plan.positions),
                "night": night,
            }
            traverse = nightloc.load_traverse(garden_nights / name)
            np.testing.assert_allclose(traverse.positions, plan.positions)
            np.testing.assert_allclose(traverse.timestamps, plan.timestamps(), rtol=0, atol=1e-9)
            assert (garden_nights / name / "poses.csv").read_text().startswith("image,x,y,heading,timestamp\n")
            odometry = (garden_nights / name / "odometry.csv").read_text()
            assert odometry.startswith("image,forward,left,turn,timestamp\n")
            assert len(odometry.splitlines()) == len(plan.positions) + 1
    record = description["nights"]
    assert record["lamps"]["darkness"] == 1.0 and record["lamps"]["moon"] is None
    assert record["darker"]["darkness"] == pytest.approx(1.3)
    assert record["moon_only"]["lamps_on"] == [] and record["moon_only"]["moon"]["level"] == 1.0
    assert record["moonlit"]["moon"]["irradiance"] == pytest.approx(MOON_IRRADIANCE)
    assert record["moonlit"]["moon"]["direction"] == record["moon_only"]["moon"]["direction"]
    assert record["lamps_moved"]["lamp_layout_seed"] == 1 and record["lamps"]["lamp_layout_seed"] is None
    usual = {lamp["name"] for lamp in record["lamps"]["lamps_on"]}
    moved = {lamp["name"] for lamp in record["lamps_moved"]["lamps_on"]}
    assert usual == {"porch_lamp", "house_window", "street_lamp"}
    assert "porch_lamp" not in moved and len(moved - usual) == 3


def test_each_night_drives_the_day_path_again_and_the_other_path_its_own_way():
    day = plan_traverses("garden", 0)[0]
    gap = lambda a, b: np.linalg.norm(a[:, None] - b[None], axis=2).min(axis=1)  # noqa: E731
    drives = {night: plan_night_drives("garden", 0, k) for k, night in enumerate(NIGHT_NAMES)}
    usual = {p.name: p for p in plan_traverses("garden", 0)}
    for drive in drives["lamps"]:  # the usual night: Table I's drives
        assert np.array_equal(drive.positions, usual[drive.name].positions)
        assert np.array_equal(drive.headings, usual[drive.name].headings)
    for night, (redrive, query) in drives.items():
        assert np.median(gap(redrive.positions, day.positions)) < 0.7  # along the day path
        assert np.mean(gap(query.positions, redrive.positions) > 0.4) > 0.3  # another path
        if night != "lamps":  # the same nominal paths, each night its own wander and wobble
            assert np.max(np.linalg.norm(redrive.positions - usual["night_reference"].positions, axis=1)) < 0.5
            assert not np.allclose(redrive.positions, usual["night_reference"].positions)
            assert not np.allclose(query.headings, usual["night_query"].headings)
    for world in ("living_room", "large_garden"):  # no night re-drive in Table I: drawn for every night
        day = plan_traverses(world, 0)[0]
        world_model = build_world(world, 0)
        for k in (0, 2):
            redrive, query = plan_night_drives(world, 0, k)
            assert (redrive.name, query.name) == ("night_reference", "night_query")
            world_model.check_camera_positions(redrive.positions)
            world_model.check_camera_positions(query.positions)
            assert np.median(gap(redrive.positions, day.positions)) < 0.3
    assert len(plan_night_drives("large_garden", 0, 1)[0].positions) == len(
        plan_traverses("large_garden", 0)[0].positions
    )
    assert np.array_equal(
        plan_night_drives("living_room", 0, 0)[1].positions, plan_traverses("living_room", 0)[1].positions
    )
    columns = plan_night_drives("large_garden", 0, 1, "columns")[0]
    assert np.median(np.abs(np.sin(columns.headings[157:]))) > 0.9  # the columns pattern's day path


def test_same_seed_gives_byte_identical_nights_whatever_the_threads(tmp_path):
    a = make_dataset("living_room", tmp_path / "a", seed=2, camera=TINY, threads=1, nights="moon_only,lamps_moved")
    b = make_dataset("living_room", tmp_path / "b", seed=2, camera=TINY, threads=2, nights=["lamps_moved", "moon_only"])
    c = make_dataset("living_room", tmp_path / "c", seed=3, camera=TINY, nights="moon_only,lamps_moved")
    assert (
        list(a)
        == list(b)
        == [
            "day_reference",
            *(f"{d}_{n}" for n in ("lamps_moved", "moon_only") for d in ("night_reference", "night_query")),
        ]
    )
    for name in a:
        assert images_of(a[name]) == images_of(b[name])
        assert (a[name] / "odometry.csv").read_bytes() == (b[name] / "odometry.csv").read_bytes()
        assert images_of(a[name]) != images_of(c[name])
    assert (tmp_path / "a" / "dataset.json").read_bytes() == (tmp_path / "b" / "dataset.json").read_bytes()


# --- the light and the sensor of each night -------------------------------------------------------


@pytest.mark.parametrize("world", ["garden", "living_room", "large_garden"])
def test_lamps_off_frames_are_darker_and_noisier_than_lamps_on(world):
    scene = SynthScene(world, seed=0, camera=SMALL)
    lamps, moon_only = scene.night("lamps"), scene.night("moon_only")
    assert moon_only.lighting["night"].lamps == () and lamps.lighting["night"].lamps
    assert moon_only.exposure["night"] == lamps.exposure["night"]  # the same night camera
    on_mean, on_snr = brightness_and_snr(lamps, POSES[world])
    off_mean, off_snr = brightness_and_snr(moon_only, POSES[world])
    print(f"{world}: lamps on mean {on_mean:.1f} SNR {on_snr:.2f}; moon only mean {off_mean:.1f} SNR {off_snr:.2f}")
    assert off_mean < 0.85 * on_mean and off_snr < 0.85 * on_snr


@pytest.mark.parametrize("world", ["garden", "living_room"])
def test_the_moon_adds_light_and_the_darker_night_only_removes_photons(world):
    scene = SynthScene(world, seed=0, camera=SMALL)
    x, y, heading = POSES[world]
    lamps, moonlit = scene.night("lamps"), scene.night("moonlit")
    usual = render_radiance(lamps.world, lamps.lighting["night"], x, y, heading, SMALL)
    brighter = render_radiance(moonlit.world, moonlit.lighting["night"], x, y, heading, SMALL)
    assert np.all(brighter >= usual - 1e-7)  # light adds up
    assert np.mean(brighter > usual * 1.01) > (0.05 if moonlit.world.indoor else 0.3)  # indoors: through the windows
    darker = scene.night("darker")
    assert darker.lighting["night"] is lamps.lighting["night"]
    assert darker.exposure["night"].electrons_per_unit == pytest.approx(
        lamps.exposure["night"].electrons_per_unit * 10**-0.6
    )
    assert darker.exposure["night"].gain == pytest.approx(lamps.exposure["night"].gain * 10**0.3)
    assert brightness_and_snr(darker, POSES[world])[1] < brightness_and_snr(lamps, POSES[world])[1]


def test_a_moonless_night_lighting_is_the_usual_night():
    for world in ("garden", "living_room"):
        model = build_world(world, 0)
        usual, same = make_lighting(model, "night", 0), make_night_lighting(model, 0)
        assert same is usual


def test_indoors_the_lamps_bounced_light_goes_with_the_lamps():
    room = build_world("living_room", 0)
    usual = make_lighting(room, "night", 0)
    dark = make_night_lighting(lamp_layout(room, 0, "off"), 0, lamp_bounce=0.0)
    np.testing.assert_allclose(dark.ambient, usual.ambient * 0.2, rtol=1e-6)  # what comes in from outside
    assert dark.lamps == () and dark.glow == {}
    half = make_night_lighting(room, 0, lamp_bounce=0.5)
    np.testing.assert_allclose(half.ambient, usual.ambient * 0.6, rtol=1e-6)
    garden = build_world("garden", 0)  # outdoors the sky's light does not depend on the lamps
    np.testing.assert_array_equal(
        make_night_lighting(lamp_layout(garden, 0, "off"), 0, lamp_bounce=0.0).ambient,
        make_lighting(garden, "night", 0).ambient,
    )


@pytest.mark.parametrize(
    ("kwargs", "message"),
    [
        ({"moon": 1.0}, "needs moon_direction"),
        ({"moon": -1.0}, "moon must be in"),
        ({"moon": float("nan")}, "moon must be in"),
        ({"moon": 1.0, "moon_direction": (1.0, 0.0, -0.2)}, "z > 0"),
        ({"moon": 1.0, "moon_direction": (1.0, 0.0)}, "moon_direction"),
        ({"lamp_bounce": -0.1}, "lamp_bounce"),
    ],
)
def test_night_lighting_bad_arguments_are_clear_errors(kwargs, message):
    with pytest.raises(ValueError, match=message):
        make_night_lighting(bare_world([]), 0, **kwargs)


def test_moon_shadow_of_a_box_falls_where_the_projection_says():
    world = bare_world([box(0.0, 0.0, 1.0, 1.0, 0.0, 2.0, "grey")])
    elevation = math.radians(45.0)
    direction = np.array([0.0, -math.cos(elevation), math.sin(elevation)])  # the moon in the south
    lighting = make_night_lighting(world, 0, moon=1.0, moon_direction=direction)
    usual = make_lighting(world, "night", 0)
    extra = lighting.ground.values / world.ground.values - usual.ground.values / world.ground.values

    def at(x, y):
        return float(extra[int((y + 10.0) * 50), int((x + 10.0) * 50), 0])

    diffuse = 0.2 * MOON_IRRADIANCE  # the moonlight scattered by the sky (outdoors)
    direct = MOON_IRRADIANCE * math.sin(elevation)
    # The 2 m box's shadow reaches 2 m north of it: x in [0, 1], y in [0, 3].
    for x, y in [(0.5, 1.5), (0.5, 2.8), (0.2, 2.0)]:
        assert at(x, y) == pytest.approx(diffuse, rel=0.02)
    for x, y in [(0.5, 3.3), (0.5, -0.5), (1.3, 2.0), (-0.3, 2.0)]:
        assert at(x, y) == pytest.approx(diffuse + direct, rel=0.02)
    # the sky is brighter with the moon, brightest at its disc
    assert lighting.sky.values.mean() > usual.sky.values.mean()
    azimuth, height = math.atan2(direction[1], direction[0]), math.asin(direction[2])
    disc = lighting.sky.sample(np.array([azimuth]), np.array([height]))
    assert disc.min() > 3 * lighting.sky.values.mean()


def test_another_lamp_layout_moves_the_lamps_out_of_the_way_and_depends_on_its_seed():
    for world_name in ("garden", "living_room", "large_garden"):
        world = build_world(world_name, 0)
        moved, again, other = (lamp_layout(world, s) for s in (5, 5, 6))
        on = {n: light for n, light in moved.lights.items() if "night" in light.conditions}
        usual = {n for n, light in world.lights.items() if "night" in light.conditions}
        new = {n: light.position for n, light in on.items() if n not in world.lights}
        assert new and not ({"porch_lamp", "floor_lamp", "table_lamp", "oven"} & set(on))
        assert set(on) - set(new) <= usual
        assert len(moved.objects) == len(world.objects) + 2 * len(new)  # a post and a glowing head each
        x0, y0, x1, y1 = world.mapped_area
        for x, y, _ in new.values():
            outside = max(x0 - x, x - x1, y0 - y, y - y1)
            assert 0.2 <= outside <= 1.2  # beside the mapped area, off every drive
        patterns = ("rows", "columns") if world_name == "large_garden" else ("rows",)
        for plan in [p for pattern in patterns for p in plan_night_drives(world_name, 0, 1, pattern)]:
            moved.check_camera_positions(plan.positions)  # raises for a drive through a lamp
        assert {n: again.lights[n].position for n in new} == new
        assert {n: light.position for n, light in other.lights.items() if n.startswith("moved")} != new
        off = lamp_layout(world, 5, "off")
        assert not any("night" in light.conditions for light in off.lights.values())
        assert lamp_layout(world, 5, "usual") is world


# --- bad input ------------------------------------------------------------------------------------


def test_night_names_parse_and_unknown_ones_name_the_choices(tmp_path):
    assert parse_nights("moon_only, lamps") == ("lamps", "moon_only")
    assert parse_nights("all") == NIGHT_NAMES and parse_nights(["darker", "darker"]) == ("darker",)
    for bad in ("moon", "lamps,,", ""):
        with pytest.raises(ValueError, match="choose from lamps, lamps_moved, moonlit, moon_only, darker"):
            parse_nights(bad)
    with pytest.raises(ValueError, match=r"unknown night 'full_moon'.*moon_only"):
        make_dataset("garden", tmp_path / "out", camera=TINY, nights="lamps,full_moon")
    assert not (tmp_path / "out").exists()
    with pytest.raises(ValueError, match="at most 3"):
        make_dataset("garden", tmp_path / "out", darkness=2.9, camera=TINY, nights="darker")
    assert not (tmp_path / "out").exists()
    with pytest.raises(ValueError, match="unknown night"):
        SynthScene("garden", 0, camera=TINY).night("noon")


def test_a_night_of_a_night_starts_from_the_usual_one():
    scene = SynthScene("garden", 0, camera=TINY)
    twice = scene.night("darker").night("lamps_moved")
    once = scene.night("lamps_moved")
    assert twice.darkness == once.darkness == 1.0
    assert twice.describe_night() == once.describe_night()
    assert np.array_equal(twice.frame("night", 3.0, 2.0, 0.5), once.frame("night", 3.0, 2.0, 0.5))


@pytest.mark.parametrize(
    ("arguments", "message"),
    [
        (["--nights", "lamps,blue_moon"], "unknown night 'blue_moon'; choose from lamps, lamps_moved"),
        (["--world", "creek", "--nights", "moonlit"], "--nights applies to"),
    ],
)
def test_cli_bad_nights_are_one_line_errors(tmp_path, capsys, arguments, message):
    assert main(["synth", "--world", "garden", "--out", str(tmp_path / "g"), *arguments]) == 2
    err = capsys.readouterr().err
    assert err.startswith("nightloc synth: error:") and err.count("\n") == 1 and message in err
    assert not (tmp_path / "g").exists()


def test_cli_renders_the_nights_asked_for(tmp_path, capsys):
    out = tmp_path / "room"
    assert main(["synth", "--world", "living_room", "--out", str(out), "--size", "48x24", "--nights", "moonlit"]) == 0
    printed = capsys.readouterr().out
    assert "living_room/night_query_moonlit: 32 frames" in printed
    assert sorted(p.name for p in out.iterdir() if not p.name.startswith(".")) == [
        "dataset.json",
        "day_reference",
        "night_query_moonlit",
        "night_reference_moonlit",
    ]
    assert list(json.loads((out / "dataset.json").read_text())["nights"]) == ["moonlit"]


# --- not pure noise: the paper's matching finds places on every night ------------------------------


@pytest.mark.slow
def test_every_garden_night_is_informative():
    """Single-frame best-reference matching of each garden night's re-drive against the day map
    (192 x 96 frames, the dataset's own noise draws): the best reference lies within 1 m far more
    often than a random one does."""
    scene = SynthScene("garden", seed=0)
    day = plan_traverses("garden", 0)[0]
    refs = nightloc.prepare(np.stack(list(scene.render_plan(day))))
    for k, night in enumerate(NIGHT_NAMES):
        redrive = plan_night_drives("garden", 0, k)[0]
        redrive = replace(redrive, name=night_traverse_name(redrive.name, night))  # its frames' noise
        queries = nightloc.prepare(np.stack(list(scene.night(night).render_plan(redrive))))
        scores, _ = nightloc.difference_matrix(queries, refs)
        distances = np.linalg.norm(redrive.positions[:, None] - day.positions[None], axis=2)
        best = distances[np.arange(len(scores)), scores.argmin(axis=1)]
        found, chance = float(np.mean(best < 1.0)), float(np.mean(distances < 1.0))
        print(f"garden {night}: median error {np.median(best):.2f} m, within 1 m {found:.0%} (random {chance:.0%})")
        assert found > 3 * chance, night
