"""The sweep that chose route mode's translation window (docs/route_mode.md, issue 19).

Route mode with the default filter and every window (columns, rows) of a grid, on

* synthetic lateral-offset routes (nightloc.synth.routes): a street walked by day and at night
  0 / 0.5 / 1 / 2 / 3 m beside the day walk, several streets (seeds), a forward camera and a
  panoramic one, day -> night and night -> day;
* the shared real pairs when present (../shared/data): Gardens Point day_right <-> night_right,
  Nordland summer -> winter (all 3576 frames, and frames 1000-1500).

Every result is one JSON line (pair, variant, window, best F1, recall at 100 % precision)::

    python tools/window_sweep.py render --out /tmp/routes --seeds 0,1,2
    python tools/window_sweep.py sweep --routes /tmp/routes --results sweep.jsonl
    python tools/window_sweep.py summary sweep.jsonl

Rendering takes about a minute per walk on one core (288 frames); prepared walks are cached as
.npz files in the routes folder.
"""

from __future__ import annotations

import argparse
import json
import math
import os
import sys
import time
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

import numpy as np

from nightloc import route
from nightloc.io.traverse import load_traverse
from nightloc.route.params import RouteParams
from nightloc.route.preparation import RoutePreparer

OFFSETS = (0.0, 0.5, 1.0, 2.0, 3.0)
#: Night walks with the camera tilted (degrees up, and a per-frame wobble): lateral offset, pitch.
TILTED = ((1.0, 2.0), (2.0, -2.0))
PITCH_WOBBLE = 0.7
WINDOWS = [(c, r) for r in (0, 1, 2, 3) for c in (0, 2, 4, 6, 8, 10, 12, 16)]
DATA = Path(os.environ.get("NIGHTLOC_SHARED_DATA", Path(__file__).resolve().parents[2] / "shared" / "data"))


def route_params(camera: str, window: tuple[int, int]) -> RouteParams:
    return route.resolve_params(None, circular_shifts=camera == "panoramic", shift_window=window)


def prepare(frames: np.ndarray, camera: str) -> np.ndarray:
    return RoutePreparer(route_params(camera, (0, 0)))(frames)


def say(line: str) -> None:
    sys.stdout.write(line + "\n")
    sys.stdout.flush()


def render(out: Path, seeds: list[int], length: float, threads: int) -> None:
    from nightloc.synth.routes import RouteScene, build_street, render_drive, street_drive

    out.mkdir(parents=True, exist_ok=True)
    for seed in seeds:
        world = build_street(seed, length)
        scene = RouteScene(world, seed)
        drives = [("day", 0.0, 0.0, 100 * seed)]
        drives += [("night", d, 0.0, 100 * seed + 1 + k) for k, d in enumerate(OFFSETS)]
        drives += [("night", d, p, 100 * seed + 50 + k) for k, (d, p) in enumerate(TILTED)]
        jobs = []
        for camera in ("forward", "panoramic"):
            for condition, offset, pitch, drive_seed in drives:
                tilt = f"_tilt{pitch:g}" if pitch else ""
                path = out / f"street{seed}_{camera}_{condition}_{offset:g}{tilt}.npz"
                if not path.exists():
                    jobs.append((camera, condition, offset, pitch, drive_seed, path))

        def one(job, world=world, scene=scene):
            camera, condition, offset, pitch, drive_seed, path = job
            start = time.perf_counter()
            wobble = PITCH_WOBBLE if pitch else 0.0
            drive = street_drive(world, condition, offset, drive_seed, pitch=pitch, pitch_jitter=wobble)
            frames = render_drive(scene, drive, camera)
            np.savez_compressed(path, images=prepare(frames, camera), positions=drive.positions)
            say(f"{path.name}: {len(frames)} frames in {time.perf_counter() - start:.0f} s")

        with ThreadPoolExecutor(max_workers=threads) as pool:
            list(pool.map(one, jobs))


def score(refs: np.ndarray, queries: np.ndarray, params: RouteParams) -> tuple[float, float]:
    result = route.match_prepared(refs, queries, params, threads=2)
    truth = route.GroundTruth.from_frames(result.n_queries, result.n_refs, tolerance=2)
    evaluation = route.evaluate_matches(result.refs, result.scores, truth)
    return float(evaluation.best_f1), float(evaluation.recall_at_100)


def synthetic_pairs(routes: Path):
    for path in sorted(routes.glob("street*_*_night_*.npz")):
        street, camera, _night, offset, *tilt = path.stem.split("_")
        day = np.load(routes / f"{street}_{camera}_day_0.npz")["images"]
        night = np.load(path)["images"]
        variant = {"street": street, "camera": camera, "offset_m": float(offset)}
        if tilt:
            variant["tilt_deg"] = float(tilt[0][len("tilt") :])
        yield "synthetic day->night", variant, camera, day, night
        yield "synthetic night->day", variant, camera, night, day


