"""The settings schema: one table per parameter class -- each field's name, type, default, range,
unit and a one-line doc -- that the checks, the TOML reader, ``--set``, the error messages and
the docs' tables come from.

The compiled core's settings structs publish theirs (``_core.GridFilterSettings.fields()``,
``PrepareSettings``, ``RouteFilterParams``, ``TrajectoryParams``; ``nightloc/settings.hpp``): a
default is written once, in the C++ struct. A parameter dataclass declares each field it shares
with one as :func:`core_field` (default, range, unit and doc from the core's row) and each field
of its own as :func:`own_field` (its default, unit and range; its doc the line of the class
docstring's ``Attributes:`` that names it)::

    GRID = CoreTable(_core.GridFilterSettings)

    @params_section("filter")
    @dataclass(frozen=True)
    class FilterParams:
        uniform_floor: float = GRID.field("uniform_floor")
        field_of_view: float = own_field(90.0, unit="degrees", range=Range(0, 360, min_open=True))

:func:`settings_schema` gives a class's whole table; :func:`nightloc.config.params_section`
checks each value against its range in the core's words (``"uniform_floor must be in [0, 1),
got 1.5"``); ``tools/settings_tables.py`` writes the docs' default tables from it.
"""

from __future__ import annotations

import dataclasses
import functools
import math
import re
import types
import typing
from typing import Any, Literal, Union

__all__ = [
    "ABOVE_0",
    "AT_LEAST_0",
    "CoreTable",
    "Range",
    "Setting",
    "core_field",
    "core_names",
    "docstring_entries",
    "own_field",
    "settings_schema",
    "value_text",
]

_KEY = "nightloc.schema"


def value_text(value: Any) -> str:
    """A value as the errors say it, the core's way: ``5000``, ``1.5``, ``0.015``, ``inf``, ``'none'``."""
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, int):
        return str(value)
    if isinstance(value, float):
        if math.isfinite(value) and value.is_integer() and abs(value) < 1e15:
            return str(int(value))
        return repr(value)
    if isinstance(value, str):
        return f"'{value}'"
    return repr(value)


@dataclasses.dataclass(frozen=True)
class Range:
    """The numbers a setting takes: ``min .. max`` (each end open or closed; an infinite end: no
    bound), finite unless ``infinite`` (then +inf too), and ``special``, a value allowed outside it
    whose meaning ``special_means`` says (nightloc/settings.hpp's SettingRange)."""

    min: float = -math.inf
    max: float = math.inf
    min_open: bool = False
    max_open: bool = False
    infinite: bool = False
    special: float | None = None
    special_means: str = ""

    def _numeric(self, value: float) -> bool:
        if math.isnan(value) or (math.isinf(value) and not (self.infinite and value > 0)):
            return False
        above = value > self.min if self.min_open else value >= self.min
        below = value < self.max if self.max_open else value <= self.max
        return above and below

    def contains(self, value: float) -> bool:
        """Whether ``value`` is allowed."""
        return (self.special is not None and value == self.special) or self._numeric(float(value))

    def text(self, kind: str, unit: str = "") -> str:
        """The range in words, as the core words it (``range_text`` in nightloc/settings.hpp)."""
        low, high = math.isfinite(self.min), math.isfinite(self.max)
        if low and high:
            body = (
                f"in {'(' if self.min_open else '['}{value_text(float(self.min))}, "
                f"{value_text(float(self.max))}{')' if self.max_open else ']'}"
            )
        elif low:
            body = f"{'>' if self.min_open else '>='} {value_text(float(self.min))}"
        elif high:
            body = f"{'<' if self.max_open else '<='} {value_text(float(self.max))}"
        else:
            body = ""
        if kind == "real":
            word = "a number" if self.infinite else "a finite number"
            text = body if low and high else f"{word} {body}".rstrip()
        else:
            text = f"an integer {body}".rstrip()
        if unit:
            text += f" {unit}"
        if self.infinite:
            text += " (inf allowed)"
        if self.special is not None:
            special = value_text(float(self.special))
            if self._numeric(float(self.special)):
                text += f" ({special}: {self.special_means})"
            else:
                text = f"{special} ({self.special_means}) or {text}"
        return text


#: The finite numbers >= 0.
AT_LEAST_0 = Range(0, math.inf)
#: The finite numbers > 0.
ABOVE_0 = Range(0, math.inf, min_open=True)


