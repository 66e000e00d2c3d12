"""The Bayes filter at lawn scale and in the rooms, judged by its tail (docs/localization.md, lawns).

    python tools/lawn_sweep.py [--cache /tmp/nightloc_lawns] [--seeds 0-4] [--extra pattern,seed7]
                               [--rooms] [--draws 3] [--teach] [--kidnap]
                               [--param name=value ...] [--grid name=v1,v2 ...] [--quiet]

Lawns: ``nightloc synth --world large_garden`` (seeds ``--seeds``; each seed draws the textures,
the drives' wobble and the wheel odometry's noise) plus ``--extra`` lawns: ``seed7`` (another
texture seed) and ``pattern`` (the same lawn mowed in columns along y instead of rows along x, the
night drive another route: ``nightloc synth --world large_garden --pattern columns``). Each is
mapped from its day drive's poses (surveyed; ``--teach`` adds a teach-run map from the day drive's
wheel odometry, the truth moved into its frame) and its night drive is localized with its own
``odometry.csv`` (the filter told what ``nightloc localize`` assumes: the step-scaled wheel noise
for wheel odometry; ``--grid log_distance_per_metre=..`` and ``log_distance_std``,
``log_heading_std``, ``log_heading_per_radian`` replace its terms). Rooms (``--rooms``): the
default dataset's garden and living room night queries against their day maps, with their own
``odometry.csv`` (as the lawns) and map-frame and wheel odometry simulated with noise models 0-3
over ``--draws`` draws.
``--lawn-noise 0,1,3`` adds the lawns' night drives with simulated map-frame odometry of those
Table III models (``nightloc evaluate --odometry map``; one draw each); ``--map-as-wheel`` adds
those steps as wheel odometry of a robot driving along them (heading = the step's direction).

Every row prints, over the frames from the 10th on (``nightloc.localization.tail``): median, p95,
share over 1 m and longest run over 1 m for the filter, the same for the paper's 10-frame
sequences, and the filter's confidently wrong share (frames more than 1 m off with confidence
above 0.9, every frame). ``--kidnap`` carries the robot on each lawn from frame 40 to frame 85 and from 25 to 50
(its odometry saying it did not move) and prints the frames until its error is below 1 m again.

Prepared maps and every frame's rotational table are cached under ``--cache`` (pickles), so a
sweep of filter parameters (``--grid likelihood_gain=2,3,4``: every combination) replays
``Localizer.update_table`` only.
"""

from __future__ import annotations

import argparse
import dataclasses
import itertools
import pickle
import sys
import time
from pathlib import Path

import numpy as np

import nightloc
from nightloc.localization.evaluation import (
    EvaluationSettings,
    QueryMatches,
    align_to_map,
    map_alignment,
    match_traverse,
    simulated_odometry,
)
from nightloc.localization.tail import TailMetrics, tail_metrics
from nightloc.motion.odometry import NOISE_MODELS, MapDisplacement, RobotMotion, log_noise_model, noise_model
from nightloc.synth import default_dataset, make_dataset

INT_PARAMS = ("heading_bins", "estimate_window", "settle_frames", "hold_frames")
#: Sweep keys that set the noise model the filter is told for a lawn's own log (not filter parameters).
LOG_NOISE_KEYS = ("log_distance_std", "log_heading_std", "log_distance_per_metre", "log_heading_per_radian")
#: The night frames a kidnapped robot is carried between (0-based): it sees frame a, then b.
KIDNAPS = ((40, 85), (25, 50))


def emit(line: str = "") -> None:
    """One line of the report on stdout."""
    sys.stdout.write(line + "\n")
    sys.stdout.flush()


def _parse_ints(text: str) -> list[int]:
    out: list[int] = []
    for part in text.split(","):
        lo, _, hi = part.partition("-")
        out.extend(range(int(lo), int(hi or lo) + 1))
    return out


def _value(name: str, text: str) -> float | int:
    return int(text) if name in INT_PARAMS else float(text)


class Case:
    """One map and one night traverse, matched once: tables, odometry, truth."""

    def __init__(self, name: str, ref_map: nightloc.ReferenceMap, matches: QueryMatches, kind: str):
        self.name, self.ref_map, self.matches, self.kind = name, ref_map, matches, kind


