"""Reference maps: build, save, load, match; corrupt files and other parameters are clear errors."""

from __future__ import annotations

import json
import math
import os
import zipfile

import numpy as np
import pytest

import nightloc
from nightloc import DatasetError, MapFormatError, PreparationParams, ReferenceMap, prepare, save_traverse
from nightloc.cli import main
from nightloc.config import save_params

from preparation_oracle import panorama


@pytest.fixture(scope="module")
def garden(tmp_path_factory):
    """A traverse of 12 panoramas on a 4x3 lawn-mower grid, 1 m apart, all heading 0."""
    root = tmp_path_factory.mktemp("garden") / "day"
    frames = [panorama(120, 480, seed=s) for s in range(12)]
    positions = np.array([(x, y) for y in range(3) for x in range(4)], dtype=np.float64)
    headings = np.linspace(-3, 3, 12)
    save_traverse(root, frames, positions, headings)
    return root, frames, positions, headings


@pytest.fixture(scope="module")
def garden_map(garden):
    return ReferenceMap.build(garden[0])


def test_build_prepares_every_frame(garden, garden_map):
    root, frames, positions, headings = garden
    assert len(garden_map) == 12 and garden_map.images.shape == (12, 24, 48)
    np.testing.assert_array_equal(garden_map.images, prepare(frames))
    np.testing.assert_array_equal(garden_map.positions, positions)
    np.testing.assert_allclose(garden_map.headings, headings)
    assert garden_map.names == tuple(f"{i:06d}.png" for i in range(12))
    assert garden_map.params == PreparationParams() and garden_map.source == str(root)
    assert not garden_map.images.flags.writeable and not garden_map.positions.flags.writeable


def test_save_load_round_trip(garden_map, tmp_path):
    path = garden_map.save(tmp_path / "garden.map")
    loaded = ReferenceMap.load(path)
    assert loaded == garden_map
    assert loaded.names == garden_map.names and loaded.source == garden_map.source
    assert ReferenceMap.load(path, params=PreparationParams()) == garden_map
    assert os.listdir(tmp_path) == ["garden.map"]  # no temporary files left
    # the file is a plain npz with a JSON header, readable without nightloc
    with np.load(path, allow_pickle=False) as archive:
        header = json.loads(archive["header"].tobytes())
        assert header["format"] == "nightloc-reference-map" and header["format_version"] == 3
        # images, positions, headings and the default localizer's five tables
        assert header["params"]["width"] == 48 and len(header["checksums"]) == 3 + 5


def test_map_without_headings_and_custom_params(tmp_path):
    frames = [panorama(60, 200, seed=s) for s in range(4)]
    params = PreparationParams(width=40, height=10, radius=2, wrap=False, equalize="clahe", crop=(0, 0.1, 0, 0))
    traverse = save_traverse(tmp_path / "t", frames, np.arange(8).reshape(4, 2))
    built = ReferenceMap.build(traverse, params)
    assert built.headings is None and built.images.shape == (4, 10, 40)
    loaded = ReferenceMap.load(built.save(tmp_path / "m.npz"), params)
    assert loaded == built and loaded.params.crop == (0, 0.1, 0, 0)


def test_match_finds_place_and_heading(garden, garden_map):
    _, frames, _, _ = garden
    for place, turn in [(0, 0), (5, 3), (11, 17)]:
        night = np.roll(frames[place], 10 * turn, axis=1) // 4  # 10 input columns per output column
        result = garden_map.match(night)
        assert result.index == place and result.shift == turn
        assert math.isclose(result.heading, 2 * math.pi * turn / 48 - (2 * math.pi if turn > 24 else 0))
    prepared = garden_map.preparer(frames[7])
    assert garden_map.match(prepared, prepared=True).index == 7
    with pytest.raises(ValueError, match="one frame"):
        garden_map.match(np.stack(frames[:2]))


def test_forward_camera_map_matches_at_shift_zero(tmp_path):
    frames = [panorama(60, 240, seed=s) for s in range(3)]
    built = ReferenceMap.build(save_traverse(tmp_path / "t", frames, np.zeros((3, 2))), PreparationParams(wrap=False))
    result = built.match(frames[2])
    assert result.index == 2 and result.shifts.tolist() == [0, 0, 0]


