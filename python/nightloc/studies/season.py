"""The season study: an experience map learning night after night, beside the day map alone.

Over a season rendered by ``nightloc synth --season N`` (:mod:`nightloc.synth.season`) the study
runs what a robot's nightly script runs, ``nightloc localize MAP season_NNN --learn NEW_MAP``,
night after night (:func:`~nightloc.experience.learning.localize_night`, then
:func:`~nightloc.experience.learning.learn`; each night's map saved and loaded again, as the
command does), in one *chain* per odometry kind:

* ``wheel``: the drive's own wheel odometry (``odometry.csv``), the filter's noise model 1 (as
  ``localize`` assumes);
* ``robotK``: robot-frame odometry simulated from the true poses with Table III model K, the
  filter told model K; ``draws`` chains of it, each its own noise (seeded by the night, the drive
  and the draw).

Each night the chain's map (the day map plus what the nights before taught it) localizes the
night's re-drive of the day path and then learns it; on a test night it also localizes the test
drive on the other path, before learning. The day map alone localizes the same drives with the
same odometry. Per night, map and drive a :class:`NightRecord`: the tail of the errors from the
10th frame (:func:`~nightloc.localization.tail.tail_metrics`), the time per frame (preparation,
matching and the filter's update, one thread), what learning added, evicted and found known,
the learned appearances used (a trusted frame's best match at its place), how many additions were
*wrong* (stored more than 1 m from where their frame was taken; every addition of a covered night
or a night in another garden), and the map's size (places, references, learned ones, bytes of
its file). :func:`write_csv` writes the records, :func:`season_summary` sums them up.
"""

from __future__ import annotations

import csv
import dataclasses
import json
import math
import os
import tempfile
import time
from collections.abc import Callable, Iterator, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Union

import numpy as np

from ..experience.learning import LearningParams, LearningReport, LocalizedNight, learn, localize_night
from ..io.atomic import atomic_file
from ..io.traverse import Traverse, load_traverse
from ..localization.localizer import Localizer
from ..localization.tail import LOST_M, TailMetrics, tail_metrics
from ..mapping.reference_map import ReferenceMap
from ..motion.odometry import Motion, simulate_robot_odometry, traverse_odometry

__all__ = [
    "CSV_HEADER",
    "NightRecord",
    "SeasonSettings",
    "odometry_kinds",
    "read_csv",
    "run_season",
    "season_summary",
    "write_csv",
]

PathLike = Union[str, "os.PathLike[str]"]


@dataclass(frozen=True)
class SeasonSettings:
    """What the season study runs.

    Attributes:
        odometry: the chains' odometry kinds: ``"wheel"`` and ``"robotK"`` (K a Table III model).
        draws: chains per simulated kind (noise draws).
        nights: the season's first nights only (None: every night).
        learning: the learning thresholds (None: :class:`LearningParams`'s defaults).
        seed: of the simulated odometry's noise.
    """

    odometry: tuple[str, ...] = ("wheel", "robot1", "robot3")
    draws: int = 3
    nights: int | None = None
    learning: LearningParams | None = None
    seed: int = 0

    def __post_init__(self) -> None:
        for kind in self.odometry:
            if kind != "wheel" and not (kind.startswith("robot") and kind[5:] in ("0", "1", "2", "3")):
                raise ValueError(f"odometry kinds are wheel or robot0..robot3, got {kind!r}")
        if self.draws < 1:
            raise ValueError(f"draws must be >= 1, got {self.draws}")
        if self.nights is not None and self.nights < 1:
            raise ValueError(f"nights must be >= 1 or None, got {self.nights}")


def odometry_kinds(settings: SeasonSettings) -> list[tuple[str, int]]:
    """The chains: ``(kind, draw)`` for every kind (``wheel`` once, a simulated kind ``draws`` times)."""
    return [(kind, draw) for kind in settings.odometry for draw in range(1 if kind == "wheel" else settings.draws)]


