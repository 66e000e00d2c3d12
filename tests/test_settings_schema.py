"""The settings schema: one table per parameter class, and everything else checked against it.

* a default is written once: a field the compiled core holds takes its default from the core's
  table (its source says ``TABLE.field("name")``, and the value equals a default-constructed
  struct's), every other field's default is its dataclass's own;
* the range in words is the core's (Python's wording of a range equals the C++ one for every row of
  every core table) and a value out of range is refused in those words, from Python and from a
  parameter file or ``--set`` alike;
* the ``.pyi`` lines of the bound classes, the ``Literal`` choices of the dataclasses and
  docs/settings.md follow the tables; the defaults docs/localization.md and docs/route_mode.md
  state are the schema's.
"""

from __future__ import annotations

import ast
import dataclasses
import inspect
import math
import re
import sys
import typing
from pathlib import Path

import pytest

import nightloc
from nightloc import _core
from nightloc.config import SettingsLayers, parse_assignment, registered_sections
from nightloc.errors import NightlocError
from nightloc.schema import Range, core_names, docstring_entries, settings_schema, value_text

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tools"))
import settings_tables

ROOT = Path(__file__).resolve().parents[1]
CORE_CLASSES = (_core.GridFilterSettings, _core.PrepareSettings, _core.RouteFilterParams, _core.TrajectoryParams)
#: nightloc's own tables (tests register classes of their own too).
SECTIONS = sorted(name for name, cls in registered_sections().items() if cls.__module__.startswith("nightloc."))


def _classes():
    return [registered_sections()[name] for name in SECTIONS]


@pytest.mark.parametrize("section", SECTIONS)
def test_every_field_has_a_row_with_a_doc(section):
    cls = registered_sections()[section]
    table = settings_schema(cls)
    assert [s.name for s in table] == [f.name for f in dataclasses.fields(cls)]
    for setting in table:
        assert setting.doc, f"[{section}] {setting.name} has no doc (its line in the docstring's Attributes)"
        assert setting.kind in ("real", "count", "integer", "flag", "choice", "value"), setting


@pytest.mark.parametrize("section", SECTIONS)
def test_a_default_is_written_once(section):
    """A core field's default is the core's (equal, same type) and its source line reads it from the
    core's table instead of writing a number; every row's default is the dataclass's default."""
    cls = registered_sections()[section]
    fields = {f.name: f for f in dataclasses.fields(cls)}
    held = core_names(cls)
    tree = ast.parse(inspect.getsource(cls))
    written = {
        node.target.id: node.value
        for node in ast.walk(tree)
        if isinstance(node, ast.AnnAssign) and isinstance(node.target, ast.Name) and node.value is not None
    }
    for setting in settings_schema(cls):
        assert setting.default == fields[setting.name].default, setting.name
        if setting.core is None:
            continue
        core_class, core_name = setting.core.split(".")
        assert held[setting.name] == core_name
        core_default = getattr(getattr(_core, core_class)(), core_name)
        assert setting.default == core_default and type(setting.default) is type(core_default), setting.name
        source = written[setting.name]  # X.field("name"): the core's, not a number
        assert isinstance(source, ast.Call) and isinstance(source.func, ast.Attribute), ast.unparse(source)
        assert source.func.attr == "field" and ast.literal_eval(source.args[0]) == core_name, ast.unparse(source)


def test_confidence_radius_has_one_default():
    """LocalizationParams' radius is the core's field: one default for the filter and the paper's method."""
    (setting,) = [s for s in settings_schema(nightloc.LocalizationParams) if s.name == "confidence_radius"]
    assert setting.core == "GridFilterSettings.confidence_radius"
    assert nightloc.LocalizationParams().confidence_radius == _core.GridFilterSettings().confidence_radius


@pytest.mark.parametrize("core_class", CORE_CLASSES, ids=lambda c: c.__name__)
def test_python_words_a_range_as_the_core_does(core_class):
    for row in core_class.fields():
        kind = row["kind"]
        if kind in ("flag", "choice"):
            continue
        special = row["special"]
        words = Range(
            -math.inf if row["min"] is None else row["min"],
            math.inf if row["max"] is None else row["max"],
            row["min_open"],
            row["max_open"],
            row["infinite"],
            None if special is None else float(special),
            row["special_means"],
        ).text("real" if kind == "real" else "integer", row["unit"])
        assert words == row["range"], row["name"]


