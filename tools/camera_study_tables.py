"""Markdown tables of a ``nightloc camera-study`` run, as docs/camera_study.md shows them.

    python tools/camera_study_tables.py OUT/camera_study.csv

Prints, per method and sensor, the median error / p95 / share of frames over 1 m by matching
resolution (rows) and darkness (columns).
"""

from __future__ import annotations

import argparse
import csv
import sys
from collections import defaultdict
from pathlib import Path


def tables(rows: list[dict[str, str]]) -> str:
    """The markdown text of every (method, sensor) table."""
    darkness = sorted({r["darkness"] for r in rows}, key=float)
    sizes = sorted({(int(r["width"]), int(r["height"])) for r in rows}, key=lambda s: s[0] * s[1])
    sensors = sorted(
        {(r["full_well_e"], r["read_noise_e"], r["pixel_pitch_um"]) for r in rows}, key=lambda s: float(s[0])
    )
    methods = list(dict.fromkeys(r["method"] for r in rows))
    cell: dict[tuple, dict[str, str]] = defaultdict(dict)
    for r in rows:
        key = (r["method"], r["full_well_e"], r["read_noise_e"], int(r["width"]), int(r["height"]), r["darkness"])
        cell[key] = r
    out = []
    for method in methods:
        for well, read, pitch in sensors:
            sensor = f"{float(pitch):.0f} µm pixel ({well} e⁻ well, {read} e⁻ read noise)"
            out.append(f"**{method}, {sensor}**: median / p95 (m) / share of frames over 1 m\n")
            out.append("| resolution | " + " | ".join(f"darkness {d}" for d in darkness) + " |")
            out.append("| --- |" + " --- |" * len(darkness))
            for w, h in sizes:
                values = []
                for d in darkness:
                    r = cell[(method, well, read, w, h, d)]
                    share = round(100 * float(r["share_over_1m"]))
                    values.append(f"{float(r['median_m']):.2f} / {float(r['p95_m']):.2f} / {share} %")
                out.append(f"| {w}x{h} ({w * h} px) | " + " | ".join(values) + " |")
            out.append("")
    return "\n".join(out)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("csv", type=Path, help="camera_study.csv of a nightloc camera-study run")
    args = parser.parse_args()
    with open(args.csv, newline="") as stream:
        sys.stdout.write(tables(list(csv.DictReader(stream))) + "\n")


if __name__ == "__main__":
    main()
