"""Reading input files: only regular files, checked before a byte is read.

A named pipe (FIFO) opened for reading blocks until a writer appears, a device can stream
forever, a socket cannot be opened at all, and a symbolic link loop or a folder is not a file:
every reader in nightloc goes through :func:`open_regular` (or :func:`check_regular` for files
that OpenCV opens itself), which names what the path is instead, at once.

:func:`open_regular` opens with ``O_NONBLOCK`` (so not even a FIFO can block the open) and then
checks the opened file itself with ``fstat``: a file swapped for a pipe between a check and the
open cannot slip through.
"""

from __future__ import annotations

import errno
import os
import stat
from pathlib import Path
from typing import BinaryIO, Union

__all__ = ["check_regular", "describe_kind", "open_regular"]

PathLike = Union[str, "os.PathLike[str]"]

_KINDS = (
    (stat.S_ISDIR, "a folder"),
    (stat.S_ISFIFO, "a named pipe (FIFO)"),
    (stat.S_ISSOCK, "a socket"),
    (stat.S_ISCHR, "a character device"),
    (stat.S_ISBLK, "a block device"),
)


def describe_kind(mode: int) -> str:
    """What a ``st_mode`` is, in words ("a regular file", "a named pipe (FIFO)", ...)."""
    if stat.S_ISREG(mode):
        return "a regular file"
    return next((words for test, words in _KINDS if test(mode)), "not a regular file")


def _problem(path: Path, error: OSError) -> str:
    if error.errno == errno.ELOOP:
        return "is a symbolic link loop"
    if error.errno == errno.ENOENT:
        return "does not exist" if not os.path.islink(path) else "is a symbolic link to a file that does not exist"
    if error.errno == errno.ENOTDIR:
        return "does not exist (a part of the path is a file, not a folder)"
    return f"cannot be read: {error.strerror or error}"


def check_regular(path: PathLike, what: str, error: type[Exception]) -> Path:
    """Raises ``error`` naming ``what`` (e.g. "poses file") and the kind of ``path`` unless it is
    a regular file (a symbolic link to one is fine); returns the path. For files a library opens
    by name (OpenCV's video reader): use :func:`open_regular` where nightloc reads the bytes."""
    file = Path(path)
    try:
        mode = os.stat(file).st_mode
    except OSError as failure:
        raise error(f"{what} {file} {_problem(file, failure)}") from None
    if not stat.S_ISREG(mode):
        raise error(f"{what} {file} is {describe_kind(mode)}, not a regular file")
    return file


def open_regular(path: PathLike, what: str, error: type[Exception]) -> BinaryIO:
    """Opens ``path`` for binary reading when it is a regular file; otherwise raises ``error``
    naming ``what`` and what the path is (a folder, a FIFO, a device, a link loop, missing).

    Permission problems keep their ``PermissionError`` (the user's fix is another one).
    """
    file = Path(path)
    try:
        handle = os.open(file, os.O_RDONLY | getattr(os, "O_NONBLOCK", 0) | getattr(os, "O_CLOEXEC", 0))
    except PermissionError:
        raise
    except IsADirectoryError:
        raise error(f"{what} {file} is a folder, not a regular file") from None
    except OSError as failure:
        if failure.errno == errno.ENXIO:  # a socket, or a FIFO opened without a writer on some systems
            mode = os.stat(file).st_mode
            raise error(f"{what} {file} is {describe_kind(mode)}, not a regular file") from None
        raise error(f"{what} {file} {_problem(file, failure)}") from None
    try:
        mode = os.fstat(handle).st_mode
        if not stat.S_ISREG(mode):
            raise error(f"{what} {file} is {describe_kind(mode)}, not a regular file")
        if hasattr(os, "set_blocking"):
            os.set_blocking(handle, True)
        return os.fdopen(handle, "rb")
    except BaseException:
        os.close(handle)
        raise
