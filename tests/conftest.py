"""Shared fixtures: every SIMD path, and the real data in ../shared/data when present."""

from __future__ import annotations

import os
import sys
from pathlib import Path

import pytest

import nightloc
from nightloc._core import ALL_SIMD_BACKENDS as ALL_BACKENDS  # every path the core knows

sys.path.insert(0, str(Path(__file__).parent))  # tests/oracle.py

_REPO = Path(__file__).resolve().parents[1]


def shared_data_dir() -> Path:
    """../shared/data beside the repository, or $NIGHTLOC_SHARED_DATA."""
    return Path(os.environ.get("NIGHTLOC_SHARED_DATA", _REPO.parent / "shared" / "data"))


@pytest.fixture
def shared_data() -> Path:
    root = shared_data_dir()
    if not root.is_dir():
        pytest.skip(f"real-image data not found at {root} (set NIGHTLOC_SHARED_DATA to its folder)")
    return root


@pytest.fixture(params=ALL_BACKENDS)
def simd_path(request):
    """Runs the test once on every SIMD path; paths this CPU lacks are skipped with the reason."""
    if request.param not in nightloc.available_simd_backends():
        pytest.skip(f"this CPU does not support the {request.param} path")
    with nightloc.use_simd_backend(request.param):
        yield request.param


@pytest.hookimpl(tryfirst=True)
def pytest_cmdline_main(config: pytest.Config) -> None:
    """With the benchmarks disabled (the README's test command), the tests run on every core with
    pytest-xdist (``-n auto``), the tests of one ``xdist_group`` on one worker. ``-n`` or ``--dist``
    choose otherwise (``-n 0``: one process). Benchmarks that are timed run in one process as
    before: pytest-benchmark does not time under xdist."""
    if not config.pluginmanager.hasplugin("xdist"):
        return  # without pytest-xdist (e.g. the sanitized run): one process
    if hasattr(config, "workerinput"):  # a worker
        if config.workerinput.get("nightloc_dist") == "loadgroup":
            config.option.loadgroup = True  # xdist marks each test with its group
        return
    chosen = config.option.numprocesses is not None or config.option.dist != "no" or config.option.tx
    if chosen or config.option.usepdb or not config.getoption("benchmark_disable", False):
        return
    config.option.numprocesses = "auto"
    config.option.dist = "loadgroup"


@pytest.hookimpl(optionalhook=True)
def pytest_configure_node(node) -> None:
    """pytest-xdist's controller, for each worker: the distribution mode chosen above."""
    node.workerinput["nightloc_dist"] = node.config.option.dist
