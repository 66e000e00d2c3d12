"""Command-line conventions: ground truth only from names that say something, ``matches.csv``
readable by numpy and naming the frames, a run that can match nothing says why, a closed pipe
ends quietly, and ``python -m nightloc`` works.

Old behaviour: ``route --ground-truth auto`` treated two logs named ``000000.png ...`` as aligned
and reported recall 0 for a correct match, with no warning; ``matches.csv`` left empty fields
where the API gives -1 / NaN (``np.loadtxt`` failed) and had no image names; ``--ds`` larger than
the traverse printed "0 matched" and exited 0; ``nightloc info | head -1`` ended in "Broken pipe"
with exit status 2.
"""

from __future__ import annotations

import json
import subprocess
import sys

import cv2
import numpy as np
import pytest

import nightloc
from nightloc.cli import main
from nightloc.route.ground_truth import names_are_positional

import route_oracle as ro


def _folder(root, images, names):
    (root / "images").mkdir(parents=True)
    for name, image in zip(names, images):
        cv2.imencode(".png", image)[1].tofile(root / "images" / name)
    return root


@pytest.fixture(scope="module")
def route_pair():
    refs, queries, _ = ro.synthetic_route(60, 40, speed=1.0, seed=21)
    return refs, queries


@pytest.mark.parametrize(
    ("names", "positional"),
    [
        ([f"{i:06d}.png" for i in range(5)], True),  # nightloc's own default names
        ([f"frame{i + 1:04d}.jpg" for i in range(5)], True),  # counted from 1
        ([f"Image{i:03d}.jpg" for i in range(5)], True),
        ([f"images-{10 * (i + 1):05d}.png" for i in range(5)], False),  # Nordland: every 10th video frame
        ([f"{i:06d}.png" for i in range(3, 8)], False),  # a log cut at frame 3
        (["a.png", "b.png", "c.png"], False),
        ([f"{i:06d}.png" for i in (0, 1, 3)], False),
    ],
)
def test_positional_names(names, positional):
    assert names_are_positional(names) is positional


def test_positional_names_give_no_ground_truth_and_say_why(route_pair, tmp_path, capsys):
    refs, queries = route_pair
    day = _folder(tmp_path / "day", refs, [f"{i:06d}.png" for i in range(len(refs))])
    night = _folder(tmp_path / "night", queries, [f"{i:06d}.png" for i in range(len(queries))])
    assert main(["route", str(day), str(night), "--out", str(tmp_path / "auto"), "--no-figures"]) == 0
    printed = capsys.readouterr().out
    assert "no ground truth (both traverses name their frames by position" in printed
    summary = json.loads((tmp_path / "auto" / "summary.json").read_text())
    assert summary["ground_truth"] == "none" and "by position" in summary["no_ground_truth_because"]
    assert not (tmp_path / "auto" / "pr.csv").exists()
    # asked for explicitly, the names are used
    assert main(["route", str(day), str(night), "--out", str(tmp_path / "names"), "--ground-truth", "names"]) == 0
    assert json.loads((tmp_path / "names" / "summary.json").read_text())["ground_truth"] == "names"


def test_distinctive_names_are_ground_truth(route_pair, tmp_path, capsys):
    """The control: names that are not positions (Nordland's) still give ground truth."""
    refs, queries = route_pair
    names = [f"images-{10 * (i + 5):05d}.png" for i in range(len(refs))]
    day = _folder(tmp_path / "day", refs, names)
    night = _folder(tmp_path / "night", queries, names[: len(queries)])
    assert main(["route", str(day), str(night), "--out", str(tmp_path / "o"), "--no-figures"]) == 0
    assert "ground truth from names" in capsys.readouterr().out


def test_matches_csv_reads_with_numpy_and_names_the_frames(route_pair, tmp_path):
    refs, queries = route_pair
    day = _folder(tmp_path / "day", refs, [f"d{i:03d}.png" for i in range(len(refs))])
    night = _folder(tmp_path / "night", queries, [f"n{i:03d}.png" for i in range(len(queries))])
    out = tmp_path / "o"
    argv = ["route", str(day), str(night), "--out", str(out), "--no-figures", "--method", "seqslam", "--mode", "causal"]
    assert main(argv) == 0  # SeqSLAM: its first ds - 1 causal queries have no match
    numbers = np.loadtxt(out / "matches.csv", delimiter=",", skiprows=1, usecols=(0, 1, 2))
    params = nightloc.route.resolve_params(None, method="seqslam", mode="causal")  # what the command resolves
    result = nightloc.route.match_route(nightloc.load_traverse(day), nightloc.load_traverse(night), params)
    np.testing.assert_array_equal(numbers[:, 0], np.arange(len(queries)))
    np.testing.assert_array_equal(numbers[:, 1], result.refs)  # -1 where there is no match
    np.testing.assert_array_equal(np.isnan(numbers[:, 2]), result.refs < 0)
    np.testing.assert_allclose(numbers[result.refs >= 0, 2], result.scores[result.refs >= 0])
    rows = [line.split(",") for line in (out / "matches.csv").read_text().splitlines()]
    assert rows[0] == ["query", "ref", "score", "query_image", "ref_image", "timestamp"]
    assert {row[5] for row in rows[1:]} == {"nan"}  # folders without a timestamp column: no times
    for q, row in enumerate(rows[1:]):
        assert row[3] == f"n{q:03d}.png"
        assert row[4] == ("" if result.refs[q] < 0 else f"d{result.refs[q]:03d}.png")
    assert (result.refs < 0).sum() > 0 and (result.refs >= 0).sum() > 0  # both kinds of row checked


@pytest.mark.parametrize(("ds", "mode"), [("50", "centred"), ("40", "centred"), ("41", "causal")])
def test_a_run_that_can_match_nothing_says_why_and_fails(route_pair, tmp_path, capsys, ds, mode):
    refs, queries = route_pair  # 40 query frames
    day = _folder(tmp_path / "day", refs, [f"d{i:03d}.png" for i in range(len(refs))])
    night = _folder(tmp_path / "night", queries, [f"n{i:03d}.png" for i in range(len(queries))])
    argv = [
        "route",
        str(day),
        str(night),
        "--out",
        str(tmp_path / "o"),
        "--method",
        "seqslam",
        "--ds",
        ds,
        "--mode",
        mode,
    ]
    assert main(argv) == 2
    err = capsys.readouterr().err
    assert "has 40 frames" in err and f"--ds {ds}" in err and err.count("\n") == 1
    assert not (tmp_path / "o").exists()


def test_a_closed_pipe_ends_quietly():
    """The reader of stdout is gone before the first line: no "Broken pipe", no traceback, exit
    status 141 (128 + SIGPIPE, what a shell reports for ``yes | head -1``)."""
    process = subprocess.Popen(
        [sys.executable, "-m", "nightloc", "info", "--refs", "50"], stdout=subprocess.PIPE, stderr=subprocess.PIPE
    )
    process.stdout.close()  # like ``| head -0``
    _, err = process.communicate(timeout=120)
    assert process.returncode == 141, err
    assert err == b""


def test_python_dash_m_nightloc_runs_the_command_line():
    """(This worked before this test was written; it keeps working.)"""
    done = subprocess.run([sys.executable, "-m", "nightloc", "--version"], capture_output=True, text=True, timeout=60)
    assert done.returncode == 0 and done.stdout.startswith("nightloc ")
    done = subprocess.run([sys.executable, "-m", "nightloc", "info", "--refs", "0"], capture_output=True, text=True)
    assert done.returncode == 2 and done.stderr.startswith("nightloc info: error:")
