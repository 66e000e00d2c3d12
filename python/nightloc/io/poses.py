"""Pose files: ``poses.csv`` (``image,x,y[,heading]``) of a traverse folder, or a CSV keyed by video
frame index (``frame,x,y[,heading]``).

Positions are metres in the map frame; headings radians, counter-clockwise from +x, wrapped to
(-pi, pi]. Reading checks every cell and raises :class:`~nightloc.errors.DatasetError` naming the
file and the line.
"""

from __future__ import annotations

import csv
import io
import math
from collections.abc import Sequence
from pathlib import Path

import numpy as np

from .._validate import MAX_COORDINATE_M, coordinates, not_masked
from ..errors import DatasetError
from .files import open_regular

__all__ = [
    "MAX_HEADING_RAD",
    "PoseRow",
    "check_heading",
    "checked_poses",
    "checked_timestamps",
    "parse_timestamp",
    "poses_from_rows",
    "read_pose_csv",
    "refuse_misspelt_columns",
    "refuse_other_delimiter",
    "wrap_headings",
    "write_pose_csv",
]

#: Largest |heading| (and |turn| per frame) a CSV may hold: beyond a full turn a value is not an
#: angle in radians (degrees, most likely).
MAX_HEADING_RAD = 2.0 * math.pi

_OTHER_DELIMITERS = {";": "semicolons", "\t": "tabs", "|": "vertical bars"}


def refuse_other_delimiter(fields: Sequence[str], file: Path, line: int, header: str) -> None:
    """DatasetError when a CSV's header row is one field holding semicolons, tabs or bars (a
    spreadsheet's export in a locale whose list separator is not the comma); ``header`` is the
    header nightloc expects, for the message."""
    if len(fields) != 1:
        return
    for mark, words in _OTHER_DELIMITERS.items():
        if mark in fields[0]:
            raise DatasetError(
                f"{file} line {line}: the columns are separated by {words} ({fields[0].strip()!r}); nightloc reads "
                f"comma-separated values: save it with commas ({header})"
            )


def _edit_distance(a: str, b: str) -> int:
    """Edits (insertions, deletions, substitutions, swaps of neighbours) that turn ``a`` into ``b``."""
    previous, current = list(range(len(b) + 1)), [0] * (len(b) + 1)
    before: list[int] = []
    for i in range(1, len(a) + 1):
        current = [i] + [0] * len(b)
        for j in range(1, len(b) + 1):
            current[j] = min(previous[j] + 1, current[j - 1] + 1, previous[j - 1] + (a[i - 1] != b[j - 1]))
            if i > 1 and j > 1 and a[i - 1] == b[j - 2] and a[i - 2] == b[j - 1]:
                current[j] = min(current[j], before[j - 2] + 1)
        before, previous = previous, current
    return previous[len(b)]


def _near_miss(column: str, known: str) -> bool:
    """True when ``column`` (not a name nightloc reads) looks like a misspelling of ``known``: at
    most one edit away from a name of 4-6 letters, two from a longer one; names of 1-3 letters
    (``x``, ``dy``) have no near misses, so ``z`` or ``dz`` are ignored like any other column."""
    if len(known) < 4 or len(column) < 3:
        return False
    return _edit_distance(column, known) <= (1 if len(known) < 7 else 2)


def refuse_misspelt_columns(header: Sequence[str], known: Sequence[str], file: Path, line: int, expected: str) -> None:
    """DatasetError when a column of ``header`` is a near miss (:func:`_near_miss`) of a name in
    ``known`` that the header lacks (``haeding`` for ``heading``): the misspelt column would
    otherwise be ignored as another column, silently. ``expected`` words the header nightloc
    reads, for the message."""
    for column in header:
        if column in known:
            continue
        close = [name for name in known if name not in header and _near_miss(column, name)]
        if close:
            raise DatasetError(
                f"{file} line {line}: column {column!r} is not one nightloc reads; did you mean {close[0]!r}? The "
                f"columns are {expected} (others are ignored): rename it"
            )


def check_heading(value: float, column: str, file: Path, line: int) -> float:
    """``value`` when it can be an angle in radians (|value| <= 2 pi), else DatasetError naming
    the file and line: headings in degrees would otherwise be taken as radians silently."""
    if abs(value) > MAX_HEADING_RAD:
        raise DatasetError(
            f"{file} line {line}: column '{column}' is {value:g}, beyond a full turn (2 pi = 6.283): angles are "
            f"radians, counter-clockwise; degrees? multiply by pi/180 (0.017453)"
        )
    return value


def finite_headings(headings: np.ndarray) -> np.ndarray:
    """``headings`` (float64) wrapped to (-pi, pi], or ValueError naming the first that is not
    finite."""
    if not np.isfinite(headings).all():
        raise ValueError(f"headings[{int(np.argwhere(~np.isfinite(headings))[0, 0])}] is not finite")
    return wrap_headings(headings)


