"""The Bayes filter's target figures beside the paper's method (docs/localization.md).

    python tools/filter_targets.py [--draws 3] [--cache DIR] [--param likelihood_gain=3.5 ...]
                                   [--figure docs/figures/filter_confidence.png]

On the embedded synthetic world (the demo's data: each world's night query against its day
map), for map-frame and wheel odometry (``RobotMotion``) with noise models 0 and 3, over
``--draws`` noise draws (seeded as ``nightloc evaluate`` does): the median distance error over the
query frames from the 10th on of the filter and of the paper's 10-frame sequences (median over
draws, with the range), the filter's median heading error, the share of all frames whose truth
lies within the filter's ``credible_radius``, and the frames a kidnapped robot (carried metres
away while its odometry says it did not move) takes until its error is below 1 m again.
Then trust over the worlds' full grid (:func:`trust_rows`): every night traverse (the
garden's query and night reference, the living room's query) x map-frame and wheel odometry x
noise models 0-3 x the draws, every frame from the first: the share of frames more than 1 m off
with confidence above 0.9 (confidently wrong), which they are, and the coverage of
``credible_radius``; ``--figure PATH`` draws the confidence against the error
(``nightloc.figures.filter.confidence_figure``, docs/figures/filter_confidence.png).
Prints markdown tables.
"""

from __future__ import annotations

import argparse
import math
import sys

import numpy as np

import nightloc
from nightloc.localization.evaluation import EvaluationSettings, match_traverse, simulated_odometry
from nightloc.localization.tail import tail_metrics
from nightloc.motion.odometry import MapDisplacement, RobotMotion, wrap_angle
from nightloc.synth import default_dataset

FIRST = 10  # errors counted from the 10th query frame on (a 10-frame sequence is full there)
INT_PARAMS = ("heading_bins", "estimate_window", "settle_frames")
#: The night traverses of the full grid of trust, per world.
TRUST_QUERIES = {"garden": ("night_query", "night_reference"), "living_room": ("night_query",)}


def _run_filter(ref_map, tables, odometry, model, overrides):
    loc = nightloc.Localizer(ref_map, odometry_noise=model, **overrides)
    return [loc.update_table(tables[i], odometry[i]) for i in range(len(tables))]


def _run_paper(ref_map, results, odometry):
    loc = nightloc.Localizer(ref_map, method="paper", seq_len=10)
    return [loc.update_match(r, odometry[i]) for i, r in enumerate(results)]


def _errors(estimates, positions):
    xy = np.array([[e.x, e.y] for e in estimates])
    return np.hypot(*(xy - positions).T)


def emit(line: str = "") -> None:
    """One line of the report on stdout."""
    sys.stdout.write(line + "\n")


def _cell(values):
    values = np.asarray(values)
    if values.size == 1:
        return f"{values[0]:.2f}"
    return f"{np.median(values):.2f} ({values.min():.2f}-{values.max():.2f})"


#: Kidnapping cases: (world, query traverse, frame order, the frame where the robot is carried off).
KIDNAPS = (
    ("garden", "night_query", [*range(20), *range(30, 41)], 20),
    ("garden", "night_query", [*range(13), *range(28, 41)], 13),
    ("garden", "night_reference", [*range(20), *range(40, 53)], 20),
    ("garden", "night_reference", [*range(30), *range(5, 25)], 30),
    ("living_room", "night_query", list(range(32)), 16),
)


