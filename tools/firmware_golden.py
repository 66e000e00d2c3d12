"""A small map and night log for the firmware path, and Python's trajectory on it.

Renders a 7 x 5 lattice of day panoramas of the synthetic garden (1 m apart, 96 x 48 pixels,
headings varied) into a map file (``nightloc build-map``'s format), and a night drive of 12 frames
through it with wheel odometry (the true motions with a little noise) as a log of PGM (grey) or
PPM (colour) frames with ``odometry.csv``: what ``nightloc_replay MAP LOG OUT.csv`` reads.
``python tools/firmware_golden.py cpp/tests/data/replay`` writes ``map.npz``, ``log/`` (and
``log_png/``, the same frames as PNG files, what the replay reads where it has libpng) and
``expected.csv`` there: the trajectory of ``nightloc.Localizer(map)`` on the log at full precision
(checked against ``nightloc localize``'s trajectory.csv, which rounds to 0.1 mm): the C++ ctest
``nightloc_replay_golden_matches_python`` compares the replay with it (within 1e-4). Rerun it
after a change of the default localizer, the preparation or the map format (and commit the
files); tests/firmware/test_replay.py makes the same data afresh in a temporary folder.
"""

from __future__ import annotations

import argparse
import math
import shutil
import sys
import tempfile
from pathlib import Path

import cv2
import numpy as np

import nightloc
from nightloc.cli import main as nightloc_main
from nightloc.motion.odometry import RobotMotion, log_noise_model, true_robot_motions
from nightloc.synth.dataset import SynthScene, forward_view
from nightloc.synth.render import Camera

#: The camera of the golden data: small frames keep the files small (the map's images are 48 x 24).
CAMERA = Camera(width=96, height=48)
#: A panorama four times as wide, whose forward quarter (:func:`forward_view`) is 96 x 48.
FORWARD_CAMERA = Camera(width=384, height=48)


def scene(forward: bool = False) -> SynthScene:
    """The synthetic garden with the golden data's camera (``forward``: the wide panorama whose
    forward quarter the frames keep)."""
    return SynthScene("garden", seed=0, camera=FORWARD_CAMERA if forward else CAMERA)


def _view(world: SynthScene, frame: np.ndarray) -> np.ndarray:
    """The frame as the camera sees it: the panorama, or a forward camera's quarter of it."""
    return forward_view(frame) if world.camera == FORWARD_CAMERA else frame


def night_drive(frames: int = 12) -> tuple[np.ndarray, np.ndarray]:
    """``(frames, 2)`` positions (metres) and ``(frames,)`` headings of a curving drive through the map."""
    t = np.arange(frames, dtype=np.float64)
    headings = 0.15 + 0.08 * t
    steps = 0.32 * np.column_stack([np.cos(headings), np.sin(headings)])
    positions = np.array([1.2, 1.1]) + np.vstack([np.zeros((1, 2)), np.cumsum(steps[:-1], axis=0)])
    return positions, (headings + math.pi) % (2 * math.pi) - math.pi


def build_map(world: SynthScene, folder: Path, params_file: Path | None = None) -> Path:
    """The map file of the day lattice, written to ``folder/map.npz`` (a forward camera's map for
    the forward scene: ``PreparationParams(wrap=False)``); with ``params_file``, by ``nightloc
    build-map DAY MAP --params params_file`` (the settings the map keeps)."""
    xs, ys = np.meshgrid(np.arange(0.5, 7.0, 1.0), np.arange(0.5, 5.0, 1.0))
    positions = np.column_stack([xs.ravel(), ys.ravel()])
    headings = np.random.default_rng(3).uniform(-math.pi, math.pi, len(positions))
    frames = [_view(world, world.frame("day", x, y, h)) for (x, y), h in zip(positions, headings)]
    day = nightloc.save_traverse(folder / "day", frames, positions, headings)
    forward = world.camera == FORWARD_CAMERA
    if params_file is not None:
        path = folder / "map.npz"
        camera = "forward" if forward else "panoramic"
        arguments = ["build-map", str(day.root), str(path), "--params", str(params_file), "--camera", camera]
        if nightloc_main(arguments) != 0:
            raise RuntimeError("nightloc build-map failed")
    else:
        params = nightloc.PreparationParams(wrap=not forward)
        path = nightloc.ReferenceMap.build(day, params).save(folder / "map.npz")
    shutil.rmtree(day.root)
    return path


