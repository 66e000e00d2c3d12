"""Every number the README states about accuracy, computed afresh (tests/cli/test_readme.py checks
that the README holds exactly these).

    python tools/readme_numbers.py [SECTION ...] [--check README.md] [--cache DIR]

Sections (all by default; each README table has its command above it):

* ``localization``: the paper's method on the synthetic worlds, as ``nightloc demo --repeats 5``
  computes it (median distance error over the night query frames and the five noise draws);
* ``filter``: the Bayes filter beside the paper's 10-frame sequences (``tools/filter_targets.py``,
  three draws): the table, the sentence under it and the numbers of the README's introduction;
* ``route``: route mode on the real Gardens Point and Nordland pairs (needs the shared data:
  ``../shared/data`` or ``$NIGHTLOC_SHARED_DATA``; skipped with a note without it).
* ``camera``: the camera study's sentence, from ``nightloc camera-study --world garden`` with its
  defaults (minutes).

Prints each block of README text; ``--check README.md`` instead compares them with the README
(blanks and line breaks aside) and exits with status 1 naming each block it lacks. Speeds are
not here: they depend on the machine (``nightloc info``, ``benchmarks/``).
"""

from __future__ import annotations

import argparse
import json
import os
import sys
import tempfile
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))

import filter_targets  # tools/ is not a package: imported from this folder

import nightloc
from nightloc.cli import main as nightloc_main
from nightloc.localization.evaluation import EvaluationSettings, evaluate, match_traverse
from nightloc.localization.tail import tail_metrics
from nightloc.synth import default_dataset

SECTIONS = ("localization", "filter", "route", "camera")
EN_DASH = "\u2013"
REPO = Path(__file__).resolve().parents[1]

#: The paper's results for each world (its Table/figures; text of the README's last column).
PAPER_2D = {"garden": "≈ 0.5 m with 10 frames", "living_room": "≤ ≈ 0.25 m with 7 frames"}
WORLD_LABEL = {"garden": "garden, night query", "living_room": "living room, night query"}


def _m(value: float) -> str:
    return f"{value:.2f}"


def localization_blocks(folders) -> list[str]:
    """The 2D table: single frame, 7 and 10 frames, 10 without interpolation, noise 1-3 at 7."""
    lines = [
        "| | single frame | 7 frames | 10 frames | 10 frames, no interpolation | 7 frames, noise 1 / 2 / 3 | paper |",
        "| --- | --- | --- | --- | --- | --- | --- |",
    ]
    settings = EvaluationSettings(repeats=5, seed=0, methods=("paper",))
    for world in ("garden", "living_room"):
        ref_map = nightloc.ReferenceMap.build(folders[world]["day_reference"])
        matches = match_traverse(ref_map, folders[world]["night_query"], f"{world}/night_query")
        ev = evaluate(ref_map, matches, settings, nightloc.LocalizationParams())

        def median(n: int, model: int = 0, interpolation: bool = True, ev=ev) -> float:
            return ev.median(seq_len=n, noise_model=model, interpolation=interpolation, method="paper")

        noise = " / ".join(_m(median(7, model)) for model in (1, 2, 3))
        lines.append(
            f"| {WORLD_LABEL[world]} | {_m(median(1))} m | {_m(median(7))} m | {_m(median(10))} m | "
            f"{_m(median(10, interpolation=False))} m | {noise} m | {PAPER_2D[world]} |"
        )
    return ["\n".join(lines)]


