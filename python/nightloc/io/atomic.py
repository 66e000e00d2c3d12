"""Outputs: a file, a folder or a command's whole result appears complete, or not at all.

**Files** (:func:`atomic_file`, :func:`write_bytes`, :func:`write_text`) are written under a
hidden temporary name in the destination's own folder (same file system), flushed to disk, then
renamed into place with ``os.replace``.

**Result sets** (:func:`output_set`): a command's output folder is built whole in a hidden
sibling folder and swapped in with one rename, so success leaves the new set, and any failure
or interruption the previous set (or nothing). The set records the files it made in a hidden
manifest (:data:`MANIFEST_NAME`); the next run replaces exactly those, and keeps every other
entry of the folder (a user's notes, say) by linking it into the new set: a command deletes only
what nightloc created. A non-empty folder without a manifest was not written by nightloc and is
refused. The swap is one atomic step where the system can (Linux ``renameat2(RENAME_EXCHANGE)``,
so even a kill at that moment leaves the old or the new folder); elsewhere the old folder is
moved aside first, and a kill between the two renames is repaired by the next write.

**Rules every output follows** (files, folders and sets alike):

* one writer at a time: a lock (``fcntl.flock`` on a hidden ``.<name>.lock`` beside the target,
  removed afterwards) makes a second writer of the same target wait (files) or refuse at once
  with one line (sets and traverse folders); the lock dies with its process;
* leftovers of killed writes of the same target (hidden ``.<name>.<random>.partial`` and
  ``.old`` entries) are removed by the next write, under the lock;
* the parent folder must exist (a typo must not create a tree of folders): FileNotFoundError;
  except for a command's outputs (an output folder with ``parents=True``, a file written inside
  :func:`parent_folders`), whose missing parents are created, those made being removed again
  when the command fails;
* a symbolic link at the output path is followed: the file or folder it points to is replaced
  and the link stays (a link loop is refused);
* an output that is, contains or lies inside one of the command's inputs is refused before any
  work (:func:`refuse_overlap`);
* new files and folders get the usual permissions (0666/0777 less the umask), unlike
  ``tempfile``'s private 0600/0700.
"""

from __future__ import annotations

import contextlib
import ctypes
import errno
import json
import os
import re
import shutil
import stat
import sys
import time
import uuid
from collections.abc import Iterable, Iterator
from pathlib import Path
from typing import IO, Union

from ..errors import with_cli_words

try:  # POSIX; elsewhere writes are not locked against each other
    import fcntl
except ImportError:  # pragma: no cover - Windows
    fcntl = None  # type: ignore[assignment]

PathLike = Union[str, "os.PathLike[str]"]

__all__ = [
    "MANIFEST_NAME",
    "OutputSet",
    "atomic_file",
    "atomic_folder",
    "check_output_path",
    "locked_target",
    "make_folder",
    "output_set",
    "parent_folders",
    "refuse_overlap",
    "replace_folder",
    "staging_folder",
    "write_bytes",
    "write_text",
]

#: The hidden file in every result set that lists the files and folders nightloc wrote there.
MANIFEST_NAME = ".nightloc-output.json"
_MANIFEST_FORMAT = "nightloc-output-set"


# --------------------------------------------------------------------------------------------
# paths


def _resolve(path: PathLike) -> Path:
    """The absolute path an output at ``path`` is written to: symbolic links followed (a link at
    the path itself included, dangling or not); raises ValueError for a link loop."""
    user = Path(path)
    try:
        return Path(os.path.realpath(user, strict=True))
    except OSError as error:
        if error.errno == errno.ELOOP:
            raise ValueError(f"{user} is a symbolic link loop; remove it or choose another output path") from None
        return Path(os.path.realpath(user))  # missing, a dangling link, a file in the way: checked later


def _check_parent(target: Path, user: Path) -> None:
    parent = target.parent
    if parent.is_dir():
        return
    shown = user.parent if str(user.parent) not in ("", ".") else parent
    if parent.exists() or any(p.exists() and not p.is_dir() for p in parent.parents):
        blocking = next((p for p in (parent, *parent.parents) if p.exists() and not p.is_dir()), parent)
        raise NotADirectoryError(f"cannot write {user}: {blocking} is a file, not a folder")
    raise FileNotFoundError(f"cannot write {user}: the folder {shown} does not exist (create it first)")


