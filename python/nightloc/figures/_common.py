"""What every figure shares: a matplotlib :class:`~matplotlib.figure.Figure` made without pyplot
(no display, no global state; the Agg canvas renders it), the house style, and atomic saving as
PNG, PDF or SVG.

Only the figures package imports this module, and so matplotlib: nothing on the robot's path
(:class:`nightloc.Localizer`, :func:`nightloc.match`, :func:`nightloc.prepare`, the route
localizer) does.
"""

from __future__ import annotations

import io
import os
from collections.abc import Callable
from functools import wraps
from pathlib import Path
from typing import Any, TypeVar, Union

import matplotlib as mpl
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure

from ..io.atomic import write_bytes
from . import FORMATS

__all__ = ["DPI", "FORMATS", "STYLE", "figure_path", "new_figure", "save_figure", "styled"]

PathLike = Union[str, "os.PathLike[str]"]
F = TypeVar("F", bound=Callable[..., Any])

#: Pixels per inch of PNG output: a figure of ``w x h`` inches is ``100 w x 100 h`` pixels.
DPI = 100

#: The house style (matplotlib rcParams), applied while a figure is drawn and saved.
STYLE: dict[Any, Any] = {  # keys: matplotlib rc names (its stubs type them as a Literal)
    "font.size": 9,
    "axes.titlesize": 10,
    "axes.labelsize": 9,
    "figure.titlesize": 11,
    "legend.fontsize": 8,
    "xtick.labelsize": 8,
    "ytick.labelsize": 8,
    "axes.grid": True,
    "grid.alpha": 0.3,
    "grid.linewidth": 0.6,
    "axes.axisbelow": True,
    "figure.dpi": DPI,
    "savefig.dpi": DPI,
    "pdf.fonttype": 42,  # TrueType in PDFs: text stays text
    "svg.hashsalt": "nightloc",  # identical SVG ids run after run
    "svg.fonttype": "none",  # SVG text stays text (searchable, selectable)
    "image.origin": "lower",  # row 0 of every image at the bottom (y up, as the map frame)
}

# Timestamps left out so that the same figure gives the same bytes (committed figures diff cleanly).
_METADATA: dict[str, dict[str, Any]] = {"png": {}, "pdf": {"CreationDate": None}, "svg": {"Date": None}}


def styled(function: F) -> F:
    """Runs ``function`` (a figure builder) under :data:`STYLE`."""

    @wraps(function)
    def wrapper(*args: Any, **kwargs: Any) -> Any:
        with mpl.rc_context(STYLE):
            return function(*args, **kwargs)

    return wrapper  # type: ignore[return-value]


def new_figure(width: float, height: float, rows: int = 1, cols: int = 1, **subplots: Any) -> tuple[Figure, Any]:
    """A ``width x height``-inch figure (constrained layout, Agg canvas) and its axes.

    Returns ``(figure, axes)`` where ``axes`` is one :class:`~matplotlib.axes.Axes` for a single
    panel, the ``(rows, cols)`` array of ``Figure.subplots`` for several, or None when ``rows`` is
    0 (the caller lays the figure out, e.g. with subfigures).
    """
    with mpl.rc_context(STYLE):
        fig = Figure(figsize=(width, height), dpi=DPI, layout="constrained")
        FigureCanvasAgg(fig)
        axes = fig.subplots(rows, cols, squeeze=True, **subplots) if rows > 0 else None
    return fig, axes


def check_format(figure_format: str) -> str:
    """``figure_format`` lower-cased, or a ValueError naming the choices."""
    text = str(figure_format).lower().lstrip(".")
    if text not in FORMATS:
        raise ValueError(f"figure format must be one of {', '.join(FORMATS)}, got {figure_format!r}")
    return text


def figure_path(folder: PathLike, stem: str, figure_format: str = "png") -> Path:
    """``folder / f"{stem}.{figure_format}"`` (format checked)."""
    return Path(folder) / f"{stem}.{check_format(figure_format)}"


def save_figure(fig: Figure, path: PathLike, figure_format: str | None = None) -> Path:
    """Writes ``fig`` to ``path`` atomically (a hidden temporary file in the same folder, then
    ``os.replace``); returns the path.

    The format is ``figure_format`` or else the suffix of ``path`` (``.png``, ``.pdf``,
    ``.svg``). PNGs are :data:`DPI` pixels per inch of the figure's size.

    Raises:
        ValueError: an unknown format, or a suffix that contradicts ``figure_format``.
    """
    target = Path(path)
    suffix = target.suffix.lower().lstrip(".")
    if figure_format is None:
        if suffix not in FORMATS:
            raise ValueError(f"cannot tell the figure format of {target}: name it .png, .pdf or .svg")
        fmt = suffix
    else:
        fmt = check_format(figure_format)
        if suffix != fmt:
            raise ValueError(f"{target} does not end in .{fmt}, the figure format asked for")
    buffer = io.BytesIO()
    with mpl.rc_context(STYLE):
        fig.savefig(buffer, format=fmt, dpi=DPI, metadata=_METADATA[fmt])
    return write_bytes(target, buffer.getvalue())
