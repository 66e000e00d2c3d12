"""Route mode when the query's speed changes, with and without odometry (docs/route_mode.md):
the sweep that chose the filter's motion defaults, and the target figures.

    python tools/route_speed_sweep.py [--data ../shared/data] [--cache DIR] [--draws 3]
        [--cases gp,nordland,synthetic] [--set filter_speed_change=0.08 ...]
        [--grid filter_speed_tau=4,8,inf --grid filter_speed_change=0.04,0.08]

Query speed cases: query frame k is the query traverse's frame at
``round(p_k)`` of a frame-aligned pair, ``p_{k+1} = p_k + 1 + a sin(2 pi k / 50 + phi)``, ``a =
0.3`` without odometry and ``0.45`` with, ``phi`` in {0, 2.1, 4.2}; with odometry the query's
``forward`` is the true advance in reference frames times ``1 + N(0, 0.05)`` (``--draws`` noise
draws per phase), the reference's 1 per frame. A query frame's row of the enhanced difference
matrix depends on that frame alone, so the resampled query's matrix is the original's rows in the
new order (exactly what ``nightloc route`` computes on the resampled folder); so are its texture
weights. The pairs: Gardens Point day_right -> night_right and Nordland summer -> winter (from
``--data``, skipped when absent), and a synthetic route rendered with :mod:`nightloc.synth` (the
garden's lawn-mower path, a day reference every 0.1 m, a night query along it at a speed
``1 + 0.5 sin(2 pi k / 40 + phi)`` from a continuous position, and the same with a 20-frame stop
and an 8-frame reverse at half speed; 180-degree forward crops of the panoramas).

Each configuration (``--set`` fields of ``[route]`` on top of the defaults, one per ``--grid``
combination) prints one markdown row per case: best F1 / recall at 100 % precision, median over
the phases (and draws) with the range, ground truth +-2 frames.

``--ratios 0.3,0.45,...`` runs the speed-ratio study instead (the speed check's sweep): queries
at a constant ratio of reference frames per query frame -- the real pairs resampled, the
synthetic route rendered at that speed -- and the traverse pairs given with ``--pair-dir
NAME=REFERENCE,QUERY`` (e.g. the garden's day reference and its night re-drive, the rendered
creek; ground truth by position, +-3 m). Each prints one row: the ratio the speed check measures
without odometry, whether it warns for the default model, and best F1 / recall at 100 % precision
of the default speed model, the window model, the speed model with wider planes (0.25-4; also
with a looser prior) and the check's advice (the window model over 0.8-1.2 times the measured
ratio).
"""

from __future__ import annotations

import argparse
import dataclasses
import itertools
import math
import sys
import zlib
from pathlib import Path

import numpy as np

import nightloc
from nightloc import route

PHASES = (0.0, 2.1, 4.2)
TOLERANCE = 2
SYNTH_SPACING = 0.1  # metres between reference frames of the synthetic route


def emit(line: str = "") -> None:
    """One line of the report on stdout."""
    sys.stdout.write(line + "\n")
    sys.stdout.flush()


# --------------------------------------------------------------------------------------------
# the difference matrices


def enhanced_pair(refs: np.ndarray, queries: np.ndarray, params: route.RouteParams) -> tuple[np.ndarray, np.ndarray]:
    """(enhanced difference matrix (queries x refs), texture weights) of prepared images."""
    difference = route.route_difference_matrix(queries, refs, params)
    enhanced = route.enhance_contrast(difference, params, offset=params.search_offset)
    return enhanced, route.texture_weights(queries, params.filter_min_texture)


def real_pair(data: Path, reference: str, query: str, params: route.RouteParams, cache: Path | None):
    """The enhanced matrix and weights of a frame-aligned real pair (cached by shape and preparation)."""
    columns, rows = params.effective_shift_window
    key = f"{reference}-{query}-{columns}x{rows}".replace("/", "_")
    stored = cache / f"{key}.npz" if cache is not None else None
    if stored is not None and stored.exists():
        with np.load(stored) as saved:
            return saved["enhanced"], saved["weights"]
    preparer = route.RoutePreparer(params)
    refs = preparer(nightloc.load_traverse(data / reference))
    queries = preparer(nightloc.load_traverse(data / query))
    enhanced, weights = enhanced_pair(refs, queries, params)
    if stored is not None:
        stored.parent.mkdir(parents=True, exist_ok=True)
        np.savez(stored, enhanced=enhanced, weights=weights)
    return enhanced, weights


