"""The firmware path: ``nightloc_replay MAP LOG OUT.csv`` (C++, no Python) equals ``nightloc
localize`` and ``nightloc.Localizer`` on the same frames, and refuses bad input clearly.

The program comes from ``$NIGHTLOC_REPLAY`` (CI builds the C++ project and names it), or is built
here with CMake into a temporary folder; without CMake, a compiler or Eigen the tests skip, saying
why. The data: a small synthetic garden map and night log (tools/firmware_golden.py).
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

sys.path.insert(0, str(Path(__file__).resolve().parents[2] / "tools"))
import firmware_golden

REPO = Path(__file__).resolve().parents[2]
TOLERANCE = 1e-4  # metres and radians: the target of the firmware path


@pytest.fixture(scope="session")
def replay(tmp_path_factory) -> Path:
    """The nightloc_replay program: $NIGHTLOC_REPLAY, or built here with CMake."""
    named = os.environ.get("NIGHTLOC_REPLAY")
    if named:
        path = Path(named)
        assert path.is_file() and os.access(path, os.X_OK), f"NIGHTLOC_REPLAY={named} is not an executable"
        return path
    cmake = shutil.which("cmake")
    if cmake is None:
        pytest.skip("cmake not found: cannot build nightloc_replay (or name it with NIGHTLOC_REPLAY)")
    build = tmp_path_factory.mktemp("replay-build")
    prefixes = [str(Path(sysconfig.get_paths()["purelib"]) / "cmeel.prefix")]
    configure = subprocess.run(
        [cmake, "-S", str(REPO / "cpp"), "-B", str(build), "-DCMAKE_BUILD_TYPE=Release",
         "-DNIGHTLOC_BUILD_TESTS=OFF", "-DNIGHTLOC_BUILD_EXAMPLES=OFF", f"-DCMAKE_PREFIX_PATH={';'.join(prefixes)}"],
        capture_output=True, text=True, check=False,
    )  # fmt: skip
    if configure.returncode != 0:
        pytest.skip(f"the C++ project does not configure here (no compiler or Eigen?): {configure.stderr[-400:]}")
    built = subprocess.run(
        [cmake, "--build", str(build), "--target", "nightloc_replay", "-j", "2"],
        capture_output=True, text=True, check=False,
    )  # fmt: skip
    assert built.returncode == 0, built.stdout[-2000:] + built.stderr[-2000:]
    return build / "nightloc_replay"


@pytest.fixture(scope="module")
def world():
    return firmware_golden.scene()


@pytest.fixture(scope="module")
def map_file(world, tmp_path_factory) -> Path:
    return firmware_golden.build_map(world, tmp_path_factory.mktemp("map"))


def run_replay(replay: Path, *args: object) -> subprocess.CompletedProcess:
    return subprocess.run([str(replay), *map(str, args)], capture_output=True, text=True, check=False, timeout=120)


def read_rows(path: Path) -> tuple[list[str], np.ndarray]:
    with open(path, newline="") as handle:
        rows = list(csv.DictReader(handle))
    names = [r["image"] for r in rows]
    columns = ("x", "y", "heading", "confidence", "credible_radius")
    return names, np.array([[float(r[c]) for c in columns] for r in rows])


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
    # the command rounds to 0.1 mm (heading 1e-5 rad): the target within that rounding
    assert_same_trajectory(actual, expected, TOLERANCE)
    # the API at full precision: the same arithmetic, so equal to the printed digits
    api = np.array(
        [(e.x, e.y, e.heading, e.confidence, e.credible_radius) for e in firmware_golden.api_trajectory(map_file, log)]
    )
    assert_same_trajectory(actual, api, 1e-8)
    if not robot_odometry:  # map-frame odometry: position-only, the heading is the closest reference's
        assert np.isfinite(actual[:, 2]).all()


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
        (lambda log: cv2.imwrite(str(log / "images" / "000004.png"), np.zeros((48, 96), np.uint8)), "000004.png"),
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
        "png",
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
    assert done.returncode == 0 and out.read_text().startswith("image,x,y,heading,confidence,credible_radius\n")
    assert sorted(p.name for p in tmp_path.iterdir()) == ["out.csv"]  # no temporary file left
