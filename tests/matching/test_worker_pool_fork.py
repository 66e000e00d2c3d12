"""The core's worker pool across fork(): children of a process whose pool is busy still match.

Not in the sanitizer subset: AddressSanitizer's own allocator is not fork-safe while another
thread allocates, so a forked child of an instrumented process can hang in ASan itself.
"""

from __future__ import annotations

import os
import subprocess
import sys

import pytest

_FORK_CHILD = """
import os, threading
import numpy as np
import nightloc
rng = np.random.default_rng(7)
refs = rng.integers(0, 256, (3000, 24, 48), dtype=np.uint8)
query = rng.integers(0, 256, (24, 48), dtype=np.uint8)
expected = nightloc.match(query, refs, threads=1).scores
stop = threading.Event()
def busy():  # keeps the parent's worker pool in the middle of jobs while the fork happens
    while not stop.is_set():
        nightloc.match(query, refs, threads=2)
worker = threading.Thread(target=busy)
worker.start()
codes = []
for _ in range(20):
    pid = os.fork()
    if pid == 0:  # the child has only this thread: threaded calls must neither hang nor differ
        ok = all(np.array_equal(nightloc.match(query, refs, threads=2).scores, expected) for _ in range(3))
        os._exit(0 if ok else 3)
    codes.append(os.waitstatus_to_exitcode(os.waitpid(pid, 0)[1]))
stop.set()
worker.join()
print("children", sorted(set(codes)))
print("parent", np.array_equal(nightloc.match(query, refs, threads=2).scores, expected))
"""


@pytest.mark.skipif(not hasattr(os, "fork"), reason="needs os.fork (POSIX)")
def test_forked_children_match_correctly_without_hanging():
    """The core keeps a process-wide pool of worker threads. Children forked while another thread
    of the parent is in the middle of pooled work have none of its threads (and copies of its locks
    in whatever state): their threaded calls must finish, with the serial answer."""
    done = subprocess.run([sys.executable, "-c", _FORK_CHILD], capture_output=True, text=True, timeout=120, check=False)
    assert done.returncode == 0, done.stderr
    assert done.stdout.split() == ["children", "[0]", "parent", "True"]
