"""Experience maps: a map that learns from its nights (docs/experience_maps.md).

Day-to-night matching is hard, night-to-night matching easy: a robot that runs every night keeps
the frames it localized confidently and matches the next night against them too.

::

    night = localize_night(day_map, load_traverse("night1"), odometry)   # the localizer's run
    new_map, report = learn(day_map, night)
    print(report.line())
    new_map.save("night1.map")

What is learned (:class:`LearningParams`, TOML ``[learning]``):

* **Only what is trusted.** A frame is learned only after the belief has settled: its confidence
  is at least ``min_confidence`` and its credible radius at most ``max_credible_radius`` metres,
  and so were the ``settled_frames - 1`` frames before it. A run that never settles adds nothing
  (the report says so).
* **Appearances of places.** A place is a distinct reference position (several references at
  one position form one place, :class:`~nightloc.localization.heatmap.HeatMapper`; the filter and
  the heat map score a place by the best of its references). A trusted frame within
  ``attach_fraction`` x the day map's place spacing (the median distance from a place to its
  nearest neighbour) of a place belongs to that place, and to every other place that near (for a
  forward camera, to the view of it whose heading is within ``heading_tolerance`` degrees): every
  place the night passes gets a look, wherever its poses fall between places, so no place is
  left without one beside neighbours that have one. Per place view and night, the frame
  nearest to the place is its candidate; it becomes another appearance of the place, stored at
  the place's position (a learned pose that is slightly wrong does not blur the heat map), when
  tonight's look is *new* there: for every frame of the night belonging to the place, the best of
  the place's appearances scores above ``novelty`` x the frame's median score over the whole map
  (the score the filter scales its likelihood by). A frame with no place
  within ``gap_fraction`` x the spacing fills a gap: a new place at the localizer's pose.
* **Usefulness.** Every trusted frame that belongs to a place counts one match for the place's
  appearance that scored best against it (:attr:`~nightloc.io.appearances.Appearances.matches`).
* **A cap per place.** A place view holds at most ``max_learned`` learned appearances; beyond,
  the retention policy (``retention``, :data:`RETENTION_POLICIES`) says which goes: by default
  the least useful one (the fewest matches, ties the oldest night, then the lowest confidence).
  The day map's references (survey or teach run) are never evicted, nor the appearance just
  learned. With the localizer's recall (``GridFilterMap::learned``: per frame only the looks
  nearest the belief, as many as the day references, are matched) memory and time per frame stay
  bounded however long the season.
* **Provenance.** Each reference records its night (0: the day map), confidence, time and match
  count (:class:`~nightloc.io.appearances.Appearances`); the map's header lists the nights learned.

A night is learned only into the map it was localized against (the map's
:attr:`~nightloc.ReferenceMap.fingerprint`), so frames of another camera or another world never
enter a map.
"""

from __future__ import annotations

import copy
import dataclasses
import datetime as dt
import math
from collections.abc import Callable, Iterable, Sequence
from dataclasses import dataclass

import numpy as np
from scipy.spatial import cKDTree

from ..config import params_section
from ..errors import MapFormatError
from ..io.appearances import Appearances, LearnedNight
from ..localization.localizer import Estimate, Localizer
from ..mapping.reference_map import ReferenceMap
from ..matching.sad import match
from ..motion.odometry import NoiseModel, as_motion, reverse_motion, wrap_angle
from ..preparation.params import PreparationParams
from ..schema import ABOVE_0, AT_LEAST_0, Range, own_field

__all__ = [
    "RETENTION_POLICIES",
    "LearningParams",
    "LearningReport",
    "LocalizedNight",
    "NightLearner",
    "RetentionPolicy",
    "backward_estimates",
    "learn",
    "localize_night",
    "smoothed_estimates",
    "trust_night",
    "trusted_frames",
]

#: The place spacing assumed for a map of a single place (metres).
_SINGLE_PLACE_SPACING = 1.0
#: A look within this many place spacings of a place is at that place or its neighbour (the
#: tolerance keeps a grid's diagonal out and its rounding in).
_SAME_PLACE = 1.01
#: Frames between two saved states of a learner's forward run at first (the spacing doubles
#: whenever more than :data:`MAX_CHECKPOINTS` states are saved).
CHECKPOINT_FRAMES = 128
#: Saved states of a learner's forward run kept at most.
MAX_CHECKPOINTS = 32
#: Bytes of forward beliefs a learner keeps by default; a longer night's are recomputed from the
#: saved states when the night ends.
BELIEF_BUDGET = 128 * 2**20


@dataclass(frozen=True)
class RetentionPolicy:
    """Which learned appearances of a place view go first when a night's new look would exceed
    the cap: :meth:`order` sorts them, the first goes first. ``key`` maps an appearance (its
    record ``Appearances``, its matches so far, tonight's night number, its index) to a sort key."""

    name: str
    description: str
    key: Callable[[Appearances, np.ndarray, int, int], tuple]

    def order(self, refs: Sequence[int], record: Appearances, matches: np.ndarray, night: int) -> list[int]:
        """``refs`` (learned appearances' indices), the first to go first."""
        return sorted(refs, key=lambda r: self.key(record, matches, night, r))


