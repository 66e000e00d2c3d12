"""The firmware path: ``nightloc_replay MAP LOG OUT.csv`` (C++, no Python) equals ``nightloc
localize`` and ``nightloc.Localizer`` on the same frames, and refuses bad input clearly.

The program is the one ``pip install`` put beside this Python's ``nightloc`` script (built from the
same core as the module), or ``$NIGHTLOC_REPLAY`` (e.g. a CMake build's). Tests of PNG frames check
whichever the build does: read them as Python does, or refuse them naming both fixes. The data: a small
synthetic garden map and night log (tools/firmware_golden.py), and a night ``nightloc synth`` wrote.
"""

from __future__ import annotations

import csv
import json
import math
import os
import shutil
import subprocess
import sys
import sysconfig
from pathlib import Path

import cv2
import numpy as np
import pytest

import nightloc
from nightloc.cli import main as nightloc_main
from nightloc.io.images import IMAGE_SUFFIXES
from nightloc.io.trajectory import TRAJECTORY_HEADER

sys.path.insert(0, str(Path(__file__).resolve().parents[2] / "tools"))
import firmware_golden

REPO = Path(__file__).resolve().parents[2]
TOLERANCE = 1e-4  # metres and radians: the target of the firmware path
PROGRAM = "nightloc_replay"


def installed_replay() -> Path | None:
    """``$NIGHTLOC_REPLAY``, else the program installed beside this interpreter's scripts, else
    the one on PATH; None when there is none."""
    named = os.environ.get("NIGHTLOC_REPLAY")
    if named:
        return Path(named).resolve()
    beside = Path(sysconfig.get_path("scripts")) / PROGRAM
    if beside.is_file():
        return beside
    found = shutil.which(PROGRAM)
    return Path(found) if found else None


@pytest.fixture(scope="session")
def replay() -> Path:
    """The nightloc_replay program (installed with the package, or named by $NIGHTLOC_REPLAY)."""
    path = installed_replay()
    assert path is not None, (
        f"{PROGRAM} is not installed beside {sys.executable}: reinstall nightloc (pip install .), which builds it with "
        f"the module, or name a build with NIGHTLOC_REPLAY=path/to/{PROGRAM}"
    )
    assert path.is_file() and os.access(path, os.X_OK), f"{path} is not an executable"
    return path


@pytest.fixture(scope="session")
def reads_png(replay) -> bool:
    """Whether this build reads PNG frames (libpng found when it was built), as its --help says."""
    shown = subprocess.run([str(replay), "--help"], capture_output=True, text=True, check=True).stdout
    assert "PNG frames: read (libpng " in shown or "PNG frames: not read (built without libpng" in shown, shown
    return "PNG frames: read" in shown


@pytest.fixture(scope="module")
def world():
    return firmware_golden.scene()


@pytest.fixture(scope="module")
def map_file(world, tmp_path_factory) -> Path:
    return firmware_golden.build_map(world, tmp_path_factory.mktemp("map"))


def run_replay(replay: Path, *args: object, cwd: Path | None = None) -> subprocess.CompletedProcess:
    return subprocess.run(
        [str(replay), *map(str, args)], capture_output=True, text=True, check=False, timeout=120, cwd=cwd
    )


def read_rows(path: Path) -> tuple[list[str], np.ndarray]:
    with open(path, newline="") as handle:
        rows = list(csv.DictReader(handle))
    names = [r["image"] for r in rows]
    columns = ("x", "y", "heading", "confidence", "credible_radius")
    return names, np.array([[float(r[c]) for c in columns] for r in rows])


def read_column(path: Path, column: str) -> list[str]:
    with open(path, newline="") as handle:
        return [row[column] for row in csv.DictReader(handle)]


def assert_same_trajectory(actual: np.ndarray, expected: np.ndarray, tolerance: float) -> None:
    for column in (0, 1, 3, 4):
        np.testing.assert_allclose(actual[:, column], expected[:, column], rtol=0, atol=tolerance)
    both_nan = np.isnan(actual[:, 2]) & np.isnan(expected[:, 2])
    turn = np.abs(np.remainder(actual[:, 2] - expected[:, 2] + math.pi, 2 * math.pi) - math.pi)
    assert (both_nan | (turn <= tolerance)).all(), (actual[:, 2], expected[:, 2])


