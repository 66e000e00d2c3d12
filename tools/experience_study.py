"""Experience maps measured: later nights against the day map alone and against maps that learned
earlier nights (docs/experience_maps.md).

    python tools/experience_study.py [--worlds garden,living_room,lawn0,lawn1,pattern] [--draws 3]
                                     [--cache DIR] [--learn-param novelty=0.5 ...] [--sweep]

Per world (the garden, the living room, the large garden of a seed ``lawnS``, and ``pattern``: the
large garden of seed 0 whose test night drives the diagonals of the columns pattern), two night
re-drives of the day path are rendered (night A at darkness 1, night B at darkness 1.5; each its
own sensor noise, 5 cm sideways and 4-8 degrees of heading wobble) with realistic wheel odometry
(``nightloc.synth.dataset.SYNTH_WHEEL_NOISE``). Night A is localized against the day map and
learned (``localize_night`` + ``learn``, odometry noise model 1, as ``nightloc localize --learn``
does): map M1; night B is localized against M1 and learned: M2. The test nights are routes the
learning nights did not drive: the world's ``night_query`` at darkness 1 (like the learned
nights) and at darkness 2 (unlike them). Each test night is localized against the day map, M1
(the second night) and M2 (the third night) with the filter and the paper's method (10-frame
sequences): map-frame odometry of Table III models 0, 1, 3 and robot-frame (wheel) odometry of
models 0, 1, 3, ``--draws`` noise draws each (seeded as ``nightloc evaluate``), and the drive's
own wheel-odometry log. Errors count from the 10th frame (:mod:`nightloc.localization.tail`);
each cell is the median over draws with the range. ``--sweep`` instead sweeps the trust and
novelty thresholds on the learning nights. Prints markdown tables.
"""

from __future__ import annotations

import argparse
import dataclasses
import pickle
import sys
from pathlib import Path

import numpy as np

import nightloc
from nightloc.experience.learning import LearningParams, learn, localize_night
from nightloc.localization.evaluation import EvaluationSettings, match_traverse, simulated_odometry
from nightloc.localization.tail import TailMetrics, tail_metrics
from nightloc.synth.dataset import SYNTH_WHEEL_NOISE, SynthScene
from nightloc.synth.paths import TraversePlan, plan_traverses, wrap_angle

FIRST = 10
DARKNESS = {"A": 1.0, "B": 1.5}
TEST_DARKNESS = {"like": 1.0, "unlike": 2.0}
#: Large gardens already rendered by tools/lawn_sweep.py (reused when present).
_RENDERED = Path("/tmp/nightloc_lawns")


def emit(line: str = "") -> None:
    sys.stdout.write(line + "\n")
    sys.stdout.flush()


def world_of(label: str) -> tuple[str, int, str]:
    """(world, seed, pattern of the test night) of a label."""
    if label in ("garden", "living_room"):
        return label, 0, "rows"
    if label == "pattern":
        return "large_garden", 0, "columns"
    return "large_garden", int(label.removeprefix("lawn")), "rows"


def redrive(day: TraversePlan, name: str, seed: int) -> TraversePlan:
    """A night drive along the day path: 5 cm sideways, the heading wobbled by 4 degrees."""
    rng = np.random.default_rng([seed, 11, sum(map(ord, name))])
    step = np.gradient(day.positions, axis=0)
    directions = np.arctan2(step[:, 1], step[:, 0])
    offset = rng.normal(0.0, 0.05, len(directions))
    positions = day.positions + offset[:, None] * np.stack([-np.sin(directions), np.cos(directions)], axis=1)
    headings = wrap_angle(day.headings + rng.normal(0.0, np.radians(4.0), len(directions)))
    return TraversePlan(name, "night", positions, headings)


