"""``nightloc build-map`` as a teach run: what it prints, its figure, its errors; ``evaluate`` on
the map it writes."""

from __future__ import annotations

import shutil
import sys

import pytest

pytest.importorskip("gtsam")

import nightloc
from nightloc.cli import main

from synth_support import default_synth_data


@pytest.fixture
def drive(tmp_path):
    day = tmp_path / "day"
    shutil.copytree(default_synth_data()["garden"]["day_reference"], day)
    return day


def test_teach_run_prints_what_it_did(drive, tmp_path, capsys):
    surveyed = drive.parent / "surveyed"
    shutil.copytree(drive, surveyed)
    (drive / "poses.csv").unlink()
    assert main(["build-map", str(drive), str(tmp_path / "teach.map"), "--figure", str(tmp_path / "teach.png")]) == 0
    out = capsys.readouterr().out
    assert "teach run: 24 frames" in out and "pose source optimised" in out
    assert "visual constraints:" in out and "accepted" in out and "rejected" in out
    assert "pose uncertainty" in out and (tmp_path / "teach.png").stat().st_size > 10_000
    taught = nightloc.ReferenceMap.load(tmp_path / "teach.map")
    assert taught.pose_source == "optimised" and taught.covariances.shape == (24, 3, 3)
    # --evaluate-poses: the same teach run on a traverse that has poses.csv too, with its ATE
    assert main(["build-map", str(surveyed), str(tmp_path / "eval.map"), "--evaluate-poses"]) == 0
    out = capsys.readouterr().out
    assert "ATE against poses.csv" in out and "dead reckoning" in out
    # evaluate aligns the frames with the day survey and says so
    night = default_synth_data()["garden"]["night_query"]
    argv = ["evaluate", str(tmp_path / "teach.map"), str(night), "--out", str(tmp_path / "ev"), "--no-figures"]
    assert main([*argv, "--seq-lengths", "1", "--noise-models", "0", "--interpolation", "on"]) == 2  # no survey
    assert "poses.csv" in capsys.readouterr().err
    assert (
        main([*argv, "--seq-lengths", "1", "--noise-models", "0", "--interpolation", "on", "--survey", str(surveyed)])
        == 0
    )
    assert "rigid 2D fit" in capsys.readouterr().out


def test_teach_options_and_errors(drive, tmp_path, capsys, monkeypatch):
    assert main(["build-map", str(drive), str(tmp_path / "a.map"), "--closed-loop"]) == 2  # has poses.csv
    assert "apply to a teach run" in capsys.readouterr().err
    (drive / "poses.csv").unlink()
    monkeypatch.setitem(sys.modules, "gtsam", None)
    assert main(["build-map", str(drive), str(tmp_path / "b.map")]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and 'pip install "nightloc[mapping]"' in err
    assert not (tmp_path / "b.map").exists()
    monkeypatch.delitem(sys.modules, "gtsam")
    (drive / "odometry.csv").unlink()
    assert main(["build-map", str(drive), str(tmp_path / "c.map")]) == 2
    assert "no poses" in capsys.readouterr().err and not (tmp_path / "c.map").exists()


def test_teach_table_of_the_params_file(drive, tmp_path, capsys):
    """build-map reads [teach] from --params beside [preparation]; a bad key is one line."""
    (drive / "poses.csv").unlink()
    params = tmp_path / "params.toml"
    params.write_text("[preparation]\nwidth = 48\n\n[teach]\nsequence_window = 0\nplace_candidates = 0\n")
    assert main(["build-map", str(drive), str(tmp_path / "a.map"), "--params", str(params)]) == 0
    out = capsys.readouterr().out
    assert "warning: no two frames of the drive matched" in out and "pose source dead-reckoned" in out
    params.write_text("[teach]\nrounds = 0\n")
    assert main(["build-map", str(drive), str(tmp_path / "b.map"), "--params", str(params)]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "rounds" in err and not (tmp_path / "b.map").exists()
    params.write_text("[teach]\nround = 2\n")
    assert main(["build-map", str(drive), str(tmp_path / "c.map"), "--params", str(params)]) == 2
    assert "unknown key 'round' in [teach]" in capsys.readouterr().err
