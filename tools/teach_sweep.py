"""The teach run's accuracy over odometry draws: map ATE and night error per world and seed.

    python tools/teach_sweep.py [--worlds garden,living_room] [--seeds 0-4] [--large DIR]
                                [--set name=value ...] [--night] [--decompose] [--night-repeats N]

For each world and seed the day drive's wheel odometry is drawn afresh
(``WheelNoise().simulate(poses, default_rng([seed, 20]))``, the draws of docs/teach_run.md),
the teach run builds the map, and the script prints the dead reckoning's and the map's ATE (RMSE
after the best rigid 2D fit), the map's ATE after the best similarity fit (rotation,
translation and scale: what is left when the scale error is taken out), the fitted scale, and
with ``--night`` the Bayes filter's median night error (wheel odometry, noise model 1, frames 10
on; the truth moved into the map's frame) on the taught map beside the surveyed map's.

``--decompose`` adds night errors on maps that carry part of the taught map's error: the
surveyed positions with the taught headings, the taught positions with the surveyed headings,
and the taught map with its scale taken out (all in the survey frame).

``--set`` overrides a :class:`~nightloc.mapping.TeachParams` field (numbers, booleans), e.g.
``--set rounds=3``. The default data is the demo's synthetic dataset (the user cache); the large
garden is ``--large DIR`` (rendered by ``nightloc synth --world large_garden --out DIR``).
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import sys
import time
import warnings
from pathlib import Path

import numpy as np

from nightloc import ReferenceMap
from nightloc.io.traverse import load_traverse
from nightloc.localization.evaluation import EvaluationSettings, align_to_map, evaluate, match_traverse
from nightloc.localization.localizer import LocalizationParams
from nightloc.mapping import TeachParams, TeachWarning, absolute_trajectory_error, rigid_fit, teach_run
from nightloc.mapping.alignment import RigidTransform2D
from nightloc.motion.wheel_noise import WheelNoise

#: The night evaluation of docs/teach_run.md: the filter with wheel odometry, noise model 1.
NIGHT = EvaluationSettings(
    seq_lengths=(1,), noise_models=(1,), interpolation=(True,), odometry="robot", methods=("filter",)
)
#: First night frame counted (0-based): the 10th on.
NIGHT_FROM = 9


def say(line: str) -> None:
    sys.stdout.write(line + "\n")
    sys.stdout.flush()


def similarity_fit(source: np.ndarray, target: np.ndarray) -> tuple[float, float, np.ndarray]:
    """``(scale, rmse, moved)``: the best rotation, translation and scale of ``source`` onto
    ``target`` (Umeyama, 2D) and the RMSE after it."""
    ca, cb = source.mean(axis=0), target.mean(axis=0)
    da, db = source - ca, target - cb
    cross = float(np.sum(da[:, 0] * db[:, 1] - da[:, 1] * db[:, 0]))
    dot = float(np.sum(da * db))
    rotation = np.arctan2(cross, dot)
    scale = np.hypot(cross, dot) / float(np.sum(da * da))
    c, s = np.cos(rotation), np.sin(rotation)
    moved = scale * da @ np.array([[c, -s], [s, c]]).T + cb
    return float(scale), float(np.sqrt(np.mean(np.sum((moved - target) ** 2, axis=1)))), moved


def heading_rmse_deg(estimate: np.ndarray, truth: np.ndarray) -> float:
    """RMS heading error, degrees."""
    error = np.remainder(np.asarray(estimate) - np.asarray(truth) + np.pi, 2 * np.pi) - np.pi
    return float(np.degrees(np.sqrt(np.mean(error**2))))


def night_error(ref_map: ReferenceMap, query: Path, transform: RigidTransform2D | None, repeats: int = 1) -> float:
    """Median night error (m) of the filter on ``ref_map`` over the query frames from the 10th
    (and ``repeats`` odometry draws); ``transform`` takes the map frame to the survey frame
    (None: the map is in the survey frame)."""
    matches = match_traverse(ref_map, query, tables=True)
    if transform is not None:
        matches = align_to_map(matches, transform)
    settings = dataclasses.replace(NIGHT, repeats=repeats)
    evaluation = evaluate(ref_map, matches, settings, LocalizationParams())
    later = evaluation.frame_index() >= NIGHT_FROM
    return float(np.median(evaluation.columns["error_m"][evaluation.select(method="filter") & later]))


def with_poses(ref_map: ReferenceMap, positions: np.ndarray, headings: np.ndarray, source: str) -> ReferenceMap:
    """``ref_map``'s images with other poses (no covariances)."""
    return ReferenceMap(
        np.asarray(ref_map.images),
        positions,
        np.pi - np.mod(np.pi - np.asarray(headings), 2 * np.pi),
        ref_map.names,
        ref_map.params,
        ref_map.source,
        ref_map.frame_size,
        pose_source=source,
    )