@dataclass(frozen=True)
class NightRecord:
    """One drive of one night localized against one map (a row of the study's CSV).

    Attributes:
        world: the dataset's world; ``odometry``, ``draw``: the chain.
        night: the season night; ``bad``: its bad kind ("" for a good night).
        drive: ``"learn"`` (the re-drive of the day path, then learned) or ``"test"`` (the other path).
        map: ``"day"`` (the day map alone) or ``"learned"`` (the chain's map before tonight).
        frames and the errors' tail: as the summary's columns of the same names
            (:data:`~nightloc.localization.evaluation.SUMMARY_COLUMNS`; from the 10th frame; NaN on
            a night in another garden, whose truth is not this map's frame).
        ms_per_frame: preparation, matching and the filter's update per frame, milliseconds.
        used: learned appearances that tonight's learning found the best match at their place
            for one of its trusted frames (``learn`` rows of the learned map; 0 elsewhere);
            ``used_share``: their share of the map's learned appearances.
        trusted, added, new_places, evicted, known, wrong: what learning tonight did (``learn``
            rows of the learned map; 0 elsewhere): frames trusted, appearances added to places,
            new places, appearances evicted, places that knew tonight's look; additions stored more
            than 1 m from where their frame was taken (all of a covered or another garden's night).
        places, references, learned_references, map_bytes: the map the drive was localized
            against (its file's size in bytes).
    """

    world: str
    odometry: str
    draw: int
    night: int
    bad: str
    drive: str
    map: str
    frames: int
    median_m: float
    p95_m: float
    share_over_1m: float
    longest_run_over_1m: int
    ms_per_frame: float
    used: int
    used_share: float
    trusted: int
    added: int
    new_places: int
    evicted: int
    known: int
    wrong: int
    places: int
    references: int
    learned_references: int
    map_bytes: int


#: The CSV's columns: :class:`NightRecord`'s fields.
CSV_HEADER: tuple[str, ...] = tuple(f.name for f in dataclasses.fields(NightRecord))


def _schedule(dataset: Path) -> tuple[str, list[dict]]:
    try:
        description = json.loads((dataset / "dataset.json").read_text())
        return str(description["world"]), list(description["season"]["schedule"])
    except (OSError, ValueError, KeyError, TypeError) as error:
        raise ValueError(
            f"{dataset} is not a season dataset (dataset.json with a season schedule): render one with "
            f"nightloc synth --world garden --season N --out {dataset}"
        ) from error


@dataclass
class _Chain:
    """One chain: its odometry, its map (and its file's size), its localizers."""

    kind: str
    draw: int
    map: ReferenceMap
    map_bytes: int
    model: int

    def localizer(self, ref_map: ReferenceMap) -> Localizer:
        return Localizer(ref_map, odometry_noise=self.model)

    def motions(self, log: Traverse, night: int, drive: str, seed: int) -> list[Motion | None]:
        if self.kind == "wheel":
            return traverse_odometry(log)
        if log.positions is None or log.headings is None:
            raise ValueError(f"{log.root} has no poses with headings: simulated robot-frame odometry needs them")
        rng = np.random.default_rng([seed, night, sum(map(ord, drive)), self.model, self.draw])
        motions: list[Motion | None] = list(simulate_robot_odometry(log.positions, log.headings, self.model, rng))
        motions[0] = None
        return motions


def _file_size(ref_map: ReferenceMap, folder: Path) -> tuple[ReferenceMap, int]:
    """The map saved and loaded again (what ``localize --learn`` hands the next night) and its bytes."""
    path = ref_map.save(folder / "night.map", overwrite=True)
    return ReferenceMap.load(path), path.stat().st_size


def _localize(
    ref_map: ReferenceMap, chain: _Chain, frames: Sequence[np.ndarray], motions: Sequence[Motion | None], log: Traverse
) -> tuple[LocalizedNight, float]:
    start = time.perf_counter()
    night = localize_night(
        ref_map,
        frames,
        motions,
        chain.localizer(ref_map),
        names=log.names,
        timestamps=log.timestamps,
        source=str(log.root),
    )
    return night, 1000.0 * (time.perf_counter() - start) / max(len(frames), 1)