def test_other_params_are_an_error_naming_the_fields(garden_map, tmp_path):
    path = garden_map.save(tmp_path / "garden.map")
    with pytest.raises(MapFormatError) as info:
        ReferenceMap.load(path, params=PreparationParams(width=64, equalize="clahe"))
    message = str(info.value)
    assert "garden.map" in message and "width: map 48, requested 64" in message and "equalize" in message
    assert "height" not in message


def test_build_needs_poses(tmp_path):
    save_traverse(tmp_path / "route", [panorama(48, 96, seed=0)])
    with pytest.raises(DatasetError, match="no poses"):
        ReferenceMap.build(tmp_path / "route")


def test_constructor_checks():
    images = np.zeros((3, 24, 48), np.uint8)
    with pytest.raises(ValueError, match=r"positions must be \(3, 2\)"):
        ReferenceMap(images, np.zeros((2, 2)))
    with pytest.raises(ValueError, match="not finite"):
        ReferenceMap(images, [[0, 0], [1, np.nan], [2, 2]])
    with pytest.raises(ValueError, match="params say 64x24"):
        ReferenceMap(images, np.zeros((3, 2)), params=PreparationParams(width=64))
    with pytest.raises(TypeError, match="uint8"):
        ReferenceMap(images.astype(np.float32), np.zeros((3, 2)))
    with pytest.raises(ValueError, match="repeat"):
        ReferenceMap(images, np.zeros((3, 2)), names=["a", "b", "a"])
    with pytest.raises(ValueError, match="headings"):
        ReferenceMap(images, np.zeros((3, 2)), headings=[0.0, 1.0])
    plain = ReferenceMap(images, np.zeros((3, 2)), headings=[0.0, 4.0, -7.0])
    assert plain.names == ("000000", "000001", "000002")
    assert np.all(np.abs(plain.headings) <= math.pi)


# -------------------------------------------------------------------------------------------
# corrupt files


def rewrite_header(path, change):
    with np.load(path, allow_pickle=False) as archive:
        arrays = {name: archive[name] for name in archive.files}
    header = json.loads(arrays["header"].tobytes())
    change(header)
    arrays["header"] = np.frombuffer(json.dumps(header).encode(), np.uint8)
    with open(path, "wb") as stream:
        np.savez(stream, **arrays)


@pytest.fixture
def saved(garden_map, tmp_path):
    return garden_map.save(tmp_path / "garden.map")


@pytest.mark.parametrize("fraction", [0.0, 0.1, 0.5, 0.9, 0.999])
def test_truncated_map(saved, fraction):
    data = saved.read_bytes()
    saved.write_bytes(data[: int(len(data) * fraction)])
    with pytest.raises(MapFormatError, match=r"garden\.map"):
        ReferenceMap.load(saved)


def test_flipped_bytes_are_detected(saved):
    data = bytearray(saved.read_bytes())
    with zipfile.ZipFile(saved) as archive:
        info = archive.getinfo("images.npy")
    # flip one byte inside the stored image array
    offset = info.header_offset + 30 + len(info.filename) + len(info.extra) + 200
    data[offset] ^= 0xFF
    saved.write_bytes(bytes(data))
    with pytest.raises(MapFormatError, match=r"garden\.map"):
        ReferenceMap.load(saved)


def test_checksum_mismatch(saved):
    rewrite_header(saved, lambda h: h["checksums"].update(positions="0" * 64))
    with pytest.raises(MapFormatError, match="checksum of 'positions'"):
        ReferenceMap.load(saved)


@pytest.mark.parametrize(
    ("change", "text"),
    [
        (lambda h: h.update(format_version=5), "newer nightloc"),
        (lambda h: h.update(format="something-else"), "not a nightloc reference map"),
        (lambda h: h["params"].update(widht=48), "unknown key 'widht'"),
        (lambda h: h["params"].update(width="48"), "width must be int"),
        (lambda h: h.pop("names"), "lacks 'names'"),
        (lambda h: h.update(count=5), "expected uint8 (5, 24, 48)"),
        (lambda h: h.update(names=["a"] * 12), "inconsistent map contents"),
    ],
)
def test_bad_headers(saved, change, text):
    rewrite_header(saved, change)
    with pytest.raises(MapFormatError, match=r"garden\.map") as info:
        ReferenceMap.load(saved)
    assert text in str(info.value)


