"""Whether the query's speed along the route lies in the range the search assumes.

The route filter's speed and window motion models, and SeqSLAM's trajectories, follow a query
that advances within a range of reference frames per query frame (:func:`motion_speeds`: the
core's registry of motion models says each model's range and the fields that set it). A query
taken at another speed ratio -- a robot re-driving its day path at half the speed, a camera at
another frame rate -- is matched badly, and nothing in the matches says why. This module
measures the ratio and says when it lies outside the range:

* **from odometry**, when both traverses carry it: each query frame's advance over the
  references' mean spacing (:func:`ratio_from_odometry`);
* **from the matches**, otherwise: a few stretches of consecutive rows of the enhanced
  difference matrix (:func:`sample_stretches`: at most ``STRETCHES x STRETCH_ROWS`` rows, the
  same wherever the rows are computed), each standardized per reference column (a reference that
  resembles every query frame must not win by standing still), are tracked by the window motion
  model under a geometric ladder of speed hypotheses (:data:`SPEEDS`); the one tracked with the
  highest mean confidence wins, and the ratio is the slope of its confident matches over
  ``SLOPE_FRAMES`` frames (:func:`ratio_from_rows`). The sweep in ``docs/route_mode.md``
  measured it on the real pairs and rendered routes from 0.3 to 3 reference frames per query
  frame.

:func:`check_speed` compares the ratio's median with the range and names what fits: the
odometry model when both traverses carry odometry, else the window model (or SeqSLAM's speeds)
centred on the measured ratio, ``vmin .. vmax`` = 0.8 .. 1.2 times it.
"""

from __future__ import annotations

import itertools
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from .filter import RouteFilter
from .params import MotionSpeeds, RouteParams, motion_speeds, resolve_params

__all__ = [
    "MatchesRatio",
    "SpeedCheck",
    "SpeedRatio",
    "StretchSampler",
    "check_speed",
    "ratio_from_odometry",
    "ratio_from_rows",
    "sample_stretches",
]

#: Stretches of consecutive query rows the matrix check reads, and the most rows of each.
STRETCHES = 4
STRETCH_ROWS = 150
#: The shortest stretch the matrix check can judge (the filter needs frames to settle).
MIN_STRETCH_ROWS = 30
#: The speed hypotheses, reference frames per query frame: a geometric ladder from about 0.25 to
#: 4 (each runs the window model over 0.8 .. 1.2 times it, so neighbours overlap).
SPEEDS = tuple(1.15**k for k in range(-10, 11))
#: Frames after a stretch's start before its matches count (the filter settles).
SETTLE_FRAMES = 20
#: Frames over which the ratio is read from the matches (their slope).
SLOPE_FRAMES = 20
#: Confidence of a match that counts, and the mean confidence below which the check has no answer.
CONFIDENT = 0.5
#: The advised window around a measured ratio, as factors of it.
ADVISED_WINDOW = (0.8, 1.2)
#: Rows standardized and filtered at once, and rows summed at once for a stretch's column
#: statistics (in float64): the check's scratch memory.
CHUNK_ROWS = 32
STATISTICS_ROWS = 8


@dataclass(frozen=True)
class SpeedRatio:
    """How fast the query moves along the reference: reference frames per query frame.

    Attributes:
        median: the median ratio.
        low, high: its 10th and 90th percentiles (over frames, or over the matches' slopes).
        source: ``"odometry"`` or ``"matches"``.
        samples: the frames (odometry) or slopes (matches) it was measured on.
    """

    median: float
    low: float
    high: float
    source: str
    samples: int

    def words(self) -> str:
        """``"0.45 reference frames per query frame (the odometry's median; 0.43..0.47 for 80 % of
        the frames)"``."""
        spread = "the frames" if self.source == "odometry" else "the matches' slopes"
        return (
            f"{self.median:.2f} reference frames per query frame (the {self.source}' median; "
            f"{self.low:.2f}..{self.high:.2f} for 80 % of {spread})"
        ).replace("odometry'", "odometry's")

    def as_dict(self) -> dict:
        """For ``summary.json``."""
        return {
            "median": round(self.median, 4),
            "p10": round(self.low, 4),
            "p90": round(self.high, 4),
            "source": self.source,
            "samples": self.samples,
        }