#: The retention policies by name (:attr:`LearningParams.retention`; the sweep in
#: docs/experience_maps.md chose the default).
RETENTION_POLICIES: dict[str, RetentionPolicy] = {
    policy.name: policy
    for policy in (
        RetentionPolicy(
            "usage",
            "the fewest matches (ties: the oldest night, the lowest confidence)",
            lambda rec, m, night, r: (int(m[r]), int(rec.night[r]), float(rec.confidence[r]), r),
        ),
        RetentionPolicy(
            "recency",
            "the oldest night learned (ties: the fewest matches)",
            lambda rec, m, night, r: (int(rec.night[r]), int(m[r]), r),
        ),
        RetentionPolicy(
            "usage_rate",
            "the fewest matches per night since learned (ties: the oldest night)",
            lambda rec, m, night, r: (int(m[r]) / max(night - int(rec.night[r]), 1), int(rec.night[r]), r),
        ),
    )
}


@params_section("learning")
@dataclass(frozen=True)
class LearningParams:
    """What a night may teach a map (TOML ``[learning]``; defaults from the sweep in
    docs/experience_maps.md).

    Attributes:
        min_confidence: a frame is trusted when the localizer's confidence is at least this (0..1).
        max_credible_radius: ... and its credible radius at most this, metres.
        settled_frames: ... and so were the frames before it: this many in a row (>= 1).
        attach_fraction: a frame belongs to every place within this fraction of the day map's
            place spacing (median nearest-neighbour distance between places).
        gap_fraction: a frame with no place within this fraction of the spacing becomes a new
            place (>= attach_fraction); frames in between are not learned.
        heading_tolerance: degrees; a forward camera's frame belongs to a place's view of the
            nearest heading within this (panoramas: any heading).
        novelty: a place learns tonight's look when, for each of tonight's frames belonging to it,
            the best of its appearances scores above this fraction of the frame's median score
            over the map (0: always, a large value: never).
        max_learned: learned appearances kept per place view (>= 1).
        retention: which learned appearance of a full place view goes for a new one, a name of
            :data:`RETENTION_POLICIES`.
        max_look_ratio: a night is not learned when its trusted frames match their places'
            learned appearances no better than this fraction of their median score over all
            learned appearances (the median over the frames): it does not look like this map's
            nights (another garden). Checked once the map has learned appearances at the places
            of at least ``settled_frames`` of the night's frames.
        min_look_hits: ... nor when fewer than this share of those frames (0..1) find their best
            learned appearance over the whole map at their place or a neighbouring one (within one
            place spacing): tonight's frames match looks anywhere, not those of where they are.
    """

    min_confidence: float = own_field(0.8, range=Range(0, 1))
    max_credible_radius: float = own_field(0.75, unit="m", range=ABOVE_0)
    settled_frames: int = own_field(5, unit="frames", range=Range(1, math.inf))
    attach_fraction: float = own_field(0.75, unit="place spacings", range=ABOVE_0)
    gap_fraction: float = own_field(1.0, unit="place spacings", range=ABOVE_0)
    heading_tolerance: float = own_field(45.0, unit="degrees", range=Range(0, 180, min_open=True))
    novelty: float = own_field(0.5, range=AT_LEAST_0)
    max_learned: int = own_field(2, range=Range(1, math.inf))
    retention: str = "usage"
    max_look_ratio: float = own_field(0.85, range=ABOVE_0)
    min_look_hits: float = own_field(0.8, range=Range(0, 1))

    def validate(self) -> None:
        """The rules the table cannot say (each field's range is checked on construction): the
        two fractions' order, the retention policy's name."""
        if self.attach_fraction > self.gap_fraction:
            raise ValueError(
                f"need attach_fraction <= gap_fraction, got {self.attach_fraction} and {self.gap_fraction}"
            )
        if self.retention not in RETENTION_POLICIES:
            raise ValueError(f"retention must be one of {', '.join(RETENTION_POLICIES)}, got {self.retention!r}")


@dataclass(frozen=True, eq=False)
class LocalizedNight:
    """A night log localized against a map: what :func:`learn` learns from.

    Attributes:
        images: ``(M, Ry, Rx)`` uint8, the frames prepared with the map's parameters.
        estimates: the localizer's M estimates (the grid filter's: confidence and credible radius).
        score_medians: ``(M,)`` float64, each frame's median over the map's references of its
            minimum score (eq. 3): the scale novelty is judged on.
        names: the M frame names; ``timestamps``: ``(M,)`` seconds or None.
        source: the log (a path), for the map's history.
        map_fingerprint: :attr:`ReferenceMap.fingerprint` of the map it was localized against.
        params: the preparation parameters of ``images``.
        backward: the M estimates of the same filter run over the night backwards (last frame
            first, each motion reversed), in frame order; None when only the forward run was made.
        smoothed: the M estimates of the product of the two runs' beliefs (each frame's forward
            belief times the backward run's prediction of it: what the whole night says of it);
            None without the backward run.
        learned_medians: ``(M,)`` each frame's median over the map's learned appearances of its
            minimum score (the scale a learned look's match is judged on), or None (a day map).
        best_looks: ``(M,)`` int, each frame's best-matching learned appearance (an index into the
            map's references), or None (a day map).
    """

    images: np.ndarray
    estimates: tuple[Estimate, ...]
    score_medians: np.ndarray
    names: tuple[str, ...]
    timestamps: np.ndarray | None
    source: str
    map_fingerprint: str
    params: PreparationParams
    backward: tuple[Estimate, ...] | None = None
    smoothed: tuple[Estimate, ...] | None = None
    learned_medians: np.ndarray | None = None
    best_looks: np.ndarray | None = None

    def __len__(self) -> int:
        return len(self.estimates)