def render(cache: Path, world: str, seed: int, plan: TraversePlan, darkness: float) -> Path:
    """The traverse folder of ``plan`` at ``darkness`` (rendered once into ``cache``)."""
    folder = cache / f"{world}-s{seed}-{plan.name}-d{darkness:g}"
    if (folder / "poses.csv").exists():
        return folder
    rendered = _RENDERED / f"large_garden-{'pattern' if plan.name == 'night_query_columns' else f'seed{seed}'}"
    name = "night_query" if plan.name == "night_query_columns" else plan.name
    if world == "large_garden" and darkness in (0.0, 1.0) and (rendered / name / "poses.csv").exists():
        return rendered / name  # tools/lawn_sweep.py's renders (darkness 1; day frames have none)
    scene = SynthScene(world, seed, darkness)
    odometry = SYNTH_WHEEL_NOISE.simulate(plan.positions, plan.headings, scene.odometry_rng(plan.name))
    nightloc.save_traverse(
        folder,
        scene.render_plan(plan, threads=1),
        plan.positions,
        plan.headings,
        odometry=odometry,
        timestamps=plan.timestamps(),
        overwrite=True,
    )
    return folder


def _cached(path: Path, build):
    if path.exists():
        with path.open("rb") as stream:
            return pickle.load(stream)
    value = build()
    with path.with_suffix(".tmp").open("wb") as stream:
        pickle.dump(value, stream, protocol=pickle.HIGHEST_PROTOCOL)
    path.with_suffix(".tmp").replace(path)
    return value


def learned_nights(ref_map, folder: Path):
    """The night at ``folder`` localized against ``ref_map`` by its wheel odometry (noise model 1)."""
    log = nightloc.load_traverse(folder)
    odometry = nightloc.localization.odometry.traverse_odometry(log)
    return localize_night(
        ref_map,
        (log.read(i) for i in range(len(log))),
        odometry,
        nightloc.Localizer(ref_map, odometry_noise=1),
        names=log.names,
        timestamps=log.timestamps,
        source=str(folder),
    ), log


def errors_of(estimates, positions) -> np.ndarray:
    xy = np.array([[e.x, e.y] for e in estimates])
    return np.hypot(*(xy - positions).T)


def runs(matches, draws: int):
    """(label, odometry, noise model) of every evaluation run."""
    yield "wheel log", [None, *matches.odometry[1:]], 1
    for kind in ("map", "robot"):
        for model in (0, 1, 3):
            settings = EvaluationSettings(odometry=kind, repeats=draws)
            for repeat in range(settings.repeats_of(model)):
                yield f"{kind} {model}", simulated_odometry(matches, model, repeat, settings), model


def evaluate(ref_map, query: Path, draws: int) -> dict[str, dict[str, list]]:
    """Per run label: the filter's and the paper's tails, one per draw."""
    matches = match_traverse(ref_map, query, tables=True, odometry=True)
    out: dict[str, dict[str, list]] = {}
    for label, odometry, model in runs(matches, draws):
        loc = nightloc.Localizer(ref_map, odometry_noise=model)
        filt = [loc.update_table(matches.tables[i], odometry[i]) for i in range(len(odometry))]
        entry = out.setdefault(label, {"filter": [], "paper": []})
        entry["filter"].append(tail_metrics(errors_of(filt, matches.positions)))
        if label.startswith("map"):
            paper = nightloc.Localizer(ref_map, method="paper", seq_len=10)
            est = [paper.update_match(r, odometry[i]) for i, r in enumerate(matches.results)]
            entry["paper"].append(tail_metrics(errors_of(est, matches.positions)))
    return out


#: The tail's numbers in a table's cells, in order: TailMetrics' fields but the count.
TAIL_CELLS = tuple(f.name for f in dataclasses.fields(TailMetrics) if f.name != "n")


def cell(tails, what: str = "median_m") -> str:
    values = np.array([getattr(t, what) for t in tails], dtype=float)
    if what == "share_over_1m":
        values = 100 * values
    if values.size == 1:
        return f"{values[0]:.2f}"
    return f"{np.median(values):.2f} ({values.min():.2f}-{values.max():.2f})"


def tail_cells(tails) -> str:
    return " | ".join(cell(tails, w) for w in TAIL_CELLS)


