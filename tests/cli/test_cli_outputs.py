"""Every command writes its outputs as one set, and never touches its inputs or a user's files.

* **A result is a set**: a run that fails or is interrupted part-way leaves the previous output
  folder byte for byte (old behaviour: ``evaluate`` and ``route`` failing on their last file had
  already rewritten the others; an interrupted ``synth --overwrite`` left a new traverse beside
  old ones and the old ``dataset.json``; Ctrl-C during a re-run of ``route`` left a new
  ``matches.csv`` beside the old ``summary.json``).
* **Commands delete only what they created** (old: ``evaluate --no-figures`` deleted the user's
  ``heatmap_frame_notes.png``).
* **Inputs are sacred**: an output that is, contains or lies inside an input is refused before any
  work (old: ``build-map t t/images/000005.png`` wrote the map over a frame, exit 0; ``route R Q
  --out R`` wrote figures into the reference folder); an existing map or dataset is replaced
  only with ``--overwrite``; a map file's missing parent folder is an error, while an output
  folder (``--out``, "created with its parents if missing") is created with its parents, which a
  failed run removes again.
"""

from __future__ import annotations

import os
import shutil

import numpy as np
import pytest

import nightloc
from nightloc.cli import main
from nightloc.commands import demo as demo_command
from nightloc.commands import route as route_command
from nightloc.localization import evaluation as evaluation_module

from reliability_support import random_frames


def _tree(root):
    return {p.relative_to(root).as_posix(): p.read_bytes() for p in sorted(root.rglob("*")) if p.is_file()}


def _hidden_beside(path):
    return sorted(p.name for p in path.parent.iterdir() if p.name.startswith("."))


@pytest.fixture
def pair(tmp_path):
    """A reference and a query traverse with poses (30 frames each, the query a noisy copy)."""
    rng = np.random.default_rng(4)
    frames = random_frames(30, seed=5)
    positions = np.column_stack([np.arange(30) * 0.3, np.zeros(30)])
    noisy = [np.clip(f.astype(int) + rng.integers(-12, 13, f.shape), 0, 255).astype(np.uint8) for f in frames]
    ref = nightloc.save_traverse(tmp_path / "ref", frames, positions, np.zeros(30)).root
    query = nightloc.save_traverse(tmp_path / "query", noisy, positions + 0.05, np.zeros(30)).root
    return ref, query


EVALUATE = ["--seq-lengths", "1,2", "--noise-models", "0", "--interpolation", "on", "--no-figures"]


def _evaluate(ref, query, out, *extra):
    return main(["evaluate", str(ref), str(query), "--out", str(out), *EVALUATE, *extra])


def _route(ref, query, out, *extra):
    return main(["route", str(ref), str(query), "--out", str(out), "--ds", "4", "--no-figures", *extra])


# --------------------------------------------------------------------------------------------
# a result is a set


def test_evaluate_failing_on_its_last_file_keeps_the_previous_set(pair, tmp_path, monkeypatch, capsys):
    ref, query = pair
    out = tmp_path / "out"
    assert _evaluate(ref, query, out) == 0
    before = _tree(out)

    def fail(self, path, query=None):
        raise OSError(28, "No space left on device", str(path))

    monkeypatch.setattr(evaluation_module.Evaluation, "write_summary_csv", fail)
    assert _evaluate(ref, query, out, "--seq-lengths", "1") == 2
    assert "No space left on device" in capsys.readouterr().err
    assert _tree(out) == before, "errors.csv was rewritten although the run failed"
    assert _hidden_beside(out) == []


@pytest.mark.parametrize("failure", [OSError(28, "No space left on device"), KeyboardInterrupt()], ids=str)
def test_route_failing_or_interrupted_on_its_last_file_keeps_the_previous_set(pair, tmp_path, monkeypatch, failure):
    ref, query = pair
    out = tmp_path / "out"
    assert _route(ref, query, out, "--ground-truth", "frames") == 0
    before = _tree(out)
    real = route_command.write_text

    def write_but_not_the_summary(path, text, *args, **kwargs):
        if os.path.basename(path) == "summary.json":
            raise failure
        return real(path, text, *args, **kwargs)

    monkeypatch.setattr(route_command, "write_text", write_but_not_the_summary)
    status = _route(ref, query, out, "--ground-truth", "none", "--ds", "6")
    assert status == (130 if isinstance(failure, KeyboardInterrupt) else 2)
    assert _tree(out) == before, "matches.csv was rewritten beside the old summary.json"
    assert _hidden_beside(out) == []