class NightLearner:
    """A night localized frame by frame, keeping what :func:`learn` needs (the streaming form of
    :func:`localize_night`, e.g. a live robot's frames).

    Args:
        ref_map: the map.
        localizer: a filter :class:`Localizer` over ``ref_map`` (default ``Localizer(ref_map)``);
            it is reset first.
        backward: keep each frame's motion and the forward run's position beliefs, so that
            :meth:`night` also runs the filter over the night backwards and smooths the two runs
            (as :func:`localize_night`).
        belief_budget: bytes of forward beliefs (``(Ny, Nx)`` float64 per frame) kept; a night
            whose beliefs would need more keeps only the filter's state every few hundred frames
            (at most :data:`MAX_CHECKPOINTS`, plus one wherever the localizer was moved between
            two frames: a reset, a set pose) and :meth:`night` recomputes the beliefs from them
            (one more forward pass, the same result). Either way the learner holds each prepared
            frame and a few numbers per frame besides.

    The localizer's noise model may change between frames (each frame's is kept); the backward
    run moves each step with the noise model of the forward step it reverses.
    """

    def __init__(
        self,
        ref_map: ReferenceMap,
        localizer: Localizer | None = None,
        *,
        backward: bool = True,
        belief_budget: int = BELIEF_BUDGET,
    ):
        loc = Localizer(ref_map) if localizer is None else localizer
        if loc.ref_map is not ref_map and loc.ref_map != ref_map:
            raise ValueError("the localizer runs over another map than ref_map")
        if loc.method != "filter":
            raise ValueError("learning needs the grid filter's confidence: a Localizer with method='filter'")
        loc.reset()
        self.ref_map = ref_map
        self.localizer = loc
        self.backward = backward
        self._images: list[np.ndarray] = []
        self._estimates: list[Estimate] = []
        self._medians: list[float] = []
        self._look_medians: list[float] = []
        self._best_looks: list[int] = []
        if belief_budget < 0:
            raise ValueError(f"belief_budget must be >= 0 bytes, got {belief_budget}")
        self._belief_budget = int(belief_budget)
        self._beliefs: list[np.ndarray] | None = []
        #: (frame, the localizer before it, pinned: the localizer was moved from outside there)
        self._checkpoints: list[tuple[int, Localizer, bool]] = []
        self._checkpoint_spacing = CHECKPOINT_FRAMES
        self._revision: int | None = None
        self._motions: list[object] = []
        self._noises: list[NoiseModel] = []
        night = None if ref_map.appearances is None else np.asarray(ref_map.appearances.night) > 0
        self._looks = night if night is not None and night.any() else None
        self._look_index = np.zeros(0, np.int64) if self._looks is None else np.flatnonzero(self._looks)

    def __len__(self) -> int:
        return len(self._estimates)

    def step(self, frame: np.ndarray, motion: object = None, *, prepared: bool = False) -> Estimate:
        """Localizes one raw camera frame (or a prepared one, ``prepared=True``) with ``motion``
        since the previous frame (see :meth:`Localizer.update`), and keeps it."""
        image = frame if prepared else self.ref_map.preparer.prepare(frame)
        if self.backward:
            k = len(self._estimates)
            moved = self._revision is not None and self.localizer.revision != self._revision
            if moved or k % self._checkpoint_spacing == 0:
                self._checkpoints.append((k, copy.copy(self.localizer), moved))  # the state before frame k
        table = self.localizer.score_table(image, prepared=True)
        estimate = self.localizer.update_table(table, motion)
        self._estimates.append(estimate)
        self._images.append(image)
        mins = table.min(axis=1)
        self._medians.append(float(np.median(mins)))
        if self._looks is not None:
            self._look_medians.append(float(np.median(mins[self._looks])))
            self._best_looks.append(int(self._look_index[np.argmin(mins[self._looks])]))
        if self.backward:
            self._revision = self.localizer.revision
            self._motions.append(motion)
            self._noises.append(self.localizer.noise)
            self._keep_belief()
        return estimate

    def _keep_belief(self) -> None:
        if self._beliefs is not None:
            belief = self.localizer.belief
            if (len(self._beliefs) + 1) * belief.nbytes > self._belief_budget:
                self._beliefs = None  # from now on recomputed from the checkpoints
            else:
                self._beliefs.append(belief)
        if sum(not pinned for _, _, pinned in self._checkpoints) > MAX_CHECKPOINTS:
            self._checkpoint_spacing *= 2
            spacing = self._checkpoint_spacing
            self._checkpoints = [c for c in self._checkpoints if c[2] or c[0] % spacing == 0]

    def _forward_beliefs_reversed(self, images: np.ndarray) -> Iterable[np.ndarray]:
        """The forward run's position beliefs from the last frame to the first: kept, or
        recomputed block by block from the checkpoints (the same filter over the same frames)."""
        if self._beliefs is not None:
            yield from reversed(self._beliefs)
            return
        ends = [start for start, _, _ in self._checkpoints[1:]] + [len(self._estimates)]
        for (start, state, _), end in reversed(list(zip(self._checkpoints, ends, strict=True))):
            replay = copy.copy(state)
            block = []
            for k in range(start, end):
                if replay.noise != self._noises[k]:
                    replay.noise = self._noises[k]
                replay.update_table(replay.score_table(images[k], prepared=True), self._motions[k])
                block.append(replay.belief)
            yield from reversed(block)

    def night(
        self,
        names: Sequence[str] | None = None,
        timestamps: Sequence[float] | np.ndarray | None = None,
        source: str = "",
    ) -> LocalizedNight:
        """The frames so far as a :class:`LocalizedNight` (``names``, ``timestamps`` in seconds
        and ``source`` as :func:`localize_night` takes them). With ``backward``, the backward run
        and the smoother run here (the localizer's belief is replaced)."""
        ref_map = self.ref_map
        m = len(self._estimates)
        if names is None:
            names = [f"{k:06d}" for k in range(m)]
        if len(names) != m:
            raise ValueError(f"{len(names)} names for {m} frames")
        times = None if timestamps is None else np.asarray(timestamps, dtype=np.float64)
        if times is not None and times.shape != (m,):
            raise ValueError(f"timestamps must be ({m},) seconds, got shape {times.shape}")
        shape = (0, ref_map.params.height, ref_map.params.width)
        images = np.stack(self._images) if self._images else np.zeros(shape, np.uint8)
        back, smoothed = None, None
        if self.backward and m > 1:
            noise = self.localizer.noise  # the backward run takes each frame's; the forward run's goes on
            smoother = self.localizer.fresh()  # its estimates carry no heading (trust_night takes a run's)
            backward, smoothing = [], []
            backward_run = _backward_run(self.localizer, images, self._motions, self._noises)
            runs = zip(backward_run, self._forward_beliefs_reversed(images))
            for (estimate, ahead), belief in runs:
                backward.append(estimate)
                smoothing.append(_smoothed(smoother, belief, ahead))
            back, smoothed = tuple(backward[::-1]), tuple(smoothing[::-1])
            self.localizer.noise = noise
        return LocalizedNight(
            images,
            tuple(self._estimates),
            np.asarray(self._medians, dtype=np.float64),
            tuple(names),
            times,
            str(source),
            ref_map.fingerprint,
            ref_map.params,
            back,
            smoothed,
            np.asarray(self._look_medians, dtype=np.float64) if self._look_medians else None,
            np.asarray(self._best_looks, dtype=np.int64) if self._best_looks else None,
        )