def run_world(
    name: str, folder: Path, seeds: list[int], teach: TeachParams, night: bool, decompose: bool, repeats: int = 1
) -> list[dict]:
    day = load_traverse(folder / "day_reference")
    query = folder / "night_query"
    truth = np.asarray(day.positions)
    truth_headings = np.asarray(day.headings)
    surveyed = ReferenceMap.build(folder / "day_reference") if night else None
    surveyed_night = night_error(surveyed, query, None, repeats) if surveyed is not None else float("nan")
    rows = []
    for seed in seeds:
        odometry = WheelNoise().simulate(truth, truth_headings, np.random.default_rng([seed, 20]))
        start = time.perf_counter()
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", TeachWarning)
            taught, report = teach_run(day, surveyed.params if surveyed is not None else None, teach, odometry=odometry)
        seconds = time.perf_counter() - start
        positions = np.asarray(taught.positions)
        scale, similar_ate, _ = similarity_fit(positions, truth)
        fit = rigid_fit(positions, truth)
        row = {
            "world": name,
            "seed": seed,
            "dr_ate": absolute_trajectory_error(report.dead_reckoning[:, :2], truth),
            "ate": absolute_trajectory_error(positions, truth),
            "similarity_ate": similar_ate,
            "scale": scale,
            "heading_rmse_deg": heading_rmse_deg(fit.apply_headings(taught.headings), truth_headings),
            "accepted": report.accepted,
            "rejected": report.rejected,
            "seconds": seconds,
        }
        if night:
            row["night"] = night_error(taught, query, fit, repeats)
            row["night_surveyed"] = surveyed_night
        if decompose and surveyed is not None:
            moved = fit.apply(positions)
            moved_headings = fit.apply_headings(taught.headings)
            row["night_taught_headings"] = night_error(
                with_poses(surveyed, truth, moved_headings, "surveyed"), query, None, repeats
            )
            row["night_taught_positions"] = night_error(
                with_poses(surveyed, moved, truth_headings, "surveyed"), query, None, repeats
            )
            _, _, rescaled = similarity_fit(positions, truth)
            row["night_unscaled"] = night_error(
                with_poses(surveyed, rescaled, moved_headings, "surveyed"), query, None, repeats
            )
        rows.append(row)
        say(json.dumps({k: round(v, 4) if isinstance(v, float) else v for k, v in row.items()}))
    return rows


def summarise(rows: list[dict]) -> None:
    keys = [k for k in rows[0] if k not in ("world", "seed")]
    for world in dict.fromkeys(r["world"] for r in rows):
        sub = [r for r in rows if r["world"] == world]
        parts = []
        for key in keys:
            values = np.array([r[key] for r in sub], dtype=np.float64)
            parts.append(f"{key} {np.median(values):.3f} [{values.min():.3f}-{values.max():.3f}]")
        say(f"{world}: " + "; ".join(parts))


def parse_value(text: str) -> object:
    if text in ("true", "false"):
        return text == "true"
    for kind in (int, float):
        try:
            return kind(text)
        except ValueError:
            pass
    return text


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--worlds", default="garden,living_room")
    parser.add_argument("--seeds", default="0-4")
    parser.add_argument("--large", type=Path, default=None, help="the large garden's dataset folder")
    parser.add_argument("--cache", type=Path, default=None, help="the default dataset's cache (default the user's)")
    parser.add_argument("--set", action="append", default=[], metavar="NAME=VALUE")
    parser.add_argument("--night", action="store_true")
    parser.add_argument("--decompose", action="store_true")
    parser.add_argument("--night-repeats", type=int, default=1, help="night odometry draws per map (default 1)")
    args = parser.parse_args(argv)
    low, _, high = args.seeds.partition("-")
    seeds = list(range(int(low), int(high or low) + 1))
    overrides = {}
    for item in args.set:
        key, _, value = item.partition("=")
        overrides[key] = parse_value(value)
    teach = dataclasses.replace(TeachParams(), **overrides)
    from nightloc.synth import default_cache_dir, default_dataset

    folders = {}
    worlds = args.worlds.split(",")
    if set(worlds) - {"large_garden"}:
        dataset = default_dataset(cache_dir=args.cache or default_cache_dir())
        folders = {w: Path(dataset[w]["day_reference"]).parent for w in worlds if w != "large_garden"}
    if "large_garden" in worlds:
        if args.large is None:
            parser.error("--large DIR is needed for the large garden")
        folders["large_garden"] = args.large
    rows = []
    for world in worlds:
        rows += run_world(
            world, folders[world], seeds, teach, args.night or args.decompose, args.decompose, args.night_repeats
        )
    summarise(rows)
    return 0


if __name__ == "__main__":
    sys.exit(main())