@dataclasses.dataclass(frozen=True)
class Setting:
    """One field of a settings table.

    Attributes:
        name: the field (the TOML key, the attribute).
        type: its Python type as text (``"float"``, ``"int"``, ``"tuple[int, int]"``, ...).
        kind: ``"real"``, ``"count"``, ``"integer"``, ``"flag"``, ``"choice"`` or ``"value"``
            (anything else: a tuple, an optional value).
        default: the default (for a core field: the C++ struct's).
        unit: ``"m"``, ``"rad"``, ``"frames"``, ... or ``""``.
        doc: one line.
        range: the numbers allowed, or None (any value of the type).
        choices: the names a choice takes (from the core's name table or a ``Literal``), or None.
        core: ``"GridFilterSettings.uniform_floor"``: the core's field that holds it, or None.
    """

    name: str
    type: str
    kind: str
    default: Any
    unit: str
    doc: str
    range: Range | None = None
    choices: tuple[str, ...] | None = None
    core: str | None = None

    @property
    def range_text(self) -> str:
        """The values allowed, in words (the errors' and the docs' wording)."""
        if self.kind == "flag":
            return "true or false"
        if self.choices is not None:
            return "one of " + ", ".join(f"'{c}'" for c in self.choices)
        if self.range is None:
            return f"a {self.type}" + (f" ({self.unit})" if self.unit else "")
        return self.range.text(self.kind, self.unit)

    def problem(self, value: Any) -> str | None:
        """``"must be in [0, 1), got 1.5"`` when ``value`` (already of the field's type) is not
        allowed, else None."""
        if value is None:
            return None
        if self.choices is not None and self.kind == "choice":
            return None if value in self.choices else f"must be {self.range_text}, got {value_text(value)}"
        if self.range is None or isinstance(value, bool) or not isinstance(value, (int, float)):
            return None
        return None if self.range.contains(value) else f"must be {self.range_text}, got {value_text(value)}"


# --------------------------------------------------------------------------------------------
# the core's tables


@dataclasses.dataclass(frozen=True)
class _CoreRef:
    table: str  # the core class's name
    name: str  # its field


@dataclasses.dataclass(frozen=True)
class _Own:
    unit: str
    range: Range | None
    doc: str | None


class CoreTable:
    """A settings class of the compiled core and its table (``cls.fields()``): its rows by name, as
    :class:`Setting`, and dataclass fields that take their default from it."""

    def __init__(self, core_class: type):
        self.core_class = core_class
        self.name = core_class.__name__
        _TABLES[self.name] = self

    @functools.cached_property
    def rows(self) -> dict[str, Setting]:
        """Field name -> :class:`Setting` (the core's default, range, unit and doc), in the table's order."""
        rows = {}
        for row in self.core_class.fields():  # type: ignore[attr-defined]
            kind = str(row["kind"])
            choices = tuple(row["choices"]) if row["choices"] is not None else None
            numeric = kind in ("real", "count", "integer")
            special = row["special"]
            rows[row["name"]] = Setting(
                name=str(row["name"]),
                type=str(row["type"]),
                kind=kind,
                default=row["default"],
                unit=str(row["unit"]),
                doc=str(row["doc"]),
                range=Range(
                    -math.inf if row["min"] is None else float(row["min"]),
                    math.inf if row["max"] is None else float(row["max"]),
                    bool(row["min_open"]),
                    bool(row["max_open"]),
                    bool(row["infinite"]),
                    None if special is None else float(special),
                    str(row["special_means"]),
                )
                if numeric
                else None,
                choices=choices,
                core=f"{self.name}.{row['name']}",
            )
        return rows

    def field(self, name: str) -> Any:
        """A dataclass field held by the core's field ``name``: its default is the core's."""
        return core_field(self, name)


#: Core class name -> its CoreTable (those made so far).
_TABLES: dict[str, CoreTable] = {}


def core_field(table: CoreTable, name: str) -> Any:
    """A dataclass field whose value the core's field ``name`` of ``table`` holds: the default,
    range, unit and doc are the core's (so the default is written once, in C++)."""
    if name not in table.rows:
        raise KeyError(f"the core's {table.name} has no field {name!r} (its fields: {', '.join(table.rows)})")
    return dataclasses.field(default=table.rows[name].default, metadata={_KEY: _CoreRef(table.name, name)})


def own_field(default: Any, *, unit: str = "", range: Range | None = None, doc: str | None = None) -> Any:
    """A dataclass field of Python's own: its ``default``, ``unit`` and ``range`` (numbers); its
    doc the class docstring's line for it unless ``doc`` is given."""
    return dataclasses.field(default=default, metadata={_KEY: _Own(unit, range, doc)})