@pytest.mark.parametrize("value", [-0.015, -1e-5, -1e16, -5000.0, -1.5, -0.1 - 0.2, -math.inf, math.nan])
def test_python_words_a_value_as_the_core_does(value):
    settings = _core.GridFilterSettings()
    with pytest.raises(_core.SettingError) as error:
        settings.likelihood_gain = value
    assert error.value.requirement.endswith(f", got {value_text(value)}")


def _outside(setting) -> object | None:
    """A value of the field's type just outside its range, or None."""
    r = setting.range
    if r is None or setting.kind not in ("real", "count", "integer"):
        return None
    if math.isfinite(r.min):
        value = r.min if r.min_open else r.min - 1
    elif math.isfinite(r.max):
        value = r.max if r.max_open else r.max + 1
    else:
        return None
    if r.special is not None and value == r.special:
        value -= 0.5
    return int(value) if setting.kind in ("count", "integer") and float(value).is_integer() else float(value)


@pytest.mark.parametrize("section", SECTIONS)
def test_a_value_out_of_range_is_refused_in_the_tables_words(section, tmp_path):
    cls = registered_sections()[section]
    checked = 0
    for setting in settings_schema(cls):
        value = _outside(setting)
        if value is None:
            continue
        words = f"{setting.name} must be {setting.range_text}, got {value_text(value)}"
        with pytest.raises(ValueError, match=re.escape(words)) as error:
            cls(**{setting.name: value})
        assert str(error.value) == words
        # a parameter file and --set: the same words after where they come from
        file = tmp_path / f"{setting.name}.toml"
        file.write_text(f"[{section}]\n{setting.name} = {nightloc.config.toml_value(value)}\n")
        with pytest.raises(NightlocError) as from_file:
            nightloc.config.load_params_file(file)
        assert str(from_file.value) == f"{file}: [{section}] {words}"
        assignment = f"{section}.{setting.name}={nightloc.config.toml_value(value)}"
        with pytest.raises(NightlocError) as from_set:
            SettingsLayers().add_assignments([assignment])
        assert str(from_set.value) == f"--set {assignment}: [{section}] {words}"
        checked += 1
    assert checked or section == "learning", f"[{section}] has no range to check"


def test_set_reads_toml_values_and_bare_words():
    assert parse_assignment("filter.uniform_floor=0.05") == ("filter", "uniform_floor", 0.05)
    assert parse_assignment("filter.heading_bins = 24") == ("filter", "heading_bins", 24)
    assert parse_assignment("preparation.wrap=false") == ("preparation", "wrap", False)
    assert parse_assignment('preparation.equalize="none"') == ("preparation", "equalize", "none")
    assert parse_assignment("preparation.equalize=none") == ("preparation", "equalize", "none")
    assert parse_assignment("preparation.crop=[0, 0.1, 0, 0]") == ("preparation", "crop", [0, 0.1, 0, 0])
    for bad, words in (
        ("uniform_floor=0.05", "expected SECTION.KEY=VALUE"),
        ("filter.uniform_floor=", "the value is missing"),
        ("filters.uniform_floor=0.05", r"unknown table \[filters\]"),
        ("filter.uniform_floor=0.05 0.1", "is not a TOML value"),
    ):
        with pytest.raises(NightlocError, match=words):
            parse_assignment(bad)


def test_layers_win_key_by_key_and_say_where_each_came_from(tmp_path):
    file = tmp_path / "tuned.toml"
    file.write_text("[filter]\nuniform_floor = 0.05\nheading_bins = 24\n")
    layers = SettingsLayers().add_file(file).add_assignments(["filter.heading_bins=12"])
    layers.add("the map m.map", {"filter": {"likelihood_gain": 2.5, "uniform_floor": 0.02}}, below=True)
    got = layers.get(nightloc.FilterParams)
    assert (got.uniform_floor, got.heading_bins, got.likelihood_gain) == (0.05, 12, 2.5)
    assert got.settle_frames == nightloc.FilterParams().settle_frames
    assert layers.origin("filter", "heading_bins") == "--set"
    assert layers.origin("filter", "uniform_floor") == str(file)
    assert layers.origin("filter", "likelihood_gain") == "the map m.map"
    assert layers.origin("filter", "settle_frames") is None
    assert layers.report(["filter"]) == [
        "the map m.map: [filter] likelihood_gain = 2.5",
        f"{file}: [filter] uniform_floor = 0.05",
        "--set: [filter] heading_bins = 12",
    ]
    assert layers.section(nightloc.LocalizationParams) is None
    # a combination no source makes alone is refused naming the sources
    route = SettingsLayers().add_assignments(["route.vmin=1.0"]).add("a file", {"route": {"vmax": 0.9}})
    with pytest.raises(NightlocError, match=r"^--set and a file: \[route\] vmax must be >= vmin \(1\), got 0.9$"):
        route.get(nightloc.RouteParams)


