"""Configuration: frozen parameter dataclasses with the paper's defaults, loaded from and saved to TOML.

Each parameter class is a frozen dataclass registered under a TOML table name with
:func:`params_section`; its fields are type-checked when an instance is made (from Python or
from a file), and a ``validate(self)`` method, when the class defines one, checks ranges. A
parameter file holds one table per class::

    [preparation]
    width = 48
    equalize = "clahe"
    crop = [0, 0.1, 0, 0]     # top, bottom, left, right: ints are pixels, floats fractions

Missing keys keep their defaults; unknown tables or keys are an error naming them. Each field's
type, default, range, unit and doc are its class's table (:mod:`nightloc.schema`): a value out of
its range is an error in the table's words. On the command line, ``--set SECTION.KEY=VALUE`` gives
one key the same way (:func:`parse_assignment`, VALUE read as TOML), and :class:`SettingsLayers`
stacks the sources (defaults, a map's stored settings, ``--params``, ``--set``), saying which key
came from where. Other modules add their own classes the same way::

    @params_section("localization")
    @dataclass(frozen=True)
    class LocalizationParams:
        grid_width: int = 100
        def validate(self): ...

    load_params("params.toml", LocalizationParams)

Supported field types: ``bool``, ``int``, ``float`` (an int is accepted), ``str``,
``Literal[...]``, ``Optional[T]`` (None is written by leaving the key out, so its default must be
None), unions such as ``int | float`` (the first type that fits wins), ``tuple[T, ...]`` and
``tuple[T1, T2]``.
"""

from __future__ import annotations

import dataclasses
import functools
import math
import os
import re
import tomllib
import types
import typing
from collections.abc import Callable, Iterable, Mapping
from pathlib import Path
from typing import Any, Literal, TypeVar, Union

import numpy as np

from ._validate import MAX_PARAMS_FILE_BYTES
from .errors import NightlocError
from .io.atomic import write_text
from .io.files import open_regular
from .schema import settings_schema, value_text

__all__ = [
    "SettingsLayers",
    "dumps_toml",
    "load_params",
    "load_params_file",
    "params_from_dict",
    "params_section",
    "params_to_dict",
    "parse_assignment",
    "read_params_tables",
    "registered_sections",
    "save_params",
    "toml_value",
]

T = TypeVar("T")

_SECTIONS: dict[str, type] = {}
_SECTION_ATTRIBUTE = "__params_section__"


# --------------------------------------------------------------------------------------------
# registration and type checking


def params_section(name: str) -> Callable[[type[T]], type[T]]:
    """Class decorator: registers a frozen dataclass as the TOML table ``[name]``.

    Apply it above ``@dataclass(frozen=True)``. It wraps ``__init__`` (so also
    ``dataclasses.replace``): after the dataclass's own initialization, every field is
    type-checked and normalized (numpy scalars to Python, lists to tuples, ints to floats for
    float fields) and checked against its range in the class's table
    (:func:`nightloc.schema.settings_schema`: ValueError ``"NAME must be RANGE, got VALUE"``), then
    the class's ``validate()`` runs when it has one (the rules between fields).
    """
    if not re.fullmatch(r"[A-Za-z0-9_-]+", name):
        raise ValueError(f"section name {name!r} must be a bare TOML key (letters, digits, _ and -)")

    def register(cls: type[T]) -> type[T]:
        if not dataclasses.is_dataclass(cls) or not cls.__dataclass_params__.frozen:  # type: ignore[attr-defined]
            raise TypeError(
                f"{cls.__name__} must be a frozen dataclass (@dataclass(frozen=True)) below @params_section"
            )
        existing = _SECTIONS.get(name)
        if existing is not None and existing.__qualname__ != cls.__qualname__:
            raise ValueError(f"section [{name}] is already taken by {existing.__qualname__}")
        hints = typing.get_type_hints(cls)
        fields = {field.name: hints[field.name] for field in dataclasses.fields(cls)}
        dataclass_init = cls.__init__
        table = settings_schema(cls)  # the rows each value is checked against

        @functools.wraps(dataclass_init)
        def __init__(self: Any, *args: Any, **kwargs: Any) -> None:
            dataclass_init(self, *args, **kwargs)
            for field_name, hint in fields.items():
                value = _coerce(getattr(self, field_name), hint, f"{cls.__name__}.{field_name}")
                object.__setattr__(self, field_name, value)
            for setting in table:
                problem = setting.problem(getattr(self, setting.name))
                if problem is not None:
                    raise ValueError(f"{setting.name} {problem}")
            validate = getattr(self, "validate", None)
            if callable(validate):
                validate()

        cls.__init__ = __init__  # type: ignore[method-assign]
        setattr(cls, _SECTION_ATTRIBUTE, name)
        _SECTIONS[name] = cls
        return cls

    return register