def study_world(label: str, cache: Path, draws: int, params: LearningParams) -> None:
    world, seed, pattern = world_of(label)
    plans = {p.name: p for p in plan_traverses(world, seed)}
    day_plan = plans["day_reference"]
    test_plan = {p.name: p for p in plan_traverses(world, seed, pattern)}["night_query"]
    day_folder = render(cache, world, seed, day_plan, 0.0)
    day = _cached(cache / f"{world}-s{seed}-day.map.pkl", lambda: nightloc.ReferenceMap.build(day_folder))
    maps = {"day": day}
    current = day
    for night, darkness in DARKNESS.items():
        folder = render(cache, world, seed, redrive(day_plan, f"redrive_{night}", seed), darkness)
        run, log = learned_nights(current, folder)
        errors = errors_of(run.estimates, log.positions)
        current, report = learn(current, run, params)
        emit(
            f"- {label}: night {night} (darkness {darkness:g}, {len(log)} frames, filter median "
            f"{np.median(errors[FIRST:]):.2f} m): {report.line()}"
        )
        maps[f"M{len(maps)}"] = current
        if night == "A":  # learning the same night again
            again_run, _ = learned_nights(current, folder)
            _, again_report = learn(current, again_run, params)
            emit(f"- {label}: night A learned again into M1: {again_report.line()}")
    for condition, darkness in TEST_DARKNESS.items():
        folder = render(
            cache,
            world,
            seed,
            test_plan if pattern == "rows" else dataclasses.replace(test_plan, name="night_query_columns"),
            darkness,
        )
        results = {name: evaluate(m, folder, draws) for name, m in maps.items()}
        emit()
        emit(
            f"#### {label}: test night {test_plan.name} ({pattern}), darkness {darkness:g} "
            f"({condition} the learned nights)"
        )
        emit()
        emit_results(results)


def emit_results(results: dict) -> None:
    """One test night's table: a row per odometry run and map (filter with its tail, the paper's method)."""
    emit("| odometry | map | filter median | p95 | % > 1 m | longest run > 1 m | paper median | paper p95 |")
    emit("| --- | --- | --- | --- | --- | --- | --- | --- |")
    for run_label in results["day"]:
        for name, res in results.items():
            entry = res[run_label]
            paper = entry["paper"]
            paper_cells = f"{cell(paper)} | {cell(paper, 'p95_m')}" if paper else "- | -"
            emit(f"| {run_label} | {name} | {tail_cells(entry['filter'])} | {paper_cells} |")


def sweep(labels: list[str], cache: Path) -> None:
    """Trust and novelty thresholds on night A: growth, the learned frames' true error, and the
    second night (test night like the learned, map-frame noise 3, one draw)."""
    grid = [
        LearningParams(min_confidence=c, max_credible_radius=r, novelty=n)
        for c in (0.5, 0.8, 0.95)
        for r in (0.5, 0.75, 1.0)
        for n in (0.3, 0.5, 0.7, 1.0)
    ]
    emit(
        "| world | min_confidence | max_credible_radius | novelty | trusted | learned frames' error p95 | added | "
        "growth | M1 filter median, map 3 / map 0 |"
    )
    emit("| --- | --- | --- | --- | --- | --- | --- | --- | --- |")
    for label in labels:
        world, seed, pattern = world_of(label)
        plans = {p.name: p for p in plan_traverses(world, seed)}
        day_plan = plans["day_reference"]
        day_folder = render(cache, world, seed, day_plan, 0.0)
        day = _cached(cache / f"{world}-s{seed}-day.map.pkl", lambda f=day_folder: nightloc.ReferenceMap.build(f))
        folder = render(cache, world, seed, redrive(day_plan, "redrive_A", seed), DARKNESS["A"])
        run, log = learned_nights(day, folder)
        errors = errors_of(run.estimates, log.positions)
        test_plan = {p.name: p for p in plan_traverses(world, seed, pattern)}["night_query"]
        test = render(cache, world, seed, test_plan, 1.0)
        matches = match_traverse(day, test, tables=True, odometry=True)
        for params in grid:
            new, report = learn(day, run, params)
            trusted = nightloc.experience.learning.trusted_frames(run.estimates, params)
            p95 = float(np.percentile(errors[trusted], 95)) if trusted.any() else float("nan")
            medians = []
            if new is not day:
                m = match_traverse(new, test, tables=True, odometry=True)
                for model in (3, 0):
                    odo = simulated_odometry(m, model, 0, EvaluationSettings(odometry="map"))
                    loc = nightloc.Localizer(new, odometry_noise=model)
                    est = [loc.update_table(m.tables[i], odo[i]) for i in range(len(odo))]
                    medians.append(f"{tail_metrics(errors_of(est, m.positions)).median_m:.2f}")
            emit(
                f"| {label} | {params.min_confidence} | {params.max_credible_radius} | {params.novelty} | "
                f"{report.trusted}/{report.frames} | {p95:.2f} | {report.appearances}+{report.places} | "
                f"{100 * report.growth:.0f} % | {' / '.join(medians) or '-'} |"
            )
        del matches


