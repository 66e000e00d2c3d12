"""Only regular files are read: a named pipe, a socket, a device, a symbolic link loop or a
folder where a file is expected gets a clear DatasetError / MapFormatError / NightlocError naming
what it is, at once.

Old behaviour: ``ReferenceMap.load`` on a FIFO and ``--params`` naming a FIFO blocked forever;
``/dev/zero`` as a parameter file or an image was read until memory ran out; a symbolic link
loop or a FIFO was reported as "does not exist". Every call here runs under an alarm, so the old
hang fails the test instead of hanging it. (Two rows of the matrix held before -- a folder given
as a map or as the poses file -- and stay as its complete rows; a link to a regular file is the
control: links are followed.)
"""

from __future__ import annotations

import contextlib
import os
import signal
import socket
import stat

import pytest

import nightloc
from nightloc import DatasetError, MapFormatError, NightlocError
from nightloc.cli import main
from nightloc.io.odometry_csv import read_odometry_rows

from reliability_support import Workspace

pytestmark = pytest.mark.skipif(not hasattr(os, "mkfifo") or not hasattr(signal, "SIGALRM"), reason="needs POSIX")

SECONDS = 10


@contextlib.contextmanager
def no_hang(seconds: int = SECONDS):
    """Fails with TimeoutError when the body blocks longer than ``seconds`` (SIGALRM interrupts
    a blocking open or read)."""

    def alarm(signum, frame):
        raise TimeoutError(f"blocked for more than {seconds} s")

    previous = signal.signal(signal.SIGALRM, alarm)
    signal.alarm(seconds)
    try:
        yield
    finally:
        signal.alarm(0)
        signal.signal(signal.SIGALRM, previous)


@pytest.fixture(scope="module")
def ws(tmp_path_factory):
    workspace = Workspace(tmp_path_factory.mktemp("special"))
    yield workspace
    for server in getattr(workspace, "sockets", []):
        server.close()


def _special(ws, kind: str, name: str):
    """A path named ``name`` in a fresh folder that is a ``kind`` of non-regular file."""
    folder = ws.fresh("special")
    folder.mkdir()
    path = folder / name
    if kind == "fifo":
        os.mkfifo(path)
    elif kind == "socket":
        server = socket.socket(socket.AF_UNIX, socket.SOCK_STREAM)
        server.bind(str(path))
        ws.sockets = [*getattr(ws, "sockets", []), server]  # kept open for the module
    elif kind == "device":
        os.symlink("/dev/zero", path)  # an endless character device
    elif kind == "link loop":
        os.symlink(path.name, path)
    elif kind == "folder":
        path.mkdir()
    elif kind == "dangling link":
        os.symlink(folder / "gone", path)
    return path


KINDS = {
    "fifo": "named pipe",
    "socket": "socket",
    "device": "character device",
    "link loop": "symbolic link loop",
    "folder": "folder",
}


def _traverse_with(ws, kind: str):
    """A copy of the good traverse whose first image (named in poses.csv) is a ``kind``."""
    root = ws.traverse_variant()
    first = root / "images" / ws.names[0]
    first.unlink()
    if kind == "socket":
        server = socket.socket(socket.AF_UNIX, socket.SOCK_STREAM)
        server.bind(str(first))
        ws.sockets = [*getattr(ws, "sockets", []), server]
    elif kind == "fifo":
        os.mkfifo(first)
    elif kind == "device":
        os.symlink("/dev/zero", first)
    elif kind == "link loop":
        os.symlink(first.name, first)
    else:
        first.mkdir()
    return root


def _listing_with(ws, kind: str):
    """A folder of images (no poses.csv, listed by name) holding one ``kind`` named like a frame."""
    root = ws.traverse_variant(remove=["poses.csv"])
    first = root / "images" / "999.png"
    if kind == "fifo":
        os.mkfifo(first)
    elif kind == "device":
        os.symlink("/dev/zero", first)
    elif kind == "link loop":
        os.symlink(first.name, first)
    elif kind == "socket":
        server = socket.socket(socket.AF_UNIX, socket.SOCK_STREAM)
        server.bind(str(first))
        ws.sockets = [*getattr(ws, "sockets", []), server]
    return root


READERS = [
    ("ReferenceMap.load", lambda ws, k: nightloc.ReferenceMap.load(_special(ws, k, "m.map")), MapFormatError),
    ("load_params", lambda ws, k: nightloc.load_params(_special(ws, k, "p.toml")), NightlocError),
    ("load_traverse root", lambda ws, k: nightloc.load_traverse(_special(ws, k, "t.mp4")), DatasetError),
    (
        "poses file",
        lambda ws, k: nightloc.load_traverse(ws.traverse.root, poses=_special(ws, k, "poses.csv")),
        DatasetError,
    ),
    (
        "odometry file",
        lambda ws, k: read_odometry_rows(_special(ws, k, "odometry.csv")),
        DatasetError,
    ),
    ("image named in poses.csv", lambda ws, k: nightloc.load_traverse(_traverse_with(ws, k)), DatasetError),
    ("image in a listed folder", lambda ws, k: nightloc.load_traverse(_listing_with(ws, k)), DatasetError),
]
CASES = [
    (reader, kind)
    for reader in READERS
    for kind in KINDS
    if not (kind == "folder" and reader[0] in ("load_traverse root", "image in a listed folder"))
]


@pytest.mark.parametrize("case", CASES, ids=[f"{r[0]}, {k}" for r, k in CASES])
def test_non_regular_files_are_named_at_once(ws, case):
    (_, call, error), kind = case
    with no_hang(), pytest.raises(error) as info:
        call(ws, kind)
    message = str(info.value)
    assert KINDS[kind] in message, message
    assert "\n" not in message


def test_a_dangling_link_says_so(ws):
    with no_hang(), pytest.raises(MapFormatError, match="symbolic link to a file that does not exist"):
        nightloc.ReferenceMap.load(_special(ws, "dangling link", "m.map"))


def test_cli_params_naming_a_fifo_fails_at_once(ws, capsys):
    fifo = _special(ws, "fifo", "params.toml")
    with no_hang():
        status = main(["build-map", str(ws.traverse.root), str(ws.fresh("m")) + ".map", "--params", str(fifo)])
    assert status == 2
    assert "named pipe (FIFO)" in capsys.readouterr().err


@pytest.mark.parametrize("command", [["localize", "--odometry", "none"], ["evaluate"]])
def test_cli_map_naming_a_fifo_is_named_at_once(ws, capsys, command):
    """The map argument of localize (as evaluate's) names a FIFO instead of calling it missing."""
    fifo = _special(ws, "fifo", "m.map")
    with no_hang():
        status = main([command[0], str(fifo), str(ws.traverse.root), "--out", str(ws.fresh("out")), *command[1:]])
    assert status == 2
    err = capsys.readouterr().err
    assert "named pipe (FIFO)" in err and "does not exist" not in err


def test_a_symbolic_link_to_a_regular_file_is_read(ws):
    link = ws.fresh("link").with_suffix(".map")
    os.symlink(ws.map_file, link)
    assert nightloc.ReferenceMap.load(link) == ws.map
    assert stat.S_ISLNK(os.lstat(link).st_mode)