def registered_sections() -> dict[str, type]:
    """TOML table name -> parameter class, for every registered class."""
    return dict(_SECTIONS)


def _section_of(cls: type) -> str:
    name = getattr(cls, _SECTION_ATTRIBUTE, None)
    if name is None or _SECTIONS.get(name) is not cls:
        raise TypeError(
            f"{getattr(cls, '__name__', cls)!r} is not a parameter class (decorate it with @params_section)"
        )
    return name


def _type_name(hint: Any) -> str:
    origin = typing.get_origin(hint)
    if origin is Literal:
        return " or ".join(repr(a) for a in typing.get_args(hint))
    if origin in (Union, types.UnionType):
        return " or ".join(_type_name(a) for a in typing.get_args(hint))
    if origin is tuple:
        args = typing.get_args(hint)
        if len(args) == 2 and args[1] is Ellipsis:
            return f"a list of {_type_name(args[0])}"
        return f"a list of {len(args)} values ({', '.join(_type_name(a) for a in args)})"
    if hint is type(None):
        return "None"
    return getattr(hint, "__name__", str(hint))


def _describe(value: Any) -> str:
    return f"{type(value).__name__} {value!r}"


class _Mismatch(Exception):
    pass


def _convert(value: Any, hint: Any) -> Any:
    """``value`` as ``hint`` (normalized), or raises _Mismatch."""
    origin = typing.get_origin(hint)
    if hint is Any:
        return value
    if hint is type(None):
        if value is None:
            return None
        raise _Mismatch
    if origin is Literal:
        for allowed in typing.get_args(hint):
            if type(value) is type(allowed) and value == allowed:
                return allowed
        raise _Mismatch
    if origin in (Union, types.UnionType):
        for option in typing.get_args(hint):
            try:
                return _convert(value, option)
            except _Mismatch:
                continue
        raise _Mismatch
    if origin is tuple:
        if isinstance(value, (str, bytes)) or not isinstance(value, (list, tuple, np.ndarray)):
            raise _Mismatch
        items = list(value)
        args = typing.get_args(hint)
        if len(args) == 2 and args[1] is Ellipsis:
            return tuple(_convert(item, args[0]) for item in items)
        if len(items) != len(args):
            raise _Mismatch
        return tuple(_convert(item, arg) for item, arg in zip(items, args))
    if hint is bool:
        if isinstance(value, (bool, np.bool_)):
            return bool(value)
        raise _Mismatch
    if hint is int:
        if isinstance(value, (int, np.integer)) and not isinstance(value, (bool, np.bool_)):
            return int(value)
        raise _Mismatch
    if hint is float:
        if isinstance(value, (int, float, np.integer, np.floating)) and not isinstance(value, (bool, np.bool_)):
            return float(value)
        raise _Mismatch
    if hint is str:
        if isinstance(value, str):
            return value
        raise _Mismatch
    raise TypeError(f"parameter type {hint!r} is not supported (see nightloc.config)")


def _coerce(value: Any, hint: Any, name: str) -> Any:
    try:
        return _convert(value, hint)
    except _Mismatch:
        raise TypeError(f"{name} must be {_type_name(hint)}, got {_describe(value)}") from None


# --------------------------------------------------------------------------------------------
# dataclass <-> dict


def params_to_dict(params: Any) -> dict[str, Any]:
    """The fields of a parameter instance as a dict (tuples as lists; None values left out)."""
    _section_of(type(params))
    out: dict[str, Any] = {}
    for field in dataclasses.fields(params):
        value = getattr(params, field.name)
        if value is None:
            continue
        out[field.name] = list(value) if isinstance(value, tuple) else value
    return out


def params_from_dict(cls: type[T], table: Mapping[str, Any], where: str = "") -> T:
    """An instance of the parameter class ``cls`` from a TOML table (missing keys: defaults).

    Raises NightlocError (a ValueError) naming ``where`` and the offending key for an unknown key,
    a wrong type or an out-of-range value.
    """
    section = _section_of(cls)
    prefix = f"{where}: " if where else ""
    if not isinstance(table, Mapping):
        raise NightlocError(f"{prefix}[{section}] must be a table of key = value pairs, got {_describe(table)}")
    names = [field.name for field in dataclasses.fields(cls)]  # type: ignore[arg-type]
    for key in table:
        if key not in names:
            close = [n for n in names if n.replace("_", "") == str(key).replace("_", "").lower()]
            hint = f" (did you mean {close[0]!r}?)" if close else ""
            raise NightlocError(f"{prefix}unknown key {key!r} in [{section}]{hint}; known keys: {', '.join(names)}")
    try:
        return cls(**table)
    except (TypeError, ValueError) as error:
        raise NightlocError(f"{prefix}[{section}] {error}") from None