def filter_blocks(folders) -> list[str]:
    """The filter table, the sentence under it, and the introduction's numbers."""
    rows = {(r["world"], r["kind"], r["model"]): r for r in filter_targets.filter_rows(folders, draws=3)}

    def cell(world: str, kind: str, model: int, what: str) -> str:
        return _m(float(np.median(rows[(world, kind, model)][what])))

    def tail(world: str, kind: str, model: int, what: str) -> str:
        t = tail_metrics(rows[(world, kind, model)][what], first_frame=filter_targets.FIRST)
        return f"{_m(t.p95_m)}, {100 * t.share_over_1m:.0f} %"

    lines = [
        "| odometry | garden: filter / paper (p95, share > 1 m) | living room: filter / paper (p95, share > 1 m) |",
        "| --- | --- | --- |",
    ]
    for kind, model, label in (
        ("robot", 0, "wheel (`RobotMotion`), exact"),
        ("robot", 3, "wheel, noise model 3"),
        ("map", 0, "map frame, exact"),
        ("map", 3, "map frame, noise model 3"),
    ):
        pairs = [
            f"**{cell(w, kind, model, 'filter')}** ({tail(w, kind, model, 'filter_runs')}) / "
            f"{cell(w, kind, model, 'paper')} m ({tail(w, kind, model, 'paper_runs')})"
            for w in rows_worlds()
        ]
        lines.append(f"| {label} | {pairs[0]} | {pairs[1]} |")
    headings = [float(np.median(r["heading"])) for key, r in rows.items() if key[1] == "robot"]
    inside = float(np.mean(np.concatenate([hits for r in rows.values() for hits in r["hits"]])))
    worst = max(max(r["recoveries"]) for r in filter_targets.kidnap_rows(folders, draws=3))
    sentence = (
        f"Its heading errs {min(headings):.1f}{EN_DASH}{max(headings):.1f}° with wheel odometry, the truth lies "
        f"within its `credible_radius` in {100 * inside:.0f} % of the frames, and a robot carried metres away is "
        f"found again within {worst} frames"
    )
    intro = (
        f"with wheel odometry it errs {cell('garden', 'robot', 0, 'filter')} / "
        f"{cell('living_room', 'robot', 0, 'filter')} m (exact) and {cell('garden', 'robot', 3, 'filter')} / "
        f"{cell('living_room', 'robot', 3, 'filter')} m (noise model 3), where the paper's 10-frame sequences err "
        f"{cell('garden', 'robot', 0, 'paper')} / {cell('living_room', 'robot', 0, 'paper')} m and "
        f"{cell('garden', 'robot', 3, 'paper')} / {cell('living_room', 'robot', 3, 'paper')} m (medians of three "
        f"noise draws"
    )
    return ["\n".join(lines), sentence, intro]


def rows_worlds() -> tuple[str, str]:
    return ("garden", "living_room")


def shared_data() -> Path:
    return Path(os.environ.get("NIGHTLOC_SHARED_DATA", REPO.parent / "shared" / "data"))


def _route(reference: Path, query: Path, *options: str) -> dict:
    """summary.json of ``nightloc route`` (per method) on the two traverses."""
    with tempfile.TemporaryDirectory() as scratch:
        out = Path(scratch) / "out"
        argv = [str(reference), str(query), "--out", str(out), "--ground-truth", "names", "--no-figures", *options]
        with open(os.devnull, "w") as quiet:
            stdout, sys.stdout = sys.stdout, quiet
            try:
                status = nightloc_main(["route", *argv])
            finally:
                sys.stdout = stdout
        if status != 0:
            raise SystemExit(f"nightloc route {' '.join(argv)} failed")
        summary = json.loads((out / "summary.json").read_text())
        if "results" in summary:
            return {m: json.loads((out / m / "summary.json").read_text()) for m in summary["methods"]}
        return {summary["method"]: summary}


def route_blocks(data: Path) -> list[str]:
    """The route table: the filter and SeqSLAM (ds 10, centred) with the default preparation,
    and the OpenSeqSLAM preset on Nordland."""

    def triple(summary: dict, bold: bool) -> str:
        text = (
            f"{summary['recall_at_100_precision']:.3f} / {summary['best_f1']:.3f} / "
            f"{100 * summary['correct_any_score']:.0f} %"
        )
        return f"**{text}**" if bold else text

    header = (
        "| data | route filter (default): recall at 100 % precision / best F1 / correct | SeqSLAM (ds 10, centred) "
        "| OpenSeqSLAM preset (bit-exact) |"
    )
    lines = [header, "| --- | --- | --- | --- |"]
    pairs = (
        ("Gardens Point, day → night", data / "gardens_point" / "day_right", data / "gardens_point" / "night_right"),
        ("Nordland, summer → winter", data / "nordland" / "summer", data / "nordland" / "winter"),
    )
    for label, reference, query in pairs:
        both = _route(reference, query, "--method", "seqslam,filter")
        frames = both["filter"]["n_queries"]
        preset = "—"
        if "Nordland" in label:
            opens = _route(reference, query, "--preset", "openseqslam")["seqslam"]
            preset = f"{opens['recall_at_100_precision']:.3f} / {opens['best_f1']:.3f}"
        filtered, seqslam = triple(both["filter"], True), triple(both["seqslam"], False)
        lines.append(f"| {label} ({frames} frames) | {filtered} | {seqslam} | {preset} |")
    return ["\n".join(lines)]


