"""The compiled core under Python threads: the GIL is released, results equal serial calls."""

from __future__ import annotations

from concurrent.futures import ThreadPoolExecutor

import numpy as np
import pytest

import nightloc
from gil_support import python_runs_during

# Run under AddressSanitizer + UBSan in CI (.ci/run: -m sanitize): these tests drive the core hard.
pytestmark = pytest.mark.sanitize


def _problem(seed, n_refs=400, n_queries=6):
    rng = np.random.default_rng(seed)
    refs = nightloc.patch_normalize(rng.integers(0, 256, (n_refs, 24, 48), dtype=np.uint8))
    queries = nightloc.patch_normalize(rng.integers(0, 256, (n_queries, 24, 48), dtype=np.uint8))
    return queries, refs


def test_eight_threads_give_serial_results():
    problems = [_problem(seed) for seed in range(8)]

    def work(index):
        queries, refs = problems[index]
        m = nightloc.match(queries[0], refs, threads=1)
        d = nightloc.difference_matrix(queries, refs, threads=2)
        p = nightloc.patch_normalize(refs[:50])
        t = nightloc.rotational_sad(queries[1], refs[:20])
        return m.scores, m.shifts, d[0], d[1], p, t

    serial = [work(i) for i in range(8)]
    for _ in range(3):
        with ThreadPoolExecutor(max_workers=8) as pool:
            parallel = list(pool.map(work, [i % 8 for i in range(16)]))
        for i, got in enumerate(parallel):
            for a, b in zip(got, serial[i % 8]):
                np.testing.assert_array_equal(a, b)


def test_shared_reference_stack_is_read_only_and_safe():
    queries, refs = _problem(42, n_refs=1000, n_queries=16)
    refs.setflags(write=False)
    before = refs.copy()
    expected = [nightloc.match(q, refs, threads=1).shifts for q in queries]
    with ThreadPoolExecutor(max_workers=8) as pool:
        got = list(pool.map(lambda q: nightloc.match(q, refs, threads=1).shifts, queries))
    for a, b in zip(got, expected):
        np.testing.assert_array_equal(a, b)
    np.testing.assert_array_equal(refs, before)


def test_gil_is_released_during_matching():
    """While one thread runs a long difference matrix, another keeps executing Python code.

    If the call held the GIL, the main thread could only run in the few milliseconds before the
    worker re-acquires it; released, the main thread runs during (nearly) the whole call.
    """
    queries, refs = _problem(1, n_refs=6000, n_queries=48)
    assert python_runs_during(lambda: nightloc.difference_matrix(queries, refs, threads=1)) > 0.5


def test_threaded_calls_from_many_python_threads_share_the_pool_correctly():
    """Sixteen Python threads each asking for two core threads: one uses the pool at a time, the
    others start threads of their own; every answer equals the serial one."""
    rng = np.random.default_rng(11)
    refs = rng.integers(0, 256, (1500, 24, 48), dtype=np.uint8)
    queries = rng.integers(0, 256, (16, 24, 48), dtype=np.uint8)
    expected = [nightloc.match(q, refs, threads=1).scores for q in queries]
    for _ in range(3):
        with ThreadPoolExecutor(max_workers=16) as pool:
            got = list(pool.map(lambda q: nightloc.match(q, refs, threads=2).scores, queries))
        for a, b in zip(got, expected):
            np.testing.assert_array_equal(a, b)