def test_not_a_map(tmp_path):
    with pytest.raises(FileNotFoundError, match="does not exist"):
        ReferenceMap.load(tmp_path / "missing.map")
    (tmp_path / "text.map").write_text("hello")
    with pytest.raises(MapFormatError, match=r"text\.map"):
        ReferenceMap.load(tmp_path / "text.map")
    np.save(tmp_path / "array.npy", np.zeros(3))
    with pytest.raises(MapFormatError, match="single numpy array"):
        ReferenceMap.load(tmp_path / "array.npy")
    np.savez(tmp_path / "other.npz", a=np.zeros(3))
    with pytest.raises(MapFormatError, match="no header"):
        ReferenceMap.load(tmp_path / "other.npz")
    with pytest.raises(MapFormatError, match="folder"):
        ReferenceMap.load(tmp_path)


def test_interrupted_save_keeps_the_old_map(garden_map, saved, monkeypatch):
    before = saved.read_bytes()

    def interrupted(stream, **arrays):
        stream.write(b"PK\x03\x04 partial")
        raise KeyboardInterrupt

    monkeypatch.setattr(np, "savez", interrupted)
    with pytest.raises(KeyboardInterrupt):
        garden_map.save(saved, overwrite=True)
    assert saved.read_bytes() == before
    assert os.listdir(saved.parent) == [saved.name]


def test_the_saved_tables_come_from_the_localization_stage(garden_map, tmp_path, monkeypatch):
    """The map stage sits below localization: importing nightloc gives it the table maker, and
    without one save refuses before any file is made."""
    from nightloc.localization.filter_tables import filter_tables
    from nightloc.mapping import reference_map

    assert reference_map._localizer_tables is filter_tables
    monkeypatch.setattr(reference_map, "_localizer_tables", None)
    with pytest.raises(RuntimeError, match="localization stage is not loaded"):
        garden_map.save(tmp_path / "no_tables.map")
    assert os.listdir(tmp_path) == []


# -------------------------------------------------------------------------------------------
# the build-map command


def test_build_map_command(garden, garden_map, tmp_path, capsys):
    out = tmp_path / "cli.map"
    assert main(["build-map", str(garden[0]), str(out)]) == 0
    printed = capsys.readouterr().out
    assert "12 frames" in printed and "wrote" in printed
    assert ReferenceMap.load(out) == garden_map


def test_build_map_command_with_params_and_step(garden, tmp_path, capsys):
    params = PreparationParams(width=32, height=16, equalize="none")
    save_params(tmp_path / "p.toml", params)
    out = tmp_path / "cli.map"
    assert main(["build-map", str(garden[0]), str(out), "--params", str(tmp_path / "p.toml"), "--frame-step", "2"]) == 0
    loaded = ReferenceMap.load(out, params)
    assert len(loaded) == 6 and loaded.images.shape[1:] == (16, 32)


@pytest.mark.parametrize(
    ("setup", "text"),
    [
        (lambda tmp: ["build-map", str(tmp / "nope"), str(tmp / "o.map")], "does not exist"),
        (
            lambda tmp: ["build-map", "TRAVERSE", str(tmp / "o.map"), "--params", str(tmp / "bad.toml")],
            "unknown key 'sigma'",
        ),
        (lambda tmp: ["build-map", "ROUTE", str(tmp / "o.map")], "no poses"),
    ],
)
def test_build_map_command_errors(garden, tmp_path, capsys, setup, text):
    (tmp_path / "bad.toml").write_text("[preparation]\nsigma = 3\n")
    save_traverse(tmp_path / "route", [panorama(48, 96, seed=0)])
    argv = [a.replace("TRAVERSE", str(garden[0])).replace("ROUTE", str(tmp_path / "route")) for a in setup(tmp_path)]
    assert main(argv) == 2
    err = capsys.readouterr().err
    assert err.startswith("nightloc build-map: error:") and text in err and err.count("\n") == 1
    assert not (tmp_path / "o.map").exists()


# -------------------------------------------------------------------------------------------
# real images: day map, night queries