# --------------------------------------------------------------------------------------------
# a class's table

_ENTRY = re.compile(r"^(\s+)([A-Za-z_][A-Za-z0-9_]*(?:\s*,\s*[A-Za-z_][A-Za-z0-9_]*)*)\s*:\s*(.*)$")


def docstring_entries(doc: str | None) -> dict[str, str]:
    """The ``Attributes:`` entries of a docstring: name -> its text on one line (an entry naming
    several fields, ``a, b: text``, gives each the text). Sub-headings end a group, not the list."""
    if not doc:
        return {}
    lines = doc.expandtabs().splitlines()
    try:
        start = next(i for i, line in enumerate(lines) if line.strip() == "Attributes:")
    except StopIteration:
        return {}
    entries: dict[str, str] = {}
    names: list[str] = []
    indent = None
    text: list[str] = []

    def flush() -> None:
        if names:
            joined = " ".join(" ".join(text).split())
            for name in names:
                entries[name] = joined

    for line in lines[start + 1 :]:
        if not line.strip():
            continue
        match = _ENTRY.match(line)
        depth = len(line) - len(line.lstrip())
        if match and (indent is None or depth <= indent):
            flush()
            indent = depth
            names = [n.strip() for n in match.group(2).split(",")]
            text = [match.group(3)]
        elif indent is not None and depth > indent:
            text.append(line.strip())
        elif indent is not None and depth < indent and not line.rstrip().endswith(":"):
            break
        else:  # a sub-heading ("Which pairs of frames are compared:")
            flush()
            names, text = [], []
    flush()
    return entries


def _type_text(hint: Any) -> str:
    origin = typing.get_origin(hint)
    if origin is Literal:
        return "str"
    if origin in (Union, types.UnionType):
        return " | ".join(_type_text(a) for a in typing.get_args(hint))
    if origin is tuple:
        args = typing.get_args(hint)
        inner = ", ".join("..." if a is Ellipsis else _type_text(a) for a in args)
        return f"tuple[{inner}]"
    if hint is type(None):
        return "None"
    return getattr(hint, "__name__", str(hint))


def _kind(hint: Any) -> str:
    if hint is bool:
        return "flag"
    if hint is int:
        return "integer"
    if hint is float:
        return "real"
    if typing.get_origin(hint) is Literal or hint is str:
        return "choice" if typing.get_origin(hint) is Literal else "value"
    return "value"


def settings_schema(cls: type) -> tuple[Setting, ...]:
    """The table of the parameter dataclass ``cls``, one :class:`Setting` per field in order: a
    :func:`core_field` from the core's row (under the dataclass's name), an :func:`own_field` from
    its metadata, any other field from its annotation and default; docs from the core or, for
    Python's own fields, the class docstring's ``Attributes:``."""
    return _schema(cls)


@functools.cache
def _schema(cls: type) -> tuple[Setting, ...]:
    hints = typing.get_type_hints(cls)
    docs = docstring_entries(cls.__doc__)
    out = []
    for f in dataclasses.fields(cls):
        meta = f.metadata.get(_KEY)
        hint = hints[f.name]
        default = f.default if f.default is not dataclasses.MISSING else None
        if isinstance(meta, _CoreRef):
            row = _TABLES[meta.table].rows[meta.name]
            out.append(dataclasses.replace(row, name=f.name, default=default))
            continue
        literal = typing.get_args(hint) if typing.get_origin(hint) is Literal else None
        own = meta if isinstance(meta, _Own) else _Own("", None, None)
        out.append(
            Setting(
                name=f.name,
                type=_type_text(hint),
                kind=_kind(hint),
                default=default,
                unit=own.unit,
                doc=own.doc or docs.get(f.name, ""),
                range=own.range,
                choices=tuple(str(a) for a in literal) if literal else None,
                core=None,
            )
        )
    return tuple(out)


def core_names(cls: type, table: CoreTable | None = None) -> dict[str, str]:
    """Field of the dataclass ``cls`` -> the name of the core's field that holds it (its
    :func:`core_field` ones; only those of ``table`` when given)."""
    return {
        f.name: meta.name
        for f in dataclasses.fields(cls)
        if isinstance(meta := f.metadata.get(_KEY), _CoreRef) and (table is None or meta.table == table.name)
    }
