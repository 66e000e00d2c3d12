"""The command line: sub-commands run, errors are one line with a non-zero exit status."""

from __future__ import annotations

import subprocess
import sys

import nightloc
from nightloc.cli import main
from nightloc.localization.evaluation import ERRORS_HEADER, SUMMARY_HEADER


def test_demo_runs_the_method_on_the_embedded_data(capsys, tmp_path):
    from synth_support import default_synth_data

    cache = default_synth_data()["garden"]["day_reference"].parents[2]  # generated once per test run
    out_dir = tmp_path / "demo"
    assert main(["demo", "--out", str(out_dir), "--cache", str(cache)]) == 0
    out = capsys.readouterr().out
    for world in ("garden", "living_room"):
        assert f"{world}: " in out
        summary = (out_dir / world / "summary.csv").read_text().splitlines()
        assert tuple(summary[0].split(",")) == SUMMARY_HEADER
        # the paper: n = 1..10, noise 0-3, interpolation on/off; the filter: noise 0-3, on/off
        assert len(summary) == 1 + 10 * 4 * 2 + 4 * 2
        assert sum(line.endswith(",filter") for line in summary) == 8
        for name in (
            "errors.csv",
            "errors_wheel.csv",
            "error_vs_seq_len.png",
            "error_vs_noise.png",
            "error_vs_interpolation.png",
            "filter_vs_paper.png",
        ):
            assert (out_dir / world / name).is_file()
        assert list((out_dir / world).glob("heatmap_frame*.png"))
        assert tuple((out_dir / world / "errors_wheel.csv").read_text().splitlines()[0].split(",")) == ERRORS_HEADER
    assert out.count("|") > 40  # the median-error tables
    assert out.count("wheel odometry (RobotMotion)  Bayes filter") == 2  # the comparison tables


def test_info_reports_paths(capsys):
    assert main(["info", "--refs", "200"]) == 0
    out = capsys.readouterr().out
    assert "SIMD path in use" in out and "scalar" in out
    if "avx512bw" in nightloc.available_simd_backends():  # which all-shift variant runs, and why
        assert "avx512bw all-shift kernel: " in out and "avx512bw vpaddw" in out


def test_bad_value_is_one_line_error(capsys):
    assert main(["info", "--refs", "0"]) == 2
    err = capsys.readouterr().err
    assert err.startswith("nightloc info: error:") and "Traceback" not in err
    assert err.count("\n") == 1


def test_console_script_entry_point():
    done = subprocess.run([sys.executable, "-m", "nightloc.cli", "--version"], capture_output=True, text=True)
    assert done.returncode == 0 and done.stdout.startswith("nightloc ")