def _cached(path: Path, build):
    if path.exists():
        with path.open("rb") as stream:
            return pickle.load(stream)
    value = build()
    tmp = path.with_suffix(".tmp")
    with tmp.open("wb") as stream:
        pickle.dump(value, stream, protocol=pickle.HIGHEST_PROTOCOL)
    tmp.replace(path)
    return value


def lawn_folders(cache: Path, label: str) -> dict[str, Path]:
    """The rendered lawn ``label`` (``seed<S>`` or ``pattern``) under ``cache``."""
    seed = 0 if label == "pattern" else int(label.removeprefix("seed"))
    out = cache / f"large_garden-{label}"
    if not (out / "dataset.json").exists():
        options = {"pattern": "columns"} if label == "pattern" else {}
        make_dataset("large_garden", out, seed=seed, overwrite=True, **options)
    return {"day_reference": out / "day_reference", "night_query": out / "night_query"}


def lawn_cases(cache: Path, labels: list[str], teach: bool) -> list[Case]:
    """Per lawn its surveyed map (and with ``teach`` its teach-run map) and matched night drive."""
    cases = []
    for label in labels:
        folders = lawn_folders(cache, label)
        maps = [("surveyed", lambda f=folders: nightloc.ReferenceMap.build(f["day_reference"]))]
        if teach:
            maps.append(("teach", lambda f=folders: _teach_map(f["day_reference"])))
        for kind, build in maps:
            ref_map = _cached(cache / f"{label}-{kind}.map.pkl", build)

            def matched(ref_map=ref_map, folders=folders):
                return match_traverse(ref_map, folders["night_query"], tables=True, odometry=True)

            matches = _cached(cache / f"{label}-{kind}.matches.pkl", matched)
            alignment = map_alignment(ref_map, folders["day_reference"])
            if alignment is not None:
                matches = align_to_map(matches, alignment[0])
            cases.append(Case(f"lawn {label} {kind}", ref_map, matches, "log"))
    return cases


def _teach_map(day: Path) -> nightloc.ReferenceMap:
    from nightloc.mapping import teach_run

    return teach_run(day, threads=1)[0]


def room_cases(cache: Path) -> list[Case]:
    """The default dataset's garden and living room night queries against their day maps."""
    folders = default_dataset()
    cases = []
    for world in ("garden", "living_room"):
        day, night = folders[world]["day_reference"], folders[world]["night_query"]
        ref_map = _cached(cache / f"{world}.map.pkl", lambda d=day: nightloc.ReferenceMap.build(d))
        matches = _cached(
            cache / f"{world}.log.matches.pkl",
            lambda m=ref_map, q=night: match_traverse(m, q, tables=True, odometry=True),
        )
        cases.append(Case(world.replace("_", " "), ref_map, matches, "sim"))
    return cases


def _errors(estimates, positions: np.ndarray) -> np.ndarray:
    xy = np.array([[e.x, e.y] for e in estimates])
    return np.hypot(*(xy - positions).T)


def run_filter(case: Case, odometry: list, noise, overrides: dict, order: list[int] | None = None):
    """The filter's errors and confidences over the case's frames (in ``order``)."""
    if noise == "log":
        noise = log_noise(overrides, odometry)
    params = {k: v for k, v in overrides.items() if k not in LOG_NOISE_KEYS}
    loc = nightloc.Localizer(case.ref_map, odometry_noise=noise, **params)
    frames = order if order is not None else range(len(odometry))
    estimates = [loc.update_table(case.matches.tables[i], odometry[k]) for k, i in enumerate(frames)]
    positions = case.matches.positions[list(frames)]
    return _errors(estimates, positions), np.array([e.confidence for e in estimates])


def log_noise(overrides: dict, odometry: list):
    """The noise the filter is told for a log's own odometry: what ``nightloc localize`` assumes
    (:func:`~nightloc.motion.odometry.log_noise_model`), its terms replaced by the sweep's
    ``log_distance_std``, ``log_heading_std``, ``log_distance_per_metre``, ``log_heading_per_radian``."""
    base = noise_model(log_noise_model(odometry))
    changes = {k.removeprefix("log_"): float(v) for k, v in overrides.items() if k in LOG_NOISE_KEYS}
    return dataclasses.replace(base, **changes) if changes else base


def run_paper(case: Case, odometry: list) -> np.ndarray:
    loc = nightloc.Localizer(case.ref_map, method="paper", seq_len=10)
    estimates = [loc.update_match(r, odometry[i]) for i, r in enumerate(case.matches.results)]
    return _errors(estimates, case.matches.positions)