def real_pairs():
    base = RouteParams()
    gp = DATA / "gardens_point"
    if gp.is_dir():
        prep = RoutePreparer(base)
        day, night = prep(load_traverse(gp / "day_right")), prep(load_traverse(gp / "night_right"))
        yield "GP day->night", {}, "forward", day, night
        yield "GP night->day", {}, "forward", night, day
    nordland = DATA / "nordland"
    if nordland.is_dir():
        prep = RoutePreparer(base)
        summer, winter = prep(load_traverse(nordland / "summer")), prep(load_traverse(nordland / "winter"))
        yield "Nordland 1000-1500", {}, "forward", summer[1000:1500], winter[1000:1500]
        yield "Nordland 3576", {}, "forward", summer, winter


def sweep(
    routes: Path | None, results: Path, windows: list[tuple[int, int]], real: bool, only: str | None = None
) -> None:
    done = set()
    if results.exists():
        for line in results.read_text().splitlines():
            row = json.loads(line)
            done.add((row["pair"], json.dumps(row["variant"], sort_keys=True), tuple(row["window"])))
    pairs = []
    if routes is not None:
        pairs.append(synthetic_pairs(routes))
    if real:
        pairs.append(real_pairs())
    with results.open("a") as out:
        for source in pairs:
            for name, variant, camera, refs, queries in source:
                if only is not None and only not in name:
                    continue
                for window in windows:
                    key = (name, json.dumps(variant, sort_keys=True), tuple(window))
                    if key in done or (camera == "panoramic" and window[0] > 0):
                        continue  # a panorama's columns are its circular shifts
                    start = time.perf_counter()
                    f1, r100 = score(refs, queries, route_params(camera, window))
                    row = {
                        "pair": name,
                        "variant": variant,
                        "window": list(window),
                        "f1": round(f1, 4),
                        "r100": round(r100, 4),
                        "seconds": round(time.perf_counter() - start, 2),
                    }
                    out.write(json.dumps(row) + "\n")
                    out.flush()
                    say(json.dumps(row))


def summary(results: Path) -> None:
    rows = [json.loads(line) for line in results.read_text().splitlines()]
    groups: dict[tuple, list] = {}
    for row in rows:
        variant = row["variant"]
        group = (
            row["pair"],
            variant.get("camera", "forward"),
            variant.get("offset_m", math.nan),
            "tilted" if "tilt_deg" in variant else "",
            tuple(row["window"]),
        )
        groups.setdefault(group, []).append((row["f1"], row["r100"]))
    for (pair, camera, offset, tilt, window), values in sorted(groups.items(), key=lambda kv: str(kv[0])):
        f1 = np.array([v[0] for v in values])
        r100 = np.array([v[1] for v in values])
        say(
            f"{pair:22s} {camera:9s} {offset:4} {tilt:6s} {window!s:8s} n={len(values)} "
            f"F1 {np.median(f1):.3f} [{f1.min():.3f}, {f1.max():.3f}]  "
            f"R@100P {np.median(r100):.3f} [{r100.min():.3f}, {r100.max():.3f}]"
        )


def main(argv: list[str]) -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    sub = parser.add_subparsers(dest="command", required=True)
    r = sub.add_parser("render")
    r.add_argument("--out", type=Path, required=True)
    r.add_argument("--seeds", default="0,1,2")
    r.add_argument("--length", type=float, default=200.0)
    r.add_argument("--threads", type=int, default=2)
    s = sub.add_parser("sweep")
    s.add_argument("--routes", type=Path)
    s.add_argument("--results", type=Path, required=True)
    s.add_argument("--windows", help="e.g. 0,0;8,2 (default: the grid)")
    s.add_argument("--real", action="store_true", help="also the shared real pairs")
    s.add_argument("--only", help="only the pairs whose name contains this text")
    m = sub.add_parser("summary")
    m.add_argument("results", type=Path)
    args = parser.parse_args(argv)
    if args.command == "render":
        render(args.out, [int(v) for v in args.seeds.split(",")], args.length, args.threads)
    elif args.command == "sweep":
        windows = (
            WINDOWS if not args.windows else [tuple(int(v) for v in w.split(",")) for w in args.windows.split(";")]
        )
        sweep(args.routes, args.results, windows, args.real, args.only)  # type: ignore[arg-type]
    else:
        summary(args.results)


if __name__ == "__main__":
    main(sys.argv[1:])
