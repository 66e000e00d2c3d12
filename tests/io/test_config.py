"""Parameter dataclasses and their TOML files; tomllib is the independent oracle of the writer."""

from __future__ import annotations

import dataclasses
import math
import os
import tomllib
from typing import Literal

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import nightloc
from nightloc import NightlocError, PreparationParams, load_params, save_params
from nightloc.config import (
    dumps_toml,
    load_params_file,
    params_from_dict,
    params_section,
    params_to_dict,
    registered_sections,
)


@params_section("test_extra")
@dataclasses.dataclass(frozen=True)
class ExtraParams:
    """A second parameter class, as another module would declare one."""

    grid: tuple[int, int] = (100, 100)
    noise: float | None = None
    mode: Literal["a", "b"] = "a"
    tags: tuple[str, ...] = ()
    weight: int | float = 1

    def validate(self) -> None:
        if min(self.grid) < 2:
            raise ValueError(f"grid must be >= 2 cells, got {self.grid}")


def test_paper_defaults():
    p = PreparationParams()
    assert (p.width, p.height, p.radius) == (48, 24, 4)  # Table II: Rx, Ry; P
    assert p.wrap is True and p.equalize == "global" and p.patch_normalize is True
    assert p.scale == nightloc.DEFAULT_PATCH_SCALE and p.crop == (0, 0, 0, 0)
    assert p.shifts is None and PreparationParams(wrap=False).shifts == [0]
    assert registered_sections()["preparation"] is PreparationParams


def test_frozen_and_normalized():
    p = PreparationParams(width=np.int64(64), scale=30, crop=[0, 0.25, np.int32(5), 0], clahe_tiles=[4, 2])
    assert p.width == 64 and type(p.width) is int
    assert p.scale == 30.0 and type(p.scale) is float
    assert p.crop == (0, 0.25, 5, 0) and type(p.crop[2]) is int and type(p.crop[1]) is float
    assert p.clahe_tiles == (4, 2)
    with pytest.raises(dataclasses.FrozenInstanceError):
        p.width = 10  # type: ignore[misc]
    assert dataclasses.replace(p, width=32).width == 32


@pytest.mark.parametrize(
    ("kwargs", "error", "text"),
    [
        ({"width": "48"}, TypeError, "width must be int, got str"),
        ({"width": 48.0}, TypeError, "width must be int"),
        ({"wrap": 1}, TypeError, "wrap must be bool"),
        ({"radius": True}, TypeError, "radius must be int"),
        ({"equalize": "histogram"}, TypeError, "'global' or 'clahe' or 'none'"),
        ({"crop": (0, 0, 0)}, TypeError, "crop must be a list of 4 values"),
        ({"width": 0}, ValueError, "width must be an integer >= 1"),
        ({"radius": -1}, ValueError, "radius"),
        ({"scale": float("nan")}, ValueError, "scale"),
        ({"crop": (0, 1.5, 0, 0)}, ValueError, "write pixels as an integer"),
        ({"crop": (0.6, 0.4, 0, 0)}, ValueError, "whole height"),
        ({"crop": (-1, 0, 0, 0)}, ValueError, ">= 0"),
        ({"clahe_clip_limit": 0}, ValueError, "clahe_clip_limit"),
        ({"clahe_tiles": (0, 8)}, ValueError, "clahe_tiles"),
    ],
)
def test_bad_values(kwargs, error, text):
    with pytest.raises(error, match=text):
        PreparationParams(**kwargs)
    with pytest.raises(error):  # replace() checks too
        dataclasses.replace(PreparationParams(), **kwargs)


def test_round_trip_through_toml(tmp_path):
    p = PreparationParams(
        width=64,
        height=16,
        radius=3,
        wrap=False,
        equalize="clahe",
        crop=(0, 0.1, 12, 0),
        scale=20.5,
        channel_order="rgb",
    )
    extra = ExtraParams(grid=(30, 20), noise=0.25, mode="b", tags=('q"uote', "back\\slash", "ü"), weight=0.5)
    save_params(tmp_path / "p.toml", [p, extra])
    assert load_params(tmp_path / "p.toml") == p
    assert load_params(tmp_path / "p.toml", PreparationParams) == p
    assert load_params(tmp_path / "p.toml", ExtraParams) == extra
    loaded = load_params(tmp_path / "p.toml")
    assert type(loaded.crop[1]) is float and type(loaded.crop[2]) is int
    text = (tmp_path / "p.toml").read_text()
    assert "[preparation]" in text and "[test_extra]" in text
    document = tomllib.loads(text)
    assert document["preparation"]["crop"] == [0, 0.1, 12, 0]


def test_none_is_left_out_and_missing_keys_default(tmp_path):
    save_params(tmp_path / "e.toml", ExtraParams())
    assert "noise" not in (tmp_path / "e.toml").read_text()
    assert load_params(tmp_path / "e.toml", ExtraParams) == ExtraParams()
    (tmp_path / "partial.toml").write_text("[preparation]\nequalize = 'none'\n")
    assert load_params(tmp_path / "partial.toml") == PreparationParams(equalize="none")
    (tmp_path / "other.toml").write_text("[test_extra]\nmode = 'b'\n")
    assert load_params(tmp_path / "other.toml") == PreparationParams()  # no [preparation]: defaults