def _tail_cells(tail: TailMetrics) -> str:
    return f"{tail.median_m:.2f} | {tail.p95_m:.2f} | {100 * tail.share_over_1m:.1f} % | {tail.longest_run_over_1m}"


def as_wheel(steps: list) -> list:
    """Map-frame steps as wheel odometry of a robot that drives along its steps: forward the step's
    length, turn the change of the step's direction (none across a standing step)."""
    out: list = [None]
    previous = None
    for step in steps[1:]:
        dx, dy = (step.dx, step.dy) if isinstance(step, MapDisplacement) else (float(step[0]), float(step[1]))
        length = float(np.hypot(dx, dy))
        direction = float(np.arctan2(dy, dx)) if length > 1e-9 else previous
        turn = (
            0.0
            if previous is None or direction is None
            else float(np.remainder(direction - previous + np.pi, 2 * np.pi) - np.pi)
        )
        out.append(RobotMotion(length, 0.0, turn))
        previous = direction
    return out


def runs_of(case: Case, draws: int, lawn_noise: tuple[int, ...] = (), map_as_wheel: bool = False):
    """``(label, odometry, noise)`` of every run of the case: its own log (the noise ``"log"``:
    what :func:`log_noise` says), a lawn's simulated map-frame odometry of the ``lawn_noise``
    Table III models (one draw each), a room's simulated map-frame and wheel odometry of every
    model over ``draws`` draws (the filter told the run's model)."""
    if case.kind == "log":
        yield "log", [None, *case.matches.odometry[1:]], "log"
        settings = EvaluationSettings(odometry="map")
        for model in lawn_noise:
            steps = simulated_odometry(case.matches, model, 0, settings)
            yield f"map {model}", steps, model
            if map_as_wheel:  # a step's direction noise becomes turn noise on both of its turns
                table = NOISE_MODELS[model]
                noise = dataclasses.replace(table, heading_std=float(np.sqrt(2)) * table.heading_std)
                yield f"map {model} as wheel", as_wheel(steps), noise
        return
    yield "log", [None, *case.matches.odometry[1:]], "log"
    for kind in ("map", "robot"):
        settings = EvaluationSettings(odometry=kind, repeats=draws)
        for model in (0, 1, 2, 3):
            for repeat in range(settings.repeats_of(model)):
                yield f"{kind} {model}", simulated_odometry(case.matches, model, repeat, settings), model


def sweep(
    cases: list[Case],
    draws: int,
    overrides: dict,
    quiet: bool,
    paper: dict,
    lawn_noise: tuple[int, ...] = (),
    map_as_wheel: bool = False,
) -> dict:
    """Runs every case; returns per group (lawn / room label) the filter's runs and counts."""
    groups: dict[str, dict] = {}
    for case in cases:
        per_label: dict[str, dict] = {}
        for label, odometry, noise in runs_of(case, draws, lawn_noise, map_as_wheel):
            errors, confidence = run_filter(case, odometry, noise, overrides)
            key = (case.name, label, len(per_label.get(label, {}).get("filter", [])))
            if key not in paper:
                paper[key] = run_paper(case, odometry)
            entry = per_label.setdefault(label, {"filter": [], "paper": [], "wrong": 0, "frames": 0})
            entry["filter"].append(errors)
            entry["paper"].append(paper[key])
            entry["wrong"] += int(np.sum((errors > 1.0) & (confidence > 0.9)))
            entry["frames"] += errors.size
        for label, entry in per_label.items():
            group = f"lawns {'' if label == 'log' else label}".strip() if case.kind == "log" else f"{case.name} {label}"
            g = groups.setdefault(group, {"filter": [], "paper": [], "wrong": 0, "frames": 0})
            for name in ("filter", "paper"):
                g[name].extend(entry[name])
            g["wrong"] += entry["wrong"]
            g["frames"] += entry["frames"]
            if not quiet:
                emit(
                    f"| {case.name} | {label} | {_tail_cells(tail_metrics(entry['filter']))} | "
                    f"{_tail_cells(tail_metrics(entry['paper']))} | {entry['wrong'] / entry['frames']:.1%} |"
                )
    return groups


