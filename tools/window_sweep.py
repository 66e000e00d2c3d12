"""The sweep that chooses route mode's translation window (docs/route_mode.md).

Route mode with the default filter and every window (columns, rows) of a grid, on

* rendered street walks (nightloc.synth.routes): a street walked by day and again at night, the
  night walk beside the day one (0 / 0.5 / 1 / 2 m) or from another vertical viewpoint (the
  camera lower, tilted, wobbling slowly as if carried by hand, and these with a lateral offset;
  VARIANTS), several streets (seeds), a forward camera and a panoramic one, day -> night and
  night -> day;
* the shared real pairs when present (../shared/data): Gardens Point day_right <-> night_right,
  the ten-place gardens_point_pairs day <-> night, Nordland summer -> winter (all 3576 frames,
  and frames 1000-1500).

Every result is one JSON line (pair, variant, window, best F1, recall at 100 % precision)::

    python tools/window_sweep.py render --out /tmp/routes --seeds 0,1,2
    python tools/window_sweep.py sweep --routes /tmp/routes --results sweep.jsonl --cache /tmp/diffs
    python tools/window_sweep.py summary sweep.jsonl

Rendering takes about a minute per forward walk on one core (126 frames on the default 120 m
street; a panoramic walk a quarter of that); prepared walks are cached as .npz files in the routes
folder, difference matrices (one per pair and window) as .npy files in --cache, results as lines of
the results file: a second run computes only what is missing.
"""

from __future__ import annotations

import argparse
import hashlib
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
from nightloc.route.filter import texture_weights
from nightloc.route.params import RouteParams
from nightloc.route.preparation import RoutePreparer

#: The night walks of every street: name -> street_drive's keyword arguments (offset metres left
#: of the day walk, camera height metres (day: 1.4), pitch degrees up, per-frame pitch jitter and
#: slow pitch wobble, degrees standard deviation).
VARIANTS: dict[str, dict[str, float]] = {
    "lateral0": {"offset": 0.0},
    "lateral0.5": {"offset": 0.5},
    "lateral1": {"offset": 1.0},
    "lateral2": {"offset": 2.0},
    "tilt1": {"offset": 1.0, "pitch": 2.0, "pitch_jitter": 0.7},
    "pitch3": {"offset": 0.0, "pitch": 3.0},
    "low": {"offset": 0.0, "height": 1.0},
    "handheld": {"offset": 0.0, "pitch_wobble": 1.5},
    "lateral1_low_down_handheld": {"offset": 1.0, "height": 1.0, "pitch": -2.0, "pitch_wobble": 1.0},
    "lateral1_high_up_handheld": {"offset": 1.0, "height": 1.7, "pitch": 3.0, "pitch_wobble": 1.0},
}
#: The variants with a vertical viewpoint change (the rest are lateral offsets only).
VERTICAL = tuple(name for name, kw in VARIANTS.items() if set(kw) - {"offset"})
WINDOWS = [(c, r) for r in (0, 1, 2, 3) for c in (0, 4, 8, 12)]
DATA = Path(os.environ.get("NIGHTLOC_SHARED_DATA", Path(__file__).resolve().parents[2] / "shared" / "data"))


def route_params(camera: str, window: tuple[int, int]) -> RouteParams:
    return route.resolve_params(None, circular_shifts=camera == "panoramic", shift_window=window)


def prepare(frames: np.ndarray, camera: str) -> np.ndarray:
    return RoutePreparer(route_params(camera, (0, 0)))(frames)


def say(line: str) -> None:
    sys.stdout.write(line + "\n")
    sys.stdout.flush()


def render(out: Path, seeds: list[int], length: float, threads: int, variants: list[str]) -> None:
    from nightloc.synth.routes import RouteScene, build_street, render_drive, street_drive

    out.mkdir(parents=True, exist_ok=True)
    for seed in seeds:
        world = build_street(seed, length)
        scene = RouteScene(world, seed)
        drives = [("day", "day", {}, 100 * seed)]
        drives += [("night", name, VARIANTS[name], 100 * seed + 1 + list(VARIANTS).index(name)) for name in variants]
        jobs = []
        for camera in ("forward", "panoramic"):
            for condition, name, kwargs, drive_seed in drives:
                path = out / f"street{seed}_{camera}_{condition}_{name}.npz"
                if not path.exists():
                    jobs.append((camera, condition, kwargs, drive_seed, path))

        def one(job, world=world, scene=scene):
            camera, condition, kwargs, drive_seed, path = job
            start = time.perf_counter()
            drive = street_drive(world, condition, seed=drive_seed, **kwargs)
            frames = render_drive(scene, drive, camera)
            partial = path.with_suffix(".part.npz")
            np.savez_compressed(partial, images=prepare(frames, camera), positions=drive.positions)
            partial.replace(path)
            say(f"{path.name}: {len(frames)} frames in {time.perf_counter() - start:.0f} s")

        with ThreadPoolExecutor(max_workers=threads) as pool:
            list(pool.map(one, jobs))