_PYI_TYPES = {"real": "float", "count": "int", "integer": "int", "flag": "bool", "choice": "str"}


@pytest.mark.parametrize("core_class", CORE_CLASSES, ids=lambda c: c.__name__)
def test_the_pyi_lines_are_the_table(core_class):
    tree = ast.parse((ROOT / "python" / "nightloc" / "_core.pyi").read_text())
    (stub,) = [n for n in tree.body if isinstance(n, ast.ClassDef) and n.name == core_class.__name__]
    lines = [(n.target.id, n.annotation) for n in stub.body if isinstance(n, ast.AnnAssign)]
    rows = core_class.fields()
    assert [name for name, _ in lines] == [row["name"] for row in rows]
    for (name, annotation), row in zip(lines, rows):
        if isinstance(annotation, ast.Subscript):  # Literal[...]: the choices, in any order
            assert row["kind"] == "choice" and ast.unparse(annotation.value) == "Literal", name
            assert set(ast.literal_eval(annotation.slice)) == set(row["choices"]), name
        else:
            assert ast.unparse(annotation) == _PYI_TYPES[row["kind"]], name


@pytest.mark.parametrize("cls", _classes(), ids=lambda c: c.__name__)
def test_a_literal_field_names_the_cores_choices(cls):
    hints = typing.get_type_hints(cls)
    for setting in settings_schema(cls):
        if setting.core is not None and setting.kind == "choice":
            literal = typing.get_args(hints[setting.name])
            if literal:
                assert set(literal) == set(setting.choices), setting.name


def test_docstring_entries_read_groups_and_sub_headings():
    doc = """Summary.

    Attributes:
        a: one
            two.
        b, c: shared.
    A sub-heading:
        d: last.
    """
    assert docstring_entries(doc) == {"a": "one two.", "b": "shared.", "c": "shared.", "d": "last."}


def test_the_settings_page_is_written_from_the_tables():
    assert (ROOT / "docs" / "settings.md").read_text(encoding="utf-8") == settings_tables.page(), (
        "docs/settings.md is stale: python tools/settings_tables.py"
    )


def _number(text: str) -> object:
    """A documented default: ``0.05 m`` -> 0.05, ``90°`` -> 90.0, ``"speed"`` -> speed, ``inf``."""
    word = text.strip().split(" ")[0].rstrip("°").strip("`")
    if word.startswith('"'):
        return word.strip('"')
    return float(word)


@pytest.mark.parametrize(
    ("page", "section", "header"),
    [
        ("localization.md", "filter", "| parameter | default | meaning |"),
        ("route_mode.md", "route", "| `[route]` field | default | meaning |"),
    ],
)
def test_the_docs_tables_state_the_schema_defaults(page, section, header):
    lines = (ROOT / "docs" / page).read_text(encoding="utf-8").splitlines()
    start = lines.index(header) + 2
    defaults = {s.name: s.default for s in settings_schema(registered_sections()[section])}
    checked = 0
    for line in lines[start:]:
        if not line.startswith("|"):
            break
        names_cell, default_cell = [cell.strip() for cell in line.strip("|").split("|")][:2]
        names = re.findall(r"`([a-z_]+)`", names_cell)
        if not all(name in defaults for name in names):
            continue  # not a field of the table (the localizer's odometry_noise)
        values = [_number(v) for v in default_cell.split(",")] if len(names) > 1 else [_number(default_cell)]
        for name, value in zip(names, values, strict=True):
            assert value == defaults[name], (
                f"{page}: {name} is documented as {value!r}, the schema's is {defaults[name]!r}"
            )
            checked += 1
    assert checked >= 10
