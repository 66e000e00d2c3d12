"""Two runs writing one output at the same time: the second refuses at once, in one line naming
the first, and the output holds one whole set. Real processes, real locks.

Old behaviour: two concurrent ``synth`` or ``evaluate`` runs into one folder mixed their files,
both exiting 0; two concurrent map saves could interleave their leftovers.
"""

from __future__ import annotations

import json
import subprocess
import sys
import textwrap

import numpy as np
import pytest

import nightloc
from nightloc.cli import main
from nightloc.io.atomic import MANIFEST_NAME

from reliability_support import random_frames

pytestmark = pytest.mark.skipif(sys.platform == "win32", reason="POSIX file locks")

_HOLDER = textwrap.dedent(
    """
    import sys
    from nightloc.io.atomic import output_set
    with output_set(sys.argv[1], command="holder") as out:
        (out / "holder.txt").write_text("the first run's set")
        print("holding", flush=True)
        sys.stdin.readline()  # until the test lets go
    print("done", flush=True)
    """
)


@pytest.fixture
def pair(tmp_path):
    frames = random_frames(12, seed=3)
    positions = np.column_stack([np.arange(12) * 0.4, np.zeros(12)])
    ref = nightloc.save_traverse(tmp_path / "ref", frames, positions).root
    return ref, nightloc.save_traverse(tmp_path / "query", frames[::-1], positions[::-1]).root


def test_a_second_run_into_a_busy_folder_refuses_in_one_line(pair, tmp_path, capsys):
    ref, query = pair
    out = tmp_path / "out"
    holder = subprocess.Popen(
        [sys.executable, "-c", _HOLDER, str(out)], stdin=subprocess.PIPE, stdout=subprocess.PIPE, text=True
    )
    try:
        assert holder.stdout.readline().strip() == "holding"
        argv = ["evaluate", str(ref), str(query), "--out", str(out), "--seq-lengths", "1", "--noise-models", "0"]
        assert main([*argv, "--no-figures"]) == 2
        err = capsys.readouterr().err
        assert f"another nightloc run (process {holder.pid}) is writing" in err and err.count("\n") == 1, err
        holder.stdin.write("\n")
        holder.stdin.flush()
        assert holder.stdout.readline().strip() == "done"
    finally:
        holder.stdin.close()
        holder.wait(timeout=60)
        holder.stdout.close()
    assert sorted(p.name for p in out.iterdir()) == [MANIFEST_NAME, "holder.txt"]  # the first run's set, whole
    assert main([*argv, "--no-figures"]) == 0  # the lock went with the first run
    assert json.loads((out / MANIFEST_NAME).read_text())["files"] == ["errors.csv", "summary.csv"]
    assert sorted(p.name for p in tmp_path.iterdir() if p.name.startswith(".")) == []


def test_concurrent_route_runs_leave_one_whole_set(pair, tmp_path):
    """Four ``nightloc route`` processes into one folder at once: each exits 0 or refuses (2), at
    least one succeeds, and the folder holds exactly one run's files, consistent with each other."""
    ref, query = pair
    out = tmp_path / "out"
    command = [sys.executable, "-m", "nightloc", "route", str(ref), str(query), "--out", str(out)]
    runs = [
        subprocess.Popen(
            [*command, "--method", "seqslam", "--ds", str(ds), "--no-figures", "--ground-truth", "frames"],
            stdout=subprocess.PIPE,
            stderr=subprocess.PIPE,
            text=True,
        )
        for ds in (4, 5, 6, 7)
    ]
    statuses = []
    for run in runs:
        _, err = run.communicate(timeout=300)
        statuses.append(run.returncode)
        assert run.returncode in (0, 2), err
        if run.returncode == 2:
            assert "another nightloc run" in err and err.count("\n") == 1, err
    assert 0 in statuses
    manifest = json.loads((out / MANIFEST_NAME).read_text())
    assert sorted(p.name for p in out.iterdir()) == sorted([MANIFEST_NAME, *manifest["files"]])
    summary = json.loads((out / "summary.json").read_text())
    matches = (out / "matches.csv").read_text().splitlines()[1:]
    ds = summary["method_params"]["ds"]
    assert sum(row.split(",")[1] != "-1" for row in matches) == summary["n_matched"]  # one run's files
    assert ds in (4, 5, 6, 7)