@pytest.mark.parametrize(
    ("colour", "robot_odometry"),
    [(False, True), (True, False)],
    ids=["pgm-wheel-odometry", "ppm-map-displacements"],
)
def test_replay_equals_localize(replay, world, map_file, tmp_path, colour, robot_odometry):
    log = firmware_golden.write_log(world, tmp_path / "log", colour=colour, robot_odometry=robot_odometry)
    out = tmp_path / "replay.csv"
    done = run_replay(replay, map_file, log, out)
    assert done.returncode == 0, done.stderr
    assert "ms per frame" in done.stderr
    names, actual = read_rows(out)
    localized, expected = read_rows(firmware_golden.localize(map_file, log, tmp_path / "run"))
    assert names == localized == [f"{k:06d}.{'ppm' if colour else 'pgm'}" for k in range(12)]
    with open(out) as handle:  # localize's columns, in its order
        assert tuple(handle.readline().strip().split(",")) == TRAJECTORY_HEADER
    assert read_column(out, "ref_index") == read_column(tmp_path / "run" / "trajectory.csv", "ref_index")
    assert read_column(out, "timestamp") == ["nan"] * 12  # the log carries no times
    # the command rounds to 0.1 mm (heading 1e-5 rad): the target within that rounding
    assert_same_trajectory(actual, expected, TOLERANCE)
    # the API at full precision: the same arithmetic, so equal to the printed digits
    api = np.array(
        [(e.x, e.y, e.heading, e.confidence, e.credible_radius) for e in firmware_golden.api_trajectory(map_file, log)]
    )
    assert_same_trajectory(actual, api, 1e-8)
    if not robot_odometry:  # map-frame odometry: position-only, the heading is the closest reference's
        assert np.isfinite(actual[:, 2]).all()


def test_a_tuned_map_replays_as_localize(replay, world, map_file, tmp_path):
    """build-map --params with [filter] and [localization]: the map keeps them, its tables are
    made with them, and nightloc_replay, localize and the API run them alike."""
    tuned = tmp_path / "tuned.toml"
    tuned.write_text(
        "[filter]\nuniform_floor = 0.05\nheading_bins = 24\nlikelihood_gain = 2.5\n"
        "[localization]\ngrid_width = 60\ngrid_height = 40\n"
    )
    tuned_map = firmware_golden.build_map(world, tmp_path, params_file=tuned)
    with np.load(tuned_map) as archive:
        tables = json.loads(archive["header"].tobytes())["localizer"]
    # what the firmware reads: the core's settings and the grid, as the file says them
    assert (tables["settings"]["uniform_floor"], tables["settings"]["heading_bins"]) == (0.05, 24)
    assert tables["settings"]["likelihood_gain"] == 2.5
    assert (tables["grid"]["width"], tables["grid"]["height"]) == (60, 40)
    assert nightloc.ReferenceMap.load(tuned_map).settings["filter"]["uniform_floor"] == 0.05
    log = firmware_golden.write_log(world, tmp_path / "log")
    done = run_replay(replay, tuned_map, log, tmp_path / "replay.csv")
    assert done.returncode == 0, done.stderr
    actual = read_rows(tmp_path / "replay.csv")[1]
    expected = read_rows(firmware_golden.localize(tuned_map, log, tmp_path / "run"))[1]
    assert_same_trajectory(actual, expected, TOLERANCE)
    api = np.array(
        [(e.x, e.y, e.heading, e.confidence, e.credible_radius) for e in firmware_golden.api_trajectory(tuned_map, log)]
    )
    assert_same_trajectory(actual, api, 1e-8)
    # the settings make a difference: the default map's trajectory is another
    assert run_replay(replay, map_file, log, tmp_path / "default.csv").returncode == 0
    assert np.abs(read_rows(tmp_path / "default.csv")[1] - actual).max() > 1e-3


def test_replay_equals_localize_for_a_forward_camera(replay, tmp_path):
    """A forward camera's map (no wrap, one shift): heading bins from the column window."""
    forward = firmware_golden.scene(forward=True)
    map_file = firmware_golden.build_map(forward, tmp_path)
    log = firmware_golden.write_log(forward, tmp_path / "log")
    done = run_replay(replay, map_file, log, tmp_path / "replay.csv")
    assert done.returncode == 0, done.stderr
    api = np.array(
        [(e.x, e.y, e.heading, e.confidence, e.credible_radius) for e in firmware_golden.api_trajectory(map_file, log)]
    )
    assert_same_trajectory(read_rows(tmp_path / "replay.csv")[1], api, 1e-8)
    with np.load(map_file) as archive:
        tables = json.loads(archive["header"].tobytes())["localizer"]
    assert tables["shifts"] == [0] and tables["window"] == [12, 0] and tables["field_of_view"] > 0