def camera_blocks() -> list[str]:
    """The README's sentence on the camera study (the paper's method, the default study)."""
    from nightloc.studies.camera import Sensor, run_camera_study

    study = run_camera_study("garden")
    small, large = Sensor(4000.0, 2.5), Sensor(64000.0, 2.0)
    at_48 = study.row(48, 24, 0.0, small, "paper").median_m
    best = min(r.median_m for r in study.rows if (r.darkness, r.sensor, r.method) == (0.0, small, "paper"))
    lost = min(
        d
        for d in study.settings.darkness
        if min(r.median_m for r in study.rows if (r.darkness, r.sensor, r.method) == (d, small, "paper")) > 1.0
    )
    dark = study.row(48, 24, 2.0, large, "paper").median_m
    within = int(np.ceil(100 * (at_48 / best - 1)))
    times = "\u00d7"
    sentence = (
        f"in enough light 48{times}24 (1 152 pixels) is within {within} % of the best resolution ({_m(at_48)} "
        f"against {_m(best)} m), as the paper claims; in the dark the pixel decides: 2 µm pixels are lost from "
        f"darkness {lost:g} ({10 ** (2 * (lost - 1)):g}{times} fewer photons than darkness 1), 8 µm ones localize "
        f"to {_m(dark)} m at darkness 2."
    )
    return [sentence]


def blocks(sections, cache: str | None) -> dict[str, list[str] | None]:
    """Each section's README blocks (None: the route data is missing)."""
    folders = default_dataset(cache_dir=cache) if set(sections) & {"localization", "filter"} else None
    out: dict[str, list[str] | None] = {}
    for section in sections:
        if section == "localization":
            out[section] = localization_blocks(folders)
        elif section == "filter":
            out[section] = filter_blocks(folders)
        elif section == "camera":
            out[section] = camera_blocks()
        else:
            data = shared_data()
            out[section] = route_blocks(data) if (data / "nordland").is_dir() else None
    return out


def emit(text: str) -> None:
    """One block of the report on stdout."""
    sys.stdout.write(text + "\n")


def _flat(text: str) -> str:
    return " ".join(text.split())


def missing_blocks(readme: str, computed: dict[str, list[str] | None]) -> list[str]:
    """The computed blocks that ``readme`` does not hold (blanks and line breaks aside), each
    after the section's command."""
    text = _flat(readme)
    lacking = []
    for section, found in computed.items():
        command = f"python tools/readme_numbers.py {section}"
        if command not in text:
            lacking.append(f"{section}: the README does not name its command ({command})")
            continue
        for block in found or []:
            if _flat(block) not in text:
                lacking.append(f"{section}:\n{block}")
    return lacking


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("sections", nargs="*", choices=[*SECTIONS, []], help="sections (default all)")
    parser.add_argument("--check", type=Path, help="compare with this README instead of printing")
    parser.add_argument("--cache", default=None, help="folder of the synthetic dataset (default the user cache)")
    args = parser.parse_args(argv)
    sections = args.sections or list(SECTIONS)
    computed = blocks(sections, args.cache)
    if args.check is not None:
        lacking = missing_blocks(args.check.read_text(encoding="utf-8"), computed)
        for item in lacking:
            emit(f"{args.check} lacks, from python tools/readme_numbers.py {item}\n")
        skipped = [s for s, found in computed.items() if found is None]
        if skipped:
            emit(f"not checked (no data at {shared_data()}): {', '.join(skipped)}")
        return 1 if lacking else 0
    for section, found in computed.items():
        emit(f"## python tools/readme_numbers.py {section}\n")
        if found is None:
            emit(f"(skipped: no data at {shared_data()})\n")
        for block in found or []:
            emit(block + "\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())