def _check_ancestors(target: Path, user: Path) -> None:
    """NotADirectoryError when an existing ancestor of ``target`` is a file (missing ones are fine)."""
    blocking = next((p for p in target.parents if p.exists() and not p.is_dir()), None)
    if blocking is not None:
        raise NotADirectoryError(f"cannot write {user}: {blocking} is a file, not a folder")


def _make_parents(target: Path, user: Path) -> list[Path]:
    """Creates the missing parent folders of ``target``; returns those it made, outermost first."""
    _check_ancestors(target, user)
    missing = [p for p in target.parents if not p.exists()][::-1]
    made = []
    try:
        for folder in missing:
            try:
                os.mkdir(folder)
            except FileExistsError:  # made meanwhile by another process: not ours to remove
                continue
            made.append(folder)
    except OSError:
        _remove_made(made)
        raise
    return made


def _remove_made(made: list[Path]) -> None:
    """Removes the folders :func:`_make_parents` made, innermost first, where they are still empty."""
    for folder in reversed(made):
        with contextlib.suppress(OSError):
            os.rmdir(folder)


@contextlib.contextmanager
def parent_folders(path: PathLike) -> Iterator[Path]:
    """Context manager: creates the missing parent folders of the output ``path`` (a command's
    output file, e.g. ``maps/garden.map``) and removes those it made again when the block raises.
    Raises NotADirectoryError naming the culprit when an existing parent is a file."""
    user = Path(path)
    made = _make_parents(_resolve(user), user)
    try:
        yield user
    except BaseException:
        _remove_made(made)
        raise


def _inside(inner: Path, outer: Path) -> bool:
    return outer in inner.parents


def refuse_overlap(output: PathLike, inputs: Iterable[PathLike | None], folder: bool) -> None:
    """Raises ValueError when ``output`` is one of ``inputs``, lies inside one, or (``folder``:
    the output replaces a whole folder) contains one. Paths are compared with symbolic links
    resolved; None inputs are skipped."""
    target = _resolve(output)
    for given in inputs:
        if given is None:
            continue
        source = _resolve(given)
        if target == source:
            raise ValueError(f"the output {output} is the input {given}; write the output elsewhere")
        if _inside(target, source):
            raise ValueError(f"the output {output} lies inside the input {given}; write the output elsewhere")
        if folder and _inside(source, target):
            raise ValueError(
                f"the output folder {output} contains the input {given} (replacing the folder would delete it); "
                f"write the output elsewhere"
            )


def check_output_path(
    path: PathLike,
    folder: bool = False,
    *,
    overwrite: bool = True,
    inputs: Iterable[PathLike | None] = (),
    parents: bool = False,
) -> Path:
    """Fails early, before any work, when ``path`` cannot become an output file (or ``folder``).

    Raises IsADirectoryError when a file is wanted and ``path`` is a folder, NotADirectoryError
    when a folder is wanted and ``path`` is a file or an existing parent is a file,
    FileNotFoundError when the parent folder is missing (unless ``parents``: it will be created),
    FileExistsError when a file exists and ``overwrite`` is False, and ValueError when the output
    overlaps ``inputs`` (:func:`refuse_overlap`). Creates nothing; returns ``path``.
    """
    user = Path(path)
    target = _resolve(user)
    if not folder and target.is_dir():
        raise IsADirectoryError(f"{user} is a folder; give a file name")
    if folder and target.exists() and not target.is_dir():
        raise NotADirectoryError(f"{user} exists and is a file, not a folder")
    if parents:
        _check_ancestors(target, user)
    else:
        _check_parent(target, user)
    refuse_overlap(user, inputs, folder)
    if not folder and not overwrite and os.path.lexists(target):
        raise with_cli_words(
            FileExistsError(f"{user} exists; pass overwrite=True to replace it"),
            f"{user} exists; pass --overwrite to replace it",
        )
    return user