def kidnaps(cases: list[Case], overrides: dict) -> list[tuple[str, int]]:
    """Frames after the kidnapping until the error is below 1 m (-1: never), per lawn and case."""
    out = []
    for case, (jump_from, jump_to) in itertools.product(cases, KIDNAPS):
        if case.kind != "log":
            continue
        n = len(case.matches.results)
        order = [*range(jump_from), *range(jump_to, n)]
        log = [None, *case.matches.odometry[1:]]
        odometry = [log[i] for i in order]
        odometry[jump_from] = RobotMotion(0.0) if isinstance(log[1], RobotMotion) else MapDisplacement(0.0, 0.0)
        errors, _ = run_filter(case, odometry, "log", overrides, order)
        after = errors[jump_from:] < 1.0
        out.append((case.name, int(np.argmax(after)) if after.any() else -1))
    return out


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--cache", type=Path, default=Path("/tmp/nightloc_lawns"), help="cache folder")
    parser.add_argument("--seeds", default="0-4", help="large_garden seeds (default 0-4)")
    parser.add_argument("--extra", default="", help="more lawns: pattern, seed7 (comma-separated)")
    parser.add_argument("--rooms", action="store_true", help="also the garden and the living room")
    parser.add_argument("--draws", type=int, default=3, help="noise draws per model in the rooms (default 3)")
    parser.add_argument("--teach", action="store_true", help="also a teach-run map per lawn")
    parser.add_argument("--kidnap", action="store_true", help="kidnap the robot on each lawn")
    parser.add_argument(
        "--lawn-noise", default="", help="also simulated map-frame odometry on the lawns, Table III models (e.g. 0,1,3)"
    )
    parser.add_argument(
        "--map-as-wheel",
        action="store_true",
        help="with --lawn-noise: also the map-frame steps as wheel odometry (heading = the step's direction)",
    )
    parser.add_argument("--param", action="append", default=[], help="filter parameter, e.g. likelihood_gain=3.5")
    parser.add_argument("--grid", action="append", default=[], help="sweep a parameter, e.g. likelihood_gain=2,3,4")
    parser.add_argument("--quiet", action="store_true", help="only the groups' summary lines")
    args = parser.parse_args()
    args.cache.mkdir(parents=True, exist_ok=True)
    base = {k: _value(k, v) for k, v in (p.split("=", 1) for p in args.param)}
    labels = [f"seed{s}" for s in _parse_ints(args.seeds)] if args.seeds else []
    labels += [x for x in args.extra.split(",") if x]
    cases = lawn_cases(args.cache, labels, args.teach)
    if args.rooms:
        cases += room_cases(args.cache)
    axes = [(k, [_value(k, v) for v in vs.split(",")]) for k, vs in (g.split("=", 1) for g in args.grid)]
    paper: dict = {}
    for combo in itertools.product(*(values for _, values in axes)) if axes else [()]:
        overrides = {**base, **{name: value for (name, _), value in zip(axes, combo)}}
        start = time.perf_counter()
        emit(f"\n### {overrides or 'defaults'}\n")
        if not args.quiet:
            emit(
                "| case | odometry | median | p95 | > 1 m | longest | paper: median | p95 | > 1 m | longest "
                "| conf. wrong |"
            )
            emit("| --- | --- | --- | --- | --- | --- | --- | --- | --- | --- | --- |")
        lawn_noise = tuple(_parse_ints(args.lawn_noise)) if args.lawn_noise else ()
        groups = sweep(cases, args.draws, overrides, args.quiet, paper, lawn_noise, args.map_as_wheel)
        emit("\n| group | median | p95 | > 1 m | longest | paper: median | p95 | > 1 m | longest | conf. wrong |")
        emit("| --- | --- | --- | --- | --- | --- | --- | --- | --- | --- |")
        for name, g in groups.items():
            emit(
                f"| {name} | {_tail_cells(tail_metrics(g['filter']))} | {_tail_cells(tail_metrics(g['paper']))} | "
                f"{g['wrong'] / g['frames']:.2%} |"
            )
        wrong = sum(g["wrong"] for g in groups.values())
        frames = sum(g["frames"] for g in groups.values())
        emit(f"\nconfidently wrong over everything: {wrong / max(frames, 1):.2%} ({wrong} of {frames} frames)")
        if args.kidnap:
            frames = [k for _, k in kidnaps(cases, overrides)]
            worst = "never" if -1 in frames else max(frames)
            emit(f"kidnapped (frames until < 1 m): {' '.join(map(str, frames))}; worst {worst}")
        emit(f"({time.perf_counter() - start:.0f} s)")


if __name__ == "__main__":
    main()
