"""The command line: sub-commands run, errors are one line with a non-zero exit status."""

from __future__ import annotations

import subprocess
import sys

from nightloc.cli import main


def test_demo_runs(capsys):
    assert main(["demo"]) == 0
    out = capsys.readouterr().out
    assert "50/50" in out


def test_info_reports_paths(capsys):
    assert main(["info", "--refs", "200"]) == 0
    out = capsys.readouterr().out
    assert "SIMD path in use" in out and "scalar" in out


def test_bad_value_is_one_line_error(capsys):
    assert main(["info", "--refs", "0"]) == 2
    err = capsys.readouterr().err
    assert err.startswith("nightloc info: error:") and "Traceback" not in err
    assert err.count("\n") == 1


def test_console_script_entry_point():
    done = subprocess.run([sys.executable, "-m", "nightloc.cli", "--version"], capture_output=True, text=True)
    assert done.returncode == 0 and done.stdout.startswith("nightloc ")
