"""The progress helper yields every item, with and without drawing."""

from __future__ import annotations

from nightloc.progress import progress


def test_progress_yields_all_items_silently(monkeypatch, capsys):
    monkeypatch.setenv("NIGHTLOC_PROGRESS", "0")
    assert list(progress(range(5), desc="x")) == [0, 1, 2, 3, 4]
    assert capsys.readouterr().err == ""


def test_progress_draws_when_enabled(monkeypatch, capsys):
    monkeypatch.setenv("NIGHTLOC_PROGRESS", "1")
    monkeypatch.setitem(__import__("sys").modules, "tqdm", None)  # force the built-in bar
    assert list(progress(iter(range(3)), total=3, desc="loading")) == [0, 1, 2]
    err = capsys.readouterr().err
    assert "loading" in err and "3/3" in err