def filter_rows(folders, draws: int = 3, overrides: dict | None = None) -> list[dict]:
    """One row per world, odometry kind ("robot" or "map") and noise model (0, 3), each over
    ``draws`` draws: the filter's and the paper's median errors from frame 10 on (m), their
    ratio, the filter's median heading error (degrees), per draw which frames had the truth
    within the credible radius (``hits``) and every frame's error (``filter_runs``,
    ``paper_runs``: what :func:`nightloc.localization.tail.tail_metrics` takes)."""
    rows = []
    for world in ("garden", "living_room"):
        ref_map = nightloc.ReferenceMap.build(folders[world]["day_reference"])
        matches = match_traverse(ref_map, folders[world]["night_query"], tables=True)
        for kind in ("robot", "map"):
            settings = EvaluationSettings(odometry=kind, repeats=draws)
            for model in (0, 3):
                row: dict = {"world": world, "kind": kind, "model": model, "filter": [], "paper": [], "ratio": []}
                row.update(heading=[], hits=[], filter_runs=[], paper_runs=[])
                for repeat in range(settings.repeats_of(model)):
                    odometry = simulated_odometry(matches, model, repeat, settings)
                    estimates = _run_filter(ref_map, matches.tables, odometry, model, overrides or {})
                    errors = _errors(estimates, matches.positions)
                    paper_errors = _errors(_run_paper(ref_map, matches.results, odometry), matches.positions)
                    row["filter_runs"].append(errors)
                    row["paper_runs"].append(paper_errors)
                    row["filter"].append(np.median(errors[FIRST - 1 :]))
                    row["paper"].append(np.median(paper_errors[FIRST - 1 :]))
                    row["ratio"].append(row["filter"][-1] / row["paper"][-1])
                    turn = wrap_angle(np.array([e.heading for e in estimates]) - matches.headings)
                    row["heading"].append(math.degrees(np.median(np.abs(turn[FIRST - 1 :]))))
                    row["hits"].append(errors <= np.array([e.credible_radius for e in estimates]))
                rows.append(row)
    return rows


def kidnap_rows(folders, draws: int = 3, overrides: dict | None = None) -> list[dict]:
    """One row per odometry kind and noise model (0, 3): for every case of :data:`KIDNAPS` and
    draw, the frames after the kidnapping until the error is below 1 m (-1: never)."""
    rows = []
    maps: dict = {}
    for kind in ("robot", "map"):
        for model in (0, 3):
            recoveries = []
            for world, query, order, jump in KIDNAPS:
                if world not in maps:
                    maps[world] = nightloc.ReferenceMap.build(folders[world]["day_reference"])
                ref_map = maps[world]
                traverse = nightloc.load_traverse(folders[world][query]).subset(order)
                matches = match_traverse(ref_map, traverse, tables=True)
                settings = EvaluationSettings(odometry=kind, repeats=draws)
                for repeat in range(settings.repeats_of(model)):
                    odometry = simulated_odometry(matches, model, repeat, settings)
                    odometry[jump] = RobotMotion(0.0) if kind == "robot" else MapDisplacement(0.0, 0.0)
                    errors = _errors(
                        _run_filter(ref_map, matches.tables, odometry, model, overrides or {}), matches.positions
                    )
                    after = errors[jump:] < 1.0
                    recoveries.append(int(np.argmax(after)) if after.any() else -1)
            rows.append({"kind": kind, "model": model, "recoveries": recoveries})
    return rows


def trust_rows(folders, draws: int = 3, overrides: dict | None = None) -> dict:
    """Over the full grid of :data:`TRUST_QUERIES` x odometry kind x noise models 0-3 x ``draws``
    draws, every frame: ``runs`` ``{label: (errors, confidences)}`` per world and odometry kind,
    ``wrong`` (where a frame was more than 1 m off with confidence above 0.9) and ``inside``
    (per run, the frames with the truth within the credible radius)."""
    runs: dict = {}
    wrong, inside = [], []
    for world, queries in TRUST_QUERIES.items():
        ref_map = nightloc.ReferenceMap.build(folders[world]["day_reference"])
        for query in queries:
            matches = match_traverse(ref_map, folders[world][query], tables=True)
            for kind in ("robot", "map"):
                settings = EvaluationSettings(odometry=kind, repeats=draws)
                label = f"{world.replace('_', ' ')}, {'wheel' if kind == 'robot' else 'map-frame'} odometry"
                for model in (0, 1, 2, 3):
                    for repeat in range(settings.repeats_of(model)):
                        odometry = simulated_odometry(matches, model, repeat, settings)
                        estimates = _run_filter(ref_map, matches.tables, odometry, model, overrides or {})
                        errors = _errors(estimates, matches.positions)
                        confidence = np.array([e.confidence for e in estimates])
                        old = runs.get(label, (np.zeros(0), np.zeros(0)))
                        runs[label] = (np.r_[old[0], errors], np.r_[old[1], confidence])
                        inside.append(errors <= np.array([e.credible_radius for e in estimates]))
                        for i in np.flatnonzero((errors > 1.0) & (confidence > 0.9)):
                            wrong.append(f"{world} {query}, {_label(kind)}, noise {model}, draw {repeat}: frame {i}")
    return {"runs": runs, "wrong": wrong, "inside": inside}


