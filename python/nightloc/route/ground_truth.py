"""Which reference frames are correct matches for each query frame of two traverses: positions
when both carry poses, else shared distinctive file names, else none (with the reason).

``nightloc route --ground-truth`` and ``--tolerance`` choose the kind and the tolerance; the
messages name those options.
"""

from __future__ import annotations

import math
import re
from collections.abc import Sequence
from pathlib import Path

import numpy as np

from ..io.traverse import Traverse
from .evaluation import GroundTruth

__all__ = [
    "DEFAULT_FRAME_TOLERANCE",
    "DEFAULT_METRE_TOLERANCE",
    "GROUND_TRUTH_KINDS",
    "MAX_FRAME_TOLERANCE",
    "ground_truth_for",
    "names_are_positional",
]

#: Default tolerances: frames for frame correspondence, metres for positions.
DEFAULT_FRAME_TOLERANCE = 2
DEFAULT_METRE_TOLERANCE = 3.0
#: Largest frame tolerance (a tolerance as long as any traverse makes every match correct).
MAX_FRAME_TOLERANCE = 1_000_000
#: The kinds :func:`ground_truth_for` takes.
GROUND_TRUTH_KINDS = ("auto", "names", "frames", "positions", "none")


def ground_truth_for(kind: str, reference: Traverse, query: Traverse, tolerance: float | None) -> tuple:
    """(GroundTruth or None, the kind used, why there is none or "") for the two traverses.

    ``auto``: positions when both traverses have poses; names when the two traverses share file
    names that are *distinctive* (:func:`names_are_positional`: not merely each frame's position
    number in both); otherwise none, with the reason. ``tolerance``: metres for positions (default
    :data:`DEFAULT_METRE_TOLERANCE`), whole frames otherwise (default
    :data:`DEFAULT_FRAME_TOLERANCE`).
    """
    same_names = _name_correspondence(reference, query)
    if kind == "auto":
        if reference.has_poses and query.has_poses:
            kind = "positions"
        elif same_names is None or not (same_names >= 0).any():
            return None, "none", "the traverses share no file names and have no poses"
        elif names_are_positional(reference.names) and names_are_positional(query.names):
            return (
                None,
                "none",
                (
                    f"both traverses name their frames by position ({query.names[0]}, {query.names[-1]}, ...), "
                    f"which says nothing about where they were taken; pass --ground-truth names or frames if "
                    f"frame i of one is frame i of the other, or add poses.csv"
                ),
            )
        else:
            kind = "names"
    if kind == "none":
        return None, "none", "--ground-truth none"
    if kind == "positions":
        if reference.positions is None or query.positions is None:
            raise ValueError("--ground-truth positions needs poses in both traverses (poses.csv or a video's CSV)")
        metres = DEFAULT_METRE_TOLERANCE if tolerance is None else tolerance
        return GroundTruth.from_positions(query.positions, reference.positions, metres), "positions", ""
    frames = DEFAULT_FRAME_TOLERANCE if tolerance is None else tolerance
    if not math.isfinite(frames) or float(frames) != int(frames) or not 0 <= frames <= MAX_FRAME_TOLERANCE:
        raise ValueError(
            f"--tolerance must be a whole number of frames in 0..{MAX_FRAME_TOLERANCE} for frame ground truth, "
            f"got {frames}"
        )
    if kind == "names":
        if same_names is None or not (same_names >= 0).any():
            raise ValueError("--ground-truth names: no query frame has the file name of a reference frame")
        return GroundTruth.from_frames(len(query), len(reference), int(frames), same_names), "names", ""
    return GroundTruth.from_frames(len(query), len(reference), int(frames)), "frames", ""


_LAST_NUMBER = re.compile(r"(\d+)(?!.*\d)")


def names_are_positional(names: Sequence[str]) -> bool:
    """True when every name's last number is its frame's position in the list, counted from 0
    or from 1 (``000000.png``, ``frame0001.jpg``, ``Image000.jpg`` ...): such names number the
    frames of any log alike and say nothing about the place. Nordland's ``images-00010.png``
    (every 10th frame of one video) is not positional."""
    for start in (0, 1):
        ok = True
        for index, name in enumerate(names):
            found = _LAST_NUMBER.search(Path(name).stem)
            if found is None or int(found.group(1)) != index + start:
                ok = False
                break
        if ok:
            return True
    return False


def _name_correspondence(reference: Traverse, query: Traverse) -> np.ndarray | None:
    """``(n_query,)`` the reference index with each query frame's file name (-1: none); None for
    a video."""
    if reference.is_video or query.is_video:
        return None
    index = {Path(name).name: i for i, name in enumerate(reference.names)}
    return np.array([index.get(Path(name).name, -1) for name in query.names], dtype=np.int64)
