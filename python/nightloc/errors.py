"""Exception and warning types of nightloc.

Every error nightloc raises on bad input is a ``TypeError`` (wrong type or dtype) or a
``ValueError`` (wrong shape, value, file content); errors about data on disk and user datasets
use :class:`NightlocError`, a ``ValueError`` that names the file and, where it applies, the line.
Input that nightloc can use after leaving part of it out gives a :class:`DatasetWarning` (the
``nightloc`` commands print it as one line on stderr).
"""

from __future__ import annotations

from typing import TypeVar

__all__ = [
    "DatasetError",
    "DatasetWarning",
    "MapFormatError",
    "MappingError",
    "MissingDependencyError",
    "NightlocError",
    "NightlocWarning",
    "cli_message",
    "with_cli_words",
]

E = TypeVar("E", bound=BaseException)

#: Attribute of an exception holding its message in the command line's words.
_CLI_ATTRIBUTE = "nightloc_cli_message"


def with_cli_words(error: E, message: str) -> E:
    """``error`` (worded for the API: "pass overwrite=True") with ``message``, the same in the
    command line's words ("pass --overwrite"), which the ``nightloc`` commands print instead."""
    setattr(error, _CLI_ATTRIBUTE, message)
    return error


def cli_message(error: BaseException) -> str | None:
    """The message :func:`with_cli_words` attached to ``error``, or None."""
    message = getattr(error, _CLI_ATTRIBUTE, None)
    return message if isinstance(message, str) else None


class NightlocError(ValueError):
    """Base class of nightloc's own errors; a ``ValueError``, so ``except ValueError`` catches it."""


class DatasetError(NightlocError):
    """A traverse on disk (images, video, poses CSV) is missing, unreadable or malformed."""


class MapFormatError(NightlocError):
    """A reference map file is corrupt, truncated, of another format version or other parameters."""


class MappingError(NightlocError):
    """A teach run cannot build its map: odometry that does not fit the frames, or a pose graph
    the optimiser cannot solve."""


class MissingDependencyError(NightlocError, ImportError):
    """An optional dependency is not installed; the message names the ``pip install`` command."""


class NightlocWarning(UserWarning):
    """Base class of nightloc's warnings: the work went on, but not with everything it was given."""


class DatasetWarning(NightlocWarning):
    """Part of a traverse was left out (e.g. a bag's frames recorded before its odometry starts)."""