# --------------------------------------------------------------------------------------------
# TOML writing (tomllib only reads)

_BARE_KEY = re.compile(r"[A-Za-z0-9_-]+")
_ESCAPES = {'"': '\\"', "\\": "\\\\", "\b": "\\b", "\t": "\\t", "\n": "\\n", "\f": "\\f", "\r": "\\r"}


def _toml_key(key: str) -> str:
    if not isinstance(key, str):
        raise TypeError(f"TOML keys must be strings, got {_describe(key)}")
    return key if _BARE_KEY.fullmatch(key) else _toml_string(key)


def _toml_string(text: str) -> str:
    out = []
    for char in text:
        if char in _ESCAPES:
            out.append(_ESCAPES[char])
        elif ord(char) < 0x20 or ord(char) == 0x7F:
            out.append(f"\\u{ord(char):04X}")
        else:
            out.append(char)
    return '"' + "".join(out) + '"'


def toml_value(value: Any) -> str:
    """``value`` as a TOML value (what a parameter file or ``--set`` writes): ``0.015``, ``24``,
    ``true``, ``"global"``, ``[8, 8]``."""
    return _toml_value(value)


def _toml_value(value: Any) -> str:
    if isinstance(value, (bool, np.bool_)):
        return "true" if value else "false"
    if isinstance(value, (int, np.integer)):
        return str(int(value))
    if isinstance(value, (float, np.floating)):
        number = float(value)
        if math.isnan(number):
            return "nan"
        if math.isinf(number):
            return "inf" if number > 0 else "-inf"
        return repr(number)  # always has '.', 'e' or is 'inf'/'nan': a TOML float, exact round trip
    if isinstance(value, str):
        return _toml_string(value)
    if isinstance(value, (list, tuple)):
        return "[" + ", ".join(_toml_value(item) for item in value) + "]"
    if isinstance(value, Mapping):
        return "{" + ", ".join(f"{_toml_key(k)} = {_toml_value(v)}" for k, v in value.items()) + "}"
    raise TypeError(f"cannot write {_describe(value)} to TOML")


def dumps_toml(document: Mapping[str, Any], header: str = "") -> str:
    """A TOML document: scalars and arrays as ``key = value``, nested mappings as ``[tables]``.

    Values: bool, int, float (exact round trip; nan and inf allowed), str, lists/tuples and
    mappings of those. None values are left out (TOML has no null). ``header`` becomes comment
    lines at the top.
    """
    lines = [f"# {line}".rstrip() for line in header.splitlines()]

    def emit(table: Mapping[str, Any], path: tuple[str, ...]) -> None:
        scalars = [(k, v) for k, v in table.items() if v is not None and not isinstance(v, Mapping)]
        tables = [(k, v) for k, v in table.items() if isinstance(v, Mapping)]
        if path and (scalars or not tables):
            if lines:
                lines.append("")
            lines.append("[" + ".".join(_toml_key(p) for p in path) + "]")
        for key, value in scalars:
            lines.append(f"{_toml_key(key)} = {_toml_value(value)}")
        for key, value in tables:
            emit(value, (*path, key))

    emit(document, ())
    return "\n".join(lines) + "\n"


# --------------------------------------------------------------------------------------------
# files


def load_params_file(path: str | os.PathLike[str]) -> dict[str, Any]:
    """Every table of a parameter file: section name -> parameter instance.

    Raises NightlocError naming the file for a missing or malformed file, a key outside a table,
    an unknown table or key, or a bad value.
    """
    file = Path(path)
    return {
        key: params_from_dict(_SECTIONS[key], table, where=str(file)) for key, table in read_params_tables(file).items()
    }