@pytest.mark.parametrize(
    ("text", "fragments"),
    [
        ("[preparation]\nwidht = 48\n", ["unknown key 'widht'", "[preparation]", "width"]),
        ("[preperation]\nwidth = 48\n", ["unknown table [preperation]", "[preparation]"]),
        ("width = 48\n", ["'width'", "outside any table", "[preparation]"]),
        ("[preparation]\nwidth = '48'\n", ["width must be int", "[preparation]"]),
        ("[preparation]\ncrop = [0, 2.0, 0, 0]\n", ["crop bottom"]),
        ("[preparation]\nwidth = 48\nwidth = 49\n", ["not valid TOML"]),
        ("[preparation\n", ["not valid TOML"]),
        ("[preparation]\nwidth = 0\n", ["width must be an integer >= 1"]),
        ("preparation = 3\n", ["[preparation] must be a table"]),
    ],
)
def test_bad_files_name_file_and_key(tmp_path, text, fragments):
    file = tmp_path / "bad.toml"
    file.write_text(text)
    with pytest.raises(NightlocError) as info:
        load_params(file)
    message = str(info.value)
    assert "bad.toml" in message
    for fragment in fragments:
        assert fragment in message, message
    assert isinstance(info.value, ValueError)


def test_unreadable_files(tmp_path):
    with pytest.raises(NightlocError, match="does not exist"):
        load_params(tmp_path / "missing.toml")
    (tmp_path / "latin.toml").write_bytes(b"[preparation]\nchannel_order = '\xe9'\n")
    with pytest.raises(NightlocError, match="UTF-8"):
        load_params(tmp_path / "latin.toml")


def test_load_params_file_returns_every_table(tmp_path):
    save_params(tmp_path / "p.toml", (PreparationParams(width=32), ExtraParams(mode="b")))
    found = load_params_file(tmp_path / "p.toml")
    assert found == {"preparation": PreparationParams(width=32), "test_extra": ExtraParams(mode="b")}


def test_save_errors_and_atomic_write(tmp_path, monkeypatch):
    with pytest.raises(ValueError, match="empty"):
        save_params(tmp_path / "p.toml", [])
    with pytest.raises(ValueError, match="two instances"):
        save_params(tmp_path / "p.toml", [PreparationParams(), PreparationParams()])
    with pytest.raises(TypeError, match="not a parameter class"):
        save_params(tmp_path / "p.toml", {"width": 3})
    save_params(tmp_path / "p.toml", PreparationParams(width=32))
    before = (tmp_path / "p.toml").read_bytes()

    def failing_replace(src, dst):
        raise OSError("disk full")

    monkeypatch.setattr(os, "replace", failing_replace)
    with pytest.raises(OSError, match="disk full"):
        save_params(tmp_path / "p.toml", PreparationParams(width=16), overwrite=True)
    assert (tmp_path / "p.toml").read_bytes() == before
    assert os.listdir(tmp_path) == ["p.toml"]


def test_save_replaces_an_existing_file_only_with_overwrite(tmp_path):
    """A user's parameter file is never replaced by accident (as maps and traverses)."""
    mine = tmp_path / "tuned.toml"
    mine.write_text("# my notes\n[preparation]\nwidth = 32\n")
    before = mine.read_bytes()
    with pytest.raises(FileExistsError, match="overwrite=True"):
        save_params(mine, PreparationParams(width=16))
    assert mine.read_bytes() == before
    save_params(mine, PreparationParams(width=16), overwrite=True)
    assert load_params(mine) == PreparationParams(width=16)
    with pytest.raises(FileNotFoundError):
        save_params(tmp_path / "missing" / "p.toml", PreparationParams())
    assert sorted(os.listdir(tmp_path)) == ["tuned.toml"]


def test_registration_rules():
    with pytest.raises(TypeError, match="frozen dataclass"):

        @params_section("test_not_frozen")
        @dataclasses.dataclass
        class NotFrozen:
            a: int = 1

    with pytest.raises(ValueError, match="already taken"):

        @params_section("preparation")
        @dataclasses.dataclass(frozen=True)
        class Clash:
            a: int = 1

    with pytest.raises(ValueError, match="bare TOML key"):
        params_section("two words")
    assert ExtraParams(weight=2).weight == 2 and type(ExtraParams(weight=2).weight) is int
    with pytest.raises(ValueError, match="grid must be >= 2"):
        ExtraParams(grid=(1, 5))
    with pytest.raises(NightlocError, match="unknown key 'x'"):
        params_from_dict(ExtraParams, {"x": 1})
    assert params_to_dict(ExtraParams(tags=("a",))) == {"grid": [100, 100], "mode": "a", "tags": ["a"], "weight": 1}


# -------------------------------------------------------------------------------------------
# the TOML writer against tomllib

keys = st.text(min_size=1, max_size=8)
scalars = st.one_of(
    st.booleans(),
    st.integers(min_value=-(2**63), max_value=2**63 - 1),
    st.floats(allow_nan=False),
    st.text(max_size=12),
)
values = st.one_of(scalars, st.lists(scalars, max_size=4), st.lists(st.lists(st.integers(), max_size=3), max_size=3))
tables = st.dictionaries(keys, values, max_size=5)
documents = st.dictionaries(keys, st.one_of(values, tables, st.dictionaries(keys, tables, max_size=2)), max_size=5)


@settings(max_examples=300, deadline=None)
@given(documents)
def test_writer_round_trips_through_tomllib(document):
    assert tomllib.loads(dumps_toml(document, header="a comment\nsecond line")) == document


def test_writer_special_floats_and_strings():
    text = dumps_toml({"t": {"a": float("inf"), "b": -float("inf"), "c": float("nan"), "d": "tab\there\x01\x7f"}})
    back = tomllib.loads(text)["t"]
    assert back["a"] == math.inf and back["b"] == -math.inf and math.isnan(back["c"])
    assert back["d"] == "tab\there\x01\x7f"
    with pytest.raises(TypeError, match="cannot write"):
        dumps_toml({"x": object()})