def _usage(before: ReferenceMap, after: ReferenceMap) -> int:
    """Learned appearances of ``before`` that tonight's learning found the best match at their
    place for one of its trusted frames (their match count grew)."""
    if before.appearances is None or after.appearances is None:
        return 0
    grown = dict(zip(after.names, after.appearances.matches, strict=True))
    learned = np.flatnonzero(np.asarray(before.appearances.night) > 0)
    return sum(int(grown.get(before.names[i], 0) > before.appearances.matches[i]) for i in learned)


def _wrong(before: ReferenceMap, after: ReferenceMap, report: LearningReport, log: Traverse, bad: str) -> int:
    """Additions of tonight stored more than LOST_M from where their frame was taken (every one on
    a covered night or a night in another garden)."""
    if report.night == 0 or after is before or after.appearances is None:
        return 0
    tonight = np.flatnonzero(np.asarray(after.appearances.night) == report.night)
    if bad in ("covered", "other_garden") or log.positions is None:
        return len(tonight)
    frame_of = {name: k for k, name in enumerate(log.names)}
    wrong = 0
    for i in tonight:
        frame = frame_of[after.names[i].split("/", 1)[1].rstrip("'")]
        wrong += int(np.hypot(*(after.positions[i] - log.positions[frame])) > LOST_M)
    return wrong


def _places(ref_map: ReferenceMap) -> int:
    return len(np.unique(np.round(ref_map.positions, 9), axis=0))


def run_season(
    dataset: PathLike,
    settings: SeasonSettings | None = None,
    *,
    log: Callable[[str], None] | None = None,
    work: PathLike | None = None,
) -> list[NightRecord]:
    """The season study over a ``nightloc synth --season`` dataset (see the module docstring).

    Args:
        dataset: the season's folder (``day_reference``, ``season_NNN``, ``dataset.json``).
        settings: the chains and the nights (default :class:`SeasonSettings`).
        log: called with a line per night and chain (progress for a long run).
        work: a folder for the chains' map files (default a temporary one, removed after).

    Raises:
        ValueError: ``dataset`` is not a season dataset.
    """
    settings = SeasonSettings() if settings is None else settings
    root = Path(dataset)
    world, schedule = _schedule(root)
    if settings.nights is not None:
        schedule = schedule[: settings.nights]
    say = log or (lambda line: None)
    with tempfile.TemporaryDirectory(prefix="nightloc-season-", dir=work) as scratch:
        day = ReferenceMap.build(root / "day_reference")
        folder = Path(scratch)
        day, day_bytes = _file_size(day, folder)
        chains = [
            _Chain(kind, draw, day, day_bytes, 1 if kind == "wheel" else int(kind[5:]))
            for kind, draw in odometry_kinds(settings)
        ]
        records: list[NightRecord] = []
        for entry in schedule:
            records.extend(_one_night(root, world, entry, chains, day, day_bytes, settings, folder, say))
    return records


