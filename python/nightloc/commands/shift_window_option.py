"""``--shift-window COLUMNS,ROWS``: the translation window of the comparison, on route
mode's commands (route) and the 2D filter's (localize, evaluate)."""

from __future__ import annotations

import argparse
import dataclasses

from ..localization.grid_filter import FilterParams

__all__ = ["add_shift_window_option", "filter_params_with_window", "parse_shift_window"]


def add_shift_window_option(parser: argparse.ArgumentParser, what: str) -> None:
    """Adds ``--shift-window``; ``what`` is its help (what the window means in this command)."""
    parser.add_argument("--shift-window", metavar="COLUMNS,ROWS", help=what)


def parse_shift_window(text: str | None) -> tuple[int, int] | None:
    """``--shift-window COLUMNS,ROWS`` as a pair of ints >= 0 (None when not given)."""
    if text is None:
        return None
    parts = str(text).split(",")
    try:
        values = tuple(int(part) for part in parts)
    except ValueError:
        values = ()
    if len(values) != 2 or min(values) < 0:
        raise ValueError(f"--shift-window {text!r}: expected COLUMNS,ROWS, two integers >= 0 such as 8,2")
    return (values[0], values[1])


def filter_params_with_window(
    filter_params: FilterParams | None, window: tuple[int, int] | None, camera: str, image_shape: tuple[int, int]
) -> FilterParams | None:
    """``filter_params`` (None: the defaults) with ``--shift-window``'s columns as its
    ``forward_window`` and its rows as its ``row_window``; unchanged when ``window`` is None.

    ``camera`` is the map's (``"panoramic"`` or ``"forward"``), ``image_shape`` its prepared
    images' ``(rows, columns)`` in pixels. A panorama is already compared at every column shift, so
    its window has no columns; a forward camera's column window is how the filter tells headings
    apart, so it has at least one column and fewer than the image's width; rows fewer than the
    image's height. Raises ValueError naming the option."""
    if window is None:
        return filter_params
    columns, rows = window
    height, width = image_shape
    if rows >= height:
        raise ValueError(
            f"--shift-window {columns},{rows}: at most {height - 1} rows (the map's images are {height} rows high; "
            f"a tilting robot needs 1 or 2)"
        )
    if camera == "panoramic" and columns != 0:
        raise ValueError(
            f"--shift-window {columns},{rows}: the map is panoramic, compared at every column shift already; "
            f"give it rows only: --shift-window 0,{rows}"
        )
    if camera == "forward" and not 1 <= columns < width:
        raise ValueError(
            f"--shift-window {columns},{rows}: a forward camera's column window must be 1..{width - 1} columns "
            f"(its images are {width} wide; the filter's default is a quarter of that, {max(1, width // 4)})"
        )
    base = filter_params if filter_params is not None else FilterParams()
    forward_window = columns if camera == "forward" else base.forward_window
    return dataclasses.replace(base, forward_window=forward_window, row_window=rows)
