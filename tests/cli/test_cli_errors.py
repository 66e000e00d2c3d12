"""Every CLI command fed bad input: exit status 2, one line on stderr naming the problem, no
traceback, and no output file written or damaged.

The cases run through :func:`nightloc.cli.main` in this process; a few also run as a separate
``python -m nightloc.cli`` process, to check what a shell user sees (exit status, stderr, no
OpenCV log noise).
"""

from __future__ import annotations

import shutil
import subprocess
import sys
from pathlib import Path

import pytest

from nightloc import cli

from reliability_support import Workspace


@pytest.fixture(scope="module")
def ws(tmp_path_factory):
    workspace = Workspace(tmp_path_factory.mktemp("cli"))
    (workspace.root / "bad.toml").write_text("[preparation]\nwidht = 3\n")
    (workspace.root / "junk.mp4").write_bytes(b"this is not a video")
    (workspace.root / "out").mkdir()
    (workspace.root / "truncated.map").write_bytes(workspace.map_file.read_bytes()[:500])
    workspace.no_poses = workspace.traverse_variant(remove=["poses.csv"])
    return workspace


def _paths(ws) -> dict:
    return {
        "trav": ws.traverse.root,
        "text": ws.text_file,
        "map": ws.map_file,
        "root": ws.root,
        "bad_toml": ws.root / "bad.toml",
        "junk_video": ws.root / "junk.mp4",
        "out": ws.root / "out",
        "new": ws.root / "never_written",
        "no_poses": ws.no_poses,
        "truncated_map": ws.root / "truncated.map",
    }