def test_gardens_point_map_round_trip(shared_data, tmp_path):
    folder = shared_data / "gardens_point_pairs"
    if not folder.is_dir():
        pytest.skip(f"{folder} not found")
    day = nightloc.load_traverse(folder / "day")
    positions = np.stack([np.arange(10.0), np.zeros(10)], axis=1)  # ten consecutive places
    traverse = save_traverse(
        tmp_path / "day", (day.read(i) for i in range(10)), positions, names=list(day.names), image_format="jpg"
    )
    params = PreparationParams(wrap=False)
    built = ReferenceMap.build(traverse, params)
    loaded = ReferenceMap.load(built.save(tmp_path / "gp.map"), params)
    night = nightloc.load_traverse(folder / "night")
    places = [loaded.match(image).index for _, image in night.frames()]
    assert sum(abs(p - i) <= 1 for i, p in enumerate(places)) >= 5  # see test_preparation


def test_build_map_from_a_video_with_odometry(tmp_path, capsys):
    import cv2

    from video_support import write_video

    video = tmp_path / "drive.avi"
    write_video(video, 12)
    if not cv2.VideoCapture(str(video)).isOpened():
        pytest.skip("this OpenCV build cannot read MJPG AVI files")
    (tmp_path / "odometry.csv").write_text("frame,x,y,heading\n" + "".join(f"{i},{0.1 * i},0,0\n" for i in range(12)))
    out = tmp_path / "drive.map"
    argv = ["build-map", str(video), str(out), "--poses", str(tmp_path / "odometry.csv"), "--frame-step", "4"]
    argv += ["--camera", "forward"]  # 4:3 frames: never prepared as panoramas unless a camera says so
    assert main(argv) == 0
    loaded = ReferenceMap.load(out, PreparationParams(wrap=False))
    assert loaded.names == ("frame_000000", "frame_000004", "frame_000008")
    np.testing.assert_allclose(loaded.positions[:, 0], [0.0, 0.4, 0.8])


def test_pickled_maps_and_traverses_stay_read_only(garden, garden_map):
    import pickle

    copy = pickle.loads(pickle.dumps(garden_map))
    assert copy == garden_map and not copy.images.flags.writeable and not copy.positions.flags.writeable
    traverse = nightloc.load_traverse(garden[0])
    twin = pickle.loads(pickle.dumps(traverse))
    assert twin.names == traverse.names and not twin.positions.flags.writeable
    np.testing.assert_array_equal(twin.read(3), traverse.read(3))


# --- format version 2: the poses' source and their covariances


def _covariances(n, seed=0):
    rng = np.random.default_rng(seed)
    a = rng.normal(0.0, 0.05, (n, 3, 3))
    return a @ np.swapaxes(a, 1, 2) + 1e-4 * np.eye(3)


def test_pose_source_and_covariances_round_trip(garden, garden_map, tmp_path):
    assert garden_map.pose_source == "surveyed" and garden_map.covariances is None
    cov = _covariances(12)
    built = ReferenceMap(
        garden_map.images,
        garden_map.positions,
        garden_map.headings,
        garden_map.names,
        pose_source="optimised",
        covariances=cov,
    )
    assert built != garden_map  # the source and covariances are part of the map
    loaded = ReferenceMap.load(built.save(tmp_path / "teach.map"))
    assert loaded == built and loaded.pose_source == "optimised"
    np.testing.assert_array_equal(loaded.covariances, cov)
    assert not loaded.covariances.flags.writeable
    with np.load(tmp_path / "teach.map", allow_pickle=False) as archive:
        header = json.loads(archive["header"].tobytes())
        assert header["pose_source"] == "optimised" and "covariances" in header["checksums"]


def as_version_2(path):
    """Rewrites a map file in the layout of format 2 (before the localizer's tables)."""
    with np.load(path, allow_pickle=False) as archive:
        arrays = {name: archive[name] for name in archive.files if not name.startswith("filter_")}
    header = json.loads(arrays["header"].tobytes())
    header.update(format_version=2)
    header.pop("localizer")
    header["checksums"] = {k: v for k, v in header["checksums"].items() if not k.startswith("filter_")}
    arrays["header"] = np.frombuffer(json.dumps(header).encode(), np.uint8)
    with open(path, "wb") as stream:
        np.savez(stream, **arrays)