def read_params_tables(path: str | os.PathLike[str]) -> dict[str, dict[str, Any]]:
    """The tables of a parameter file as written (section -> key -> value), each checked as
    :func:`load_params_file` checks it (the same errors)."""
    file = Path(path)
    try:
        with open_regular(file, "parameter file", NightlocError) as stream:  # a FIFO must not block
            data = stream.read(MAX_PARAMS_FILE_BYTES + 1)
    except OSError as error:
        raise NightlocError(f"parameter file {file} cannot be read: {error.strerror or error}") from error
    if len(data) > MAX_PARAMS_FILE_BYTES:
        raise NightlocError(
            f"parameter file {file} is larger than {MAX_PARAMS_FILE_BYTES} bytes (MAX_PARAMS_FILE_BYTES); "
            f"a parameter file holds a few tables of key = value lines"
        )
    try:
        document = tomllib.loads(data.decode("utf-8-sig"))  # a byte-order mark (Windows editors) is fine
    except UnicodeDecodeError as error:
        raise NightlocError(f"parameter file {file} is not UTF-8 text (byte {error.start})") from None
    except tomllib.TOMLDecodeError as error:
        raise NightlocError(f"parameter file {file} is not valid TOML: {error}") from None
    result: dict[str, dict[str, Any]] = {}
    for key, value in document.items():
        cls = _SECTIONS.get(key)
        if cls is None:
            owner = [name for name, c in _SECTIONS.items() if key in {f.name for f in dataclasses.fields(c)}]
            if not isinstance(value, dict) and owner:
                raise NightlocError(f"{file}: key {key!r} is outside any table; put it under [{owner[0]}]")
            raise NightlocError(
                f"{file}: unknown {'table [' + key + ']' if isinstance(value, dict) else 'key ' + repr(key)}; "
                f"known tables: {', '.join('[' + name + ']' for name in sorted(_SECTIONS))}"
            )
        params_from_dict(cls, value, where=str(file))  # every error now, naming the file
        result[key] = dict(value)
    return result


def load_params(path: str | os.PathLike[str], cls: type[T] | None = None) -> T:
    """The parameters of class ``cls`` (default :class:`~nightloc.PreparationParams`) from a TOML file.

    Reads the table ``[section]`` of ``cls``; a file without it gives the defaults. The whole
    file is checked: unknown tables or keys are an error naming them.
    """
    # the parameters most files hold; PreparationParams registers itself as [preparation]
    chosen: type = _SECTIONS["preparation"] if cls is None else cls
    section = _section_of(chosen)
    found = load_params_file(path)
    return found[section] if section in found else chosen()


def save_params(path: str | os.PathLike[str], params: Any | Iterable[Any], *, overwrite: bool = False) -> None:
    """Writes one parameter instance, or several of different classes, to a TOML file.

    Every field is written, defaults included, so the file documents the full configuration.
    The write is atomic (temporary file, then rename). An existing file is replaced only with
    ``overwrite=True`` (else FileExistsError, the file untouched); the parent folder must exist.
    """
    items = list(params) if isinstance(params, (list, tuple)) else [params]
    if not items:
        raise ValueError("params is empty: pass at least one parameter instance")
    document: dict[str, Any] = {}
    for item in items:
        section = _section_of(type(item))
        if section in document:
            raise ValueError(f"two instances for table [{section}]")
        document[section] = params_to_dict(item)
    write_text(Path(path), dumps_toml(document, header="nightloc parameters"), overwrite=overwrite)


# --------------------------------------------------------------------------------------------
# the command line: --set SECTION.KEY=VALUE, and settings from several sources

_ASSIGNMENT = re.compile(r"^\s*([A-Za-z0-9_-]+)\.([A-Za-z0-9_-]+)\s*=(.*)$", re.S)


def parse_assignment(text: str) -> tuple[str, str, Any]:
    """``"filter.uniform_floor=0.05"`` -> ``("filter", "uniform_floor", 0.05)``: VALUE is read as a
    TOML value (``0.05``, ``24``, ``true``, ``"none"``, ``[0, 0.1, 0, 0]``), a bare word as a string
    (``route.filter_motion=speed``). The section and key are checked with the value, by
    :func:`params_from_dict` (the errors of a parameter file). Raises NightlocError."""
    match = _ASSIGNMENT.match(str(text))
    if match is None:
        raise NightlocError(f"--set {text!r}: expected SECTION.KEY=VALUE, e.g. --set filter.uniform_floor=0.05")
    section, key, raw = match.group(1), match.group(2), match.group(3).strip()
    if not raw:
        raise NightlocError(f"--set {text}: the value is missing (SECTION.KEY=VALUE)")
    try:
        value = tomllib.loads(f"value = {raw}")["value"]
    except tomllib.TOMLDecodeError:
        if not re.fullmatch(r"[A-Za-z_][A-Za-z0-9_.-]*", raw):
            raise NightlocError(
                f'--set {text}: {raw!r} is not a TOML value (numbers, true/false, "text", [lists]) or a bare word'
            ) from None
        value = raw
    if section not in _SECTIONS:
        raise NightlocError(
            f"--set {text}: unknown table [{section}]; known tables: "
            f"{', '.join('[' + name + ']' for name in sorted(_SECTIONS))}"
        )
    return section, key, value