# (id, argv template, words the error line must contain)
CASES = [
    ("info refs 0", "info --refs 0", "--refs"),
    ("demo negative seed", "demo --seed -1", "non-negative"),
    ("build-map missing traverse", "build-map {root}/nope {new}.map", "does not exist"),
    ("build-map text file as traverse", "build-map {text} {new}.map", "not a traverse"),
    ("build-map junk video", "build-map {junk_video} {new}.map", "cannot be opened"),
    ("build-map output under a file", "build-map {trav} {text}/x.map", "is a file"),
    ("build-map output is a folder", "build-map {trav} {out}", "is a folder"),
    ("build-map bad params key", "build-map {trav} {new}.map --params {bad_toml}", "unknown key 'widht'"),
    ("build-map missing params file", "build-map {trav} {new}.map --params {root}/nope.toml", "does not exist"),
    ("build-map params file is a map", "build-map {trav} {new}.map --params {map}", "UTF-8"),
    ("build-map frame step 0", "build-map {trav} {new}.map --frame-step 0", "--frame-step"),
    ("build-map missing poses", "build-map {trav} {new}.map --poses {root}/nope.csv", "does not exist"),
    ("build-map poses is a folder", "build-map {trav} {new}.map --poses {root}", "folder"),
    ("route missing query", "route {trav} {root}/nope --out {new}", "does not exist"),
    ("route out is a file", "route {trav} {trav} --out {text}", "not a folder"),
    ("route out under a file", "route {trav} {trav} --out {text}/o", "is a file"),
    ("route ds 1", "route {trav} {trav} --out {new} --ds 1", "ds must be"),
    ("route vmin NaN", "route {trav} {trav} --out {new} --vmin nan", "vmin"),
    ("route vmin above vmax", "route {trav} {trav} --out {new} --vmin 2 --vmax 1", "--vmax must be >= --vmin"),
    ("route negative tolerance", "route {trav} {trav} --out {new} --tolerance -1", "tolerance"),
    ("route bad params", "route {trav} {trav} --out {new} --params {bad_toml}", "widht"),
    ("route threads 0", "route {trav} {trav} --out {new} --threads 0", "threads"),
    ("route search too large", "route {trav} {trav} --out {new} --ds 100000 --vmax 1000", "too large a search"),
    ("route frame step 0", "route {trav} {trav} --out {new} --frame-step 0", "frame-step"),
    ("route too few frames", "route {trav} {trav} --out {new} --method seqslam --ds 4", "uniqueness window"),
    ("evaluate missing reference", "evaluate {root}/nope {trav} --out {new}", "does not exist"),
    ("evaluate reference without poses", "evaluate {no_poses} {trav} --out {new}", "no poses"),
    ("evaluate query without poses", "evaluate {trav} {no_poses} --out {new}", "no poses"),
    ("evaluate truncated map", "evaluate {truncated_map} {trav} --out {new}", "truncated"),
    ("evaluate text file as map", "evaluate {text} {trav} --out {new}", "not a nightloc reference map"),
    ("evaluate seq length 0", "evaluate {trav} {trav} --out {new} --seq-lengths 0", "--seq-lengths"),
    ("evaluate seq lengths text", "evaluate {trav} {trav} --out {new} --seq-lengths x", "--seq-lengths"),
    ("evaluate seq lengths backwards", "evaluate {trav} {trav} --out {new} --seq-lengths 10-1", "backwards"),
    ("evaluate seq lengths huge", "evaluate {trav} {trav} --out {new} --seq-lengths 1-100000", "too long"),
    ("evaluate noise model 7", "evaluate {trav} {trav} --out {new} --noise-models 7", "--noise-models"),
    ("evaluate interpolation maybe", "evaluate {trav} {trav} --out {new} --interpolation maybe", "--interpolation"),
    ("evaluate repeats 0", "evaluate {trav} {trav} --out {new} --repeats 0", "--repeats"),
    ("evaluate out is a file", "evaluate {trav} {trav} --out {text}", "is a file"),
    ("evaluate out under a file", "evaluate {trav} {trav} --out {text}/o", "is a file"),
    ("evaluate bad params", "evaluate {trav} {trav} --out {new} --params {bad_toml}", "widht"),
    (
        "evaluate heat-map frame past the end",
        "evaluate {trav} {trav} --out {new} --heatmap-frames 999",
        "heatmap-frames",
    ),
    ("evaluate threads 0", "evaluate {trav} {trav} --out {new} --threads 0", "threads"),
    ("demo out is a file", "demo --out {text}", "is a file"),
    ("synth out is a file", "synth --out {text}", "is a file"),
    ("synth darkness 9", "synth --out {new} --darkness 9", "--darkness"),
    ("synth negative seed", "synth --out {new} --seed -1", "--seed"),
    ("synth threads 0", "synth --out {new} --threads 0", "threads"),
]

# argparse's own usage errors: exit 2 with its usage lines, never a traceback
USAGE_CASES = [
    ("no command", ""),
    ("unknown command", "localize"),
    ("non-integer option", "build-map trav out.map --frame-step x"),
    ("missing argument", "build-map"),
    ("unknown option", "info --fast"),
    ("bad choice", "route a b --out o --mode sideways"),
]


def _argv(template: str, ws) -> list:
    return template.format(**_paths(ws)).split()


def _snapshot(ws) -> dict:
    """Every file under the workspace with its bytes (a failed command must change none)."""
    return {p: p.read_bytes() for p in ws.root.rglob("*") if p.is_file()}


@pytest.mark.parametrize("case", CASES, ids=[c[0] for c in CASES])
def test_cli_error_is_one_line_exit_2_and_writes_nothing(ws, case, capsys):
    _, template, words = case
    before = _snapshot(ws)
    status = cli.main(_argv(template, ws))
    captured = capsys.readouterr()
    command = template.split()[0]
    assert status == 2, captured.err
    assert captured.err.startswith(f"nightloc {command}: error: "), captured.err
    assert captured.err.count("\n") == 1, captured.err
    assert "Traceback" not in captured.err
    assert words.lower() in captured.err.lower(), captured.err
    assert _snapshot(ws) == before, "a failed command changed or wrote files"
    assert not any(p.name.startswith(".") for p in ws.root.rglob("*")), "temporary files left behind"
    leftovers = [p for p in ws.root.iterdir() if p.name.startswith("never_written")]
    for path in leftovers:  # an output folder created for a command that then failed must be empty
        assert path.is_dir() and not any(path.iterdir()), path
        shutil.rmtree(path)