def score(
    refs: np.ndarray, queries: np.ndarray, params: RouteParams, cache: Path | None, key: str, tolerance: int = 2
) -> tuple[float, float, float]:
    """Best F1 and recall at 100 % precision of the route filter, and the share of queries whose
    single most similar reference (the difference row's minimum) is right, frames within
    +-``tolerance``; the difference matrix is read from (or written to) ``cache`` under ``key``."""
    path = None if cache is None else cache / (hashlib.sha1(key.encode()).hexdigest()[:16] + ".npy")
    if path is not None and path.exists():
        difference = np.load(path)
    else:
        difference = route.route_difference_matrix(queries, refs, params, threads=2)
        if path is not None and difference.size <= 4_000_000:
            path.parent.mkdir(parents=True, exist_ok=True)
            np.save(path.with_suffix(".part.npy"), difference)
            path.with_suffix(".part.npy").replace(path)
    best = np.argmin(difference, axis=1)
    top1 = float(np.mean(np.abs(best - np.arange(len(best))) <= tolerance))  # query q shows reference q
    weights = texture_weights(queries, params.filter_min_texture)
    result = route.match_difference(difference, params, threads=2, weights=weights)
    truth = route.GroundTruth.from_frames(result.n_queries, result.n_refs, tolerance=tolerance)
    evaluation = route.evaluate_matches(result.refs, result.scores, truth)
    return float(evaluation.best_f1), float(evaluation.recall_at_100), top1


def synthetic_pairs(routes: Path):
    for path in sorted(routes.glob("street*_*_night_*.npz")):
        if path.name.endswith(".part.npz"):
            continue
        street, camera, _night, name = path.stem.split("_", 3)
        day = np.load(routes / f"{street}_{camera}_day_day.npz")["images"]
        night = np.load(path)["images"]
        variant = {"street": street, "camera": camera, "walk": name}
        yield "synthetic day->night", variant, camera, day, night
        yield "synthetic night->day", variant, camera, night, day


def real_pairs():
    base = RouteParams()
    prep = RoutePreparer(base)
    gp = DATA / "gardens_point"
    if gp.is_dir():
        day, night = prep(load_traverse(gp / "day_right")), prep(load_traverse(gp / "night_right"))
        yield "GP day->night", {}, "forward", day, night
        yield "GP night->day", {}, "forward", night, day
    pairs = DATA / "gardens_point_pairs"
    if pairs.is_dir():
        day, night = prep(load_traverse(pairs / "day")), prep(load_traverse(pairs / "night"))
        yield "GP pairs day->night", {"tolerance": 1}, "forward", day, night
        yield "GP pairs night->day", {"tolerance": 1}, "forward", night, day
    nordland = DATA / "nordland"
    if nordland.is_dir():
        summer, winter = prep(load_traverse(nordland / "summer")), prep(load_traverse(nordland / "winter"))
        yield "Nordland 1000-1500", {}, "forward", summer[1000:1500], winter[1000:1500]
        yield "Nordland 3576", {}, "forward", summer, winter