def localize_night(
    ref_map: ReferenceMap,
    frames: Iterable[np.ndarray],
    odometry: Sequence[object] | None = None,
    localizer: Localizer | None = None,
    *,
    names: Sequence[str] | None = None,
    timestamps: Sequence[float] | np.ndarray | None = None,
    source: str = "",
    backward: bool = True,
) -> LocalizedNight:
    """Runs the grid filter over a night's frames, keeping what :func:`learn` needs.

    Args:
        ref_map: the map.
        frames: raw camera frames (prepared here with the map's parameters).
        odometry: one motion per frame (see :meth:`Localizer.update`), or None: all unknown.
        localizer: a filter :class:`Localizer` over ``ref_map`` (default ``Localizer(ref_map)``);
            it is reset first.
        names, timestamps, source: the log's frame names, times (seconds) and path.
        backward: also run the filter over the night backwards (:func:`backward_estimates`), so
            that the frames before the forward run settled can be learned too, and a frame the
            two runs place apart is not (:func:`trust_night`).
    """
    learner = NightLearner(ref_map, localizer, backward=backward)
    for k, frame in enumerate(frames):
        learner.step(frame, None if odometry is None else odometry[k])
    return learner.night(names, timestamps, source)


def backward_estimates(
    localizer: Localizer, images: np.ndarray, odometry: Sequence[object]
) -> tuple[tuple[Estimate, ...], list[np.ndarray | None]]:
    """The filter run over a night backwards: prepared ``images`` ``(M, Ry, Rx)`` from the last to
    the first, each fed the reverse of the motion that led to the next frame
    (:func:`~nightloc.motion.odometry.reverse_motion`). Returns the M estimates and, per frame, the
    run's position belief predicted to it before its own frame (None for the last frame: no
    prediction), both in frame order. The localizer is reset first."""
    out: list[Estimate] = []
    predicted: list[np.ndarray | None] = []
    for estimate, ahead in _backward_run(localizer, images, odometry):
        out.append(estimate)
        predicted.append(ahead)
    return tuple(out[::-1]), predicted[::-1]


def _backward_run(
    localizer: Localizer,
    images: np.ndarray,
    odometry: Sequence[object],
    noises: Sequence[NoiseModel] | None = None,
) -> Iterable[tuple[Estimate, np.ndarray | None]]:
    """:func:`backward_estimates`' run, one frame at a time from the last: its estimate and the
    belief predicted to it (each step moved with ``noises[k + 1]``, the noise model of the
    forward step it reverses, when given)."""
    localizer.reset()
    for k in range(len(images) - 1, -1, -1):
        table = localizer.score_table(images[k], prepared=True)
        motion = None if k + 1 == len(images) else reverse_motion(as_motion(odometry[k + 1]))
        if noises is not None and motion is not None and localizer.noise != noises[k + 1]:
            localizer.noise = noises[k + 1]
        if motion is None:
            yield localizer.update_table(table), None
        else:
            yield localizer.update_table_with_prior(table, motion)


