"""Where each reference image of an experience map came from: the day map, or a night it learned.

A map that learns from its nights (:mod:`nightloc.experience.learning`) keeps the day map's
references and adds night frames as further *appearances* of its places. :class:`Appearances`
is the record of each reference's provenance, one entry per reference of the map (in its order):

* ``night``: ``(N,)`` int32, 0 for the day map's references (the survey or the teach run), else
  the learned night's number (1 = the first night learned into this map's line);
* ``confidence``: ``(N,)`` float64, the localizer's confidence in the frame when it was learned
  (NaN for the day map);
* ``time``: ``(N,)`` float64 seconds, the frame's timestamp in its log (NaN: the day map, or a
  log without times);
* ``matches``: ``(N,)`` int64, how many trusted night frames this reference was the best match of
  its place for (what the cap per place evicts by);

with the history of the nights learned (:class:`LearnedNight`) and the fingerprint of the day map
the line started from (:func:`map_fingerprint`). Map files store them as the arrays
``appearance_night``, ``appearance_confidence``, ``appearance_time``, ``appearance_matches`` and
the header's ``experience`` object (map format 4, :mod:`nightloc.io.map_file`).
"""

from __future__ import annotations

import hashlib
import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

__all__ = ["APPEARANCE_ARRAYS", "ORIGINS", "Appearances", "LearnedNight", "map_fingerprint"]

#: Where an appearance came from: the day map's survey, its teach run, or a learned night.
ORIGINS = ("survey", "teach", "learned")
#: The arrays an experience map file adds (one entry per reference).
APPEARANCE_ARRAYS = ("appearance_night", "appearance_confidence", "appearance_time", "appearance_matches")


def map_fingerprint(images: np.ndarray, positions: np.ndarray, headings: np.ndarray | None) -> str:
    """SHA-256 (hex) over a map's prepared images, positions and headings: two maps share it only
    when they hold the same references at the same poses."""
    digest = hashlib.sha256()
    for array in (images, positions, headings):
        if array is not None:
            a = np.ascontiguousarray(array)
            digest.update(f"{a.dtype.str}{a.shape}".encode())
            digest.update(a.tobytes())
    return digest.hexdigest()


@dataclass(frozen=True)
class LearnedNight:
    """One night learned into a map (the header's history).

    Attributes:
        night: its number (1, 2, ...).
        source: the log it came from (a path, as given).
        learned_at: UTC time of learning, ISO 8601.
        frames: frames in the log; ``trusted``: those confident enough to learn from.
        appearances: appearances added to existing places; ``places``: new places (gaps filled).
        evicted: learned appearances evicted by the cap per place.
    """

    night: int
    source: str
    learned_at: str
    frames: int
    trusted: int
    appearances: int
    places: int
    evicted: int

    def to_json(self) -> dict[str, Any]:
        return {
            "night": self.night,
            "source": self.source,
            "learned_at": self.learned_at,
            "frames": self.frames,
            "trusted": self.trusted,
            "appearances": self.appearances,
            "places": self.places,
            "evicted": self.evicted,
        }

    @classmethod
    def from_json(cls, item: Any) -> LearnedNight:
        """ValueError when ``item`` is not a learned night's record."""
        if not isinstance(item, dict):
            raise ValueError(f"a learned night's record must be an object, got {item!r}")
        try:
            counts = {k: item[k] for k in ("night", "frames", "trusted", "appearances", "places", "evicted")}
            texts = {k: item[k] for k in ("source", "learned_at")}
        except KeyError as error:
            raise ValueError(f"a learned night's record lacks {error}") from None
        for key, value in counts.items():
            if isinstance(value, bool) or not isinstance(value, int) or value < 0:
                raise ValueError(f"a learned night's {key} must be a non-negative integer, got {value!r}")
        for key, value in texts.items():
            if not isinstance(value, str):
                raise ValueError(f"a learned night's {key} must be a string, got {value!r}")
        return cls(**counts, **texts)


def _vector(values: Any, n: int, dtype: type, what: str) -> np.ndarray:
    try:
        array: np.ndarray = np.array(values, dtype=dtype)
    except (TypeError, ValueError) as error:
        raise ValueError(f"appearance {what} must be ({n},) numbers: {error}") from None
    if array.shape != (n,):
        raise ValueError(f"appearance {what} must have shape ({n},) (one per reference), got {array.shape}")
    array.setflags(write=False)
    return array


