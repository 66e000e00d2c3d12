"""A check that a compiled call releases the GIL (shared by the tests of every core module)."""

from __future__ import annotations

import threading
import time
from collections.abc import Callable


def python_runs_during(call: Callable[[], object]) -> float:
    """Runs ``call`` in a worker thread while this thread keeps executing Python code; returns
    the share (0..1) of the call's duration during which this thread ran.

    A call that holds the GIL lets this thread run only in the few milliseconds before the worker
    re-acquires it (a share near 0); a call that releases it lets it run nearly throughout (near 1).
    """
    state: dict[str, float] = {}

    def worker() -> None:
        state["t0"] = time.perf_counter()
        call()
        state["t1"] = time.perf_counter()

    thread = threading.Thread(target=worker)
    first = last = None
    thread.start()
    while "t1" not in state:
        now = time.perf_counter()
        if "t0" in state:
            first = now if first is None else first
            last = now
    thread.join()
    if first is None or last is None:
        return 0.0
    return (last - first) / (state["t1"] - state["t0"])
