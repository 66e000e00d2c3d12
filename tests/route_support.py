"""The shared real route pairs (../shared/data) matched once per test process with the default
route parameters. Nordland's 3576 x 3576 difference matrix is the suite's largest computation
(about 16 s of CPU with the default translation window), and the filter's targets, the window's
targets, the speed cases and the search benchmark read the same one. Its arrays are read-only: a
test that wrote into them would change the others' input."""

from __future__ import annotations

import dataclasses
import functools
from pathlib import Path
from typing import NamedTuple

import numpy as np

import nightloc
from nightloc import route

#: The xdist group of the tests that read Nordland's default match: one worker computes it once.
NORDLAND_GROUP = "nordland-default-match"


class MatchedPair(NamedTuple):
    """Prepared ``(N, H, W)`` uint8 stacks and the :class:`~nightloc.route.RouteResult` of the
    queries along the references (difference matrix kept)."""

    refs: np.ndarray
    queries: np.ndarray
    result: route.RouteResult


@functools.cache
def default_match(data: Path, reference: str, query: str) -> MatchedPair:
    """``route.match_prepared`` of the traverse ``data / query`` along ``data / reference``, both
    prepared by ``route.RoutePreparer(route.RouteParams())``, with ``route.RouteParams()``."""
    params = route.RouteParams()
    preparer = route.RoutePreparer(params)
    refs = preparer(nightloc.load_traverse(data / reference))
    queries = preparer(nightloc.load_traverse(data / query))
    result = route.match_prepared(refs, queries, params)
    fields = [getattr(result, field.name) for field in dataclasses.fields(result)]
    for array in (refs, queries, *fields):
        if isinstance(array, np.ndarray):
            array.flags.writeable = False
    return MatchedPair(refs, queries, result)