def make_folder(folder: PathLike) -> Path:
    """Creates ``folder`` and its parents when missing; returns it.

    For folders inside a staging folder; outputs themselves need an existing parent. Raises
    NotADirectoryError naming the culprit when ``folder`` or one of its parents is a file.
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


# --------------------------------------------------------------------------------------------
# one writer per target, and the leftovers of killed ones


def _lock_path(target: Path) -> Path:
    return target.parent / f".{target.name}.lock"


def _holder(handle: int) -> str:
    try:
        text = os.pread(handle, 32, 0).decode("ascii", "replace").strip()
    except OSError:
        return ""
    return f" (process {text})" if text.isdigit() else ""


def _acquire(target: Path, wait: float | None, shown: Path) -> int | None:
    """Locks ``target`` for this writer; returns the lock file's descriptor (None without fcntl).

    ``wait``: seconds to wait for another writer (None: as long as it takes; 0: refuse at once
    with BlockingIOError naming the holder)."""
    if fcntl is None:  # pragma: no cover
        return None
    path = _lock_path(target)
    deadline = None if wait is None else time.monotonic() + wait
    while True:
        try:
            handle = os.open(path, os.O_RDWR | os.O_CREAT | getattr(os, "O_CLOEXEC", 0), 0o666)
        except PermissionError as error:  # name the folder the user cannot write in, not the lock file
            raise PermissionError(error.errno, error.strerror, str(target.parent)) from None
        try:
            if deadline is None:
                fcntl.flock(handle, fcntl.LOCK_EX)
            else:
                while True:
                    try:
                        fcntl.flock(handle, fcntl.LOCK_EX | fcntl.LOCK_NB)
                        break
                    except BlockingIOError:
                        if time.monotonic() >= deadline:
                            raise BlockingIOError(
                                f"another nightloc run{_holder(handle)} is writing {shown}; wait for it to "
                                f"finish or write elsewhere"
                            ) from None
                        time.sleep(0.05)
            # A writer that just finished unlinks its lock file: ours must still be the one at the path.
            try:
                same = os.path.samestat(os.fstat(handle), os.stat(path))
            except FileNotFoundError:
                same = False
            if same:
                os.ftruncate(handle, 0)
                os.pwrite(handle, f"{os.getpid()}\n".encode(), 0)
                return handle
        except BaseException:
            os.close(handle)
            raise
        os.close(handle)


def _release(target: Path, handle: int | None) -> None:
    if handle is None:  # pragma: no cover
        return
    try:
        with contextlib.suppress(FileNotFoundError):
            os.unlink(_lock_path(target))
    finally:
        os.close(handle)


def _leftovers(target: Path) -> list[Path]:
    pattern = re.compile(rf"\.{re.escape(target.name)}\.[0-9a-f]{{12}}\.(partial|old)")
    try:
        names = os.listdir(target.parent)
    except OSError:
        return []
    return [target.parent / name for name in names if pattern.fullmatch(name)]


def _remove(path: Path) -> None:
    if path.is_dir() and not path.is_symlink():
        shutil.rmtree(path, ignore_errors=True)
    else:
        with contextlib.suppress(FileNotFoundError):
            path.unlink()


def _clean_leftovers(target: Path) -> None:
    """Removes the leftovers of killed writes of ``target`` (call with the lock held). A folder
    moved aside by a killed two-rename swap (``.old``) while ``target`` is missing is restored."""
    leftovers = _leftovers(target)
    if not os.path.lexists(target):
        moved_aside = [p for p in leftovers if p.name.endswith(".old") and p.is_dir()]
        if len(moved_aside) == 1:
            os.rename(moved_aside[0], target)
            leftovers.remove(moved_aside[0])
    for path in leftovers:
        _remove(path)


@contextlib.contextmanager
def locked_target(path: PathLike, wait: float | None = None) -> Iterator[Path]:
    """Context manager: holds the write lock of the output ``path`` (resolved, see the module
    docstring) with its leftovers cleaned; yields the resolved path. Raises FileNotFoundError
    when the parent folder is missing, BlockingIOError when another writer holds the lock
    beyond ``wait`` seconds (None: wait as long as it takes)."""
    user = Path(path)
    target = _resolve(user)
    _check_parent(target, user)
    handle = _acquire(target, wait, user)
    try:
        _clean_leftovers(target)
        yield target
    finally:
        _release(target, handle)


# --------------------------------------------------------------------------------------------
# files


@contextlib.contextmanager
def atomic_file(
    path: PathLike,
    mode: str = "wb",
    encoding: str | None = None,
    newline: str | None = None,
    *,
    overwrite: bool = True,
) -> Iterator[IO]:
    """Context manager yielding a file object whose content replaces ``path`` on success.

    ``mode`` is ``"wb"`` or ``"w"`` (text, ``encoding`` defaults to UTF-8; text from file names
    that are not valid UTF-8 is written as the names' own bytes). On an exception the
    temporary file is removed and ``path`` is left as it was. A second writer of the same path
    waits for the first. With ``overwrite=False`` an existing ``path`` raises FileExistsError
    (checked under the lock: of two writers of a new file, one succeeds).
    """
    if mode not in ("wb", "w"):
        raise ValueError(f"mode must be 'wb' or 'w', got {mode!r}")
    user = Path(path)
    if _resolve(user).is_dir():
        raise IsADirectoryError(f"{user} is a folder, not a file name")
    with locked_target(user) as target:
        if target.is_dir():
            raise IsADirectoryError(f"{user} is a folder, not a file name")
        if not overwrite and os.path.lexists(target):
            raise with_cli_words(
                FileExistsError(f"{user} exists; pass overwrite=True to replace it"),
                f"{user} exists; pass --overwrite to replace it",
            )
        temporary = _temporary_name(target)
        handle = os.open(temporary, os.O_WRONLY | os.O_CREAT | os.O_EXCL, 0o666)  # the umask applies
        try:
            stream: IO
            if mode == "w":  # file names that are not UTF-8 are written back as their own bytes
                stream = os.fdopen(handle, "w", encoding=encoding or "utf-8", errors="surrogateescape", newline=newline)
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


def write_bytes(path: PathLike, data: bytes, *, overwrite: bool = True) -> Path:
    """Writes ``data`` to ``path`` atomically; returns the path."""
    with atomic_file(path, "wb", overwrite=overwrite) as stream:
        stream.write(data)
    return Path(path)


def write_text(path: PathLike, text: str, newline: str | None = "\n", *, overwrite: bool = True) -> Path:
    """Writes ``text`` (UTF-8) to ``path`` atomically; returns the path."""
    with atomic_file(path, "w", newline=newline, overwrite=overwrite) as stream:
        stream.write(text)
    return Path(path)


# --------------------------------------------------------------------------------------------
# folders


def staging_folder(target: PathLike) -> Path:
    """Creates and returns an empty hidden folder beside ``target`` to build it in (the parent
    folder must exist)."""
    target = Path(target)
    _check_parent(target, target)
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


def replace_folder(staging: PathLike, target: PathLike, keep_previous: bool = False) -> Path | None:
    """Renames ``staging`` to ``target``. An existing ``target`` is swapped with ``staging`` in
    one atomic step where possible; otherwise it is moved aside first (restored if the rename
    fails). The previous folder is removed, or with ``keep_previous`` returned (hidden, beside
    the target) for the caller to look through and remove."""
    staging, target = Path(staging), Path(target)
    if not target.exists():
        os.rename(staging, target)
        return None
    if target.is_dir() and _exchange(staging, target):
        previous = staging  # now holds the previous folder
    else:
        previous = _temporary_name(target).with_suffix(".old")
        os.rename(target, previous)
        try:
            os.rename(staging, target)
        except BaseException:
            os.rename(previous, target)
            raise
    if keep_previous:
        return previous
    shutil.rmtree(previous, ignore_errors=True)
    return None


@contextlib.contextmanager
def atomic_folder(target: PathLike, *, wait: float | None = 0.0) -> Iterator[Path]:
    """Context manager yielding a staging folder that replaces ``target`` whole on success.

    On an exception the staging folder is removed and ``target`` is left as it was. Holds the
    target's lock (another writer: BlockingIOError after ``wait`` seconds).
    """
    with locked_target(target, wait=wait) as resolved:
        staging = staging_folder(resolved)
        try:
            yield staging
            replace_folder(staging, resolved)
        except BaseException:
            shutil.rmtree(staging, ignore_errors=True)
            raise


# --------------------------------------------------------------------------------------------
# result sets


def _walk(root: Path, skip_manifest: bool = True) -> tuple[list[str], list[str]]:
    """(files, folders) under ``root`` as sorted relative POSIX paths; symbolic links and other
    non-folders count as files, links are not followed."""
    files: list[str] = []
    folders: list[str] = []
    for directory, subdirs, names in os.walk(root):
        base = Path(directory).relative_to(root)
        for name in subdirs:
            folders.append((base / name).as_posix())
        for name in names:
            relative = (base / name).as_posix()
            if not (skip_manifest and relative == MANIFEST_NAME):
                files.append(relative)
    return sorted(files), sorted(folders)


def _fsync_tree(root: Path) -> None:
    """Flushes every file under ``root`` (one ``syncfs`` on Linux) before the set is swapped in."""
    if sys.platform.startswith("linux"):
        with contextlib.suppress(OSError, AttributeError):
            handle = os.open(root, os.O_RDONLY)
            try:
                if ctypes.CDLL(None, use_errno=True).syncfs(handle) == 0:
                    return
            finally:
                os.close(handle)
    for directory, _, names in os.walk(root):  # pragma: no cover - other systems
        for name in names:
            with contextlib.suppress(OSError):
                handle = os.open(Path(directory) / name, os.O_RDONLY)
                try:
                    os.fsync(handle)
                finally:
                    os.close(handle)


class _Previous:
    """What an existing output folder holds: nightloc's files and folders (from its manifest)."""

    def __init__(self, files: Iterable[str] = (), folders: Iterable[str] = (), command: str = ""):
        self.files = set(files)
        self.folders = set(folders)
        self.command = command

    def foreign(self, root: Path) -> list[str]:
        """Entries under ``root`` that nightloc did not write (relative POSIX paths; a foreign
        folder is one entry, not descended into)."""
        found: list[str] = []

        def visit(folder: Path, base: str) -> None:
            for entry in sorted(os.scandir(folder), key=lambda e: e.name):
                relative = f"{base}{entry.name}"
                if relative == MANIFEST_NAME:
                    continue
                if relative in self.folders and entry.is_dir(follow_symlinks=False):
                    visit(Path(entry.path), relative + "/")
                elif relative not in self.files:
                    found.append(relative)

        if root.is_dir():
            visit(root, "")
        return found


def _read_previous(target: Path, user: Path, overwrite: bool, overwrite_hint: str) -> _Previous:
    if not target.exists():
        return _Previous()
    if not target.is_dir():
        raise NotADirectoryError(f"{user} exists and is a file, not a folder")
    manifest = target / MANIFEST_NAME
    if not manifest.exists():
        entries = sorted(os.listdir(target))
        if not entries:
            return _Previous()
        listing = ", ".join(entries[:3]) + (", ..." if len(entries) > 3 else "")
        raise FileExistsError(
            f"{user} already holds files that nightloc did not write ({listing}); nightloc replaces its output "
            f"folders whole, so choose a new or an empty folder"
        )
    try:
        content = json.loads(manifest.read_text(encoding="utf-8"))
        if not isinstance(content, dict) or content.get("format") != _MANIFEST_FORMAT:
            raise ValueError("not a manifest")
        files, folders = content["files"], content["folders"]
        if not all(isinstance(item, str) for item in [*files, *folders]):
            raise ValueError("not a manifest")
        previous = _Previous(files, folders, str(content.get("command", "")))
    except (OSError, ValueError, KeyError, TypeError):
        raise FileExistsError(
            f"{user}: its record of nightloc's files ({MANIFEST_NAME}) is damaged, so nightloc cannot tell its "
            f"files from yours; move your files out and delete the folder, or choose another"
        ) from None
    if not overwrite and (previous.files or previous.folders or previous.foreign(target)):
        what = f"the output of nightloc {previous.command}" if previous.command else "nightloc's output"
        raise with_cli_words(
            FileExistsError(f"{user} exists and holds {what}; pass {overwrite_hint} to replace it"),
            f"{user} exists and holds {what}; pass --overwrite to replace it",
        )
    return previous


def _link_entry(source: Path, destination: Path) -> None:
    """Puts ``source`` (a user's entry) at ``destination`` without copying data where possible:
    hard links for files, a new link for a symbolic link, folders recreated around them."""
    if source.is_symlink():
        os.symlink(os.readlink(source), destination)
    elif source.is_dir():
        os.mkdir(destination)
        shutil.copymode(source, destination)
        for entry in os.scandir(source):
            _link_entry(Path(entry.path), destination / entry.name)
    else:
        try:
            os.link(source, destination, follow_symlinks=False)
        except OSError:
            if not stat.S_ISREG(os.lstat(source).st_mode):
                raise
            shutil.copy2(source, destination)  # a file system without hard links


class OutputSet:
    """A result set being built: write into :attr:`path`; see :func:`output_set`.

    Attributes:
        path: the hidden staging folder the command writes its files into.
        target: where the set appears on success (symbolic links resolved).
        destination: the output path as the caller gave it (for messages).
        command: the name recorded in the manifest (e.g. ``"evaluate"``).
    """

    def __init__(self, path: Path, target: Path, destination: Path, command: str, previous: _Previous):
        self.path = path
        self.target = target
        self.destination = destination
        self.command = command
        self._previous = previous

    def __truediv__(self, name: str) -> Path:
        return self.path / name

    def __repr__(self) -> str:
        return f"OutputSet({str(self.destination)!r}, command={self.command!r})"

    def _commit(self) -> None:
        from .._core import __version__

        files, folders = _walk(self.path)
        made = set(files) | set(folders)
        foreign = self._previous.foreign(self.target)
        for relative in foreign:
            if relative in made or any(_inside(Path(relative), Path(f)) for f in files):
                raise FileExistsError(
                    f"{self.destination / relative} was not written by nightloc, and this run writes that name; "
                    f"move it away and run again"
                )
        carried = set(foreign)
        for relative in foreign:
            destination = self.path / relative
            for parent in reversed(Path(relative).parents[:-1]):  # folders nightloc made before
                if not (self.path / parent).exists():
                    os.mkdir(self.path / parent)
                    folders.append(parent.as_posix())
            _link_entry(self.target / relative, destination)
        manifest = {
            "format": _MANIFEST_FORMAT,
            "format_version": 1,
            "command": self.command,
            "nightloc_version": __version__,
            "files": files,
            "folders": sorted(set(folders)),
        }
        with open(self.path / MANIFEST_NAME, "w", encoding="utf-8") as stream:
            json.dump(manifest, stream, indent=1)
            stream.write("\n")
        _fsync_tree(self.path)
        if self.target.is_dir():
            shutil.copymode(self.target, self.path)
        previous_folder = replace_folder(self.path, self.target, keep_previous=True)
        if previous_folder is None:
            return
        # A user's file added while the set was swapped in is in the previous folder: move it over.
        for relative in self._previous.foreign(previous_folder):
            if relative not in carried and not os.path.lexists(self.target / relative):
                with contextlib.suppress(OSError):
                    os.makedirs((self.target / relative).parent, exist_ok=True)
                    os.rename(previous_folder / relative, self.target / relative)
        shutil.rmtree(previous_folder, ignore_errors=True)


@contextlib.contextmanager
def output_set(
    path: PathLike,
    *,
    command: str,
    overwrite: bool = True,
    inputs: Iterable[PathLike | None] = (),
    overwrite_hint: str = "--overwrite",
    wait: float | None = 0.0,
    parents: bool = False,
) -> Iterator[OutputSet]:
    """Context manager: a command's output folder, written as one set (see the module docstring).

    Enter it before the work (it checks and locks the output at once); write the files into
    ``result.path``; on a normal exit the folder appears whole at ``path``, with any entries of
    the previous folder that nightloc did not write kept. On an exception (or Ctrl-C) nothing
    at ``path`` changes.

    Args:
        path: the output folder (its parent must exist, unless ``parents``).
        command: recorded in the manifest and named in messages, e.g. ``"evaluate"``.
        overwrite: replace an earlier set at ``path`` (results: True; user data such as a
            dataset: False unless asked, ``overwrite_hint`` naming how).
        inputs: the command's input paths; an output equal to, inside or containing one is
            refused (ValueError).
        wait: seconds to wait for another run writing ``path`` (0: refuse at once with
            BlockingIOError; None: wait as long as it takes).
        parents: create the missing parent folders of ``path`` (a command's ``--out``); those
            made are removed again when the set is not written.

    Raises:
        FileNotFoundError: the parent folder is missing (and not ``parents``).
        NotADirectoryError: ``path`` (or one of its parents) is a file.
        FileExistsError: ``path`` holds files nightloc did not write (and no manifest), or an
        earlier set with ``overwrite=False``, or a user's file where this run writes one (at the
        end; the previous set stays). ValueError: overlap with an input, ``path`` is the
        current folder, or a symbolic link loop. BlockingIOError: another run holds the lock.
    """
    user = Path(path)
    target = _resolve(user)
    if target.exists() and not target.is_dir():
        raise NotADirectoryError(f"{user} exists and is a file, not a folder")
    refuse_overlap(user, inputs, folder=True)
    cwd = Path(os.path.realpath(os.getcwd()))
    if target == cwd or _inside(cwd, target):
        raise ValueError(
            f"the output folder {user} is (or contains) the current folder, which replacing it would pull "
            f"from under you; choose a sub-folder"
        )
    with parent_folders(user) if parents else contextlib.nullcontext(user), locked_target(user, wait=wait):
        previous = _read_previous(target, user, overwrite, overwrite_hint)
        staging = staging_folder(target)
        try:
            result = OutputSet(staging, target, user, command, previous)
            yield result
            result._commit()
        except BaseException:
            shutil.rmtree(staging, ignore_errors=True)
            raise
