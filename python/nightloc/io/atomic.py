"""Atomic outputs: a file or a folder appears complete, or not at all.

Everything is first written under a hidden temporary name in the destination's own folder (same
file system), flushed to disk, then renamed into place with ``os.replace``/``os.rename``. An
interrupted write (exception, kill, power loss) leaves the previous version intact and at most a
hidden ``.<name>.<random>.partial`` entry behind. New files and folders get the usual permissions
(0666/0777 less the umask), unlike ``tempfile``'s private 0600/0700.

Replacing an existing folder swaps the two folders in one step where the system can (Linux
``renameat2(RENAME_EXCHANGE)``), so even a kill at that moment leaves the old or the new folder
at the target; elsewhere the old folder is moved aside first (a kill between the two renames
leaves it under its hidden ``.old`` name).
"""

from __future__ import annotations

import contextlib
import ctypes
import errno
import os
import shutil
import sys
import uuid
from collections.abc import Iterator
from pathlib import Path
from typing import IO, Union

PathLike = Union[str, "os.PathLike[str]"]

__all__ = [
    "atomic_file",
    "atomic_folder",
    "check_output_path",
    "make_folder",
    "replace_folder",
    "staging_folder",
    "write_bytes",
    "write_text",
]


def check_output_path(path: PathLike, folder: bool = False) -> Path:
    """Fails early, before any work, when ``path`` cannot become an output file (or ``folder``).

    Raises IsADirectoryError when a file is wanted and ``path`` is a folder, NotADirectoryError
    when a folder is wanted and ``path`` is a file, or when an existing parent is a file.
    Creates nothing.
    """
    target = Path(path)
    if not folder and target.is_dir():
        raise IsADirectoryError(f"{target} is a folder; give a file name")
    if folder and target.exists() and not target.is_dir():
        raise NotADirectoryError(f"{target} exists and is a file, not a folder")
    blocking = next((p for p in target.parents if p.exists()), None)
    if blocking is not None and not blocking.is_dir():
        raise NotADirectoryError(f"cannot write {target}: {blocking} is a file, not a folder")
    return target


def make_folder(folder: PathLike) -> Path:
    """Creates ``folder`` and its parents when missing; returns it.

    Raises NotADirectoryError naming the culprit when ``folder`` or one of its parents is a file
    (``mkdir`` alone reports a bare "File exists").
    """
    folder = Path(folder)
    try:
        folder.mkdir(parents=True, exist_ok=True)
    except (FileExistsError, NotADirectoryError):
        blocking = next((p for p in (folder, *folder.parents) if p.exists() and not p.is_dir()), folder)
        raise NotADirectoryError(
            f"cannot create the folder {folder}: {blocking} is a file, not a folder; choose another output path"
        ) from None
    return folder


def _temporary_name(target: Path) -> Path:
    return target.parent / f".{target.name}.{uuid.uuid4().hex[:12]}.partial"


@contextlib.contextmanager
def atomic_file(
    path: PathLike, mode: str = "wb", encoding: str | None = None, newline: str | None = None
) -> Iterator[IO]:
    """Context manager yielding a file object whose content replaces ``path`` on success.

    ``mode`` is ``"wb"`` or ``"w"`` (text, ``encoding`` defaults to UTF-8). On an exception the
    temporary file is removed and ``path`` is left as it was.
    """
    if mode not in ("wb", "w"):
        raise ValueError(f"mode must be 'wb' or 'w', got {mode!r}")
    target = Path(path)
    if target.is_dir():
        raise IsADirectoryError(f"{target} is a folder, not a file name")
    make_folder(target.parent)
    temporary = _temporary_name(target)
    handle = os.open(temporary, os.O_WRONLY | os.O_CREAT | os.O_EXCL, 0o666)  # the umask applies
    try:
        if mode == "w":
            stream = os.fdopen(handle, "w", encoding=encoding or "utf-8", newline=newline)
        else:
            stream = os.fdopen(handle, "wb")
    except BaseException:
        os.close(handle)
        temporary.unlink(missing_ok=True)
        raise
    try:
        with stream:
            yield stream
            stream.flush()
            os.fsync(stream.fileno())
        os.replace(temporary, target)
    except BaseException:
        temporary.unlink(missing_ok=True)
        raise


def write_bytes(path: PathLike, data: bytes) -> Path:
    """Writes ``data`` to ``path`` atomically; returns the path."""
    with atomic_file(path, "wb") as stream:
        stream.write(data)
    return Path(path)


def write_text(path: PathLike, text: str, newline: str | None = "\n") -> Path:
    """Writes ``text`` (UTF-8) to ``path`` atomically; returns the path."""
    with atomic_file(path, "w", newline=newline) as stream:
        stream.write(text)
    return Path(path)


def staging_folder(target: PathLike) -> Path:
    """Creates and returns an empty hidden folder beside ``target`` to build it in."""
    target = Path(target)
    make_folder(target.parent)
    staging = _temporary_name(target)
    os.mkdir(staging, 0o777)  # the umask applies
    return staging


_RENAME_EXCHANGE = 2  # linux/fs.h
_AT_FDCWD = -100


def _exchange(first: Path, second: Path) -> bool:
    """Swaps two existing paths atomically (Linux ``renameat2`` with ``RENAME_EXCHANGE``).

    Returns False where the C library, the kernel or the file system cannot, so the caller falls
    back to two renames; raises OSError for other failures.
    """
    if not sys.platform.startswith("linux"):
        return False
    try:
        renameat2 = ctypes.CDLL(None, use_errno=True).renameat2
    except (OSError, AttributeError):  # a C library without the wrapper (glibc < 2.28, musl)
        return False
    renameat2.argtypes = [ctypes.c_int, ctypes.c_char_p, ctypes.c_int, ctypes.c_char_p, ctypes.c_uint]
    renameat2.restype = ctypes.c_int
    if renameat2(_AT_FDCWD, os.fsencode(first), _AT_FDCWD, os.fsencode(second), _RENAME_EXCHANGE) == 0:
        return True
    code = ctypes.get_errno()
    if code in (errno.ENOSYS, errno.EINVAL, errno.ENOTSUP, errno.EOPNOTSUPP):
        return False
    raise OSError(code, os.strerror(code), str(first), None, str(second))


def replace_folder(staging: PathLike, target: PathLike) -> None:
    """Renames ``staging`` to ``target``. An existing ``target`` is swapped with ``staging`` in
    one atomic step where possible (then removed); otherwise it is moved aside first and removed
    only once the new folder is in place (restored if the rename fails)."""
    staging, target = Path(staging), Path(target)
    if not target.exists():
        os.rename(staging, target)
        return
    if target.is_dir() and _exchange(staging, target):
        shutil.rmtree(staging, ignore_errors=True)  # now holds the previous folder
        return
    trash = _temporary_name(target).with_suffix(".old")
    os.rename(target, trash)
    try:
        os.rename(staging, target)
    except BaseException:
        os.rename(trash, target)
        raise
    shutil.rmtree(trash, ignore_errors=True)


@contextlib.contextmanager
def atomic_folder(target: PathLike) -> Iterator[Path]:
    """Context manager yielding a staging folder that replaces ``target`` on success.

    On an exception the staging folder is removed and ``target`` is left as it was.
    """
    staging = staging_folder(target)
    try:
        yield staging
        replace_folder(staging, target)
    except BaseException:
        shutil.rmtree(staging, ignore_errors=True)
        raise