@dataclass(frozen=True, eq=False)
class Appearances:
    """Provenance of every reference of a map (see the module docstring); immutable.

    Raises ValueError for arrays of different lengths, negative nights or match counts, a night
    beyond the history, or a confidence outside [0, 1].
    """

    night: np.ndarray
    confidence: np.ndarray
    time: np.ndarray
    matches: np.ndarray
    nights: tuple[LearnedNight, ...] = ()
    day_fingerprint: str = ""

    def __post_init__(self) -> None:
        n = np.asarray(self.night).shape[0] if np.ndim(self.night) == 1 else -1
        if n < 0:
            raise ValueError(f"appearance night must be a vector, got shape {np.shape(self.night)}")
        object.__setattr__(self, "night", _vector(self.night, n, np.int32, "night"))
        object.__setattr__(self, "confidence", _vector(self.confidence, n, np.float64, "confidence"))
        object.__setattr__(self, "time", _vector(self.time, n, np.float64, "time"))
        object.__setattr__(self, "matches", _vector(self.matches, n, np.int64, "matches"))
        object.__setattr__(self, "nights", tuple(self.nights))
        if (self.night < 0).any() or (self.matches < 0).any():
            raise ValueError("appearance nights and match counts must not be negative")
        if n and int(self.night.max()) > len(self.nights):
            raise ValueError(
                f"an appearance is of night {int(self.night.max())} but the history lists {len(self.nights)} nights"
            )
        learned = self.night > 0
        confidence = self.confidence[learned]
        if not (np.isfinite(confidence) & (confidence >= 0) & (confidence <= 1)).all():
            raise ValueError("a learned appearance's confidence must be in [0, 1]")
        if not isinstance(self.day_fingerprint, str):
            raise ValueError("day_fingerprint must be a string")

    @classmethod
    def day(cls, n: int, fingerprint: str = "") -> Appearances:
        """The record of a day map of ``n`` references: all night 0, never matched yet."""
        return cls(
            np.zeros(n, np.int32), np.full(n, math.nan), np.full(n, math.nan), np.zeros(n, np.int64), (), fingerprint
        )

    def __len__(self) -> int:
        return int(self.night.shape[0])

    def __eq__(self, other: object) -> bool:
        if not isinstance(other, Appearances):
            return NotImplemented
        return (
            np.array_equal(self.night, other.night)
            and np.array_equal(self.confidence, other.confidence, equal_nan=True)
            and np.array_equal(self.time, other.time, equal_nan=True)
            and np.array_equal(self.matches, other.matches)
            and self.nights == other.nights
            and self.day_fingerprint == other.day_fingerprint
        )

    __hash__ = None  # type: ignore[assignment]

    def origins(self, pose_source: str) -> list[str]:
        """Each reference's origin (:data:`ORIGINS`); the day map's is ``"survey"`` for surveyed
        poses, else ``"teach"`` (``pose_source`` of the map)."""
        day = "survey" if pose_source == "surveyed" else "teach"
        return ["learned" if n > 0 else day for n in self.night.tolist()]

    def subset(self, keep: Sequence[int] | np.ndarray) -> Appearances:
        """The record of the references ``keep`` (indices, in that order)."""
        k = np.asarray(keep, dtype=np.int64)
        return Appearances(
            self.night[k], self.confidence[k], self.time[k], self.matches[k], self.nights, self.day_fingerprint
        )

    def to_arrays(self) -> dict[str, np.ndarray]:
        """The file's arrays (:data:`APPEARANCE_ARRAYS`)."""
        return {
            "appearance_night": self.night,
            "appearance_confidence": self.confidence,
            "appearance_time": self.time,
            "appearance_matches": self.matches,
        }

    def to_json(self) -> dict[str, Any]:
        """The header's ``experience`` object."""
        return {"day_fingerprint": self.day_fingerprint, "nights": [n.to_json() for n in self.nights]}

    @classmethod
    def from_file(cls, experience: Any, arrays: dict[str, np.ndarray], n: int) -> Appearances:
        """From the header's ``experience`` object and the file's arrays; ValueError when they
        are missing or inconsistent."""
        if not isinstance(experience, dict):
            raise ValueError("the header's experience is not an object")
        missing = [name for name in APPEARANCE_ARRAYS if name not in arrays]
        if missing:
            raise ValueError(f"the map lacks its {', '.join(missing)} array(s)")
        nights = experience.get("nights", [])
        if not isinstance(nights, list):
            raise ValueError("the header's experience nights are not a list")
        fingerprint = experience.get("day_fingerprint", "")
        records = tuple(LearnedNight.from_json(item) for item in nights)
        if [r.night for r in records] != list(range(1, len(records) + 1)):
            raise ValueError("the header's learned nights are not numbered 1, 2, ...")
        for name in APPEARANCE_ARRAYS:
            if arrays[name].shape != (n,):
                raise ValueError(f"{name} has shape {arrays[name].shape}, expected ({n},)")
        return cls(
            arrays["appearance_night"],
            arrays["appearance_confidence"],
            arrays["appearance_time"],
            arrays["appearance_matches"],
            records,
            fingerprint,
        )