def write_log(world: SynthScene, folder: Path, *, colour: bool = False, robot_odometry: bool = True) -> Path:
    """The night log: ``images/`` (PPM colour or PGM grey frames), ``poses.csv`` (the truth) and
    ``odometry.csv`` (wheel odometry ``forward,left,turn`` with noise, or map-frame ``dx,dy``)."""
    positions, headings = night_drive()
    rng = np.random.default_rng(11)
    frames = []
    for (x, y), h in zip(positions, headings):
        frame = _view(world, world.frame("night", x, y, h, rng))
        frames.append(frame if colour else cv2.cvtColor(frame, cv2.COLOR_BGR2GRAY))
    if robot_odometry:
        odometry: list[object] = [
            RobotMotion(m.forward + rng.normal(0, 0.02), m.left, m.turn + rng.normal(0, 0.01))
            for m in true_robot_motions(positions, headings)
        ]
    else:
        steps = np.vstack([np.zeros((1, 2)), np.diff(positions, axis=0)])
        odometry = [(float(dx + rng.normal(0, 0.02)), float(dy + rng.normal(0, 0.02))) for dx, dy in steps]
    image_format = "ppm" if colour else "pgm"
    return nightloc.save_traverse(
        folder, frames, positions, headings, odometry=odometry, image_format=image_format
    ).root


def png_copy(log: Path, target: Path) -> Path:
    """``log`` with its frames as PNG files (the same pixels) and its odometry rows renamed to match."""
    (target / "images").mkdir(parents=True)
    odometry = (log / "odometry.csv").read_text()
    for frame in sorted((log / "images").iterdir(), key=lambda p: p.name):
        png = frame.with_suffix(".png").name
        if not cv2.imwrite(str(target / "images" / png), cv2.imread(str(frame), cv2.IMREAD_UNCHANGED)):
            raise RuntimeError(f"OpenCV could not write {png}")
        odometry = odometry.replace(frame.name, png)
    (target / "odometry.csv").write_text(odometry)
    return target


def localize(map_file: Path, log: Path, out: Path) -> Path:
    """``nightloc localize MAP LOG --out OUT --no-figures``; the path of its trajectory.csv."""
    status = nightloc_main(["localize", str(map_file), str(log), "--out", str(out), "--no-figures"])
    if status != 0:
        raise RuntimeError(f"nightloc localize failed with status {status}")
    return out / "trajectory.csv"


def api_trajectory(map_file: Path, log: Path) -> list[nightloc.Estimate]:
    """The default localizer's estimates for every frame of ``log`` with its odometry (the noise
    ``nightloc localize`` assumes for it: the step-scaled wheel model for wheel odometry)."""
    traverse = nightloc.load_traverse(log)
    odometry = nightloc.traverse_odometry(traverse)
    noise = log_noise_model(odometry)
    localizer = nightloc.Localizer(nightloc.ReferenceMap.load(map_file), odometry_noise=noise)
    return [localizer.update(frame, odometry[i]) for i, frame in traverse.frames()]


def write_expected(path: Path, names: list[str], estimates: list[nightloc.Estimate]) -> None:
    """``image,x,y,heading,confidence,credible_radius`` at full precision (repr of the floats)."""
    lines = ["image,x,y,heading,confidence,credible_radius"]
    lines += [
        f"{name},{e.x!r},{e.y!r},{e.heading!r},{e.confidence!r},{e.credible_radius!r}"
        for name, e in zip(names, estimates)
    ]
    path.write_text("\n".join(lines) + "\n")


def main(argv: list[str]) -> int:
    parser = argparse.ArgumentParser(
        prog="python tools/firmware_golden.py",
        description="Writes map.npz, log/, log_png/ and expected.csv (the firmware replay's golden data) into "
        "OUT_FOLDER.",
    )
    parser.add_argument("out_folder", type=Path, help="where to write them (e.g. cpp/tests/data/replay)")
    target = parser.parse_args(argv).out_folder
    target.mkdir(parents=True, exist_ok=True)
    world = scene()
    with tempfile.TemporaryDirectory() as scratch:
        work = Path(scratch)
        map_file = build_map(world, work)
        log = write_log(world, work / "log")
        trajectory = localize(map_file, log, work / "run")
        estimates = api_trajectory(map_file, log)
        rows = np.loadtxt(trajectory, delimiter=",", skiprows=1, usecols=(1, 2, 3, 4, 5))
        api = np.array([(e.x, e.y, e.heading, e.confidence, e.credible_radius) for e in estimates])
        if not np.allclose(rows, api, rtol=0, atol=6e-5):  # the command rounds to 4 or 5 decimals
            raise RuntimeError("nightloc localize and nightloc.Localizer disagree")
        names = sorted(p.name for p in (log / "images").iterdir())
        write_expected(work / "expected.csv", names, estimates)
        png_copy(log, work / "log_png")
        for name in ("map.npz", "log", "log_png", "expected.csv"):
            old = target / name
            if old.is_dir():
                shutil.rmtree(old)
            elif old.exists():
                old.unlink()
        shutil.copy(map_file, target / "map.npz")
        shutil.copytree(log, target / "log")
        shutil.copytree(work / "log_png", target / "log_png")
        shutil.copy(work / "expected.csv", target / "expected.csv")
    sys.stdout.write(f"wrote {target}/map.npz, log/, log_png/ and expected.csv\n")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