def _night_folder(root: Path, kind: str, night: str) -> Path:
    """``night_reference`` / ``night_query`` of ``night`` in a ``nightloc synth --nights`` dataset
    (the usual night, ``lamps``, keeps Table I's names where the world has them)."""
    named = root / f"{kind}_{night}"
    return named if named.exists() or night != "lamps" else root / kind


def study_nights(root: Path, label: str, draws: int, params: LearningParams, tests: list[str]) -> None:
    """``nightloc synth --nights`` data at ``root``: learn the usual night's re-drive of the day path
    (M1), then the moonlit night's (M2); test every night's other path against the day map, M1 and M2."""
    day = nightloc.ReferenceMap.build(root / "day_reference")
    maps = {"day": day}
    current = day
    for night in ("lamps", "moonlit"):
        folder = _night_folder(root, "night_reference", night)
        run, log = learned_nights(current, folder)
        errors = errors_of(run.estimates, log.positions)
        current, report = learn(current, run, params)
        emit(
            f"- {label}: learned {folder.name} ({len(log)} frames, filter median {np.median(errors[FIRST:]):.2f} m): "
            f"{report.line()}"
        )
        maps[f"M{len(maps)}"] = current
        if night == "lamps":
            again_run, _ = learned_nights(current, folder)
            _, again_report = learn(current, again_run, params)
            emit(f"- {label}: {folder.name} learned again into M1: {again_report.line()}")
    for night in tests:
        folder = _night_folder(root, "night_query", night)
        results = {name: evaluate(m, folder, draws) for name, m in maps.items()}
        emit()
        emit(f"#### {label}: test night {folder.name}")
        emit()
        emit_results(results)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--worlds", default="garden,living_room,lawn0", help="comma-separated labels")
    parser.add_argument("--draws", type=int, default=3, help="noise draws per model (default 3)")
    parser.add_argument("--cache", type=Path, default=Path("/tmp/nightloc_experience"), help="render cache")
    parser.add_argument("--learn-param", action="append", default=[], help="a LearningParams field, e.g. novelty=0.4")
    parser.add_argument("--sweep", action="store_true", help="sweep the trust and novelty thresholds instead")
    parser.add_argument(
        "--nights",
        type=Path,
        help="instead: a `nightloc synth --nights` world folder (learn lamps then moonlit; test --tests)",
    )
    parser.add_argument("--tests", default="lamps,moonlit,moon_only,lamps_moved,darker", help="--nights: test nights")
    args = parser.parse_args()
    args.cache.mkdir(parents=True, exist_ok=True)
    labels = [w.strip() for w in args.worlds.split(",") if w.strip()]
    if args.nights is not None:
        tests = [t.strip() for t in args.tests.split(",") if t.strip()]
        study_nights(args.nights, args.nights.name, args.draws, LearningParams(), tests)
        return
    if args.sweep:
        sweep(labels, args.cache)
        return
    fields = {f.name: f.type for f in dataclasses.fields(LearningParams)}
    overrides = {}
    for item in args.learn_param:
        name, value = item.split("=", 1)
        overrides[name] = int(value) if fields[name] in ("int", int) else float(value)
    params = LearningParams(**overrides)
    for label in labels:
        study_world(label, args.cache, args.draws, params)


if __name__ == "__main__":
    main()
