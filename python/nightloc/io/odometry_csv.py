"""A robot's odometry log on disk: ``odometry.csv`` beside a traverse's ``poses.csv``.

One row per frame, the motion since the previous frame of the log, in one of two forms (the
header says which; docs/design.md, conventions)::

    image,forward,left,turn        wheel odometry: metres ahead, metres left, radians turned
    000000.png,0,0,0                (counter-clockwise) in the robot's frame at the previous frame
    000001.png,0.402,-0.003,0.021

    image,dx,dy                     map-frame displacements, metres

A video log keys its rows by frame index (column ``frame`` instead of ``image``). This module
reads and writes the rows as numbers; :func:`nightloc.motion.odometry.read_odometry` turns
them into motions for a traverse's frames.
"""

from __future__ import annotations

import csv
import io
import math
import os
from collections.abc import Iterable, Sequence
from pathlib import Path
from typing import Any, Union, cast

import numpy as np

from ..errors import DatasetError
from .atomic import atomic_file
from .files import open_regular
from .poses import check_heading, parse_timestamp, refuse_misspelt_columns, refuse_other_delimiter

__all__ = [
    "MAP_COLUMNS",
    "ODOMETRY_FILE",
    "ROBOT_COLUMNS",
    "OdometryRow",
    "read_odometry_rows",
    "read_odometry_timestamps",
    "write_odometry_csv",
]

PathLike = Union[str, "os.PathLike[str]"]

#: The odometry file of a traverse folder.
ODOMETRY_FILE = "odometry.csv"
#: Columns of wheel odometry and of map-frame displacements.
ROBOT_COLUMNS = ("forward", "left", "turn")
MAP_COLUMNS = ("dx", "dy")

#: One row: (key, values, line): key an image name or frame index, values 3 (robot) or 2 (map) floats.
OdometryRow = tuple[object, tuple[float, ...], int]


def _number(text: str, column: str, file: Path, line: int) -> float:
    try:
        value = float(text)
    except ValueError:
        raise DatasetError(f"{file} line {line}: column {column!r} holds {text!r}, not a number") from None
    if not math.isfinite(value):
        raise DatasetError(f"{file} line {line}: column {column!r} is {text!r}; odometry must be finite")
    return value


def _odometry_header(
    fields: list[str], path: Path, line: int, key_column: str
) -> tuple[list[str], str, tuple[str, ...]]:
    """The header's column names (lower case), its form (``"robot"`` or ``"map"``) and the form's
    value columns, checked."""
    refuse_other_delimiter(fields, path, line, f"{key_column},forward,left,turn or {key_column},dx,dy")
    header = [f.strip().lower() for f in fields]
    refuse_misspelt_columns(
        header,
        (key_column, *ROBOT_COLUMNS, *MAP_COLUMNS, "timestamp"),
        path,
        line,
        f"{key_column},forward,left,turn or {key_column},dx,dy [,timestamp]",
    )
    if key_column not in header:
        raise DatasetError(
            f"{path} line {line}: missing column {key_column!r}; the header must be "
            f"{key_column},forward,left,turn (wheel odometry) or {key_column},dx,dy (map frame)"
        )
    if all(c in header for c in ROBOT_COLUMNS):
        return header, "robot", ROBOT_COLUMNS
    if all(c in header for c in MAP_COLUMNS):
        return header, "map", MAP_COLUMNS
    raise DatasetError(
        f"{path} line {line}: the header ({', '.join(header)}) has neither forward,left,turn "
        f"(wheel odometry) nor dx,dy (map-frame displacements)"
    )


def _odometry_key(raw_key: str, key_column: str, seen: dict[object, int], path: Path, line: int) -> object:
    """A row's key: a frame index or an image name, unique (``seen`` maps each key to its line)."""
    raw = raw_key.strip()
    if key_column == "frame":
        try:
            key: object = int(raw)
        except ValueError:
            raise DatasetError(f"{path} line {line}: frame {raw!r} is not an integer") from None
    else:
        key = raw
        if not raw:
            raise DatasetError(f"{path} line {line}: column 'image' is empty")
    if key in seen:
        raise DatasetError(f"{path} line {line}: {key_column} {key!r} is listed twice (line {seen[key]})")
    seen[key] = line
    return key


def read_odometry_rows(file: PathLike, key_column: str = "image") -> tuple[list[OdometryRow], str]:
    """The rows of an odometry CSV in file order and its form, ``"robot"`` or ``"map"``.

    Columns other than the key, ``forward,left,turn``, ``dx,dy`` and ``timestamp`` are ignored,
    except a near miss of one of those names (``trun``), which is refused naming it.

    Raises:
        DatasetError: missing file, header without a known form, a misspelt column, malformed or
            repeated rows.
    """
    path = Path(file)
    if not os.path.lexists(path) or path.is_dir():
        raise DatasetError(
            f"odometry file {path} {'is a folder' if path.is_dir() else 'does not exist'}; a robot's log needs one "
            f"row per frame: {key_column},forward,left,turn (wheel odometry) or {key_column},dx,dy (map frame)"
        )
    rows: list[OdometryRow] = []
    header = None
    columns: tuple[str, ...]
    try:
        # only a regular file is read: a FIFO, device, socket or link loop is named at once
        with io.TextIOWrapper(
            open_regular(path, "odometry file", DatasetError), newline="", encoding="utf-8-sig"
        ) as handle:
            reader = csv.reader(handle)
            for fields in reader:
                line = reader.line_num
                if not any(f.strip() for f in fields):
                    continue
                if header is None:
                    header, form, columns = _odometry_header(fields, path, line, key_column)
                    index = [header.index(c) for c in columns]
                    key_index = header.index(key_column)
                    seen: dict[object, int] = {}
                    continue
                if len(fields) != len(header):
                    raise DatasetError(f"{path} line {line}: {len(fields)} fields, but the header has {len(header)}")
                key = _odometry_key(fields[key_index], key_column, seen, path, line)
                values = tuple(_number(fields[i], c, path, line) for i, c in zip(index, columns))
                if form == "robot":
                    check_heading(values[2], "turn", path, line)
                rows.append((key, values, line))
    except UnicodeDecodeError as error:
        raise DatasetError(f"{path} is not UTF-8 text ({error.reason} at byte {error.start})") from None
    except csv.Error as error:
        raise DatasetError(f"{path}: malformed CSV ({error})") from None
    except OSError as error:
        raise DatasetError(f"odometry file {path} cannot be read: {error.strerror or error}") from error
    if header is None or not rows:
        raise DatasetError(f"{path} has no odometry rows; it needs a header and one row per frame")
    return rows, form