def sweep(
    routes: Path | None,
    results: Path,
    windows: list[tuple[int, int]],
    real: bool,
    only: str | None = None,
    cache: Path | None = None,
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
                    key = f"{name}|{json.dumps(variant, sort_keys=True)}|{window[0]},{window[1]}"
                    if (name, json.dumps(variant, sort_keys=True), tuple(window)) in done or (
                        camera == "panoramic" and window[0] > 0
                    ):
                        continue  # a panorama's columns are its circular shifts
                    start = time.perf_counter()
                    tolerance = int(variant.get("tolerance", 2))
                    f1, r100, top1 = score(refs, queries, route_params(camera, window), cache, key, tolerance)
                    row = {
                        "pair": name,
                        "variant": variant,
                        "window": list(window),
                        "f1": round(f1, 4),
                        "r100": round(r100, 4),
                        "top1": round(top1, 4),
                        "seconds": round(time.perf_counter() - start, 2),
                    }
                    out.write(json.dumps(row) + "\n")
                    out.flush()
                    say(json.dumps(row))


def summary(results: Path) -> None:
    """One line per pair, camera, walk and window: the median [min, max] over streets (and
    directions for the rendered walks, which are pooled)."""
    rows = [json.loads(line) for line in results.read_text().splitlines()]
    groups: dict[tuple, list] = {}
    for row in rows:
        variant = row["variant"]
        pair = "synthetic" if row["pair"].startswith("synthetic") else row["pair"]
        group = (pair, variant.get("camera", "forward"), variant.get("walk", ""), tuple(row["window"]))
        groups.setdefault(group, []).append((row["f1"], row["r100"], row.get("top1", math.nan)))
    for (pair, camera, walk, window), values in sorted(groups.items(), key=lambda kv: kv[0]):
        f1 = np.array([v[0] for v in values])
        r100 = np.array([v[1] for v in values])
        top1 = np.array([v[2] for v in values])
        say(
            f"{pair:20s} {camera:9s} {walk:28s} {window!s:8s} n={len(values)} "
            f"F1 {np.median(f1):.3f} [{f1.min():.3f}, {f1.max():.3f}]  "
            f"R@100P {np.median(r100):.3f} [{r100.min():.3f}, {r100.max():.3f}]  "
            f"top1 {np.median(top1):.3f} [{top1.min():.3f}, {top1.max():.3f}]"
        )


def table(results: Path, camera: str, metric: str) -> None:
    """A markdown table of the rendered walks: a row per window, a column per walk, each cell the
    median [min-max] of ``metric`` over streets and directions; then the medians pooled over the
    lateral-only walks up to 1 m and over the walks with a vertical change."""
    rows = [json.loads(line) for line in results.read_text().splitlines()]
    rows = [r for r in rows if r["pair"].startswith("synthetic") and r["variant"]["camera"] == camera]
    walks = [w for w in VARIANTS if any(r["variant"]["walk"] == w for r in rows)]
    windows = sorted({tuple(r["window"]) for r in rows}, key=lambda w: (w[1], w[0]))
    lateral = [w for w in walks if w not in VERTICAL and VARIANTS[w]["offset"] <= 1.0]
    vertical = [w for w in walks if w in VERTICAL]
    say("| window | " + " | ".join(walks) + " | lateral ≤ 1 m | vertical |")
    say("| --- " * (len(walks) + 3) + "|")
    for window in windows:
        cells: list[str] = []
        pooled: dict[str, list[float]] = {"lateral": [], "vertical": []}
        for walk in walks:
            values = np.array(
                [r[metric] for r in rows if r["variant"]["walk"] == walk and tuple(r["window"]) == window]
            )
            cells.append(f"{np.median(values):.2f} [{values.min():.2f}\u2013{values.max():.2f}]")
            if walk in lateral or walk in vertical:
                pooled["lateral" if walk in lateral else "vertical"] += list(values)
        say(
            f"| {window[0]}, {window[1]} | "
            + " | ".join(cells)
            + f" | {np.median(pooled['lateral']):.2f} | {np.median(pooled['vertical']):.2f} |"
        )


def main(argv: list[str]) -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    sub = parser.add_subparsers(dest="command", required=True)
    r = sub.add_parser("render")
    r.add_argument("--out", type=Path, required=True)
    r.add_argument("--seeds", default="0,1,2")
    r.add_argument("--length", type=float, default=120.0)
    r.add_argument("--threads", type=int, default=2)
    r.add_argument("--variants", default=",".join(VARIANTS), help="night walks (VARIANTS), comma-separated")
    s = sub.add_parser("sweep")
    s.add_argument("--routes", type=Path)
    s.add_argument("--results", type=Path, required=True)
    s.add_argument("--windows", help="e.g. 0,0;8,2 (default: the grid)")
    s.add_argument("--real", action="store_true", help="also the shared real pairs")
    s.add_argument("--only", help="only the pairs whose name contains this text")
    s.add_argument("--cache", type=Path, help="a folder for the difference matrices (reused by later runs)")
    m = sub.add_parser("summary")
    m.add_argument("results", type=Path)
    t = sub.add_parser("table", help="a markdown table of the rendered walks")
    t.add_argument("results", type=Path)
    t.add_argument("--camera", default="forward", choices=("forward", "panoramic"))
    t.add_argument("--metric", default="f1", choices=("f1", "r100", "top1"))
    args = parser.parse_args(argv)
    if args.command == "render":
        variants = args.variants.split(",")
        unknown = sorted(set(variants) - set(VARIANTS))
        if unknown:
            parser.error(f"--variants: unknown {unknown}; known: {list(VARIANTS)}")
        render(args.out, [int(v) for v in args.seeds.split(",")], args.length, args.threads, variants)
    elif args.command == "sweep":
        windows = (
            WINDOWS if not args.windows else [tuple(int(v) for v in w.split(",")) for w in args.windows.split(";")]
        )
        sweep(args.routes, args.results, windows, args.real, args.only, args.cache)  # type: ignore[arg-type]
    elif args.command == "table":
        table(args.results, args.camera, args.metric)
    else:
        summary(args.results)


if __name__ == "__main__":
    main(sys.argv[1:])