def test_interrupted_synth_overwrite_keeps_the_whole_previous_dataset(tmp_path, monkeypatch, capsys):
    import nightloc.synth.dataset as dataset

    out = tmp_path / "room"
    small = ["synth", "--world", "living_room", "--out", str(out), "--size", "16x8", "--threads", "1"]
    assert main([*small, "--seed", "0"]) == 0
    before = _tree(out)
    real = dataset.save_traverse
    calls = []

    def interrupted_after_one_traverse(*args, **kwargs):
        if calls:
            raise KeyboardInterrupt
        calls.append(args[0])
        return real(*args, **kwargs)

    monkeypatch.setattr(dataset, "save_traverse", interrupted_after_one_traverse)
    assert main([*small, "--seed", "7", "--overwrite"]) == 130
    assert _tree(out) == before, "a traverse of seed 7 beside traverses and dataset.json of seed 0"
    assert _hidden_beside(out) == []
    monkeypatch.setattr(dataset, "save_traverse", real)
    assert main([*small, "--seed", "7"]) == 2  # an existing dataset needs --overwrite
    assert "--overwrite" in capsys.readouterr().err
    assert main([*small, "--seed", "7", "--overwrite"]) == 0
    assert '"seed": 7' in (out / "dataset.json").read_text()


def test_demo_failing_in_its_second_world_keeps_the_previous_set(tmp_path, monkeypatch):
    from synth_support import default_synth_data

    cache = default_synth_data()["garden"]["day_reference"].parents[2]
    real = demo_command.evaluate
    worlds = []

    def quick(ref_map, query, settings, params, **kwargs):  # one configuration: the same code, faster
        worlds.append(kwargs["progress_desc"].split(":")[0])  # two evaluations per world (map, wheel odometry)
        if fail and len(set(worlds)) == 2:
            raise ValueError("simulated failure in the second world")
        one = evaluation_module.EvaluationSettings((1,), (0,), (True,), odometry=settings.odometry)
        return real(ref_map, query, one, params, **kwargs)

    monkeypatch.setattr(demo_command, "evaluate", quick)
    out = tmp_path / "demo"
    fail = False
    assert main(["demo", "--out", str(out), "--cache", str(cache), "--no-figures"]) == 0
    before = _tree(out)
    assert sorted(before) == [
        ".nightloc-output.json",
        *(f"{w}/{f}" for w in ("garden", "living_room") for f in ("errors.csv", "errors_wheel.csv", "summary.csv")),
    ]
    fail, worlds[:] = True, []
    assert main(["demo", "--out", str(out), "--cache", str(cache), "--no-figures", "--seed", "3"]) == 2
    assert _tree(out) == before, "the first world was rewritten although the demo failed"


def test_evaluate_keeps_the_users_files_in_its_folder(pair, tmp_path):
    ref, query = pair
    out = tmp_path / "out"
    assert _evaluate(ref, query, out) == 0
    (out / "heatmap_frame_notes.png").write_bytes(b"the user's notes")
    (out / "analysis.ipynb").write_text("{}")
    assert _evaluate(ref, query, out) == 0
    assert (out / "heatmap_frame_notes.png").read_bytes() == b"the user's notes"
    assert (out / "analysis.ipynb").read_text() == "{}"


def test_a_folder_nightloc_did_not_write_is_refused(pair, tmp_path, capsys):
    ref, query = pair
    mine = tmp_path / "mine"
    mine.mkdir()
    (mine / "thesis.tex").write_text("\\section{}")
    assert _route(ref, query, mine) == 2
    assert "did not write" in capsys.readouterr().err
    assert _tree(mine) == {"thesis.tex": b"\\section{}"}


# --------------------------------------------------------------------------------------------
# inputs are sacred


def _frame(ref, index=5):
    return ref / "images" / f"{index:06d}.png"