def read_odometry_timestamps(file: PathLike, key_column: str = "image") -> dict[object, tuple[float, int]] | None:
    """``{key: (timestamp seconds, line)}`` from an odometry CSV's ``timestamp`` column, or None
    when it has none (the rest of the file is read by :func:`read_odometry_rows`)."""
    path = Path(file)
    try:
        with io.TextIOWrapper(
            open_regular(path, "odometry file", DatasetError), newline="", encoding="utf-8-sig"
        ) as handle:
            reader = csv.reader(handle)
            header = None
            found: dict[object, tuple[float, int]] = {}
            for fields in reader:
                if not any(f.strip() for f in fields):
                    continue
                if header is None:  # a header without the column (or a malformed one): no times from here
                    header = [f.strip().lower() for f in fields]
                    if "timestamp" not in header or key_column not in header:
                        return None
                    key_index, time_index = header.index(key_column), header.index("timestamp")
                    continue
                if len(fields) != len(header):
                    raise DatasetError(
                        f"{path} line {reader.line_num}: {len(fields)} fields, but the header has {len(header)}"
                    )
                raw = fields[key_index].strip()
                key: object = raw
                if key_column == "frame":
                    try:
                        key = int(raw)
                    except ValueError:
                        raise DatasetError(f"{path} line {reader.line_num}: frame {raw!r} is not an integer") from None
                found[key] = (parse_timestamp(fields[time_index], path, reader.line_num), reader.line_num)
    except UnicodeDecodeError as error:
        raise DatasetError(f"{path} is not UTF-8 text ({error.reason} at byte {error.start})") from None
    except csv.Error as error:
        raise DatasetError(f"{path}: malformed CSV ({error})") from None
    return found if header is not None else None


def odometry_values(motions: Sequence[object]) -> tuple[str, list[tuple[float, ...]]]:
    """The form and the numbers of a sequence of motions: objects with ``forward, left, turn``
    (wheel odometry) or ``dx, dy`` attributes, or ``(dx, dy)`` pairs, all of one form; None
    (before the first frame) becomes zeros."""
    values: list[tuple[float, ...] | None] = []
    forms = set()
    for k, m in enumerate(motions):
        if m is None:
            values.append(None)
        elif all(hasattr(m, a) for a in ROBOT_COLUMNS):
            forms.add("robot")
            values.append(tuple(float(getattr(m, a)) for a in ROBOT_COLUMNS))
        elif all(hasattr(m, a) for a in MAP_COLUMNS):
            forms.add("map")
            values.append(tuple(float(getattr(m, a)) for a in MAP_COLUMNS))
        else:
            try:
                pair = tuple(float(v) for v in cast("Iterable[Any]", m))  # duck-typed: errors caught below
            except (TypeError, ValueError):
                pair = ()
            if len(pair) != 2:
                raise TypeError(
                    f"odometry[{k}] must be a RobotMotion, a MapDisplacement, a (dx, dy) pair or None, got {m!r}"
                )
            forms.add("map")
            values.append(pair)
    if len(forms) > 1:
        raise ValueError("odometry must be all wheel odometry (RobotMotion) or all map-frame displacements")
    form = forms.pop() if forms else "robot"
    zeros = (0.0,) * (3 if form == "robot" else 2)
    out = [zeros if v is None else v for v in values]
    if any(not math.isfinite(x) for v in out for x in v):
        raise ValueError("odometry holds NaN or infinity")
    return form, out


def write_odometry_csv(
    file: PathLike,
    keys: Sequence[object],
    motions: Sequence[object],
    key_column: str = "image",
    timestamps: Sequence[float] | np.ndarray | None = None,
) -> Path:
    """Writes an odometry CSV atomically, one row per key (see :func:`odometry_values`), with a
    ``timestamp`` column (seconds) when ``timestamps`` are given."""
    if len(keys) != len(motions):
        raise ValueError(f"{len(motions)} odometry rows for {len(keys)} frames")
    if timestamps is not None and len(timestamps) != len(keys):
        raise ValueError(f"{len(timestamps)} timestamps for {len(keys)} frames")
    form, values = odometry_values(motions)
    with atomic_file(file, "w", newline="") as stream:
        writer = csv.writer(stream, lineterminator="\n")
        columns = [key_column, *(ROBOT_COLUMNS if form == "robot" else MAP_COLUMNS)]
        writer.writerow(columns + (["timestamp"] if timestamps is not None else []))
        for k, (key, row) in enumerate(zip(keys, values)):
            stamp = [] if timestamps is None else [repr(float(timestamps[k]))]
            writer.writerow([key, *(repr(v) for v in row), *stamp])
    return Path(file)