def _one_night(
    root: Path,
    world: str,
    entry: dict,
    chains: list[_Chain],
    day: ReferenceMap,
    day_bytes: int,
    settings: SeasonSettings,
    folder: Path,
    say: Callable[[str], None],
) -> Iterator[NightRecord]:
    """The night's records, every chain's map moved on by the night's learning."""
    night, bad = int(entry["night"]), str(entry.get("bad") or "")
    drives = [("learn", str(entry["traverses"][0]))] + [("test", str(t)) for t in entry["traverses"][1:]]
    logs = {name: load_traverse(root / name) for _, name in drives}
    frames = {name: [log.read(i) for i in range(len(log))] for name, log in logs.items()}
    for chain in chains:
        for drive, name in sorted(drives, key=lambda d: d[0] != "test"):  # test drives before learning
            log = logs[name]
            motions = chain.motions(log, night, name, settings.seed)
            base = {"world": world, "odometry": chain.kind, "draw": chain.draw, "night": night, "bad": bad}
            base["drive"] = drive
            day_run, day_ms = _localize(day, chain, frames[name], motions, log)
            yield _record(base, "day", day_run, log, day_ms, day, day_bytes)
            run, ms = _localize(chain.map, chain, frames[name], motions, log)
            if drive == "test":
                yield _record(base, "learned", run, log, ms, chain.map, chain.map_bytes)
                continue
            new_map, report = learn(chain.map, run, settings.learning)
            learned = _record(base, "learned", run, log, ms, chain.map, chain.map_bytes, report)
            used = _usage(chain.map, new_map)
            yield dataclasses.replace(
                learned,
                wrong=_wrong(chain.map, new_map, report, log, bad),
                used=used,
                used_share=used / max(learned.learned_references, 1),
            )
            if new_map is not chain.map:
                chain.map, chain.map_bytes = _file_size(new_map, folder)
            say(
                f"night {night:3d}{' (' + bad + ')' if bad else ''} {chain.kind} draw {chain.draw}: "
                f"median {learned.median_m:.2f} m, p95 {learned.p95_m:.2f} m; {report.line()}"
            )


def _record(
    base: dict,
    ref_map_name: str,
    run: LocalizedNight,
    log: Traverse,
    ms: float,
    ref_map: ReferenceMap,
    map_bytes: int,
    report: LearningReport | None = None,
) -> NightRecord:
    """The record of ``run`` (a drive localized against ``ref_map``) and of tonight's learning."""
    foreign = base["bad"] == "other_garden"  # its poses are not in this map's frame
    truth = log.positions
    if foreign or truth is None:
        tail = TailMetrics(len(run.estimates), math.nan, math.nan, math.nan, 0)
    else:
        xy = np.array([[e.x, e.y] for e in run.estimates])
        tail = tail_metrics(np.hypot(*(xy - truth).T))
    appearances = ref_map.appearances
    learned = 0 if appearances is None else int(np.sum(np.asarray(appearances.night) > 0))
    return NightRecord(
        **base,
        map=ref_map_name,
        frames=len(run.estimates),
        median_m=tail.median_m,
        p95_m=tail.p95_m,
        share_over_1m=tail.share_over_1m,
        longest_run_over_1m=tail.longest_run_over_1m,
        ms_per_frame=ms,
        used=0,
        used_share=0.0,
        trusted=0 if report is None else report.trusted,
        added=0 if report is None else report.appearances,
        new_places=0 if report is None else report.places,
        evicted=0 if report is None else report.evicted,
        known=0 if report is None else report.known,
        wrong=0,
        places=_places(ref_map),
        references=len(ref_map),
        learned_references=learned,
        map_bytes=map_bytes,
    )


def write_csv(records: Sequence[NightRecord], path: PathLike) -> Path:
    """The records as a CSV (:data:`CSV_HEADER`), written atomically."""
    with atomic_file(path, "w", newline="") as stream:
        writer = csv.writer(stream)
        writer.writerow(CSV_HEADER)
        for record in records:
            writer.writerow([f"{v:.6g}" if isinstance(v, float) else v for v in dataclasses.astuple(record)])
    return Path(path)


def read_csv(path: PathLike) -> list[NightRecord]:
    """The records of a CSV written by :func:`write_csv`."""
    types = {f.name: f.type for f in dataclasses.fields(NightRecord)}
    casts = {"int": int, "float": float, "str": str}
    with open(path, newline="") as stream:
        rows = list(csv.DictReader(stream))
    return [NightRecord(**{k: casts[str(types[k])](v) for k, v in row.items()}) for row in rows]