@pytest.mark.parametrize("case", USAGE_CASES, ids=[c[0] for c in USAGE_CASES])
def test_usage_errors_exit_2_without_traceback(case, capsys):
    with pytest.raises(SystemExit) as info:
        cli.main(case[1].split())
    assert info.value.code == 2
    err = capsys.readouterr().err
    assert "usage: nightloc" in err and "error:" in err and "Traceback" not in err


def test_internal_error_is_one_line_exit_1(monkeypatch, capsys):
    """A bug (an exception that is not about the user's input) still gives one line, status 1."""
    from nightloc.commands import info

    def broken(args):
        raise RuntimeError("simulated bug\nsecond line")

    monkeypatch.setattr(info, "run", broken)
    assert cli.main(["info"]) == 1
    err = capsys.readouterr().err
    assert err.startswith("nightloc info: internal error: RuntimeError: simulated bug second line")
    assert err.count("\n") == 1 and "NIGHTLOC_DEBUG=1" in err


def test_debug_environment_shows_the_traceback(monkeypatch):
    monkeypatch.setenv("NIGHTLOC_DEBUG", "1")
    with pytest.raises(ValueError, match="--refs"):
        cli.main(["info", "--refs", "0"])


def test_existing_output_survives_a_failed_build(ws, capsys):
    """A map that exists is left as it was when a rebuild fails half-way (a frame cannot be read)."""
    target = ws.root / "kept.map"
    shutil.copy(ws.map_file, target)
    before = target.read_bytes()
    broken = ws.traverse_variant(images={ws.names[4]: b"\x89PNG\r\n\x1a\n truncated"})
    assert cli.main(["build-map", str(broken), str(target), "--overwrite"]) == 2
    assert ws.names[4] in capsys.readouterr().err
    assert target.read_bytes() == before
    assert sorted(p.name for p in ws.root.iterdir() if p.name.startswith(".")) == []


SUBPROCESS_CASES = [
    ("build-map {trav} {text}/x.map", 2, "is a file"),
    ("build-map {junk_video} {new}.map", 2, "cannot be opened"),
    ("route {trav} {root}/nope --out {new}", 2, "does not exist"),
    ("synth --out {new} --darkness 9", 2, "--darkness"),
    ("info --refs 0", 2, "--refs"),
    ("evaluate {truncated_map} {trav} --out {new}", 2, "truncated"),
]


def test_cli_errors_as_a_separate_process(ws):
    """What a shell user sees: exit status 2 and exactly one line on stderr (no OpenCV or FFmpeg
    log lines, no traceback), nothing on stdout."""
    processes = [
        (
            subprocess.Popen(
                [sys.executable, "-m", "nightloc.cli", *_argv(template, ws)],
                stdout=subprocess.PIPE,
                stderr=subprocess.PIPE,
                text=True,
                cwd=ws.root,
            ),
            status,
            words,
        )
        for template, status, words in SUBPROCESS_CASES
    ]
    for process, status, words in processes:
        out, err = process.communicate(timeout=120)
        assert process.returncode == status, err
        assert err.count("\n") == 1 and words in err and "Traceback" not in err, err
        assert out == ""
    assert not (ws.root / "never_written.map").exists()


def test_paths_in_messages_are_the_users(ws, capsys):
    """Relative paths come back as the user typed them."""
    assert cli.main(["build-map", "no/such/traverse", str(ws.root / "x.map")]) == 2
    assert "no/such/traverse" in capsys.readouterr().err
    assert not (ws.root / "x.map").exists()
    assert Path(ws.root).is_dir()