class SettingsLayers:
    """Parameter tables from several sources, a later source winning key by key: e.g. a map's
    stored settings, then ``--params FILE``, then ``--set``. Each source's table is checked on its
    own when added (the errors name the source); :meth:`get` builds the instance of a section from
    its class's defaults and every source, and :meth:`origin` says which source gave a key."""

    def __init__(self) -> None:
        self._layers: list[tuple[str, dict[str, dict[str, Any]]]] = []

    def add(
        self, source: str, tables: Mapping[str, Mapping[str, Any]], *, below: bool = False, where: str | None = None
    ) -> SettingsLayers:
        """Adds ``tables`` (section -> key -> value) from ``source`` (words such as ``"the map
        garden.map"``), above the others (or below them: ``below``). Raises NightlocError naming
        ``where`` (default ``source``) for an unknown table or key or a bad value."""
        checked: dict[str, dict[str, Any]] = {}
        for section, table in tables.items():
            cls = _SECTIONS.get(section)
            if cls is None:
                raise NightlocError(f"{where or source}: unknown table [{section}]")
            params_from_dict(cls, table, where=where or source)
            checked[section] = dict(table)
        if below:
            self._layers.insert(0, (source, checked))
        else:
            self._layers.append((source, checked))
        return self

    def add_file(self, path: str | os.PathLike[str] | None) -> SettingsLayers:
        """The tables of a parameter file (nothing for None)."""
        if path is not None:
            self._layers.append((str(path), read_params_tables(path)))
        return self

    def add_assignments(self, assignments: Iterable[str] | None) -> SettingsLayers:
        """``--set`` assignments, each its own source (``--set SECTION.KEY=VALUE``), in order."""
        for text in assignments or ():
            section, key, value = parse_assignment(text)
            self.add("--set", {section: {key: value}}, where=f"--set {text}")
        return self

    def table(self, section: str) -> dict[str, Any]:
        """The section's keys that any source sets, with the winning values."""
        merged: dict[str, Any] = {}
        for _, tables in self._layers:
            merged.update(tables.get(section, {}))
        return merged

    def given(self, section: str) -> bool:
        """Whether any source sets a key of ``section``."""
        return any(section in tables for _, tables in self._layers)

    def origin(self, section: str, key: str) -> str | None:
        """The source whose value of ``section.key`` wins, or None (the default)."""
        for source, tables in reversed(self._layers):
            if key in tables.get(section, {}):
                return source
        return None

    def get(self, cls: type[T]) -> T:
        """The instance of the parameter class ``cls``: its defaults with every source's keys.
        A combination the class refuses (e.g. ``vmin`` from one source above ``vmax`` from
        another) is a NightlocError naming the sources."""
        section = _section_of(cls)
        sources = [source for source, tables in self._layers if section in tables]
        return params_from_dict(cls, self.table(section), where=" and ".join(sources))

    def section(self, cls: type[T]) -> T | None:
        """:meth:`get` when any source sets a key of ``cls``'s section, else None."""
        return self.get(cls) if self.given(_section_of(cls)) else None

    def report(self, sections: Iterable[str]) -> list[str]:
        """Lines saying where the settings of ``sections`` came from, one per source: ``"--set:
        [filter] uniform_floor = 0.05, heading_bins = 24"``, the keys whose value it gives (the
        lowest source's only where they differ from the defaults)."""
        lowest = self._layers[0][0] if self._layers else None
        given: dict[str, dict[str, list[str]]] = {}  # source -> section -> "key = value"
        for section in sections:
            defaults = params_to_dict(_SECTIONS[section]())
            for key in self.table(section):
                source = self.origin(section, key)
                value = self.table(section)[key]
                if source is None or (source == lowest and defaults.get(key) == value):
                    continue
                given.setdefault(source, {}).setdefault(section, []).append(f"{key} = {value_text(value)}")
        order = list(dict.fromkeys(source for source, _ in self._layers))  # lowest first
        return [
            f"{source}: " + "; ".join(f"[{section}] {', '.join(items)}" for section, items in given[source].items())
            for source in order
            if source in given
        ]