def test_replay_reads_an_experience_map(replay, world, map_file, tmp_path):
    """A map that learned a night (format 4: appearances at their places' positions, new places):
    the firmware runs it as Python does."""
    import nightloc
    from nightloc.experience.learning import LearningParams, learn, localize_night
    from nightloc.localization.odometry import traverse_odometry

    day = nightloc.ReferenceMap.load(map_file)
    night_log = nightloc.load_traverse(firmware_golden.write_log(world, tmp_path / "night", colour=True))
    night = localize_night(day, (night_log.read(i) for i in range(len(night_log))), traverse_odometry(night_log))
    everything = LearningParams(min_confidence=0.0, max_credible_radius=1e3, settled_frames=1, novelty=0.0)
    learned, report = learn(day, night, everything)
    assert report.appearances + report.places > 0
    learned_file = learned.save(tmp_path / "learned.map")
    with np.load(learned_file) as archive:
        assert json.loads(archive["header"].tobytes())["format_version"] == 4
    log = firmware_golden.write_log(world, tmp_path / "log")
    done = run_replay(replay, learned_file, log, tmp_path / "replay.csv")
    assert done.returncode == 0, done.stderr
    api = np.array(
        [
            (e.x, e.y, e.heading, e.confidence, e.credible_radius)
            for e in firmware_golden.api_trajectory(learned_file, log)
        ]
    )
    assert_same_trajectory(read_rows(tmp_path / "replay.csv")[1], api, 1e-8)


def test_replay_golden_files_match_python_today(replay, tmp_path):
    """The committed golden data (the ctest's) still is what today's Python computes: rerun
    tools/firmware_golden.py after changing the default localizer."""
    golden = REPO / "cpp" / "tests" / "data" / "replay"
    estimates = firmware_golden.api_trajectory(golden / "map.npz", golden / "log")
    _, expected = read_rows(golden / "expected.csv")
    api = np.array([(e.x, e.y, e.heading, e.confidence, e.credible_radius) for e in estimates])
    assert_same_trajectory(api, expected, 1e-9)
    done = run_replay(replay, golden / "map.npz", golden / "log", tmp_path / "out.csv")
    assert done.returncode == 0, done.stderr
    assert_same_trajectory(read_rows(tmp_path / "out.csv")[1], expected, 1e-8)


@pytest.fixture
def log(world, tmp_path_factory) -> Path:
    return firmware_golden.write_log(world, tmp_path_factory.mktemp("log") / "log")


def rewrite_map(source: Path, target: Path, change=None, *, compressed: bool = False, drop=()) -> Path:
    with np.load(source, allow_pickle=False) as archive:
        arrays = {name: archive[name] for name in archive.files if name not in drop}
    header = json.loads(arrays["header"].tobytes())
    if change is not None:
        change(header, arrays)
    arrays["header"] = np.frombuffer(json.dumps(header).encode(), np.uint8)
    with open(target, "wb") as stream:
        (np.savez_compressed if compressed else np.savez)(stream, **arrays)
    return target


def written(target: Path, data: bytes) -> Path:
    target.write_bytes(data)
    return target


def version_2(header, arrays):
    """The layout of map format 2 (before the localizer's tables); the tables' arrays are dropped."""
    header.update(format_version=2)
    header.pop("localizer")
    header["checksums"] = {k: v for k, v in header["checksums"].items() if not k.startswith("filter_")}


def corrupt_images(header, arrays):
    arrays["images"] = arrays["images"].copy()
    arrays["images"][0, 0, 0] ^= 1


