"""The season study (docs/experience_maps.md): ``localize --learn`` night after night over a
rendered season, beside the day map alone (:mod:`nightloc.studies.season`).

    nightloc synth --world garden --season 30 --out /tmp/garden_season
    nice -n 10 python tools/season_study.py /tmp/garden_season --csv docs/season_garden.csv \\
        --figure docs/figures/season_garden.png --log /tmp/garden_season.log &
    python tools/season_study.py /tmp/garden_season --quick          # 6 nights, one draw: minutes

Runs one chain per odometry kind and draw (``--odometry wheel,robot1,robot3``, ``--draws 3``),
writes every night's records as a CSV (``--csv``) and the curves (``--figure``), appends a line per
night and chain to ``--log`` (progress of a long run), and prints the per-night table of the test
drives and the summary beside the issue's targets as markdown. ``--from-csv`` redraws the figure
and the tables from a CSV written before.
"""

from __future__ import annotations

import argparse
import dataclasses
import math
import sys
import time
from pathlib import Path

import numpy as np

from nightloc.experience.learning import LearningParams
from nightloc.figures.season import season_figure
from nightloc.studies.season import NightRecord, SeasonSettings, read_csv, run_season, season_summary, write_csv


def emit(line: str = "") -> None:
    sys.stdout.write(line + "\n")
    sys.stdout.flush()


def spread(values: list[float], digits: int = 2) -> str:
    """The median of draws and their range, e.g. ``0.21 (0.19-0.24)``."""
    finite = [v for v in values if math.isfinite(v)]
    if not finite:
        return "-"
    if len(finite) == 1:
        return f"{finite[0]:.{digits}f}"
    return f"{np.median(finite):.{digits}f} ({min(finite):.{digits}f}-{max(finite):.{digits}f})"


def test_table(records: list[NightRecord]) -> None:
    """Per test night and odometry kind: the day map's and the experience map's median, p95 and
    share over 1 m (the median over draws and their range)."""
    emit("| night | odometry | median: day / experience | p95: day / experience | % > 1 m: day / experience |")
    emit("| --- | --- | --- | --- | --- |")
    tests = [r for r in records if r.drive == "test"]
    for night in sorted({r.night for r in tests}):
        for kind in sorted({r.odometry for r in tests}, key=lambda k: (k != "wheel", k)):
            cells = []
            for field, scale in (("median_m", 1.0), ("p95_m", 1.0), ("share_over_1m", 100.0)):
                day, learned = (
                    [scale * getattr(r, field) for r in tests if (r.night, r.odometry, r.map) == (night, kind, m)]
                    for m in ("day", "learned")
                )
                cells.append(f"{spread(day)} / {spread(learned)}")
            emit(f"| {night} | {kind} | {' | '.join(cells)} |")


def summary_table(records: list[NightRecord]) -> None:
    """The figures beside the issue's targets, per odometry kind (per test night the median over
    the draws; in brackets the worst single draw)."""
    emit(
        "| odometry | worst median - day map's (≤ 0.02 m) | worst p95 - day map's (≤ 0) | worst % > 1 m (≤ 1 %; "
        "the day map's worst) | test nights over 1 % | references after the last night / day map's (≤ 4) | last 10 "
        "nights' new places, net references / places (≤ 5 %) | time per frame / day map's (study; ≤ 2 in "
        "benchmarks/) | wrong additions |"
    )
    emit("| --- | --- | --- | --- | --- | --- | --- | --- | --- |")
    for kind, s in season_summary(records).items():
        growth = s["growth"]
        ratio = [g["references"] / g["day_references"] for g in growth]
        places = [100 * g["last_places_share"] for g in growth]
        net = [100 * g["last_net_share"] for g in growth]
        emit(
            f"| {kind} | {s['median_excess_m']:+.2f} ({s['median_excess_draws_m']:+.2f}) | {s['p95_excess_m']:+.2f} "
            f"({s['p95_excess_draws_m']:+.2f}) | {100 * s['share_over_1m']:.1f} % "
            f"({100 * s['day_worst_share_over_1m']:.1f} %) "
            f"| {', '.join(map(str, s['nights_over_1pct'])) or '-'} | {spread(ratio)} | {spread(places, 1)} %, "
            f"{spread(net, 1)} % | {s['time_ratio']:.2f} | {s['wrong']} |"
        )


def learning_params(items: list[str]) -> LearningParams | None:
    """LearningParams with ``name=value`` overrides (None: the defaults)."""
    if not items:
        return None
    fields = {f.name: f.type for f in dataclasses.fields(LearningParams)}
    overrides: dict[str, object] = {}
    for item in items:
        name, _, value = item.partition("=")
        if name not in fields:
            raise SystemExit(f"--learn-param: unknown field {name!r}; LearningParams has {', '.join(fields)}")
        kind = str(fields[name])
        overrides[name] = int(value) if kind == "int" else value if kind == "str" else float(value)
    return LearningParams(**overrides)  # type: ignore[arg-type]


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("dataset", type=Path, nargs="?", help="a season dataset (nightloc synth --season N)")
    parser.add_argument("--odometry", default="wheel,robot1,robot3", help="chains' odometry kinds")
    parser.add_argument("--draws", type=int, default=3, help="chains per simulated kind (default 3)")
    parser.add_argument("--nights", type=int, default=None, help="the season's first nights only")
    parser.add_argument("--quick", action="store_true", help="6 nights, one draw of wheel and robot3")
    parser.add_argument("--csv", type=Path, default=None, help="write the records here")
    parser.add_argument("--figure", type=Path, default=None, help="draw the curves here (.png, .pdf, .svg)")
    parser.add_argument("--log", type=Path, default=None, help="append a progress line per night and chain here")
    parser.add_argument("--from-csv", type=Path, default=None, help="tables and figure from this CSV instead")
    parser.add_argument("--learn-param", action="append", default=[], help="a LearningParams field, e.g. novelty=0.4")
    args = parser.parse_args()
    if args.from_csv is not None:
        records = read_csv(args.from_csv)
    else:
        if args.dataset is None:
            parser.error("give a season DATASET (or --from-csv)")
        settings = SeasonSettings(
            odometry=("wheel", "robot3") if args.quick else tuple(k.strip() for k in args.odometry.split(",")),
            draws=1 if args.quick else args.draws,
            nights=6 if args.quick and args.nights is None else args.nights,
            learning=learning_params(args.learn_param),
        )
        start = time.perf_counter()

        def log(line: str) -> None:
            if args.log is not None:
                with args.log.open("a") as stream:
                    stream.write(f"[{time.perf_counter() - start:7.0f} s] {line}\n")

        records = run_season(args.dataset, settings, log=log)
        log("done")
        if args.csv is not None:
            write_csv(records, args.csv)
    title = f"season of {records[0].world}" if records else ""
    if args.figure is not None and records:
        season_figure(records, title, args.figure)
    emit(f"### {title}: test drives")
    emit()
    test_table(records)
    emit()
    emit(f"### {title}: beside the targets (test drives from the third night on)")
    emit()
    summary_table(records)


if __name__ == "__main__":
    main()