def _tail(runs) -> str:
    """p95 (m), share over 1 m and longest run over 1 m of the draws, from the 10th frame."""
    tail = tail_metrics(runs, first_frame=FIRST)
    return f"{tail.p95_m:.2f}, {100 * tail.share_over_1m:.0f} %, {tail.longest_run_over_1m}"


def _label(kind: str) -> str:
    return "wheel (RobotMotion)" if kind == "robot" else "map frame"


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--draws", type=int, default=3, help="noise draws per noise model (default 3)")
    parser.add_argument("--cache", default=None, help="folder of the synthetic dataset (default the user cache)")
    parser.add_argument(
        "--param", action="append", default=[], help="filter parameter override, e.g. likelihood_gain=3.5"
    )
    parser.add_argument("--figure", default=None, help="write the confidence-against-error figure here (.png)")
    args = parser.parse_args()
    overrides = {k: int(v) if k in INT_PARAMS else float(v) for k, v in (p.split("=") for p in args.param)}
    folders = default_dataset(cache_dir=args.cache)
    emit(
        "| world | odometry | noise | filter (m) | paper n=10 (m) | filter / paper | filter: p95, > 1 m, longest "
        "| paper: p95, > 1 m, longest | filter heading (deg) | within credible radius |"
    )
    emit("| --- | --- | --- | --- | --- | --- | --- | --- | --- | --- |")
    rows = filter_rows(folders, args.draws, overrides)
    for row in rows:
        inside = np.mean([hits.mean() for hits in row["hits"]])
        emit(
            f"| {row['world']} | {_label(row['kind'])} | {row['model']} | {_cell(row['filter'])} | "
            f"{_cell(row['paper'])} | {_cell(row['ratio'])} | {_tail(row['filter_runs'])} | "
            f"{_tail(row['paper_runs'])} | {_cell(row['heading'])} | {inside:.0%} |"
        )
    share = np.mean(np.concatenate([hits for row in rows for hits in row["hits"]]))
    emit(f"\nAll frames of these runs: the truth within credible_radius in {share:.1%}.\n")

    # kidnapping: frames [0, j) then the traverse continues elsewhere; the odometry says "no motion"
    emit(
        "| odometry | noise | frames after the kidnapping until the error is below 1 m (every case and draw) | worst |"
    )
    emit("| --- | --- | --- | --- |")
    for row in kidnap_rows(folders, args.draws, overrides):
        recoveries = row["recoveries"]
        worst = "never" if -1 in recoveries else max(recoveries)
        emit(f"| {_label(row['kind'])} | {row['model']} | {' '.join(map(str, recoveries))} | {worst} |")

    trust = trust_rows(folders, args.draws, overrides)
    total = sum(errors.size for errors, _ in trust["runs"].values())
    emit(
        f"\nTrust over the full grid ({total} frames: every night traverse, map-frame and wheel odometry, noise "
        f"models 0-3, {args.draws} draws, every frame): more than 1 m off with confidence above 0.9 in "
        f"{len(trust['wrong']) / total:.2%} ({len(trust['wrong'])} frames); the truth within credible_radius in "
        f"{np.concatenate(trust['inside']).mean():.1%}."
    )
    for where in trust["wrong"]:
        emit(f"- {where}")
    if args.figure:
        from nightloc.figures.filter import confidence_figure

        title = f"Bayes filter on the synthetic worlds: noise models 0-3, {args.draws} draws, every frame"
        confidence_figure(trust["runs"], title, args.figure)
        emit(f"\nwrote {args.figure}")


if __name__ == "__main__":
    main()