@pytest.mark.parametrize(
    ("make", "message"),
    [
        (lambda m, t: rewrite_map(m, t, compressed=True), "compressed (zip method 8, deflate)"),
        (
            lambda m, t: rewrite_map(m, t, version_2, drop=firmware_golden_filter_arrays()),
            "ReferenceMap.load('OLD.map').save('NEW.map')",
        ),
        (lambda m, t: rewrite_map(m, t, lambda h, a: h.update(format_version=5)), "newer nightloc"),
        (lambda m, t: rewrite_map(m, t, corrupt_images), "checksum of 'images' does not match"),
        (lambda m, t: rewrite_map(m, t, drop=("filter_closest_ref",)), "lacks its 'filter_closest_ref' array"),
        (
            lambda m, t: rewrite_map(m, t, lambda h, a: h["localizer"]["settings"].update(new_knob=1.0)),
            "unknown grid filter setting 'new_knob'",
        ),
        (
            lambda m, t: rewrite_map(m, t, lambda h, a: h["params"].update(equalize="clahe")),
            "equalized with CLAHE, which the C++ core does not implement",
        ),
        (lambda m, t: written(t, m.read_bytes()[:-200]), "truncated"),
        (lambda m, t: written(t, b"not a map"), "not an .npz zip archive"),
    ],
    ids=[
        "compressed",
        "format-2",
        "format-4",
        "checksum",
        "missing-table",
        "unknown-setting",
        "clahe",
        "truncated",
        "text",
    ],
)
def test_bad_maps_are_named_errors(replay, map_file, log, tmp_path, make, message):
    bad = make(map_file, tmp_path / "bad.map")
    out = tmp_path / "out.csv"
    done = run_replay(replay, bad, log, out)
    assert done.returncode == 2 and not out.exists()
    assert str(bad) in done.stderr and message in done.stderr, done.stderr


def firmware_golden_filter_arrays() -> tuple[str, ...]:
    from nightloc.localization.filter_tables import FILTER_ARRAYS

    return FILTER_ARRAYS


def test_a_format_2_map_still_loads_in_python_and_its_resave_replays(replay, map_file, log, tmp_path):
    old = rewrite_map(map_file, tmp_path / "old.map", version_2, drop=firmware_golden_filter_arrays())
    resaved = nightloc.ReferenceMap.load(old).save(tmp_path / "new.map")  # the upgrade the error names
    done = run_replay(replay, resaved, log, tmp_path / "out.csv")
    assert done.returncode == 0, done.stderr


def _edit_odometry(log: Path, line: int, text: str) -> None:
    path = log / "odometry.csv"
    lines = path.read_text().splitlines()
    lines[line - 1] = text
    path.write_text("\n".join(lines) + "\n")


@pytest.mark.parametrize(
    ("damage", "message"),
    [
        (lambda log: _edit_odometry(log, 3, "000001.pgm,0.3,zero,0.1"), "odometry.csv line 3: column 'left' holds"),
        (lambda log: _edit_odometry(log, 4, "000002.pgm,0.3,0,45"), "odometry.csv line 4: column 'turn' is"),
        (lambda log: _edit_odometry(log, 1, "image,speed,left,turn"), "neither forward,left,turn"),
        (lambda log: _edit_odometry(log, 5, "000002.pgm,0.3,0,0.1"), "line 5: image '000002.pgm' is listed twice"),
        (lambda log: _edit_odometry(log, 5, "000099.pgm,0.3,0,0.1"), "has no row for image '000003.pgm'"),
        (lambda log: (log / "odometry.csv").unlink(), "odometry.csv does not exist"),
        (lambda log: (log / "images" / "000004.pgm").write_bytes(b"P5\n96 48\n255\n123"), "truncated pixel data"),
        (lambda log: (log / "images" / "000004.pgm").write_bytes(b"P2\n1 1\n255\n0\n"), "PNM type P2"),
        (
            lambda log: cv2.imwrite(str(log / "images" / "000004.pgm"), np.zeros((48, 96), np.uint16)),
            "16-bit PNM",
        ),
        (
            lambda log: cv2.imwrite(str(log / "images" / "000004.png"), np.zeros((48, 96), np.uint8)),
            "has no row for image '000004.png'",
        ),
        (
            lambda log: cv2.imwrite(str(log / "images" / "000004.pgm"), np.zeros((24, 48), np.uint8)),
            "000004.pgm: the frame is 48x24 pixels but the map was built from 96x48",
        ),
    ],
    ids=[
        "not-a-number",
        "degrees",
        "header",
        "twice",
        "missing-row",
        "no-odometry",
        "truncated-frame",
        "ascii-pnm",
        "16-bit",
        "extra-png-frame",
        "other-camera",
    ],
)
def test_bad_logs_are_named_errors(replay, map_file, log, tmp_path, damage, message):
    damage(log)
    out = tmp_path / "out.csv"
    done = run_replay(replay, map_file, log, out)
    assert done.returncode == 2 and not out.exists(), done.stderr
    assert message in done.stderr, done.stderr