def wrap_headings(headings: np.ndarray) -> np.ndarray:
    """Angles (radians) wrapped to (-pi, pi]; values already inside are returned bit-exact."""
    values = np.asarray(headings, dtype=np.float64)
    outside = (values <= -math.pi) | (values > math.pi)
    if not outside.any():
        return values.copy()
    wrapped = np.mod(values + math.pi, 2.0 * math.pi) - math.pi
    wrapped = np.where(wrapped <= -math.pi, math.pi, wrapped)
    return np.where(outside, wrapped, values)


class PoseRow:
    """One row of a pose file: its line number, key (image name or frame index), x, y, heading,
    timestamp (seconds; None without the column)."""

    __slots__ = ("heading", "key", "line", "timestamp", "x", "y")

    def __init__(
        self, line: int, key: str | int, x: float, y: float, heading: float | None, timestamp: float | None = None
    ):
        self.line, self.key, self.x, self.y, self.heading = line, key, x, y, heading
        self.timestamp = timestamp


def parse_timestamp(text: str, file: Path, line: int) -> float:
    """A ``timestamp`` cell: finite seconds (any epoch), or DatasetError naming file and line."""
    cell = text.strip()
    try:
        value = float(cell)
    except ValueError:
        raise DatasetError(f"{file} line {line}: column 'timestamp' holds {cell!r}, not a number of seconds") from None
    if not math.isfinite(value):
        raise DatasetError(f"{file} line {line}: column 'timestamp' is {cell!r}; times must be finite seconds")
    return value


def checked_timestamps(values: Sequence[float], lines: Sequence[int], file: Path) -> np.ndarray:
    """``(N,)`` float64 seconds in frame order, or DatasetError at the first that goes back in time."""
    times = np.array(values, dtype=np.float64)
    backwards = np.flatnonzero(np.diff(times) < 0)
    if backwards.size:
        k = int(backwards[0]) + 1
        raise DatasetError(
            f"{file} line {lines[k]}: timestamp {values[k]!r} is before the previous frame's ({values[k - 1]!r}, "
            f"line {lines[k - 1]}); frames must be in the order they were recorded"
        )
    return times


def _parse_number(text: str, column: str, file: Path, line: int) -> float:
    cell = text.strip()
    if not cell:
        raise DatasetError(f"{file} line {line}: column '{column}' is empty; every row needs a number there")
    try:
        value = float(cell)
    except ValueError:
        raise DatasetError(f"{file} line {line}: column '{column}' holds {cell!r}, which is not a number") from None
    if not math.isfinite(value):
        raise DatasetError(
            f"{file} line {line}: column '{column}' is {cell!r}; positions and headings must be finite numbers"
        )
    if column != "heading" and abs(value) >= MAX_COORDINATE_M:
        raise DatasetError(
            f"{file} line {line}: column '{column}' is {cell!r}; positions must lie within {MAX_COORDINATE_M:.0e} m of "
            f"the origin (MAX_COORDINATE_M): subtract a local origin"
        )
    return value


def _parse_frame(text: str, file: Path, line: int) -> int:
    cell = text.strip()
    try:
        value = int(cell)
    except ValueError:
        raise DatasetError(
            f"{file} line {line}: column 'frame' holds {cell!r}; expected a frame index (an integer >= 0)"
        ) from None
    if value < 0:
        raise DatasetError(f"{file} line {line}: frame index {value} is negative")
    return value


def _pose_header(fields: list[str], file: Path, line: int, key_column: str) -> tuple[list[str], dict[str, int]]:
    """The header's column names (lower case) and the index of each column read (``heading`` and
    ``timestamp`` only when present), checked: the required columns, once each."""
    refuse_other_delimiter(fields, file, line, f"{key_column},x,y[,heading]")
    header = [field.strip().lower() for field in fields]
    refuse_misspelt_columns(
        header, (key_column, "x", "y", "heading", "timestamp"), file, line, f"{key_column},x,y[,heading][,timestamp]"
    )
    for column in (key_column, "x", "y"):
        if column not in header:
            raise DatasetError(
                f"{file} line {line}: missing column '{column}' (the header has: "
                f"{', '.join(repr(h) for h in header)}); the header must be "
                f"{key_column},x,y[,heading]"
            )
    duplicates = sorted({h for h in header if header.count(h) > 1 and h})
    if duplicates:
        raise DatasetError(f"{file} line {line}: column {duplicates[0]!r} appears twice in the header")
    index = {name: header.index(name) for name in (key_column, "x", "y")}
    for optional in ("heading", "timestamp"):
        if optional in header:
            index[optional] = header.index(optional)
    return header, index


def _pose_row(
    fields: list[str], index: dict[str, int], key_column: str, seen: dict[str | int, int], file: Path, line: int
) -> PoseRow:
    """One row, checked: its key (unique: ``seen`` maps each key to its line), x, y (metres), the
    heading (radians) and the timestamp (seconds) where the header has them."""
    raw_key = fields[index[key_column]]
    if key_column == "frame":
        key: str | int = _parse_frame(raw_key, file, line)
    else:
        key = raw_key.strip()
        if not key:
            raise DatasetError(f"{file} line {line}: column 'image' is empty")
    if key in seen:
        raise DatasetError(f"{file} line {line}: {key_column} {key!r} is listed twice (first on line {seen[key]})")
    seen[key] = line
    x = _parse_number(fields[index["x"]], "x", file, line)
    y = _parse_number(fields[index["y"]], "y", file, line)
    heading = None
    if "heading" in index:
        heading = check_heading(_parse_number(fields[index["heading"]], "heading", file, line), "heading", file, line)
    stamp = parse_timestamp(fields[index["timestamp"]], file, line) if "timestamp" in index else None
    return PoseRow(line, key, x, y, heading, stamp)