def sinusoidal_speed_positions(n_refs: int, amplitude: float, phase: float) -> np.ndarray:
    """p_0 = 0, p_{k+1} = p_k + 1 + a sin(2 pi k / 50 + phase), while round(p) is a reference."""
    positions = [0.0]
    k = 0
    while True:
        following = positions[-1] + 1.0 + amplitude * math.sin(2 * math.pi * k / 50 + phase)
        k += 1
        if round(following) > n_refs - 1:
            return np.array(positions)
        positions.append(following)


# --------------------------------------------------------------------------------------------
# the synthetic route


def _path(spacing: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Arc lengths, points and headings of the garden's lawn-mower path every ``spacing`` metres."""
    from nightloc.synth.paths import GARDEN_ROW_X, GARDEN_ROW_Y

    corners = []
    for row, y in enumerate(GARDEN_ROW_Y):
        ends = (GARDEN_ROW_X[0], GARDEN_ROW_X[-1]) if row % 2 == 0 else (GARDEN_ROW_X[-1], GARDEN_ROW_X[0])
        corners += [(ends[0], y), (ends[1], y)]
    corners = np.array(corners)
    segments = np.diff(corners, axis=0)
    lengths = np.hypot(segments[:, 0], segments[:, 1])
    cumulative = np.r_[0.0, np.cumsum(lengths)]
    return cumulative, corners, segments


def path_pose(arc: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Points (n, 2) and headings (n,) at arc lengths ``arc`` along the synthetic route."""
    cumulative, corners, segments = _path(SYNTH_SPACING)
    arc = np.clip(arc, 0.0, cumulative[-1])
    index = np.clip(np.searchsorted(cumulative, arc, side="right") - 1, 0, len(segments) - 1)
    t = (arc - cumulative[index]) / np.hypot(segments[index, 0], segments[index, 1])
    return corners[index] + segments[index] * t[:, None], np.arctan2(segments[index, 1], segments[index, 0])


def forward_crop(panorama: np.ndarray) -> np.ndarray:
    """The 180 degrees ahead of a panorama (column 0 = heading, azimuth decreasing to the right)."""
    width = panorama.shape[1]
    return np.roll(panorama, width // 4, axis=1)[:, : width // 2]


def synthetic_speeds(kind: str, phase: float, frames: int) -> np.ndarray:
    """Per-frame advances (reference frames) of a synthetic query: ``"constant"``: 1; ``"speed"``: 1 + 0.5 sin(2 pi k
    / 40 + phase); ``"stop"``: the same with 20 frames at 0 from frame 90; ``"reverse"``: with 8
    frames at -0.5 from frame 90."""
    k = np.arange(frames)
    speeds = 1.0 + 0.5 * np.sin(2 * np.pi * k / 40 + phase)
    if kind == "constant":
        speeds[:] = 1.0
    elif kind == "stop":
        speeds[90:110] = 0.0
    elif kind == "reverse":
        speeds[90:98] = -0.5
    return speeds


class SyntheticRoute:
    """The garden's lawn-mower path by day (references) and night (queries), rendered on demand
    and cached in ``cache`` (prepared 48 x 24 images)."""

    def __init__(self, params: route.RouteParams, cache: Path | None, seed: int = 0):
        from nightloc.synth.dataset import SynthScene

        self.params = params
        self.cache = cache
        self.scene = SynthScene("garden", seed)
        self.preparer = route.RoutePreparer(params)
        self.length = _path(SYNTH_SPACING)[0][-1]
        self.n_refs = int(self.length / SYNTH_SPACING) + 1
        self.refs = self._images("day", np.arange(self.n_refs) * SYNTH_SPACING, "reference")

    def _images(self, condition: str, arc: np.ndarray, name: str) -> np.ndarray:
        stored = self.cache / f"synthetic_{name}.npy" if self.cache is not None else None
        if stored is not None and stored.exists():
            return np.load(stored)
        points, headings = path_pose(arc)
        rng = np.random.default_rng(zlib.crc32(name.encode()))  # str hash() differs per process
        # a driven robot wanders a little sideways and in heading
        side = np.convolve(rng.normal(0, 0.03, len(arc) + 8), np.ones(9) / 3, mode="valid")[: len(arc)]
        points = points + side[:, None] * np.stack([-np.sin(headings), np.cos(headings)], axis=1)
        headings = headings + rng.normal(0, np.radians(3.0), len(arc))
        frames = []
        for i, ((x, y), heading) in enumerate(zip(points, headings)):
            noise = self.scene.frame_rng(name, i) if condition == "night" else None
            frames.append(forward_crop(self.scene.frame(condition, float(x), float(y), float(heading), noise)))
        prepared = self.preparer(np.stack(frames))
        if stored is not None:
            stored.parent.mkdir(parents=True, exist_ok=True)
            np.save(stored, prepared)
        return prepared

    def case(self, kind: str, phase: float) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """(enhanced matrix, weights, true reference per query, true advance per query) of one
        synthetic query (positions from 2 frames in, until the route ends)."""
        speeds = synthetic_speeds(kind, phase, 4 * self.n_refs)
        positions = 2.0 + np.r_[0.0, np.cumsum(speeds)]
        positions = positions[: int(np.argmax(positions > self.n_refs - 1.5))]
        queries = self._images("night", positions * SYNTH_SPACING, f"{kind}-{phase}")
        enhanced, weights = enhanced_pair(self.refs, queries, self.params)
        return enhanced, weights, np.rint(positions).astype(np.int64), np.diff(positions, prepend=positions[0])


# --------------------------------------------------------------------------------------------
# evaluation


def evaluate(params: route.RouteParams, enhanced, weights, truth, advances=None, distances=None) -> tuple:
    """(best F1, recall at 100 % precision) of the filter on rows ``enhanced`` with true refs ``truth``."""
    refs, confidence, _ = route.route_filter(
        np.ascontiguousarray(enhanced), params, weights, advances=advances, reference_distances=distances
    )
    truth_ = route.GroundTruth.from_frames(len(truth), enhanced.shape[1], TOLERANCE, truth)
    result = route.evaluate_matches(refs, 1.0 - confidence, truth_)
    return result.best_f1, result.recall_at_100


def cell(values: list) -> str:
    """``median [min-max]`` of (F1, R@100P) pairs."""
    array = np.array(values)
    med = np.median(array, axis=0)
    if len(array) == 1:
        return f"{med[0]:.3f} / {med[1]:.3f}"
    return (
        f"{med[0]:.3f} / {med[1]:.3f} [{array[:, 0].min():.2f}-{array[:, 0].max():.2f} / "
        f"{array[:, 1].min():.2f}-{array[:, 1].max():.2f}]"
    )


def real_cases(enhanced, weights, draws: int) -> dict:
    """The speed and odometry cases on one frame-aligned pair.

    name -> list of (rows, weights, truth, advances, distances)."""
    n = enhanced.shape[1]
    cases: dict[str, list] = {"constant": [(enhanced, weights, np.arange(len(enhanced)), None, None)]}
    cases["speed 0.7-1.3"] = []
    for phase in PHASES:
        positions = sinusoidal_speed_positions(n, 0.3, phase)
        index = np.rint(positions).astype(np.int64)
        cases["speed 0.7-1.3"].append((enhanced[index], weights[index], index, None, None))
    cases["odometry 0.55-1.45"] = []
    cases["query odometry only 0.55-1.45"] = []
    for phase in PHASES:
        positions = sinusoidal_speed_positions(n, 0.45, phase)
        index = np.rint(positions).astype(np.int64)
        true_advance = np.diff(positions, prepend=positions[0])
        cases["query odometry only 0.55-1.45"].append((enhanced[index], weights[index], index, None, None))
        for draw in range(draws):
            rng = np.random.default_rng([int(phase * 10), draw])
            advance = true_advance * (1.0 + rng.normal(0.0, 0.05, len(positions)))
            cases["odometry 0.55-1.45"].append((enhanced[index], weights[index], index, advance, np.arange(float(n))))
    return cases


def synthetic_cases(synthetic: SyntheticRoute, draws: int) -> dict:
    """The synthetic route's cases: 0.5-1.5x, a stop, a reverse, each with and without odometry."""
    cases: dict[str, list] = {}
    distances = np.arange(float(synthetic.n_refs))
    enhanced, weights, truth, _ = synthetic.case("constant", 0.0)
    cases["synthetic constant"] = [(enhanced, weights, truth, None, None)]
    for kind in ("speed", "stop", "reverse"):
        cases[f"synthetic {kind}"] = []
        cases[f"synthetic {kind}, odometry"] = []
        for phase in PHASES:
            enhanced, weights, truth, true_advance = synthetic.case(kind, phase)
            cases[f"synthetic {kind}"].append((enhanced, weights, truth, None, None))
            for draw in range(draws):
                rng = np.random.default_rng([int(phase * 10), draw, 7])
                advance = true_advance * (1.0 + rng.normal(0.0, 0.05, len(true_advance)))
                cases[f"synthetic {kind}, odometry"].append((enhanced, weights, truth, advance, distances))
    return cases


# --------------------------------------------------------------------------------------------
# the speed-ratio study

#: The study's configurations: name -> [route] changes (the advice is added per case).
RATIO_CONFIGS = {
    "default (speed model)": {},
    "window model": {"filter_motion": "window"},
    "speed planes 0.25-4": {"filter_speed_min": 0.25, "filter_speed_max": 4.0},
    "speed planes 0.25-4, loose prior": {
        "filter_speed_min": 0.25,
        "filter_speed_max": 4.0,
        "filter_speed_change": 0.1,
        "filter_speed_tau": 6.0,
    },
}


def evaluate_truth(params: route.RouteParams, enhanced, weights, truth: route.GroundTruth) -> tuple:
    """(best F1, recall at 100 % precision) of the filter against a ground truth."""
    refs, confidence, _ = route.route_filter(np.ascontiguousarray(enhanced), params, weights)
    result = route.evaluate_matches(refs, 1.0 - confidence, truth)
    return result.best_f1, result.recall_at_100


def ratio_row(name: str, base: route.RouteParams, enhanced, weights, truth: route.GroundTruth) -> str:
    """One markdown row of the study: measured ratio, the default's warning, each configuration."""
    from nightloc.route.speed_check import StretchSampler, check_speed

    sampler = StretchSampler(len(enhanced))
    sampler.take(0, enhanced, copy=False)
    check = check_speed(base, base.filter_motion, sampler.rows())
    measured = "-" if check.ratio is None else f"{check.ratio.median:.2f}"
    cells = [name, measured, "no" if check.fits else "**yes**"]
    for changes in RATIO_CONFIGS.values():
        f1, r100 = evaluate_truth(dataclasses.replace(base, **changes), enhanced, weights, truth)
        cells.append(f"{f1:.3f} / {r100:.3f}")
    if check.ratio is not None:
        low, high = 0.8 * check.ratio.median, 1.2 * check.ratio.median
        advised = dataclasses.replace(base, filter_motion="window", vmin=low, vmax=high)
        f1, r100 = evaluate_truth(advised, enhanced, weights, truth)
        cells.append(f"{f1:.3f} / {r100:.3f}")
    else:
        cells.append("-")
    return "| " + " | ".join(cells) + " |"


def traverse_case(reference: Path, query: Path, params: route.RouteParams) -> tuple:
    """(enhanced, weights, ground truth by position +-3 m) of two traverse folders with poses."""
    ref_traverse, query_traverse = nightloc.load_traverse(reference), nightloc.load_traverse(query)
    preparer = route.RoutePreparer(params)
    enhanced, weights = enhanced_pair(preparer(ref_traverse), preparer(query_traverse), params)
    truth = route.GroundTruth.from_positions(query_traverse.positions, ref_traverse.positions, 3.0)
    return enhanced, weights, truth


def ratio_study(args, base: route.RouteParams, cache: Path | None, data: Path) -> None:
    ratios = [float(v) for v in args.ratios.split(",")]
    emit(
        "| case | measured ratio | default warns | "
        + " | ".join(RATIO_CONFIGS)
        + " | advised: window 0.8-1.2 x measured |"
    )
    emit("| --- " * (4 + len(RATIO_CONFIGS)) + "|")
    for item in args.pair_dir:
        name, folders = item.split("=", 1)
        reference, query = folders.split(",")
        emit(ratio_row(name, base, *traverse_case(Path(reference), Path(query), base)))
    wanted = args.cases.split(",")
    for name, reference, query in (
        ("gp", "gardens_point/day_right", "gardens_point/night_right"),
        ("nordland", "nordland/summer", "nordland/winter"),
    ):
        if name not in wanted or not (data / reference).is_dir():
            continue
        enhanced, weights = real_pair(data, reference, query, base, cache)
        n = enhanced.shape[1]
        for ratio in ratios:
            index = np.rint(np.arange(0.0, n - 1, ratio)).astype(np.int64)
            truth = route.GroundTruth.from_frames(len(index), n, TOLERANCE, index)
            emit(ratio_row(f"{name} x {ratio:g}", base, enhanced[index], weights[index], truth))
    if "synthetic" in wanted:
        synthetic = SyntheticRoute(base, cache)
        for ratio in ratios:
            positions = np.arange(2.0, synthetic.n_refs - 1.5, ratio)
            queries = synthetic._images("night", positions * SYNTH_SPACING, f"ratio-{ratio:g}")
            enhanced, weights = enhanced_pair(synthetic.refs, queries, base)
            truth_refs = np.rint(positions).astype(np.int64)
            truth = route.GroundTruth.from_frames(len(positions), synthetic.n_refs, TOLERANCE, truth_refs)
            emit(ratio_row(f"synthetic x {ratio:g}", base, enhanced, weights, truth))


def parse_value(text: str) -> object:
    """A ``--set`` / ``--grid`` value: int, float (inf), a tuple ``8:2`` or a string."""
    if ":" in text:
        return tuple(parse_value(part) for part in text.split(":"))
    for convert in (int, float):
        try:
            return convert(text)
        except ValueError:
            pass
    return text


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--data", default="../shared/data", help="the shared real data (default ../shared/data)")
    parser.add_argument("--cache", help="folder for the matrices and rendered frames (default: none)")
    parser.add_argument("--draws", type=int, default=3, help="odometry noise draws per phase (default 3)")
    parser.add_argument("--cases", default="gp,nordland,synthetic", help="pairs to run (default all three)")
    parser.add_argument(
        "--pair",
        action="append",
        default=[],
        help="NAME=FILE.npz: a frame-aligned pair's saved enhanced matrix and weights",
    )
    parser.add_argument("--only", help="comma-separated words: run the cases whose name holds one")
    parser.add_argument("--set", action="append", default=[], help="FIELD=VALUE of [route] for every row")
    parser.add_argument("--grid", action="append", default=[], help="FIELD=V1,V2,... swept (product of all grids)")
    parser.add_argument("--ratios", help="run the speed-ratio study at these constant ratios (e.g. 0.3,0.45,1,2)")
    parser.add_argument(
        "--pair-dir", action="append", default=[], help="NAME=REFERENCE,QUERY traverse folders with poses (study)"
    )
    args = parser.parse_args()
    base = route.RouteParams(**{k: parse_value(v) for k, v in (item.split("=", 1) for item in args.set)})
    cache = Path(args.cache) if args.cache else None
    data = Path(args.data)
    if args.ratios:
        ratio_study(args, base, cache, data)
        return
    pairs: dict[str, dict] = {}
    wanted = args.cases.split(",")
    for name, reference, query in (
        ("gp", "gardens_point/day_right", "gardens_point/night_right"),
        ("nordland", "nordland/summer", "nordland/winter"),
    ):
        if name in wanted and (data / reference).is_dir() and (data / query).is_dir():
            pairs[name] = real_cases(*real_pair(data, reference, query, base, cache), args.draws)
        elif name in wanted:
            emit(f"({name}: {data / reference} or {data / query} missing, skipped)")
    for item in args.pair:
        name, file = item.split("=", 1)
        with np.load(file) as saved:
            pairs[name] = real_cases(saved["enhanced"], saved["weights"], args.draws)
    if "synthetic" in wanted:
        pairs["synthetic"] = synthetic_cases(SyntheticRoute(base, cache), args.draws)
    grids = [
        (field, [parse_value(v) for v in values.split(",")]) for field, values in (g.split("=", 1) for g in args.grid)
    ]
    emit("| configuration | pair | case | best F1 / R@100P, median [range] |")
    emit("| --- | --- | --- | --- |")
    for combination in itertools.product(*[values for _, values in grids]) if grids else [()]:
        changes = {field: value for (field, _), value in zip(grids, combination)}
        params = dataclasses.replace(base, **changes) if changes else base
        label = ", ".join(f"{k}={v}" for k, v in changes.items()) or "defaults"
        for pair, cases in pairs.items():
            for case, runs in cases.items():
                if args.only and not any(word in case for word in args.only.split(",")):
                    continue
                scores = [evaluate(params, *run) for run in runs]
                emit(f"| {label} | {pair} | {case} | {cell(scores)} |")


if __name__ == "__main__":
    main()