def test_an_existing_output_is_kept_unless_overwrite(replay, map_file, log, tmp_path):
    out = tmp_path / "out.csv"
    out.write_text("the user's file\n")
    done = run_replay(replay, map_file, log, out)
    assert done.returncode == 2 and "--overwrite" in done.stderr
    assert out.read_text() == "the user's file\n"
    done = run_replay(replay, "--overwrite", map_file, log, out)
    assert done.returncode == 0 and out.read_text().startswith(",".join(TRAJECTORY_HEADER) + "\n")
    assert sorted(p.name for p in tmp_path.iterdir()) == ["out.csv"]  # no temporary file left


def test_help_documents_the_inputs_the_output_and_the_options(replay):
    shown = subprocess.run([str(replay), "--help"], capture_output=True, text=True, check=True).stdout
    for needed in (
        "usage: nightloc_replay [--overwrite] MAP LOG OUT.csv",
        "nightloc build-map",
        "LOG/images/",
        "natural name order",
        "LOG/odometry.csv",
        "image,forward,left,turn",
        "image,dx,dy",
        "timestamp column",
        "nightloc export-log LOG NEW_LOG",
        ",".join(TRAJECTORY_HEADER),  # the output's columns: localize's trajectory.csv
        "--overwrite",
        "-h, --help",
        "exit status 2",
    ):
        assert needed in shown, needed
    assert run_replay(replay, "--frames", "a", "b", "c").stderr.startswith("nightloc_replay: unknown option --frames")


# --- a night as `nightloc synth` writes it (PNG frames, odometry.csv keyed by PNG name, times)


@pytest.fixture(scope="module")
def synth_night(tmp_path_factory) -> tuple[Path, Path, Path]:
    """``(map, night log, localize's trajectory.csv)``: ``nightloc synth`` of the garden (96 x 48
    panoramas), ``nightloc build-map`` of its day reference, ``nightloc localize`` of its night."""
    root = tmp_path_factory.mktemp("synth")
    assert nightloc_main(["synth", "--world", "garden", "--size", "96x48", "--out", str(root / "garden")]) == 0
    map_file = root / "day.map"
    assert nightloc_main(["build-map", str(root / "garden" / "day_reference"), str(map_file)]) == 0
    night = root / "garden" / "night_query"
    return map_file, night, firmware_golden.localize(map_file, night, root / "run")


def assert_replays_localize(replayed: Path, localized: Path) -> None:
    """The replay's trajectory is localize's: the same frames, every value within the target, the
    same closest references and times."""
    names, actual = read_rows(replayed)
    expected_names, expected = read_rows(localized)
    assert [Path(n).stem for n in names] == [Path(n).stem for n in expected_names]
    assert_same_trajectory(actual, expected, TOLERANCE)
    assert read_column(replayed, "ref_index") == read_column(localized, "ref_index")
    times = [float(t) for t in read_column(replayed, "timestamp")]
    assert times == [float(t) for t in read_column(localized, "timestamp")] and np.isfinite(times).all()


def tree_state(folder: Path) -> dict[str, tuple[bytes, int]]:
    """Every file under ``folder``: its bytes and modification time."""
    return {
        str(p.relative_to(folder)): (p.read_bytes(), p.stat().st_mtime_ns) for p in folder.rglob("*") if p.is_file()
    }


def test_a_synth_night_replays_unconverted_as_localize(replay, reads_png, synth_night, tmp_path):
    map_file, night, localized = synth_night
    out = tmp_path / "replay.csv"
    done = run_replay(replay, map_file, night, out)
    if reads_png:
        assert done.returncode == 0, done.stderr
        assert_replays_localize(out, localized)
    else:  # a build without libpng (a fresh machine): the first frame named, and both ways to replay
        assert done.returncode == 2 and not out.exists()
        assert f"{night}/images/000000.png: this nightloc_replay was built without libpng" in done.stderr
        assert f"nightloc export-log {night} NEW_LOG" in done.stderr and "libpng-dev" in done.stderr