def smoothed_estimates(
    localizer: Localizer, forward: Sequence[np.ndarray], predicted: Sequence[np.ndarray | None]
) -> tuple[Estimate, ...]:
    """Per frame the estimate of its forward belief times the backward run's prediction of it
    (the night's evidence before and after the frame, the frame's own once): the two-filter
    smoother, over position. ``localizer``'s belief is replaced (it ends at the first frame's)."""
    return tuple(_smoothed(localizer, belief, ahead) for belief, ahead in zip(forward, predicted, strict=True))


def _smoothed(localizer: Localizer, belief: np.ndarray, ahead: np.ndarray | None) -> Estimate:
    product = belief if ahead is None else belief * ahead
    return localizer.estimate_belief(product if product.sum() > 0 else belief)


def trusted_frames(estimates: Sequence[Estimate], params: LearningParams) -> np.ndarray:
    """``(M,)`` bool: the frames learned from (confident, tight, after the belief settled)."""
    good = np.array([_confident(e, params) for e in estimates], dtype=bool)
    run = 0
    trusted = np.zeros_like(good)
    for k, ok in enumerate(good):
        run = run + 1 if ok else 0
        trusted[k] = run >= params.settled_frames
    return trusted


def _confident(estimate: Estimate, params: LearningParams) -> bool:
    return (
        math.isfinite(estimate.confidence)
        and estimate.confidence >= params.min_confidence
        and math.isfinite(estimate.credible_radius)
        and estimate.credible_radius <= params.max_credible_radius
        and math.isfinite(estimate.x)
        and math.isfinite(estimate.y)
    )


def trust_night(night: LocalizedNight, params: LearningParams, agree: float) -> tuple[np.ndarray, tuple[Estimate, ...]]:
    """The frames learned from, ``(M,)`` bool, and the estimate each is learned at.

    A frame is trusted by a run: the forward run, the backward run or their product (the
    smoother), each settled as :func:`trusted_frames` says (the backward run's settled frames count
    backwards in time). It is learned at the smoother's position (with the tighter run's heading)
    if that trusts it, else at the tighter trusting run's estimate; unless the forward or the
    backward run, confident there (confidence and credible radius within the thresholds), places
    it more than ``agree`` metres away: the runs then disagree (a robot carried off, a
    look-alike), and nothing is taken.
    """
    runs = [night.estimates] if night.backward is None else [night.estimates, night.backward]
    trusted = [trusted_frames(night.estimates, params)]
    if night.backward is not None:
        trusted.append(trusted_frames(night.backward[::-1], params)[::-1])
    smoothed = night.smoothed
    by_smoother = np.zeros(len(night), dtype=bool) if smoothed is None else trusted_frames(smoothed, params)
    chosen: list[Estimate] = []
    keep = np.zeros(len(night), dtype=bool)
    for k in range(len(night)):
        candidates = [run[k] for run, ok in zip(runs, trusted, strict=True) if ok[k]]
        tightest = min(candidates or [run[k] for run in runs], key=lambda e: e.credible_radius)
        best = tightest
        if smoothed is not None and by_smoother[k]:  # the smoother's position, a run's heading
            best = dataclasses.replace(smoothed[k], heading=tightest.heading)
        chosen.append(best)
        keep[k] = (bool(candidates) or bool(by_smoother[k])) and all(
            math.hypot(run[k].x - best.x, run[k].y - best.y) <= agree for run in runs if _confident(run[k], params)
        )
    return keep, tuple(chosen)


@dataclass(frozen=True)
class LearningReport:
    """What a night taught a map.

    Attributes:
        night: the night's number in the map's line (0: nothing was learned).
        frames: frames of the night; ``trusted``: those learned from; ``first_trusted``: the
            first of them (None: the belief never settled).
        attached: trusted frames that belong to a place; ``known``: places that had a look like
            tonight's already (nothing learned there).
        appearances: appearances added to places; ``places``: new places; ``evicted``: learned
            appearances evicted by the cap.
        places_before: places of the map before learning; ``references``: references after.
        refused: why the night was not learned although frames were trusted ("" when it was).
    """

    night: int
    frames: int
    trusted: int
    first_trusted: int | None
    attached: int
    known: int
    appearances: int
    places: int
    evicted: int
    places_before: int
    references: int
    refused: str = ""

    @property
    def growth(self) -> float:
        """References added (appearances and new places, less evictions) per place before."""
        return (self.appearances + self.places - self.evicted) / max(self.places_before, 1)

    def line(self) -> str:
        """One line for a person."""
        if self.refused:
            return f"learned nothing: {self.refused}"
        if self.first_trusted is None:
            return (
                f"learned nothing: the localizer never settled on a confident pose in {self.frames} frames "
                f"(see [learning] min_confidence, max_credible_radius, settled_frames)"
            )
        return (
            f"night {self.night}: {self.trusted} of {self.frames} frames trusted (from frame {self.first_trusted}); "
            f"{self.appearances} appearances added to places, {self.places} new places, {self.known} already known, "
            f"{self.evicted} evicted by the cap; {self.references} references "
            f"({100 * self.growth:+.1f} % of {self.places_before} places)"
        )