def test_version_2_map_loads_and_saves_as_version_3(saved, garden_map, tmp_path):
    """A map written before the localizer's tables (format 2) loads unchanged; saving it again
    writes format 3 with the tables (how firmware users upgrade a map)."""
    as_version_2(saved)
    with np.load(saved) as archive:
        assert not any(name.startswith("filter_") for name in archive.files)
    loaded = ReferenceMap.load(saved)
    assert loaded == garden_map
    upgraded = loaded.save(tmp_path / "upgraded.map")
    with np.load(upgraded) as archive:
        header = json.loads(archive["header"].tobytes())
        assert header["format_version"] == 3 and "filter_closest_ref" in archive.files


def test_the_stored_tables_are_the_default_localizers(saved, garden_map):
    """Format 3 stores what ``nightloc.Localizer(map)`` computes once per map: its filter's settings
    (key for key), grid, interpolation weights, places and each cell's closest reference."""
    localizer = nightloc.Localizer(garden_map)
    flt, mapper = localizer.grid_filter, localizer.mapper
    with np.load(saved) as archive:
        header = json.loads(archive["header"].tobytes())["localizer"]
        assert header["settings"] == flt.settings.to_dict() and header["method"] == "filter"
        assert header["grid"] == {
            "x0": mapper.grid.x0,
            "y0": mapper.grid.y0,
            "dx": mapper.grid.dx,
            "dy": mapper.grid.dy,
            "width": 100,
            "height": 100,
        }
        assert header["shifts"] == list(range(48)) and header["window"] == [0, 0] and header["columns"] == 48
        assert header["odometry_noise"] == [0.1, 0.02]
        dense = np.zeros(mapper.weights.shape, np.float32)
        indptr, indices = archive["filter_weights_indptr"], archive["filter_weights_indices"]
        for cell in range(dense.shape[0]):
            span = slice(indptr[cell], indptr[cell + 1])
            dense[cell, indices[span]] = archive["filter_weights_data"][span]
        np.testing.assert_array_equal(dense, mapper.weights.toarray().astype(np.float32))
        np.testing.assert_array_equal(archive["filter_place_of_ref"], mapper.place_of_ref)
        # the closest reference of each cell: the nearest position to its centre (all distinct here)
        centres = mapper.grid.centres()
        nearest = np.argmin(np.hypot(*(centres[:, None, :] - garden_map.positions[None]).transpose(2, 0, 1)), axis=1)
        np.testing.assert_array_equal(archive["filter_closest_ref"], nearest)


def test_version_1_map_loads_as_surveyed(saved):
    """A map written before format 2 (no pose_source, no covariances) still loads, as surveyed."""

    def as_version_1(header):
        header.update(format_version=1)
        header.pop("pose_source")

    rewrite_header(saved, as_version_1)
    loaded = ReferenceMap.load(saved)
    assert loaded.pose_source == "surveyed" and loaded.covariances is None and len(loaded) == 12


@pytest.mark.parametrize(
    ("change", "text"),
    [
        (lambda h: h.update(pose_source="guessed"), "pose_source 'guessed'"),
        (lambda h: h["checksums"].update(covariances="0" * 64), "lacks its 'covariances' array"),
    ],
)
def test_bad_pose_fields(saved, change, text):
    rewrite_header(saved, change)
    with pytest.raises(MapFormatError, match=r"garden\.map") as info:
        ReferenceMap.load(saved)
    assert text in str(info.value)


@pytest.mark.parametrize(
    ("covariances", "pose_source", "text"),
    [
        (np.zeros((11, 3, 3)), "optimised", r"\(12, 3, 3\)"),
        (np.full((12, 3, 3), np.nan), "optimised", "NaN"),
        (-np.ones((12, 3, 3)), "optimised", "negative variances"),
        (np.triu(np.ones((12, 3, 3))), "optimised", "symmetric"),
        (None, "surveyed-ish", "pose_source must be one of"),
    ],
)
def test_bad_pose_arguments(garden_map, covariances, pose_source, text):
    with pytest.raises(ValueError, match=text):
        ReferenceMap(garden_map.images, garden_map.positions, pose_source=pose_source, covariances=covariances)