def read_pose_csv(file: Path, key_column: str) -> tuple[list[PoseRow], bool]:
    """Rows of a poses CSV: ``(rows, has_heading)``.

    The CSV must have a header with ``key_column`` (``image`` or ``frame``), ``x`` and ``y``;
    ``heading`` and ``timestamp`` (seconds) are optional and other columns are ignored, except a
    near miss of one of these names (``haeding``), which is refused naming it
    (:func:`refuse_misspelt_columns`). Column names are matched without case and surrounding
    blanks; a UTF-8 byte-order mark and CRLF line ends are accepted; blank lines are skipped.
    Keys must be unique.
    """
    try:
        with io.TextIOWrapper(
            open_regular(file, "poses file", DatasetError), newline="", encoding="utf-8-sig"
        ) as handle:
            reader = csv.reader(handle)
            header: list | None = None
            header_line = 0
            rows: list[PoseRow] = []
            seen: dict[str | int, int] = {}
            for fields in reader:
                line = reader.line_num
                if not any(field.strip() for field in fields):
                    continue
                if header is None:
                    header, index = _pose_header(fields, file, line, key_column)
                    has_heading = "heading" in index
                    header_line = line
                    continue
                if len(fields) != len(header):
                    raise DatasetError(
                        f"{file} line {line}: {len(fields)} fields, but the header (line {header_line}) has "
                        f"{len(header)}"
                    )
                rows.append(_pose_row(fields, index, key_column, seen, file, line))
    except UnicodeDecodeError as error:
        raise DatasetError(f"{file} is not UTF-8 text ({error.reason} at byte {error.start})") from None
    except csv.Error as error:
        raise DatasetError(f"{file}: malformed CSV ({error})") from None
    except OSError as error:
        raise DatasetError(f"{file} cannot be read: {error.strerror or error}") from error
    if header is None:
        raise DatasetError(f"{file} is empty; it needs the header {key_column},x,y[,heading] and one row per frame")
    if not rows:
        raise DatasetError(f"{file} has a header but no rows; add one row per frame")
    return rows, has_heading


def poses_from_rows(rows: Sequence[PoseRow], has_heading: bool) -> tuple[np.ndarray, np.ndarray | None]:
    """``(N, 2)`` positions and ``(N,)`` wrapped headings (or None) of pose rows."""
    positions = np.array([(row.x, row.y) for row in rows], dtype=np.float64).reshape(-1, 2)
    headings = wrap_headings(np.array([row.heading for row in rows], dtype=np.float64)) if has_heading else None
    return positions, headings


def checked_poses(positions: object | None, headings: object | None) -> tuple[np.ndarray | None, np.ndarray | None]:
    """Positions ``(N, 2)`` metres and headings ``(N,)`` radians given by a caller, as float64;
    headings wrapped to (-pi, pi]. Raises ValueError for wrong shapes or non-finite values."""
    if positions is None:
        if headings is not None:
            raise ValueError("headings need positions: pass positions too, or neither")
        return None, None
    not_masked(positions, "positions")
    pos = np.asarray(positions, dtype=np.float64)
    if pos.ndim != 2 or pos.shape[1] != 2:
        raise ValueError(f"positions must be (N, 2) metres, got shape {pos.shape}")
    coordinates(pos, "positions")
    head = None
    if headings is not None:
        not_masked(headings, "headings")
        head = np.asarray(headings, dtype=np.float64)
        if head.shape != (len(pos),):
            raise ValueError(f"headings must be ({len(pos)},) radians to match positions, got shape {head.shape}")
        head = finite_headings(head)
    return pos, head


def write_pose_csv(
    file: Path,
    names: Sequence[str],
    positions: np.ndarray,
    headings: np.ndarray | None,
    timestamps: Sequence[float] | np.ndarray | None = None,
) -> None:
    """Writes ``image,x,y[,heading][,timestamp]`` rows (``repr`` of the floats: they read back
    bit-exact; ``timestamps`` in seconds)."""
    with open(file, "w", newline="", encoding="utf-8") as handle:
        writer = csv.writer(handle, lineterminator="\n")
        writer.writerow(
            ["image", "x", "y"]
            + (["heading"] if headings is not None else [])
            + (["timestamp"] if timestamps is not None else [])
        )
        for i, name in enumerate(names):
            row = [name, repr(float(positions[i, 0])), repr(float(positions[i, 1]))]
            if headings is not None:
                row.append(repr(float(headings[i])))
            if timestamps is not None:
                row.append(repr(float(timestamps[i])))
            writer.writerow(row)