def _places(positions: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Distinct positions ``(P, 2)`` and the place of each reference ``(N,)`` (as the heat map groups them)."""
    places, inverse = np.unique(np.round(positions, 9), axis=0, return_inverse=True)
    return places, np.asarray(inverse).ravel()


def place_spacing(positions: np.ndarray) -> float:
    """Median distance (metres) from a place to its nearest neighbouring place."""
    places, _ = _places(positions)
    if len(places) < 2:
        return _SINGLE_PLACE_SPACING
    distances, _ = cKDTree(places).query(places, k=2)
    return float(np.median(distances[:, 1]))


def _check_night(ref_map: ReferenceMap, night: LocalizedNight) -> None:
    if not isinstance(night, LocalizedNight):
        raise TypeError(f"night must be a LocalizedNight (localize_night), got {type(night).__name__}")
    if night.params != ref_map.params:
        different = ", ".join(night.params.differences(ref_map.params))
        raise MapFormatError(
            f"the night's frames were prepared with other parameters than the map's ({different}): a map of "
            f"another camera; localize the night against this map to learn from it"
        )
    if night.map_fingerprint != ref_map.fingerprint:
        raise MapFormatError(
            f"the night was localized against another map (fingerprint {night.map_fingerprint[:12]}, this map "
            f"{ref_map.fingerprint[:12]}): a night is learned only into the map it was localized against; "
            f"localize it against this map first (nightloc localize MAP LOG --out RUN --learn NEW_MAP)"
        )
    shape = (len(night), ref_map.params.height, ref_map.params.width)
    if night.images.shape != shape or night.score_medians.shape != (len(night),) or len(night.names) != len(night):
        raise ValueError(f"the night's arrays disagree: images {night.images.shape}, expected {shape}")


#: A place view: (place index, heading in radians; 0.0 for a panorama's single view).
_View = tuple[int, float]


class _PlaceViews:
    """The map's place views: a panorama's place has one, a forward camera's one per distinct
    reference heading there (a frame belongs to the view nearest in heading, within ``tolerance``
    radians)."""

    def __init__(self, ref_map: ReferenceMap, place_of_ref: np.ndarray, tolerance: float):
        self.forward = not ref_map.params.wrap and ref_map.headings is not None
        self.headings = ref_map.headings
        self.place_of_ref = place_of_ref
        self.tolerance = tolerance

    def of(self, place: int, heading: float) -> _View | None:
        """The place view a frame of ``heading`` belongs to (forward: nearest heading in tolerance)."""
        if not self.forward:
            return (place, 0.0)
        assert self.headings is not None
        members = np.flatnonzero(self.place_of_ref == place)
        views = np.unique(np.round(self.headings[members], 9))
        gaps = np.abs(wrap_angle(views - heading))
        k = int(np.argmin(gaps))
        return (place, float(views[k])) if gaps[k] <= self.tolerance else None

    def refs(self, view: _View) -> np.ndarray:
        """The indices of the view's references."""
        members = self.place_of_ref == view[0]
        if self.forward:
            assert self.headings is not None
            members &= np.round(self.headings, 9) == view[1]
        return np.flatnonzero(members)


def _attach_frames(
    estimates: tuple[Estimate, ...],
    trusted: np.ndarray,
    places: np.ndarray,
    views: _PlaceViews,
    attach: float,
    gap: float,
) -> tuple[dict[_View, list[int]], dict[int, _View], list[int]]:
    """The trusted frames within ``attach`` metres of a place, by place view (a frame belongs to
    every place that near: each place passed gets a look, however the night's poses fall between
    places), each attached frame's nearest place view, and the frames that fill a gap (no place
    within ``gap`` metres, nor a gap frame of this night nearer than its place)."""
    tree = cKDTree(places)
    new_places: list[int] = []  # frames that become new places
    attached: dict[_View, list[int]] = {}
    nearest: dict[int, _View] = {}
    for k in np.flatnonzero(trusted):
        e = estimates[k]
        distance, place = tree.query((e.x, e.y))
        if new_places:
            new_xy = np.array([(estimates[f].x, estimates[f].y) for f in new_places])
            nearest_new = float(np.min(np.hypot(*(new_xy - (e.x, e.y)).T)))
            if nearest_new < distance:
                if nearest_new >= gap:
                    new_places.append(int(k))
                continue  # near a place of this night: it holds this night's look already
        if distance <= attach:
            view = views.of(int(place), e.heading)
            if view is not None:
                nearest[int(k)] = view
            for near in tree.query_ball_point((e.x, e.y), attach):
                view = views.of(int(near), e.heading)
                if view is not None:
                    attached.setdefault(view, []).append(int(k))
        elif distance >= gap:
            new_places.append(int(k))
    return attached, nearest, new_places


@dataclass
class _Looks:
    """What tonight's attached frames say of their place views.

    Attributes:
        matches: ``(N,)`` the map's match counts plus tonight's (one per attached frame and view it
            belongs to, to the view's best appearance).
        learned: per view whose look is new: (view, the frame learned, its best appearance).
        known: views that had a look like tonight's already.
        look_ratios: per attached frame whose nearest view has learned appearances: their best
            score there over the frame's median score over all learned appearances.
        look_hits: per such frame, whether its best learned appearance over the whole map stands
            within one place spacing of that view's place.
    """

    matches: np.ndarray
    learned: list[tuple[_View, int, int]]
    known: int
    look_ratios: list[float]
    look_hits: list[bool]


def _judge_looks(
    ref_map: ReferenceMap,
    night: LocalizedNight,
    record: Appearances,
    estimates: tuple[Estimate, ...],
    places: np.ndarray,
    views: _PlaceViews,
    attached: dict[_View, list[int]],
    nearest: dict[int, _View],
    novelty: float,
    spacing: float,
) -> _Looks:
    """Each view's frames matched against its appearances: the match counts, and whether tonight's
    look is new there (no frame scores within ``novelty`` x its median score)."""
    looks = _Looks(record.matches.copy(), [], 0, [], [])
    shifts = ref_map.params.shifts
    for target, frames in attached.items():
        refs = views.refs(target)
        learned_refs = record.night[refs] > 0
        spot = places[target[0]]
        candidate = min(frames, key=lambda f: (_distance(estimates[f], spot), -estimates[f].confidence))
        seen, best_of_candidate = False, -1
        for f in frames:
            result = match(night.images[f], ref_map.images[refs], shifts=shifts, threads=1)
            looks.matches[refs[result.index]] += 1
            seen |= bool(result.score <= novelty * night.score_medians[f])
            if learned_refs.any() and night.learned_medians is not None and nearest.get(f) == target:
                looks.look_ratios.append(float(result.scores[learned_refs].min() / night.learned_medians[f]))
                if night.best_looks is not None:
                    where = ref_map.positions[night.best_looks[f]]
                    looks.look_hits.append(math.dist(where, spot) <= spacing * _SAME_PLACE)
            if f == candidate:
                best_of_candidate = int(refs[result.index])
        if seen:
            looks.known += 1  # the place has a look like tonight's already
        else:
            looks.learned.append((target, candidate, best_of_candidate))
    return looks


def _evictions(
    looks: _Looks, views: _PlaceViews, record: Appearances, number: int, params: LearningParams
) -> list[int]:
    """The cap: the retention policy's first learned appearances of each view that would overflow."""
    policy = RETENTION_POLICIES[params.retention]
    evict: list[int] = []
    for view, _, _ in looks.learned:
        refs = views.refs(view)
        old = [int(r) for r in refs if record.night[r] > 0]
        excess = len(old) + 1 - params.max_learned
        if excess > 0:
            evict.extend(policy.order(old, record, looks.matches, number)[:excess])
    return evict


class _NewReferences:
    """The map's kept references, then the night's frames added one by one (:meth:`add`)."""

    def __init__(self, ref_map: ReferenceMap, night: LocalizedNight, number: int, keep: np.ndarray):
        self.night, self.number = night, number
        self.images = [ref_map.images[keep]]
        self.positions = [ref_map.positions[keep]]
        self.headings = None if ref_map.headings is None else [ref_map.headings[keep]]
        self.covariances = None if ref_map.covariances is None else [ref_map.covariances[keep]]
        self.names = [ref_map.names[i] for i in keep]
        self.taken = set(self.names)
        self.nights: list[int] = []
        self.confidences: list[float] = []
        self.times: list[float] = []

    def add(self, frame: int, estimate: Estimate, position: np.ndarray, heading: float, covariance) -> None:
        """Frame ``frame`` of the night as a reference at ``position`` (metres), ``heading`` (radians)."""
        night = self.night
        self.images.append(night.images[frame][None])
        self.positions.append(np.asarray(position, dtype=np.float64)[None])
        if self.headings is not None:
            self.headings.append(np.array([heading]))
        if self.covariances is not None and covariance is not None:
            self.covariances.append(covariance[None])
        name = f"night{self.number}/{night.names[frame]}"
        while name in self.taken:
            name += "'"
        self.taken.add(name)
        self.names.append(name)
        self.nights.append(self.number)
        self.confidences.append(min(max(float(estimate.confidence), 0.0), 1.0))
        self.times.append(math.nan if night.timestamps is None else float(night.timestamps[frame]))


def _add_night(
    ref_map: ReferenceMap,
    night: LocalizedNight,
    estimates: tuple[Estimate, ...],
    learned: list[tuple[_View, int, int]],
    new_places: list[int],
    views: _PlaceViews,
    new: _NewReferences,
) -> None:
    """The learned looks, each at its place's position (a view's heading, or the frame's), and the
    gap frames, each a new place at the localizer's pose with its uncertainty."""
    for view, f, best in learned:
        e = estimates[f]
        heading = view[1] if views.forward else _frame_heading(e, ref_map, night, f, best)
        cov = None if ref_map.covariances is None else ref_map.covariances[best]
        new.add(f, e, ref_map.positions[best], heading, cov)
    for f in new_places:
        e = estimates[f]
        best = int(match(night.images[f], ref_map.images, shifts=ref_map.params.shifts, threads=1).index)
        heading = e.heading if math.isfinite(e.heading) else _frame_heading(e, ref_map, night, f, best)
        cov = None
        if ref_map.covariances is not None:
            cov = np.zeros((3, 3))
            cov[:2, :2] = np.asarray(e.covariance) if e.covariance is not None else np.eye(2) * e.credible_radius**2
            cov[2, 2] = (math.pi / ref_map.params.width) ** 2
        new.add(f, e, np.array([e.x, e.y]), heading, cov)


def _learned_map(
    ref_map: ReferenceMap,
    record: Appearances,
    history: LearnedNight,
    matches: np.ndarray,
    keep: np.ndarray,
    new: _NewReferences,
) -> ReferenceMap:
    """The map of ``new``'s references with their provenance (the kept ones' from ``record``)."""
    added = record.subset(keep)
    appearances = Appearances(
        np.concatenate([added.night, np.asarray(new.nights, np.int32)]),
        np.concatenate([added.confidence, np.asarray(new.confidences, np.float64)]),
        np.concatenate([added.time, np.asarray(new.times, np.float64)]),
        np.concatenate([matches[keep], np.zeros(len(new.nights), np.int64)]),
        (*record.nights, history),
        record.day_fingerprint,
    )
    return ReferenceMap(
        np.concatenate(new.images),
        np.concatenate(new.positions),
        None if new.headings is None else np.concatenate(new.headings),
        new.names,
        ref_map.params,
        ref_map.source,
        ref_map.frame_size,
        pose_source=ref_map.pose_source,
        covariances=None if new.covariances is None else np.concatenate(new.covariances),
        appearances=appearances,
        settings=ref_map.settings,
    )


def _look_refusal(looks: _Looks, params: LearningParams) -> str:
    """Why the night is not learned ("" when it is): its frames match their places' learned looks
    no better than ``max_look_ratio`` of the typical learned look, or too few of them find their
    best look at their place (``min_look_hits``): another garden."""
    ratio = float(np.median(looks.look_ratios)) if len(looks.look_ratios) >= params.settled_frames else math.nan
    if ratio > params.max_look_ratio:
        return (
            f"its frames match their places' learned appearances at {ratio:.2f} of the typical one's score "
            f"(more than [learning] max_look_ratio {params.max_look_ratio:g}): not a night of this map's places "
            f"(another garden?)"
        )
    hits = float(np.mean(looks.look_hits)) if len(looks.look_hits) >= params.settled_frames else math.nan
    if hits < params.min_look_hits:
        return (
            f"only {hits:.0%} of its frames find their best learned appearance at or beside their place "
            f"(fewer than [learning] min_look_hits {params.min_look_hits:g}): not a night of this map's places "
            f"(another garden?)"
        )
    return ""


def learn(
    ref_map: ReferenceMap, night: LocalizedNight, params: LearningParams | None = None
) -> tuple[ReferenceMap, LearningReport]:
    """The map plus what ``night`` taught (see the module docstring); ``ref_map`` is unchanged.

    Returns the new map (``ref_map`` itself when nothing was trusted) and a :class:`LearningReport`.

    Raises:
        MapFormatError: the night was localized against another map, or prepared otherwise.
    """
    params = LearningParams() if params is None else params
    if not isinstance(params, LearningParams):
        raise TypeError(f"params must be a LearningParams, got {type(params).__name__}")
    _check_night(ref_map, night)
    record = ref_map.appearances or Appearances.day(len(ref_map), ref_map.fingerprint)
    spacing = place_spacing(ref_map.positions[record.night == 0])
    attach, gap = params.attach_fraction * spacing, params.gap_fraction * spacing
    trusted, estimates = trust_night(night, params, gap)
    places, place_of_ref = _places(ref_map.positions)
    n_places = len(places)
    if not trusted.any():
        report = LearningReport(0, len(night), 0, None, 0, 0, 0, 0, 0, n_places, len(ref_map))
        return ref_map, report
    number = len(record.nights) + 1
    views = _PlaceViews(ref_map, place_of_ref, math.radians(params.heading_tolerance))
    attached, nearest, new_places = _attach_frames(estimates, trusted, places, views, attach, gap)
    looks = _judge_looks(ref_map, night, record, estimates, places, views, attached, nearest, params.novelty, spacing)
    refusal = _look_refusal(looks, params)
    if refusal:  # not this map's nights: learn nothing
        refused = LearningReport(0, len(night), int(trusted.sum()), None, 0, 0, 0, 0, 0, n_places, len(ref_map))
        return ref_map, dataclasses.replace(refused, refused=refusal)

    evict = _evictions(looks, views, record, number, params)
    keep = np.setdiff1d(np.arange(len(ref_map)), np.asarray(evict, dtype=np.int64))
    new = _NewReferences(ref_map, night, number, keep)
    _add_night(ref_map, night, estimates, looks.learned, new_places, views, new)
    history = LearnedNight(
        number,
        night.source,
        dt.datetime.now(dt.UTC).isoformat(timespec="seconds"),
        len(night),
        int(trusted.sum()),
        len(looks.learned),
        len(new_places),
        len(evict),
    )
    new_map = _learned_map(ref_map, record, history, looks.matches, keep, new)
    report = LearningReport(
        number,
        len(night),
        int(trusted.sum()),
        int(np.flatnonzero(trusted)[0]),
        sum(len(f) for f in attached.values()),
        looks.known,
        len(looks.learned),
        len(new_places),
        len(evict),
        n_places,
        len(new_map),
    )
    return new_map, report


def _distance(estimate: Estimate, place: np.ndarray) -> float:
    return math.hypot(estimate.x - float(place[0]), estimate.y - float(place[1]))


def _frame_heading(estimate: Estimate, ref_map: ReferenceMap, night: LocalizedNight, frame: int, ref: int) -> float:
    """A learned frame's heading: the localizer's, else the reference's plus the panoramic shift."""
    if math.isfinite(estimate.heading) or ref_map.headings is None:
        return float(estimate.heading) if math.isfinite(estimate.heading) else 0.0
    result = match(night.images[frame], ref_map.images[ref : ref + 1], shifts=ref_map.params.shifts, threads=1)
    return float(wrap_angle(ref_map.headings[ref] + result.headings[0]))