def season_summary(records: Sequence[NightRecord], first_test_night: int = 3, last: int = 10) -> dict[str, dict]:
    """Per odometry kind, the study's figures beside the targets: over the test drives from
    ``first_test_night`` on (good nights), each night's median over the draws of the learned
    map's median, p95 and share over 1 m beside the day map's: the worst excess of the median
    and of the p95 (m), the worst share (and the day map's at that night, and its worst); ``*_draws``: the worst
    excess of a single draw (the spread); the nights where the learned map's share exceeds 1 %;
    per chain (``growth``) the references after the last night, the day map's, and the places the
    ``last`` nights added, as new places and as net references (added + new places - evicted),
    each a share of the final places; the time per frame against the day map's (the median of the
    learning drives' ratios); wrong additions in all."""
    out: dict[str, dict] = {}
    for kind in sorted({r.odometry for r in records}):
        rows = [r for r in records if r.odometry == kind]
        tests = [r for r in rows if r.drive == "test" and r.night >= first_test_night and not r.bad]
        pairs = _pairs(tests)
        learn_rows = sorted(
            (r for r in rows if r.drive == "learn" and r.map == "learned"), key=lambda r: (r.draw, r.night)
        )
        draws = sorted({r.draw for r in rows})
        growth = []
        for draw in draws:
            chain = [r for r in learn_rows if r.draw == draw]
            if not chain:
                continue
            final_places = chain[-1].places + chain[-1].new_places
            tail = chain[-last:]
            growth.append(
                {
                    "references": chain[-1].references + chain[-1].added + chain[-1].new_places - chain[-1].evicted,
                    "day_references": next(r.references for r in rows if r.map == "day"),
                    "last_places_share": sum(r.new_places for r in tail) / max(final_places, 1),
                    "last_net_share": sum(r.added + r.new_places - r.evicted for r in tail) / max(final_places, 1),
                }
            )
        ms = [(r.ms_per_frame, d.ms_per_frame) for d, r in _pairs([r for r in rows if r.drive == "learn"])]
        nights = sorted({r.night for r in tests})
        per_night = {n: _over_draws([pair for pair in pairs if pair[1].night == n]) for n in nights}
        worst_share = max(nights, key=lambda n: per_night[n]["share"][1], default=None)
        out[kind] = {
            "median_excess_m": max((v["median"][1] - v["median"][0] for v in per_night.values()), default=math.nan),
            "p95_excess_m": max((v["p95"][1] - v["p95"][0] for v in per_night.values()), default=math.nan),
            "share_over_1m": math.nan if worst_share is None else per_night[worst_share]["share"][1],
            "day_share_over_1m": math.nan if worst_share is None else per_night[worst_share]["share"][0],
            "day_worst_share_over_1m": max((v["share"][0] for v in per_night.values()), default=math.nan),
            "nights_over_1pct": [n for n in nights if per_night[n]["share"][1] > 0.01],
            "median_excess_draws_m": max((r.median_m - d.median_m for d, r in pairs), default=math.nan),
            "p95_excess_draws_m": max((r.p95_m - d.p95_m for d, r in pairs), default=math.nan),
            "growth": growth,
            "time_ratio": float(np.median([a / b for a, b in ms])) if ms else math.nan,
            "wrong": sum(r.wrong for r in learn_rows),
        }
    return out


def _over_draws(pairs: Sequence[tuple[NightRecord, NightRecord]]) -> dict[str, tuple[float, float]]:
    """(day map's, learned map's) median over the draws of a night's median, p95 and share."""

    def both(field: str) -> tuple[float, float]:
        day = [getattr(d, field) for d, _ in pairs]
        learned = [getattr(r, field) for _, r in pairs]
        return float(np.median(day)), float(np.median(learned))

    return {"median": both("median_m"), "p95": both("p95_m"), "share": both("share_over_1m")}


def _pairs(rows: Sequence[NightRecord]) -> list[tuple[NightRecord, NightRecord]]:
    """(day map's row, learned map's row) of each drive."""
    key = lambda r: (r.odometry, r.draw, r.night, r.drive)  # noqa: E731
    days = {key(r): r for r in rows if r.map == "day"}
    return [(days[key(r)], r) for r in rows if r.map == "learned" and key(r) in days]