def test_a_synth_night_replays_as_localize_after_export_log(replay, synth_night, tmp_path, capsys):
    map_file, night, localized = synth_night
    before = tree_state(night)
    exported = tmp_path / "firmware" / "night"  # its parent is created
    assert nightloc_main(["export-log", str(night), str(exported)]) == 0
    assert "41 PPM frames, odometry.csv with times, poses.csv" in capsys.readouterr().out
    assert tree_state(night) == before  # the user's log is only read
    out = tmp_path / "replay.csv"
    done = run_replay(replay, map_file, exported, out)
    assert done.returncode == 0, done.stderr
    assert_replays_localize(out, localized)
    # the exported log is still a log for Python: localize gives the same trajectory from it
    again = firmware_golden.localize(map_file, exported, tmp_path / "run")
    assert_same_trajectory(read_rows(again)[1], read_rows(localized)[1], 0.0)


# --- errors: the first bad frame in frame order, the folder the user gave


def renamed_frames(log: Path, suffix: str, encode=None) -> Path:
    """Renames every frame of ``log`` (and its rows in odometry.csv and poses.csv) to ``suffix``;
    ``encode(frame)`` -> the new file's bytes (default: the old bytes)."""
    tables = {name: (log / name).read_text() for name in ("odometry.csv", "poses.csv")}
    for frame in sorted((log / "images").iterdir()):
        data = frame.read_bytes() if encode is None else encode(cv2.imread(str(frame), cv2.IMREAD_UNCHANGED))
        frame.unlink()
        frame.with_suffix(suffix).write_bytes(data)
        tables = {name: text.replace(frame.name, frame.with_suffix(suffix).name) for name, text in tables.items()}
    for name, text in tables.items():
        (log / name).write_text(text)
    return log


def test_the_first_bad_frame_in_frame_order_and_the_folder_given_are_named(replay, world, map_file, tmp_path):
    log = firmware_golden.write_log(world, tmp_path / "night")
    renamed_frames(log, ".jpg", lambda frame: cv2.imencode(".jpg", frame)[1].tobytes())
    done = run_replay(replay, map_file, "night", "out.csv", cwd=tmp_path)  # LOG as a relative path
    assert done.returncode == 2 and not (tmp_path / "out.csv").exists()
    # twelve JPEG frames: the message names the first one, whatever order the folder lists them in
    assert done.stderr.startswith("nightloc_replay: night/images/000000.jpg: the firmware path reads"), done.stderr
    assert "nightloc export-log night NEW_LOG" in done.stderr


def test_frames_converted_without_their_rows_are_named_with_the_fix(replay, world, map_file, tmp_path):
    log = firmware_golden.write_log(world, tmp_path / "night")
    odometry = log / "odometry.csv"
    odometry.write_text(odometry.read_text().replace(".pgm", ".png"))  # the rows of the PNG log it came from
    done = run_replay(replay, map_file, log, tmp_path / "out.csv")
    assert done.returncode == 2
    assert "has no row for image '000000.pgm' (it lists '000000.png'" in done.stderr
    assert "nightloc export-log converts both" in done.stderr


def test_a_missing_output_folder_is_named(replay, map_file, log, tmp_path):
    out = tmp_path / "fw" / "out.csv"
    done = run_replay(replay, map_file, log, out)
    assert done.returncode == 2 and not (tmp_path / "fw").exists()
    assert f"the folder of {out}, {tmp_path / 'fw'}, does not exist" in done.stderr
    assert ".tmp" not in done.stderr


@pytest.mark.parametrize("suffix", sorted(IMAGE_SUFFIXES - {".pgm", ".ppm", ".pnm", ".png"}))
def test_every_image_file_nightloc_reads_is_a_frame_here(replay, map_file, log, tmp_path, suffix):
    """A frame in a format the firmware does not read is refused by name, never skipped."""
    (log / "images" / "000005.pgm").rename(log / "images" / f"000005{suffix}")
    _edit_odometry(log, 7, f"000005{suffix},0.3,0,0.1")
    done = run_replay(replay, map_file, log, tmp_path / "out.csv")
    assert done.returncode == 2
    assert f"images/000005{suffix}: the firmware path reads PGM/PPM" in done.stderr, done.stderr


# --- PNG frames of every kind: the pixels Python decodes (OpenCV), or the error naming the fix


