"""Peak memory and time of learning over a long night (docs/experience_maps.md, "Memory over a
long night"): one night's frames played ``--repeats`` times in a row through a
:class:`~nightloc.experience.NightLearner`, then its smoother.

    nightloc synth --world large_garden --season 1 --out /tmp/lawn
    python tools/learner_memory.py /tmp/lawn/day_reference /tmp/lawn/season_001 --repeats 8

Prints the frames, the time per frame of the forward run and of ``night()``, the process' peak
resident memory after the frames and after ``night()``, and a checksum of the smoothed positions
(equal for every ``--belief-budget``). Run each setting in its own process: the peak is the
process'.
"""

from __future__ import annotations

import argparse
import resource
import sys
import time
from pathlib import Path

import numpy as np

import nightloc
from nightloc.commands.options import load_reference
from nightloc.experience.learning import BELIEF_BUDGET, NightLearner
from nightloc.io.traverse import load_traverse
from nightloc.motion.odometry import traverse_odometry


def peak_mb() -> float:
    """The process' peak resident memory so far, MB (Linux reports KiB)."""
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("map", help="the day map: a map file, or a traverse folder or bag to build it from")
    parser.add_argument("night", help="a night's traverse folder with odometry.csv")
    parser.add_argument("--repeats", type=int, default=3, help="times the night is played in a row (default 3)")
    parser.add_argument("--noise", type=int, default=1, help="the localizer's odometry noise model (default 1)")
    parser.add_argument(
        "--belief-budget", type=int, default=BELIEF_BUDGET, help=f"bytes of kept beliefs (default {BELIEF_BUDGET})"
    )
    args = parser.parse_args()
    ref_map = load_reference(Path(args.map), None)
    log = load_traverse(args.night)
    frames = [ref_map.preparer.prepare(frame) for _, frame in log.frames()]
    motions = traverse_odometry(log)
    localizer = nightloc.Localizer(ref_map, odometry_noise=args.noise)
    learner = NightLearner(ref_map, localizer, belief_budget=args.belief_budget)
    start = time.perf_counter()
    for _ in range(args.repeats):
        for k, frame in enumerate(frames):
            learner.step(frame, motions[k] if k else None, prepared=True)  # each play starts with no motion
    stepped = time.perf_counter()
    peak_frames = peak_mb()
    night = learner.night()
    done = time.perf_counter()
    positions = np.array([(e.x, e.y) for e in night.smoothed or ()])
    m = len(learner)
    sys.stdout.write(
        f"{m} frames: forward {1e3 * (stepped - start) / m:.2f} ms/frame, night() {done - stepped:.1f} s "
        f"({1e3 * (done - stepped) / m:.2f} ms/frame); peak {peak_frames:.0f} MB after the frames, "
        f"{peak_mb():.0f} MB after night(); smoothed checksum {positions.sum():.9f}\n"
    )


if __name__ == "__main__":
    main()
