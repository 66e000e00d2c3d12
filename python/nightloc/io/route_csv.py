"""Route mode's CSV files (``nightloc route``'s ``matches.csv`` and ``pr.csv``) as text.

* ``matches.csv``: ``query,ref,score,query_image,ref_image`` (0-based positions in the traverse
  order and the frames' names; ``ref`` -1, ``score`` nan and ``ref_image`` empty where a query
  has no match), then ``confidence,off_route`` when the route filter gave them, then
  ``timestamp``, the query frame's time in seconds (``nan`` when the traverse carries none).
* ``pr.csv``: ``threshold,precision,recall``, thresholds ascending.

Numbers are written with ``repr`` (the float round-trips) and ``nan``, so
``numpy.loadtxt(..., usecols=(0, 1, 2))`` reads the numbers of ``matches.csv``.
"""

from __future__ import annotations

import csv
import io
import math
from collections.abc import Sequence

import numpy as np

__all__ = ["matches_csv", "pr_csv"]


def _number(value: float) -> str:
    return "nan" if math.isnan(value) else repr(float(value))


def matches_csv(
    refs: np.ndarray,
    scores: np.ndarray,
    query_names: Sequence[str],
    ref_names: Sequence[str],
    confidence: np.ndarray | None = None,
    off_route: np.ndarray | None = None,
    query_times: Sequence[float] | np.ndarray | None = None,
) -> str:
    """The text of ``matches.csv``: one row per query of ``(n_query,)`` ``refs`` (int, -1: no
    match) and ``scores`` (lower = more confident); the ``confidence,off_route`` columns when
    both are given (``(n_query,)`` each)."""
    buffer = io.StringIO()
    writer = csv.writer(buffer, lineterminator="\n")
    filtered = confidence is not None and off_route is not None
    writer.writerow(
        [
            "query",
            "ref",
            "score",
            "query_image",
            "ref_image",
            *(["confidence", "off_route"] if filtered else []),
            "timestamp",
        ]
    )
    for q in range(len(refs)):
        ref = int(refs[q])
        matched = ref >= 0
        row: list = [
            q,
            ref if matched else -1,
            _number(scores[q]) if matched else "nan",
            query_names[q],
            ref_names[ref] if matched else "",
        ]
        if confidence is not None and off_route is not None:
            row += [_number(confidence[q]), _number(off_route[q])]
        row.append("nan" if query_times is None else _number(query_times[q]))
        writer.writerow(row)
    return buffer.getvalue()


def pr_csv(thresholds: Sequence[float], precision: Sequence[float], recall: Sequence[float]) -> str:
    """The text of ``pr.csv`` from a precision-recall curve's ``(n,)`` thresholds (ascending),
    precision and recall."""
    buffer = io.StringIO()
    writer = csv.writer(buffer, lineterminator="\n")
    writer.writerow(["threshold", "precision", "recall"])
    for t, p, r in zip(thresholds, precision, recall):
        writer.writerow([repr(float(t)), repr(float(p)), repr(float(r))])
    return buffer.getvalue()
