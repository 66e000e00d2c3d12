"""The tail of a localizer's errors: what a median hides.

A robot that is 12 m off for a dozen frames has a fine median and is lost. Every reporter of
distance errors (``nightloc evaluate``'s ``summary.csv``, ``nightloc localize``, the tools that
write the docs' tables) computes its figures here, over the frames from the ``first_frame``-th
on (the first frames start from nothing; a 10-frame sequence is full at the 10th):

* ``median_m`` and ``p95_m``: the median and the 95th percentile (linear between order
  statistics, ``numpy.percentile``'s default) of the pooled errors, metres;
* ``share_over_1m``: the share of frames more than ``threshold`` (1 m) off;
* ``longest_run_over_1m``: the most consecutive frames of one run more than ``threshold`` off
  (runs are never joined: the last frame of one and the first of the next are not consecutive).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

__all__ = ["FIRST_FRAME", "LOST_M", "TailMetrics", "longest_run", "tail_metrics"]

#: Errors are counted from this frame on (1-based: the 10th frame, index 9).
FIRST_FRAME = 10
#: Metres: a frame farther than this from the truth counts as lost.
LOST_M = 1.0


@dataclass(frozen=True)
class TailMetrics:
    """Distance-error statistics of one or more runs, over their frames from ``first_frame`` on.

    Attributes:
        n: frames counted (pooled over the runs).
        median_m, p95_m: median and 95th percentile, metres (NaN when ``n`` is 0).
        share_over_1m: share of the frames more than the threshold off (0..1; NaN when ``n`` is 0).
        longest_run_over_1m: the most consecutive frames of one run more than the threshold off.
    """

    n: int
    median_m: float
    p95_m: float
    share_over_1m: float
    longest_run_over_1m: int

    def line(self) -> str:
        """One line for a terminal: ``median 0.16 m, p95 0.52 m, 1.2 % of frames over 1 m (longest run 2)``."""
        return (
            f"median {self.median_m:.2f} m, p95 {self.p95_m:.2f} m, {100 * self.share_over_1m:.1f} % of frames over "
            f"{LOST_M:g} m (longest run {self.longest_run_over_1m})"
        )


def longest_run(flags: np.ndarray) -> int:
    """The most consecutive True values of a 1-D boolean array (0 when none)."""
    flags = np.asarray(flags, dtype=bool).ravel()
    if not flags.any():
        return 0
    padded = np.concatenate([[False], flags, [False]]).astype(np.int8)
    edges = np.flatnonzero(np.diff(padded))
    return int((edges[1::2] - edges[::2]).max())


def tail_metrics(
    runs: np.ndarray | Sequence[np.ndarray], *, first_frame: int = FIRST_FRAME, threshold: float = LOST_M
) -> TailMetrics:
    """The tail of the per-frame errors of one run or several.

    Args:
        runs: ``(N,)`` the distance errors (metres) of one run's frames in their order, or a
            sequence of such arrays (several runs: noise draws, seeds, traverses).
        first_frame: the first frame counted, 1-based (default the 10th).
        threshold: metres beyond which a frame counts as lost (default 1 m).

    Raises:
        ValueError: ``first_frame`` below 1, a negative or non-finite threshold, or a run that is
            not one-dimensional.
    """
    if isinstance(first_frame, bool) or not isinstance(first_frame, (int, np.integer)) or first_frame < 1:
        raise ValueError(f"first_frame must be an int >= 1 (1 counts every frame), got {first_frame!r}")
    if not (math.isfinite(threshold) and threshold >= 0):
        raise ValueError(f"threshold must be a finite number of metres >= 0, got {threshold!r}")
    if isinstance(runs, np.ndarray) and runs.ndim == 1:
        runs = [runs]
    kept = []
    for run in runs:
        errors = np.asarray(run, dtype=np.float64)
        if errors.ndim != 1:
            raise ValueError(f"each run must be a 1-D array of per-frame errors, got shape {errors.shape}")
        kept.append(errors[first_frame - 1 :])
    pooled = np.concatenate(kept) if kept else np.zeros(0)
    if pooled.size == 0:
        return TailMetrics(0, math.nan, math.nan, math.nan, 0)
    return TailMetrics(
        n=int(pooled.size),
        median_m=float(np.median(pooled)),
        p95_m=float(np.percentile(pooled, 95)),
        share_over_1m=float(np.mean(pooled > threshold)),
        longest_run_over_1m=max(longest_run(e > threshold) for e in kept),
    )