def png_bytes(pixels: np.ndarray, colour_type: int, depth: int = 8, palette: np.ndarray | None = None) -> bytes:
    """A PNG file of ``pixels`` (rows of samples, channels last), written by hand (filter 0, no
    interlace): an encoder independent of OpenCV and libpng."""
    import struct
    import zlib

    def chunk(kind: bytes, data: bytes) -> bytes:
        return struct.pack(">I", len(data)) + kind + data + struct.pack(">I", zlib.crc32(kind + data))

    height, width = pixels.shape[:2]
    if depth == 1:
        rows = np.packbits(pixels.reshape(height, width) > 0, axis=1)
    else:
        rows = pixels.reshape(height, -1).astype(">u2" if depth == 16 else np.uint8).view(np.uint8)
    raw = b"".join(b"\0" + row.tobytes() for row in rows)
    header = struct.pack(">IIBBBBB", width, height, depth, colour_type, 0, 0, 0)
    body = chunk(b"IHDR", header) + (chunk(b"PLTE", palette.astype(np.uint8).tobytes()) if palette is not None else b"")
    return b"\x89PNG\r\n\x1a\n" + body + chunk(b"IDAT", zlib.compress(raw)) + chunk(b"IEND", b"")


def _palette(bgr: np.ndarray) -> bytes:
    levels = np.round(bgr[..., ::-1].astype(np.float64) / 51).astype(np.uint8)  # 6 levels per RGB channel
    index = (levels[..., 0] * 36 + levels[..., 1] * 6 + levels[..., 2]).astype(np.uint8)
    palette = np.array([(r, g, b) for r in range(6) for g in range(6) for b in range(6)]) * 51
    return png_bytes(index, 3, palette=palette)


def _with_alpha(frame: np.ndarray) -> np.ndarray:
    return np.dstack([frame, np.arange(frame[..., 0].size, dtype=np.uint8).reshape(frame.shape[:2])])


PNG_KINDS = {  # a colour frame (BGR) -> the PNG file's bytes
    "grey": lambda bgr: png_bytes(cv2.cvtColor(bgr, cv2.COLOR_BGR2GRAY), 0),
    "rgb": lambda bgr: png_bytes(bgr[..., ::-1], 2),
    "rgba": lambda bgr: png_bytes(_with_alpha(bgr[..., ::-1]), 6),
    "grey-alpha": lambda bgr: png_bytes(_with_alpha(cv2.cvtColor(bgr, cv2.COLOR_BGR2GRAY)[..., None]), 4),
    "palette": _palette,
    "1-bit-grey": lambda bgr: png_bytes(cv2.cvtColor(bgr, cv2.COLOR_BGR2GRAY) > 100, 0, depth=1),
}


@pytest.mark.parametrize("kind", PNG_KINDS)
def test_png_frames_of_every_kind_replay_as_python_reads_them(replay, reads_png, world, map_file, tmp_path, kind):
    log = renamed_frames(firmware_golden.write_log(world, tmp_path / "log", colour=True), ".png", PNG_KINDS[kind])
    out = tmp_path / "out.csv"
    done = run_replay(replay, map_file, log, out)
    if not reads_png:
        assert done.returncode == 2 and f"{log}/images/000000.png: this nightloc_replay was built without libpng" in (
            done.stderr
        )
        return
    assert done.returncode == 0, done.stderr
    api = np.array(
        [(e.x, e.y, e.heading, e.confidence, e.credible_radius) for e in firmware_golden.api_trajectory(map_file, log)]
    )
    assert_same_trajectory(read_rows(out)[1], api, 1e-8)


def test_a_16_bit_png_frame_is_refused_by_name(replay, reads_png, world, map_file, tmp_path):
    log = firmware_golden.write_log(world, tmp_path / "log")
    frame = cv2.imread(str(log / "images" / "000003.pgm"), cv2.IMREAD_UNCHANGED).astype(np.uint16) * 257
    (log / "images" / "000003.pgm").unlink()
    (log / "images" / "000003.png").write_bytes(png_bytes(frame, 0, depth=16))
    _edit_odometry(log, 5, (log / "odometry.csv").read_text().splitlines()[4].replace(".pgm", ".png"))
    done = run_replay(replay, map_file, log, tmp_path / "out.csv")
    assert done.returncode == 2
    expected = (
        "a 16-bit PNG; the firmware path prepares 8-bit" if reads_png else "this nightloc_replay was built without"
    )
    assert f"{log}/images/000003.png: {expected}" in done.stderr, done.stderr