SACRED = [
    ("build-map over a frame", lambda r, q, t: ["build-map", str(r), str(_frame(r))], "lies inside the input"),
    ("build-map over the poses", lambda r, q, t: ["build-map", str(r), str(r / "poses.csv")], "lies inside"),
    ("build-map into the traverse", lambda r, q, t: ["build-map", str(r), str(r / "ref.map")], "lies inside"),
    (
        "build-map over its params",
        lambda r, q, t: ["build-map", str(r), str(t / "p.toml"), "--params", str(t / "p.toml"), "--overwrite"],
        "is the input",
    ),
    ("route out is the reference", lambda r, q, t: ["route", str(r), str(q), "--out", str(r)], "is the input"),
    ("route out inside the query", lambda r, q, t: ["route", str(r), str(q), "--out", str(q / "o")], "lies inside"),
    ("route out contains the inputs", lambda r, q, t: ["route", str(r), str(q), "--out", str(t)], "contains the input"),
    ("evaluate out is the query", lambda r, q, t: ["evaluate", str(r), str(q), "--out", str(q)], "is the input"),
    (
        "evaluate out contains the map",
        lambda r, q, t: ["evaluate", str(t / "m" / "ref.map"), str(q), "--out", str(t / "m")],
        "contains the input",
    ),
    ("demo out contains the cache", lambda r, q, t: ["demo", "--out", str(t), "--cache", str(t / "c")], "contains"),
    ("build-map over an existing map", lambda r, q, t: ["build-map", str(r), str(t / "m" / "ref.map")], "--overwrite"),
    ("build-map under a file", lambda r, q, t: ["build-map", str(r), str(t / "p.toml" / "x.map")], "is a file"),
    ("route under a file", lambda r, q, t: ["route", str(r), str(q), "--out", str(t / "p.toml" / "o")], "is a file"),
]


@pytest.mark.parametrize("case", SACRED, ids=[c[0] for c in SACRED])
def test_outputs_never_land_on_inputs(pair, tmp_path, case, capsys):
    ref, query = pair
    (tmp_path / "p.toml").write_text("[preparation]\nwidth = 48\n")
    (tmp_path / "m").mkdir()
    nightloc.ReferenceMap.build(ref).save(tmp_path / "m" / "ref.map")
    before = _tree(tmp_path)
    _, argv, words = case
    assert main(argv(ref, query, tmp_path)) == 2
    err = capsys.readouterr().err
    assert words in err and err.count("\n") == 1, err
    assert _tree(tmp_path) == before, "an input or an existing output was changed"
    assert len(nightloc.load_traverse(ref)) == 30


OUT_FOLDER_COMMANDS = {
    "localize": lambda r, q, out: ["localize", str(r), str(q), "--out", str(out), "--odometry", "none"],
    "evaluate": lambda r, q, out: ["evaluate", str(r), str(q), "--out", str(out), *EVALUATE],
    "route": lambda r, q, out: ["route", str(r), str(q), "--out", str(out), "--ds", "4", "--no-figures"],
    "synth": lambda r, q, out: ["synth", "--world", "living_room", "--size", "16x8", "--out", str(out)],
    "demo": None,  # its parents are created the same way (output_set(..., parents=True)); a run takes minutes
    "camera-study": lambda r, q, out: ["camera-study", "--quick", "--method", "paper", "--out", str(out)],
}


def test_every_out_folder_says_it_is_created_with_its_parents():
    """--help and behaviour agree: every command whose --out is a folder says so."""
    from nightloc.cli import build_parser

    commands = build_parser()._subparsers._group_actions[0].choices
    for name, parser in commands.items():
        out = [a for a in parser._actions if "--out" in a.option_strings]
        if out:
            assert name in OUT_FOLDER_COMMANDS and "created with its parents if missing" in out[0].help, name
    assert set(OUT_FOLDER_COMMANDS) <= set(commands)


@pytest.mark.parametrize("command", [name for name, argv in OUT_FOLDER_COMMANDS.items() if argv is not None])
def test_out_folders_are_created_with_their_parents(pair, tmp_path, command, capsys):
    ref, query = pair
    out = tmp_path / "runs" / "night" / command
    assert main(OUT_FOLDER_COMMANDS[command](ref, query, out)) == 0, capsys.readouterr().err
    assert (out / ".nightloc-output.json").is_file()
    assert sorted(p.name for p in (tmp_path / "runs" / "night").iterdir()) == [command]  # no lock or staging left


def test_a_failed_run_removes_the_parents_it_created(pair, tmp_path, capsys):
    ref, query = pair
    broken = tmp_path / "broken"
    shutil.copytree(query, broken)
    (broken / "images" / "000017.png").write_bytes(b"not an image")  # found while localizing
    before = _tree(tmp_path)
    argv = ["localize", str(ref), str(broken), "--out", str(tmp_path / "runs" / "night" / "o"), "--odometry", "none"]
    assert main(argv) == 2
    assert "000017.png" in capsys.readouterr().err
    assert not (tmp_path / "runs").exists() and _tree(tmp_path) == before
    # a parent that existed stays
    (tmp_path / "runs").mkdir()
    assert main(argv) == 2
    assert [p.name for p in (tmp_path / "runs").iterdir()] == []
