"""``nightloc localize MAP LOG --out RUN --learn NEW_MAP``: an experience map from a night."""

from __future__ import annotations

import hashlib

import numpy as np
import pytest

import nightloc
from nightloc.cli import main

from synth_support import default_synth_data


def _digest(path):
    return hashlib.sha256(path.read_bytes()).hexdigest()


@pytest.fixture(scope="module")
def garden_map(tmp_path_factory):
    folders = default_synth_data()["garden"]
    map_file = tmp_path_factory.mktemp("learn") / "day.map"
    assert main(["build-map", str(folders["day_reference"]), str(map_file)]) == 0
    return folders, map_file


def test_learn_writes_a_new_map_and_leaves_the_day_map_untouched(garden_map, tmp_path, capsys):
    folders, map_file = garden_map
    before = _digest(map_file)
    new_map = tmp_path / "night1.map"
    args = ["localize", str(map_file), str(folders["night_reference"]), "--out", str(tmp_path / "run"), "--no-figures"]
    assert main([*args, "--learn", str(new_map)]) == 0
    printed = capsys.readouterr().out
    assert _digest(map_file) == before
    assert "night 1:" in printed and f"wrote {new_map}" in printed
    day = nightloc.ReferenceMap.load(map_file)
    learned = nightloc.ReferenceMap.load(new_map)
    rec = learned.appearances
    assert rec is not None and rec.nights[0].source == str(folders["night_reference"])
    n = len(day)
    # the day map's references come first, unchanged; the learned ones stand at a day place or in a gap
    np.testing.assert_array_equal(learned.images[:n], day.images)
    assert rec.night[:n].tolist() == [0] * n and (rec.night[n:] == 1).all() and len(learned) > n
    day_places = {tuple(p) for p in day.positions.tolist()}
    at_places = [tuple(p) in day_places for p in learned.positions[n:].tolist()]
    assert sum(at_places) == rec.nights[0].appearances
    # the trajectory is the plain localizer's (learning only watches it)
    plain = tmp_path / "plain"
    assert main(["localize", str(map_file), str(folders["night_reference"]), "--out", str(plain), "--no-figures"]) == 0
    assert (plain / "trajectory.csv").read_text() == (tmp_path / "run" / "trajectory.csv").read_text()

    # the same night again: the map grows by at most 10 % of its places
    again = tmp_path / "night1-again.map"
    log = str(folders["night_reference"])
    assert (
        main(["localize", str(new_map), log, "--out", str(tmp_path / "run2"), "--no-figures", "--learn", str(again)])
        == 0
    )
    relearned = nightloc.ReferenceMap.load(again)
    places = len(np.unique(learned.positions, axis=0))
    assert len(relearned) - len(learned) <= 0.1 * places


def test_learn_refuses_the_map_itself_and_an_existing_file(garden_map, tmp_path, capsys):
    folders, map_file = garden_map
    base = ["localize", str(map_file), str(folders["night_reference"]), "--out", str(tmp_path / "run"), "--no-figures"]
    before = _digest(map_file)
    assert main([*base, "--learn", str(map_file)]) != 0
    assert "is the map itself" in capsys.readouterr().err
    existing = tmp_path / "taken.map"
    existing.write_bytes(b"mine")
    assert main([*base, "--learn", str(existing)]) != 0
    assert "--overwrite" in capsys.readouterr().err
    assert existing.read_bytes() == b"mine" and _digest(map_file) == before
    assert main([*base, "--overwrite"]) != 0
    assert "--learn" in capsys.readouterr().err
