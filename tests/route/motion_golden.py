"""The route filter's outputs for every motion model on fixed problems, as stored in
``tests/route/data/motion_golden.npz``: the reference the core's results are compared with bit
for bit (``test_route_motion_models.py``). ``python tests/route/motion_golden.py`` rewrites the
file from the installed core (only when a change of the results is intended)."""

from __future__ import annotations

import dataclasses
from pathlib import Path

import numpy as np

from nightloc import route

GOLDEN = Path(__file__).parent / "data" / "motion_golden.npz"

#: Case name -> (motion model, RouteParams overrides, problem seed).
CASES = {
    "window": ("window", {}, 1),
    "window_backward": ("window", {"filter_backward": 0.1, "filter_clip": float("inf"), "vmin": 0.0, "vmax": 2.5}, 2),
    "speed": ("speed", {}, 3),
    "speed_backward": (
        "speed",
        {"filter_backward": 0.05, "filter_speed_cells": 1, "filter_speed_min": -0.5, "filter_floor": 1e-2},
        4,
    ),
    "speed_still": ("speed", {"filter_speed_change": 0.0, "filter_speed_tau": float("inf")}, 5),
    "speed_fast_change": ("speed", {"filter_speed_change": 0.3, "filter_speed_cells": 3}, 6),
    "odometry": ("odometry", {}, 7),
    "odometry_plain": (
        "odometry",
        {
            "filter_odometry_novelty": 0.0,
            "filter_odometry_cells": 1,
            "filter_odometry_noise": 0.0,
            "filter_odometry_jitter": 0.0,
        },
        8,
    ),
    "odometry_noisy": ("odometry", {"filter_odometry_noise": 0.4, "filter_backward": 0.02}, 9),
}


def problem(seed: int, n_query: int = 90, n_ref: int = 70) -> dict:
    """A difference matrix with a true reference 0.7 per frame lower by 2 (a row without spread,
    NaN and inf entries), evidence weights (one 0), the query's advances (some 0, some
    negative) and the references' irregular distances along the route."""
    rng = np.random.default_rng(seed)
    matrix = rng.normal(3.0, 1.0, size=(n_query, n_ref)).astype(np.float32)
    truth = (np.arange(n_query) * 0.7).astype(int) % n_ref
    matrix[np.arange(n_query), truth] -= 2.0
    matrix[5, :] = 1.0
    matrix[9, ::7] = np.nan
    matrix[10, :] = np.nan
    matrix[11, 3] = np.inf
    weights = rng.uniform(0, 1, n_query)
    weights[20] = 0.0
    gaps = rng.uniform(0.5, 1.5, n_ref - 1)
    gaps[10] = 0.0  # two references at one place
    distances = np.r_[0.0, np.cumsum(gaps)]
    advances = rng.normal(0.7, 0.3, n_query)
    advances[30:33] = 0.0
    advances[40] = -0.8
    return {"matrix": matrix, "weights": weights, "advances": advances, "distances": distances}


def outputs(case: str) -> dict:
    """The core's results for one case: the batch run (refs, confidence, off_route, speed), the
    same frames one by one with a state set halfway and a reset, and the final belief."""
    motion, overrides, seed = CASES[case]
    data = problem(seed)
    odometry = motion == "odometry"
    # The odometry model runs when given the distances, whatever filter_motion says.
    params = dataclasses.replace(route.RouteParams(), **overrides, **({} if odometry else {"filter_motion": motion}))
    advances = data["advances"] if odometry else None
    distances = data["distances"] if odometry else None
    refs, confidence, off_route, speed, ran = route.route_filter_run(
        data["matrix"], params, data["weights"], 2, advances, distances
    )
    assert ran == motion, (case, ran)
    stepper = route.RouteFilter(data["matrix"].shape[1], params, distances)
    steps = []
    for q, row in enumerate(data["matrix"]):
        if q == 45:
            stepper.set_state(np.linspace(1.0, 2.0, data["matrix"].shape[1]), 0.1)
        if q == 70:
            stepper.reset()
        step = stepper.step(row, float(data["weights"][q]), 0.0 if advances is None else float(advances[q]))
        steps.append((step.ref, step.confidence, step.off_route, np.nan if step.speed is None else step.speed))
    stepped = np.array(steps, dtype=np.float64)
    return {
        f"{case}/refs": refs,
        f"{case}/confidence": confidence,
        f"{case}/off_route": off_route,
        f"{case}/speed": speed,
        f"{case}/stepped": stepped,
        f"{case}/belief": stepper.belief,
    }


def main() -> None:
    arrays: dict = {}
    for case in CASES:
        arrays.update(outputs(case))
    GOLDEN.parent.mkdir(exist_ok=True)
    np.savez_compressed(GOLDEN, **arrays)
    print(f"wrote {GOLDEN} ({len(arrays)} arrays)")


if __name__ == "__main__":
    main()