def _ratio(values: np.ndarray, source: str) -> SpeedRatio | None:
    values = values[np.isfinite(values)]
    if values.size == 0:
        return None
    low, median, high = np.percentile(values, [10, 50, 90])
    return SpeedRatio(float(median), float(low), float(high), source, int(values.size))


def ratio_from_odometry(advances: np.ndarray, reference_distances: np.ndarray) -> SpeedRatio | None:
    """The ratio from odometry: ``|advances[k]| / spacing`` for each query frame after the first,
    ``spacing`` the references' mean distance apart (the odometry model's, in the same unit);
    None when the references never move or there is only one query frame."""
    steps = np.abs(np.asarray(advances, dtype=np.float64))[1:]
    distances = np.asarray(reference_distances, dtype=np.float64)
    if distances.size < 2 or not distances[-1] > distances[0]:
        return None
    spacing = (distances[-1] - distances[0]) / (distances.size - 1)
    return _ratio(steps / spacing, "odometry")


def sample_stretches(n_queries: int) -> list[tuple[int, int]]:
    """The stretches ``(start, stop)`` of query rows the matrix check reads: the route cut into
    ``ceil(n / STRETCH_ROWS)`` equal consecutive stretches when that is at most ``STRETCHES``,
    else ``STRETCHES`` stretches of ``STRETCH_ROWS`` rows spread evenly from its first frame to
    its last."""
    if n_queries <= 0:
        return []
    count = -(-n_queries // STRETCH_ROWS)
    if count <= STRETCHES:
        edges = np.linspace(0, n_queries, count + 1).round().astype(int)
        return [(int(lo), int(hi)) for lo, hi in itertools.pairwise(edges)]
    starts = np.linspace(0, n_queries - STRETCH_ROWS, STRETCHES).round().astype(int)
    return [(int(start), int(start) + STRETCH_ROWS) for start in starts]


class StretchSampler:
    """Collects the rows of :func:`sample_stretches` from bands of rows given in any order.

    Example::

        sampler = StretchSampler(n_queries)
        for start, band in bands:          # (rows, n_ref) float32, rows start .. start+rows-1
            sampler.take(start, band)
        sampler.rows()                     # one (rows, n_ref) array per stretch

    In a stream, :meth:`complete` hands each stretch over as soon as it is whole
    (:class:`MatchesRatio` takes them one at a time).
    """

    def __init__(self, n_queries: int):
        self.stretches = sample_stretches(n_queries)
        self._parts: list[dict[int, np.ndarray]] = [{} for _ in self.stretches]
        self._done: set[int] = set()

    def take(self, start: int, band: np.ndarray, copy: bool = True) -> None:
        """Keeps the rows of ``band`` (query rows ``start ..``) that lie in a stretch: copies, or
        views with ``copy=False`` (``band`` must then outlive the sampler's use)."""
        stop = start + band.shape[0]
        for parts, (first, last) in zip(self._parts, self.stretches):
            lo, hi = max(first, start), min(last, stop)
            if lo < hi:
                piece = band[lo - start : hi - start]
                parts[lo] = np.array(piece, dtype=np.float32) if copy else piece

    def complete(self) -> list[np.ndarray]:
        """The stretches given whole since the last call, in order, released from the sampler (so
        that a stream holds at most the stretches still being filled)."""
        out = []
        for index, (parts, (first, last)) in enumerate(zip(self._parts, self.stretches)):
            if parts and sum(piece.shape[0] for piece in parts.values()) == last - first:
                pieces = [parts[key] for key in sorted(parts)]
                out.append(pieces[0] if len(pieces) == 1 else np.concatenate(pieces, axis=0))
                self._parts[index] = {}
                self._done.add(index)
        return out

    def rows(self) -> list[np.ndarray]:
        """Each stretch's rows, in order; raises ValueError when a row was never given."""
        out = []
        for index, (parts, (first, last)) in enumerate(zip(self._parts, self.stretches)):
            pieces = [parts[key] for key in sorted(parts)]
            if len(pieces) == 1:
                rows = pieces[0]
            else:
                rows = np.concatenate(pieces, axis=0) if pieces else np.zeros((0, 0), np.float32)
            if rows.shape[0] != last - first:
                done = " (already handed over by complete())" if index in self._done else ""
                raise ValueError(f"the speed check's stretch {first}..{last - 1} was not given whole{done}")
            out.append(rows)
        return out


def _column_statistics(stretch: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Per reference column of ``stretch``: the mean of its finite values and the inverse of their
    standard deviation (float32; 0 and 1 where a column has none or no spread), accumulated in
    float64 over chunks of rows."""
    n_refs = stretch.shape[1]
    count, total, squares = np.zeros(n_refs), np.zeros(n_refs), np.zeros(n_refs)
    for start in range(0, stretch.shape[0], STATISTICS_ROWS):
        chunk = stretch[start : start + STATISTICS_ROWS].astype(np.float64)
        finite = np.isfinite(chunk)
        chunk[~finite] = 0.0
        count += finite.sum(axis=0)
        total += chunk.sum(axis=0)
        squares += (chunk * chunk).sum(axis=0)
    mean = np.divide(total, count, out=np.zeros(n_refs), where=count > 0)
    variance = np.divide(squares, count, out=np.zeros(n_refs), where=count > 0) - mean * mean
    spread = np.sqrt(np.maximum(variance, 0.0))
    inverse = np.divide(1.0, spread, out=np.ones(n_refs), where=spread > 1e-12)
    return mean.astype(np.float32), inverse.astype(np.float32)


def _track(stretch: np.ndarray, mean: np.ndarray, inverse: np.ndarray, speed: float) -> tuple[np.ndarray, np.ndarray]:
    """(refs, confidence) of the window model at ``speed`` over ``stretch`` standardized per column."""
    params = RouteParams(filter_motion="window", vmin=ADVISED_WINDOW[0] * speed, vmax=ADVISED_WINDOW[1] * speed)
    tracker = RouteFilter(stretch.shape[1], params)
    refs, confidence = [], []
    scratch = np.empty((CHUNK_ROWS, stretch.shape[1]), np.float32)
    for start in range(0, stretch.shape[0], CHUNK_ROWS):
        rows = stretch[start : start + CHUNK_ROWS]
        chunk = scratch[: rows.shape[0]]
        np.subtract(rows, mean, out=chunk)
        np.multiply(chunk, inverse, out=chunk)
        np.nan_to_num(chunk, copy=False, nan=0.0, posinf=0.0, neginf=0.0)
        matched, sure, _ = tracker.run(chunk)
        refs.append(matched)
        confidence.append(sure)
    return np.concatenate(refs), np.concatenate(confidence)


def _slopes(refs: np.ndarray, confidence: np.ndarray, settled: int) -> np.ndarray:
    """``(refs[k + s] - refs[k]) / s`` where both matches are confident, ``s = SLOPE_FRAMES`` (or
    a third of a short stretch)."""
    frames = min(SLOPE_FRAMES, max(1, (len(refs) - settled) // 3))
    ok = confidence >= CONFIDENT
    first = np.arange(settled, len(refs) - frames)
    both = first[ok[first] & ok[first + frames]]
    return (refs[both + frames] - refs[both]).astype(np.float64) / frames


class MatchesRatio:
    """The ratio the matches show, from stretches of consecutive rows of an enhanced difference
    matrix given one at a time (``(rows, n_ref)`` float32 each, lower = more similar): each
    stretch standardized per reference column (a reference that resembles every query frame must
    not win by standing still) and tracked by the window model under each of :data:`SPEEDS`; the
    speed tracked with the highest mean confidence over all stretches (after each one's first
    ``SETTLE_FRAMES``) wins, and the ratio is the slope of its confident matches. Scratch memory:
    ``CHUNK_ROWS`` rows; a stretch may be dropped once added."""

    def __init__(self) -> None:
        self._confident = np.zeros(len(SPEEDS))
        self._counted = 0
        self._slopes: list[list[np.ndarray]] = [[] for _ in SPEEDS]

    def add(self, stretch: np.ndarray) -> None:
        """Tracks one stretch (ignored when shorter than ``MIN_STRETCH_ROWS``)."""
        if stretch.shape[0] < MIN_STRETCH_ROWS or stretch.shape[1] < 2:
            return
        mean, inverse = _column_statistics(stretch)
        settled = min(SETTLE_FRAMES, stretch.shape[0] // 5)
        self._counted += stretch.shape[0] - settled
        for index, speed in enumerate(SPEEDS):
            refs, confidence = _track(stretch, mean, inverse, speed)
            self._confident[index] += confidence[settled:].sum()
            self._slopes[index].append(_slopes(refs, confidence, settled).astype(np.float32))

    def ratio(self) -> SpeedRatio | None:
        """The ratio, or None when no stretch was long enough or no speed is tracked with a mean
        confidence of at least ``CONFIDENT`` (a query off the route)."""
        if self._counted == 0:
            return None
        best = int(np.argmax(self._confident))
        if self._confident[best] / self._counted < CONFIDENT:
            return None
        return _ratio(np.concatenate(self._slopes[best]).astype(np.float64), "matches")


def ratio_from_rows(stretches: list[np.ndarray]) -> SpeedRatio | None:
    """:class:`MatchesRatio` of these stretches."""
    matches = MatchesRatio()
    for stretch in stretches:
        matches.add(stretch)
    return matches.ratio()


@dataclass(frozen=True)
class SpeedCheck:
    """The measured speed ratio beside the range the search assumes.

    Attributes:
        ratio: the measured ratio, or None (not measurable).
        speeds: the range the search follows (:func:`~nightloc.route.params.motion_speeds`).
        advice: :class:`RouteParams` fields and values that fit the ratio (e.g.
            ``{"filter_motion": "odometry"}`` or ``{"filter_motion": "window", "vmin": 0.36,
            "vmax": 0.54}``), empty when the range covers it.
    """

    ratio: SpeedRatio | None
    speeds: MotionSpeeds
    advice: dict

    @property
    def fits(self) -> bool:
        """True unless the ratio was measured and its median lies outside the range."""
        return self.ratio is None or self.speeds.covers(self.ratio.median)

    def message(self, option: Callable[[str], str] | None = None) -> str:
        """One line naming the measured ratio, the range and what fits ("" when it fits).

        ``option(field)`` names a :class:`RouteParams` field as the user sets it (a command's
        ``--vmin``); the advice is then written ``--vmin 0.36``. Default: the fields themselves,
        written ``vmin = 0.36`` as in a ``[route]`` table."""
        if self.fits or self.ratio is None:
            return ""
        if option is None:
            advice = ", ".join(f"{key} = {value!r}" for key, value in self.advice.items())
            words = self.speeds.words()
        else:
            advice = " ".join(f"{option(key)} {value}" for key, value in self.advice.items())
            words = self.speeds.words(option)
        return f"the query advances {self.ratio.words()}, outside {words}; {advice} fits"

    def as_dict(self) -> dict:
        """For ``summary.json``: the ratio, the range and whether it fits."""
        return {
            "ratio": None if self.ratio is None else self.ratio.as_dict(),
            "search": self.speeds.search,
            "range": [self.speeds.lowest, self.speeds.highest] if self.speeds.bounded else None,
            "fits": self.fits,
            "advice": self.advice or None,
        }


def check_speed(
    params: RouteParams | str | None,
    motion: str | None,
    stretches: list[np.ndarray] | None = None,
    odometry: tuple[np.ndarray, np.ndarray] | None = None,
    matches: MatchesRatio | None = None,
) -> SpeedCheck:
    """The speed check of a run.

    Args:
        params: the run's :class:`RouteParams` (or a preset name).
        motion: the filter's motion model that ran, or None for SeqSLAM.
        stretches: the enhanced rows of :func:`sample_stretches` (:class:`StretchSampler`); read
            only without odometry.
        odometry: ``(advances, reference_distances)`` when both traverses carry odometry (used or
            not by the search): the ratio comes from it.
        matches: a :class:`MatchesRatio` already given the stretches (a stream), instead of
            ``stretches``.
    """
    p = resolve_params(params)
    speeds = motion_speeds(p, motion)
    if odometry is not None:
        ratio = ratio_from_odometry(*odometry)
    elif matches is not None and speeds.bounded:
        ratio = matches.ratio()
    elif stretches is not None and speeds.bounded:
        ratio = ratio_from_rows(stretches)
    else:
        ratio = None
    advice: dict = {}
    if ratio is not None and not speeds.covers(ratio.median):
        if odometry is not None and motion is not None:
            advice = {"filter_motion": "odometry"}
        else:
            low, high = (round(factor * ratio.median, 2) for factor in ADVISED_WINDOW)
            advice = ({"filter_motion": "window"} if motion is not None else {}) | {"vmin": low, "vmax": high}
    return SpeedCheck(ratio, speeds, advice)
