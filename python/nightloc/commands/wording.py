"""What the commands say: durations, option names in place of the API's field names, and paths
given in the wrong place named for what they are."""

from __future__ import annotations

import re
from collections.abc import Iterable
from pathlib import Path

from ..errors import DatasetError
from ..io.kinds import MAP, path_kind

__all__ = ["duration", "in_option_words", "refuse_map_as_traverse"]


def duration(seconds: float) -> str:
    """``seconds`` for a person: ``"3.4 ms"`` below 10 ms (where ``"0.00 s"`` would say
    nothing), ``"0.12 s"`` below 10 s, ``"12.3 s"`` above."""
    if seconds < 0.01:
        return f"{1000.0 * seconds:.1f} ms"
    return f"{seconds:.2f} s" if seconds < 10 else f"{seconds:.1f} s"


def in_option_words(error: ValueError, options: Iterable[str]) -> ValueError:
    """``error`` with each API field name in ``options`` (e.g. ``vmin``) written as the command's
    option (``--vmin``), for errors raised by a parameter class on the command's behalf."""
    message = str(error)
    for name in options:
        flag = "--" + name.replace("_", "-")
        message = re.sub(rf"(?<![\w-]){re.escape(name)}\b(?!\s*=\s*[A-Za-z'\"])", flag, message)
    return type(error)(message) if isinstance(error, ValueError) else ValueError(message)


def refuse_map_as_traverse(path: str | Path, role: str, usage: str) -> None:
    """DatasetError when ``path``, given as the traverse ``role`` (e.g. "LOG"), is a reference
    map: the arguments are swapped or the wrong file was named; ``usage`` shows the order."""
    if path_kind(path) == MAP:
        raise DatasetError(
            f"{role} {path} is {MAP}, not a traverse (a folder of images, a video or a ROS bag): {usage}"
        )
