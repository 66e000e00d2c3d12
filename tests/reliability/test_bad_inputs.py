"""The bad-input matrix: every public entry point, fed hostile input, raises the documented
exception with a message that names the problem, never a crash, a hang or a silent result.

Each row of ``REJECTED`` is (id, call, exception type, words the message must contain). The
exception types are the ones docs/reliability.md documents:

* ``TypeError``: wrong type or dtype (a float image, a list where an array is needed);
* ``ValueError``: wrong rank, size, range or value (empty stacks, NaN, too many threads);
* ``nightloc.DatasetError`` (a ValueError): a traverse on disk is missing, unreadable, malformed;
* ``nightloc.MapFormatError`` (a ValueError): a map file is corrupt, foreign, of another version
  or of other parameters;
* ``nightloc.NightlocError`` (a ValueError): a parameter file is unreadable or wrong;
* ``OSError`` subclasses for paths: FileNotFoundError, FileExistsError, IsADirectoryError,
  NotADirectoryError (a file where a folder is needed), PermissionError.

``ACCEPTED`` holds the hostile-looking inputs that are valid (read-only and non-contiguous
frames, one-element inputs, BOMs and CRLF line ends, extra CSV columns): they must give the same
result as the plain input.
"""

from __future__ import annotations

import os

import cv2
import numpy as np
import pytest

import nightloc
from nightloc import DatasetError, MapFormatError, NightlocError, route, synth
from nightloc.localization import evaluation

from reliability_support import Workspace

# Run under AddressSanitizer + UBSan in CI (.ci/run: -m sanitize): these tests drive the core hard.
pytestmark = pytest.mark.sanitize

IMG = np.zeros((24, 48), np.uint8)
STACK = np.random.default_rng(0).integers(0, 256, (5, 24, 48), dtype=np.uint8)
RAMP = np.arange(24 * 48, dtype=np.uint8).reshape(24, 48)
FRAME = np.random.default_rng(1).integers(0, 256, (40, 80, 3), dtype=np.uint8)
F32 = np.float32


@pytest.fixture(scope="module")
def ws(tmp_path_factory):
    return Workspace(tmp_path_factory.mktemp("reliability"))


def _png(ws):
    return (ws.traverse.root / "images" / ws.names[0]).read_bytes()


def _jpeg_half(ws):
    _, data = cv2.imencode(".jpg", ws.frames[0])
    return data.tobytes()[: data.size // 2]


def _read_frame(root, index=2):
    return nightloc.load_traverse(root).read(index)


def _huge_stack():
    return np.zeros((1 << 31, 1, 1), np.uint8)  # 2 GiB of virtual zero pages; never touched


# --------------------------------------------------------------------------------------------
# (id, call(ws), exception, words)

CORE = [
    ("match float query", lambda ws: nightloc.match(IMG.astype(np.float64), STACK), TypeError, "uint8"),
    ("match int16 refs", lambda ws: nightloc.match(IMG, STACK.astype(np.int16)), TypeError, "uint8"),
    ("match bool refs", lambda ws: nightloc.match(IMG, STACK.astype(bool)), TypeError, "uint8"),
    ("match list query", lambda ws: nightloc.match(IMG.tolist(), STACK), TypeError, "ndarray"),
    ("match None query", lambda ws: nightloc.match(None, STACK), TypeError, "ndarray"),
    ("match numpy scalar", lambda ws: nightloc.match(np.uint8(3), STACK), TypeError, "ndarray"),
    ("match rank 3 query", lambda ws: nightloc.match(STACK, STACK), ValueError, "2-D"),
    ("match rank 2 refs", lambda ws: nightloc.match(IMG, IMG), ValueError, "newaxis"),
    ("match rank 4 refs", lambda ws: nightloc.match(IMG, STACK[None]), ValueError, "3-D"),
    ("match empty refs", lambda ws: nightloc.match(IMG, STACK[:0]), ValueError, "empty"),
    ("match zero-width query", lambda ws: nightloc.match(IMG[:, :0], STACK), ValueError, "empty"),
    ("match size mismatch", lambda ws: nightloc.match(IMG[:, :40].copy(), STACK), ValueError, "24x40"),
    ("match non-contiguous", lambda ws: nightloc.match(IMG[:, ::2], STACK[:, :, ::2]), ValueError, "contiguous"),
    ("match Fortran order", lambda ws: nightloc.match(np.asfortranarray(RAMP), STACK), ValueError, "contiguous"),
    ("match shift out of range", lambda ws: nightloc.match(IMG, STACK, shifts=[48]), ValueError, "[0, 48)"),
    ("match shift 2**40", lambda ws: nightloc.match(IMG, STACK, shifts=[2**40]), ValueError, "[0, 48)"),
    ("match float shifts", lambda ws: nightloc.match(IMG, STACK, shifts=[0.5]), TypeError, "integers"),
    ("match string shifts", lambda ws: nightloc.match(IMG, STACK, shifts="0"), TypeError, "integers"),
    ("match 2-D shifts", lambda ws: nightloc.match(IMG, STACK, shifts=[[0]]), ValueError, "1-D"),
    ("match empty shifts", lambda ws: nightloc.match(IMG, STACK, shifts=[]), ValueError, "non-empty"),
    ("match threads 0", lambda ws: nightloc.match(IMG, STACK, threads=0), ValueError, "threads"),
    ("match threads 2**40", lambda ws: nightloc.match(IMG, STACK, threads=2**40), ValueError, "threads"),
    ("match threads float", lambda ws: nightloc.match(IMG, STACK, threads=1.5), TypeError, "threads"),
    ("match threads str", lambda ws: nightloc.match(IMG, STACK, threads="2"), TypeError, "threads"),
    ("match threads bool", lambda ws: nightloc.match(IMG, STACK, threads=True), TypeError, "threads"),
    (
        "match huge image",
        lambda ws: nightloc.match(np.zeros((1, 1 << 25), np.uint8), np.zeros((1, 1, 1 << 25), np.uint8)),
        ValueError,
        "too large",
    ),
    ("difference_matrix rank 2", lambda ws: nightloc.difference_matrix(IMG, STACK), ValueError, "3-D"),
    ("difference_matrix empty queries", lambda ws: nightloc.difference_matrix(STACK[:0], STACK), ValueError, "empty"),
    ("difference_matrix float32", lambda ws: nightloc.difference_matrix(STACK.astype(F32), STACK), TypeError, "uint8"),
    (
        "difference_matrix output too big",
        lambda ws: nightloc.difference_matrix(_huge_stack(), _huge_stack()),
        ValueError,
        "too big",
    ),
    (
        "rotational_sad size mismatch",
        lambda ws: nightloc.rotational_sad(IMG, STACK[:, :, :47].copy()),
        ValueError,
        "24x47",
    ),
    ("rotational_sad threads 0", lambda ws: nightloc.rotational_sad(IMG, STACK, threads=0), ValueError, "threads"),
    ("patch_normalize float", lambda ws: nightloc.patch_normalize(IMG.astype(F32)), TypeError, "uint8"),
    ("patch_normalize rank 4", lambda ws: nightloc.patch_normalize(STACK[None]), ValueError, "3-D"),
    ("patch_normalize radius -1", lambda ws: nightloc.patch_normalize(IMG, radius=-1), ValueError, "radius"),
    ("patch_normalize radius 10**9", lambda ws: nightloc.patch_normalize(IMG, radius=10**9), ValueError, "radius"),
    ("patch_normalize radius float", lambda ws: nightloc.patch_normalize(IMG, radius=1.5), ValueError, "radius"),
    ("patch_normalize scale NaN", lambda ws: nightloc.patch_normalize(IMG, scale=float("nan")), ValueError, "scale"),
    ("patch_normalize scale inf", lambda ws: nightloc.patch_normalize(IMG, scale=float("inf")), ValueError, "scale"),
    ("patch_normalize scale str", lambda ws: nightloc.patch_normalize(IMG, scale="24"), TypeError, "scale"),
    ("patch_normalize non-contiguous", lambda ws: nightloc.patch_normalize(STACK[:, ::2]), ValueError, "contiguous"),
    ("block_normalize side 1", lambda ws: nightloc.block_normalize(IMG, side=1), ValueError, "side"),
    ("block_normalize side 2**40", lambda ws: nightloc.block_normalize(IMG, side=2**40), ValueError, "side"),
    ("block_normalize int8", lambda ws: nightloc.block_normalize(IMG.astype(np.int8)), TypeError, "uint8"),
    ("shifts_to_headings width 0", lambda ws: nightloc.shifts_to_headings([1], 0), ValueError, "width"),
    ("set_simd_backend unknown", lambda ws: nightloc.set_simd_backend("altivec"), ValueError, "unknown"),
]

PREPARATION = [
    ("prepare float frame", lambda ws: nightloc.prepare(FRAME.astype(F32)), TypeError, "uint8 or uint16"),
    ("prepare bool frame", lambda ws: nightloc.prepare(FRAME.astype(bool)), TypeError, "dtype bool"),
    ("prepare int8 frame", lambda ws: nightloc.prepare(FRAME.astype(np.int8)), TypeError, "dtype int8"),
    ("prepare nested list", lambda ws: nightloc.prepare(FRAME.tolist()), TypeError, "numpy.ndarray"),
    ("prepare empty list", lambda ws: nightloc.prepare([]), ValueError, "empty"),
    ("prepare empty stack", lambda ws: nightloc.prepare(np.zeros((0, 40, 80), np.uint8)), ValueError, "empty"),
    ("prepare zero-size frame", lambda ws: nightloc.prepare(np.zeros((0, 80, 3), np.uint8)), ValueError, "empty"),
    ("prepare rank 5", lambda ws: nightloc.prepare(np.zeros((1, 2, 3, 4, 5), np.uint8)), ValueError, "(N, H, W)"),
    ("prepare None in a generator", lambda ws: nightloc.prepare(f for f in [FRAME, None]), TypeError, "images[1]"),
    ("prepare a path string", lambda ws: nightloc.prepare("frames/0001.png"), TypeError, "load_traverse"),
    ("prepare params dict", lambda ws: nightloc.prepare(FRAME, params={"width": 48}), TypeError, "PreparationParams"),
    (
        "prepare crop removes frame",
        lambda ws: nightloc.prepare(FRAME, nightloc.PreparationParams(crop=(20, 20, 0, 0))),
        ValueError,
        "removes the whole",
    ),
    ("Preparer params str", lambda ws: nightloc.Preparer("paper"), TypeError, "PreparationParams"),
    ("params width 0", lambda ws: nightloc.PreparationParams(width=0), ValueError, "width"),
    ("params width float", lambda ws: nightloc.PreparationParams(width=48.0), TypeError, "width must be int"),
    ("params huge size", lambda ws: nightloc.PreparationParams(width=100000, height=100000), ValueError, "too large"),
    ("params radius 10**9", lambda ws: nightloc.PreparationParams(radius=10**9), ValueError, "radius"),
    ("params scale NaN", lambda ws: nightloc.PreparationParams(scale=float("nan")), ValueError, "scale"),
    ("params crop length", lambda ws: nightloc.PreparationParams(crop=(0, 0)), TypeError, "crop"),
    (
        "params crop fraction 1",
        lambda ws: nightloc.PreparationParams(crop=(0.5, 0.5, 0, 0)),
        ValueError,
        "whole height",
    ),
    ("params equalize unknown", lambda ws: nightloc.PreparationParams(equalize="auto"), TypeError, "equalize"),
]

PARAMS_FILES = [
    ("load_params missing", lambda ws: nightloc.load_params(ws.root / "missing.toml"), NightlocError, "does not exist"),
    ("load_params folder", lambda ws: nightloc.load_params(ws.root), NightlocError, "is a folder"),
    (
        "load_params binary",
        lambda ws: nightloc.load_params(ws.write("b.toml", b"\x89PNG\x00\xff")),
        NightlocError,
        "UTF-8",
    ),
    (
        "load_params truncated",
        lambda ws: nightloc.load_params(ws.write("t.toml", "[preparation]\nwidth = ")),
        NightlocError,
        "not valid TOML",
    ),
    (
        "load_params duplicate key",
        lambda ws: nightloc.load_params(ws.write("d.toml", "[preparation]\nwidth = 1\nwidth = 2\n")),
        NightlocError,
        "not valid TOML",
    ),
    (
        "load_params NaN",
        lambda ws: nightloc.load_params(ws.write("n.toml", "[preparation]\nscale = nan\n")),
        NightlocError,
        "scale",
    ),
    (
        "load_params unknown key",
        lambda ws: nightloc.load_params(ws.write("k.toml", "[preparation]\nwidht = 32\n")),
        NightlocError,
        "unknown key 'widht'",
    ),
    (
        "load_params unknown table",
        lambda ws: nightloc.load_params(ws.write("u.toml", "[prep]\nwidth = 32\n")),
        NightlocError,
        "unknown table [prep]",
    ),
    (
        "load_params key outside table",
        lambda ws: nightloc.load_params(ws.write("o.toml", "width = 32\n")),
        NightlocError,
        "outside any table",
    ),
    (
        "load_params wrong type",
        lambda ws: nightloc.load_params(ws.write("w.toml", '[preparation]\nwidth = "32"\n')),
        NightlocError,
        "width must be int",
    ),
    (
        "load_params huge int",
        lambda ws: nightloc.load_params(ws.write("h.toml", "[preparation]\nwidth = 99999999999999999999\n")),
        NightlocError,
        "too large",
    ),
    (
        "save_params under a file",
        lambda ws: nightloc.save_params(ws.text_file / "p.toml", nightloc.PreparationParams()),
        NotADirectoryError,
        "is a file",
    ),
    (
        "save_params to a folder",
        lambda ws: nightloc.save_params(ws.root, nightloc.PreparationParams()),
        IsADirectoryError,
        "folder",
    ),
    (
        "save_params a dict",
        lambda ws: nightloc.save_params(ws.fresh("p.toml"), {"width": 3}),
        TypeError,
        "not a parameter class",
    ),
]


def _csv(ws, header="image,x,y,heading", edit=None):
    text = ws.pose_rows(header)
    return edit(text) if edit else text


TRAVERSES = [
    ("traverse missing folder", lambda ws: nightloc.load_traverse(ws.root / "nope"), DatasetError, "does not exist"),
    (
        "traverse is an image file",
        lambda ws: nightloc.load_traverse(ws.traverse.root / "images" / ws.names[0]),
        DatasetError,
        "single file",
    ),
    (
        "traverse is a text file",
        lambda ws: nightloc.load_traverse(ws.text_file),
        DatasetError,
        "is a text file, not a traverse",
    ),
    (
        "traverse zero-byte video",
        lambda ws: nightloc.load_traverse(ws.write("v.mp4", b"")),
        DatasetError,
        "cannot be opened",
    ),
    (
        "traverse without images",
        lambda ws: nightloc.load_traverse(ws.traverse_variant(remove=["images"])),
        DatasetError,
        "no 'images/' folder",
    ),
    (
        "poses missing column",
        lambda ws: nightloc.load_traverse(
            ws.traverse_variant("image,x,heading\n" + "".join(f"{n},1,2\n" for n in ws.names))
        ),
        DatasetError,
        "missing column 'y'",
    ),
    (
        "poses extra field in a row",
        lambda ws: nightloc.load_traverse(ws.traverse_variant(_csv(ws) + f"{ws.names[0]}x,1,2,3,4\n")),
        DatasetError,
        "5 fields",
    ),
    (
        "poses non-numeric",
        lambda ws: nightloc.load_traverse(
            ws.traverse_variant("image,x,y\n" + "".join(f"{n},1.5,north\n" for n in ws.names))
        ),
        DatasetError,
        "'north', which is not a number",
    ),
    (
        "poses NaN",
        lambda ws: nightloc.load_traverse(
            ws.traverse_variant("image,x,y\n" + "".join(f"{n},nan,0\n" for n in ws.names))
        ),
        DatasetError,
        "finite",
    ),
    (
        "poses inf heading",
        lambda ws: nightloc.load_traverse(
            ws.traverse_variant("image,x,y,heading\n" + "".join(f"{n},0,0,inf\n" for n in ws.names))
        ),
        DatasetError,
        "finite",
    ),
    (
        "poses duplicate image",
        lambda ws: nightloc.load_traverse(ws.traverse_variant(_csv(ws) + f"{ws.names[0]},1,2,3\n")),
        DatasetError,
        "listed twice",
    ),
    (
        "poses duplicate column",
        lambda ws: nightloc.load_traverse(
            ws.traverse_variant("image,x,y,x\n" + "".join(f"{n},1,2,3\n" for n in ws.names))
        ),
        DatasetError,
        "appears twice",
    ),
    ("poses zero bytes", lambda ws: nightloc.load_traverse(ws.traverse_variant(b"")), DatasetError, "is empty"),
    (
        "poses header only",
        lambda ws: nightloc.load_traverse(ws.traverse_variant("image,x,y\n")),
        DatasetError,
        "no rows",
    ),
    (
        "poses binary",
        lambda ws: nightloc.load_traverse(ws.traverse_variant(b"\x00\xff\xfe\x89PNG")),
        DatasetError,
        "UTF-8",
    ),
    (
        "poses Latin-1",
        lambda ws: nightloc.load_traverse(ws.traverse_variant(_csv(ws).encode() + b"caf\xe9.png,1,2,3\n")),
        DatasetError,
        "UTF-8",
    ),
    (
        "poses names a missing image",
        lambda ws: nightloc.load_traverse(ws.traverse_variant(remove=["images/" + ws.names[1]])),
        DatasetError,
        "does not exist",
    ),
    (
        "poses path outside",
        lambda ws: nightloc.load_traverse(ws.traverse_variant("image,x,y\n../poses.csv,1,2\n")),
        DatasetError,
        "inside",
    ),
    (
        "poses file missing",
        lambda ws: nightloc.load_traverse(ws.traverse.root, poses=ws.root / "nope.csv"),
        DatasetError,
        "does not exist",
    ),
    (
        "poses file is a folder",
        lambda ws: nightloc.load_traverse(ws.traverse.root, poses=ws.root),
        DatasetError,
        "folder",
    ),
    ("frame_step 0", lambda ws: nightloc.load_traverse(ws.traverse.root, frame_step=0), ValueError, "frame_step"),
    (
        "zero-byte image",
        lambda ws: _read_frame(ws.traverse_variant(images={"000002.png": b""})),
        DatasetError,
        "0 bytes",
    ),
    (
        "truncated PNG",
        lambda ws: _read_frame(ws.traverse_variant(images={"000002.png": _png(ws)[:100]})),
        DatasetError,
        "OpenCV can decode",
    ),
    (
        "text file named .png",
        lambda ws: _read_frame(ws.traverse_variant(images={"000002.png": b"hello"})),
        DatasetError,
        "OpenCV can decode",
    ),
    (
        "truncated JPEG",
        lambda ws: nightloc.prepare(
            nightloc.load_traverse(
                ws.traverse_variant("image,x,y\nhalf.jpg,0,0\n", images={"half.jpg": _jpeg_half(ws)})
            )
        ),
        DatasetError,
        "half.jpg",
    ),
    (
        "prepare a traverse with a bad image",
        lambda ws: nightloc.prepare(nightloc.load_traverse(ws.traverse_variant(images={"000004.png": b"GIF89a"}))),
        DatasetError,
        "000004.png",
    ),
    ("read index past the end", lambda ws: ws.traverse.read(99), IndexError, "out of range"),
    ("read index str", lambda ws: ws.traverse.read("0"), TypeError, "int"),
    ("frames batch 0", lambda ws: list(ws.traverse.frames(batch_size=0)), ValueError, "batch_size"),
    ("save_traverse no images", lambda ws: nightloc.save_traverse(ws.fresh(), []), ValueError, "empty"),
    (
        "save_traverse NaN positions",
        lambda ws: nightloc.save_traverse(ws.fresh(), ws.frames, np.full((6, 2), np.nan)),
        ValueError,
        "finite",
    ),
    (
        "save_traverse inf headings",
        lambda ws: nightloc.save_traverse(ws.fresh(), ws.frames, ws.positions, np.full(6, np.inf)),
        ValueError,
        "finite",
    ),
    (
        "save_traverse count mismatch",
        lambda ws: nightloc.save_traverse(ws.fresh(), ws.frames, ws.positions[:3]),
        ValueError,
        "3 positions",
    ),
    (
        "save_traverse float images",
        lambda ws: nightloc.save_traverse(ws.fresh(), [f.astype(float) for f in ws.frames]),
        TypeError,
        "dtype float64",
    ),
    (
        "save_traverse duplicate names",
        lambda ws: nightloc.save_traverse(ws.fresh(), ws.frames[:2], names=["a.png"] * 2),
        ValueError,
        "repeats",
    ),
    (
        "save_traverse unknown format",
        lambda ws: nightloc.save_traverse(ws.fresh(), ws.frames, image_format="xyz"),
        ValueError,
        "image_format",
    ),
    (
        "save_traverse exists",
        lambda ws: nightloc.save_traverse(ws.traverse.root, ws.frames),
        FileExistsError,
        "overwrite",
    ),
    (
        "save_traverse over a file",
        lambda ws: nightloc.save_traverse(ws.text_file, ws.frames, overwrite=True),
        FileExistsError,
        "not a traverse folder",
    ),
    (
        "save_traverse under a file",
        lambda ws: nightloc.save_traverse(ws.text_file / "t", ws.frames),
        NotADirectoryError,
        "is a file",
    ),
]


def _flip(data: bytes, position: int) -> bytes:
    changed = bytearray(data)
    changed[position] ^= 0xFF
    return bytes(changed)


MAPS = [
    ("map missing", lambda ws: nightloc.ReferenceMap.load(ws.root / "nope.map"), FileNotFoundError, "does not exist"),
    ("map is a folder", lambda ws: nightloc.ReferenceMap.load(ws.root), MapFormatError, "folder"),
    ("map zero bytes", lambda ws: nightloc.ReferenceMap.load(ws.write("z.map", b"")), MapFormatError, "empty file"),
    ("map text file", lambda ws: nightloc.ReferenceMap.load(ws.text_file), MapFormatError, "(it is a text file)"),
    ("map is a PNG", lambda ws: nightloc.ReferenceMap.load(ws.write("p.map", _png(ws))), MapFormatError, "not an .npz"),
    (
        "map truncated to 100 bytes",
        lambda ws: nightloc.ReferenceMap.load(ws.write("t.map", ws.map_bytes()[:100])),
        MapFormatError,
        "truncated",
    ),
    (
        "map truncated by half",
        lambda ws: nightloc.ReferenceMap.load(ws.write("h.map", ws.map_bytes()[: len(ws.map_bytes()) // 2])),
        MapFormatError,
        "truncated",
    ),
    (
        "map last byte missing",
        lambda ws: nightloc.ReferenceMap.load(ws.write("l.map", ws.map_bytes()[:-1])),
        MapFormatError,
        "truncated",
    ),
    (
        "map byte flipped in the images",
        lambda ws: nightloc.ReferenceMap.load(ws.write("f.map", _flip(ws.map_bytes(), len(ws.map_bytes()) // 2))),
        MapFormatError,
        "corrupt",
    ),
    (
        "map single numpy array",
        lambda ws: nightloc.ReferenceMap.load(ws.write("a.npy", _npy_bytes())),
        MapFormatError,
        "single numpy array",
    ),
    (
        "map foreign npz",
        lambda ws: nightloc.ReferenceMap.load(ws.write("o.npz", _npz_bytes())),
        MapFormatError,
        "no header",
    ),
    (
        "map newer format version",
        lambda ws: nightloc.ReferenceMap.load(ws.map_variant({"format_version": 5})),
        MapFormatError,
        "upgrade nightloc",
    ),
    (
        "map format version 0",
        lambda ws: nightloc.ReferenceMap.load(ws.map_variant({"format_version": 0})),
        MapFormatError,
        "format_version",
    ),
    (
        "map format version string",
        lambda ws: nightloc.ReferenceMap.load(ws.map_variant({"format_version": "1"})),
        MapFormatError,
        "format_version",
    ),
    (
        "map another format",
        lambda ws: nightloc.ReferenceMap.load(ws.map_variant({"format": "other-map"})),
        MapFormatError,
        "not a nightloc reference map",
    ),
    (
        "map other parameters",
        lambda ws: nightloc.ReferenceMap.load(ws.map_file, nightloc.PreparationParams(radius=3)),
        MapFormatError,
        "radius: map 4, requested 3",
    ),
    (
        "map params not PreparationParams",
        lambda ws: nightloc.ReferenceMap.load(ws.map_file, {"radius": 3}),
        TypeError,
        "PreparationParams",
    ),
    (
        "map header params invalid",
        lambda ws: nightloc.ReferenceMap.load(ws.map_variant({"params": {"width": -1}})),
        MapFormatError,
        "width",
    ),
    (
        "map header lacks names",
        lambda ws: nightloc.ReferenceMap.load(_map_without_key(ws, "names")),
        MapFormatError,
        "lacks 'names'",
    ),
    (
        "map checksum missing",
        lambda ws: nightloc.ReferenceMap.load(ws.map_variant({"checksums": {}})),
        MapFormatError,
        "no checksum",
    ),
    (
        "map checksums not a table",
        lambda ws: nightloc.ReferenceMap.load(ws.map_variant({"checksums": 5})),
        MapFormatError,
        "checksums",
    ),
    (
        "map images replaced",
        lambda ws: nightloc.ReferenceMap.load(ws.map_variant(arrays={"images": np.zeros((6, 24, 48), np.uint8)})),
        MapFormatError,
        "checksum of 'images'",
    ),
    (
        "map headings unverified",
        lambda ws: nightloc.ReferenceMap.load(_map_without_checksum(ws, "headings")),
        MapFormatError,
        "'headings'",
    ),
    (
        "map positions dropped",
        lambda ws: nightloc.ReferenceMap.load(ws.map_variant(drop=["positions"])),
        MapFormatError,
        "lacks its 'positions'",
    ),
    (
        "map count wrong",
        lambda ws: nightloc.ReferenceMap.load(ws.map_variant({"count": 7})),
        MapFormatError,
        "expected",
    ),
    (
        "map count string",
        lambda ws: nightloc.ReferenceMap.load(ws.map_variant({"count": "6"})),
        MapFormatError,
        "count",
    ),
    (
        "map duplicate names",
        lambda ws: nightloc.ReferenceMap.load(ws.map_variant({"names": ["a"] * 6})),
        MapFormatError,
        "repeat",
    ),
    (
        "map header not JSON",
        lambda ws: nightloc.ReferenceMap.load(ws.map_variant(raw_header=b"{nope")),
        MapFormatError,
        "corrupt",
    ),
    (
        "map header a list",
        lambda ws: nightloc.ReferenceMap.load(ws.map_variant(raw_header=b"[1, 2]")),
        MapFormatError,
        "JSON object",
    ),
    (
        "map header not UTF-8",
        lambda ws: nightloc.ReferenceMap.load(ws.map_variant(raw_header=b"\xff\xfe")),
        MapFormatError,
        "utf-8",
    ),
    (
        "map object array",
        lambda ws: nightloc.ReferenceMap.load(ws.map_variant(arrays={"images": np.array([1, None])})),
        MapFormatError,
        "Python objects",
    ),
    ("map save to a folder", lambda ws: ws.map.save(ws.root), IsADirectoryError, "folder"),
    ("map save under a file", lambda ws: ws.map.save(ws.text_file / "m.map"), NotADirectoryError, "is a file"),
    (
        "map build without poses",
        lambda ws: nightloc.ReferenceMap.build(ws.traverse_variant(remove=["poses.csv"])),
        DatasetError,
        "no poses",
    ),
    (
        "ReferenceMap float images",
        lambda ws: nightloc.ReferenceMap(STACK.astype(float), np.zeros((5, 2))),
        TypeError,
        "uint8",
    ),
    (
        "ReferenceMap NaN position",
        lambda ws: nightloc.ReferenceMap(STACK, [[0, 0]] * 4 + [[np.nan, 0]]),
        ValueError,
        "positions[4]",
    ),
    (
        "ReferenceMap inf heading",
        lambda ws: nightloc.ReferenceMap(STACK, np.zeros((5, 2)), [0, 0, np.inf, 0, 0]),
        ValueError,
        "headings[2]",
    ),
    ("ReferenceMap text positions", lambda ws: nightloc.ReferenceMap(STACK, "abc"), ValueError, "positions"),
    ("ReferenceMap positions shape", lambda ws: nightloc.ReferenceMap(STACK, np.zeros((5, 3))), ValueError, "(5, 2)"),
    (
        "ReferenceMap duplicate names",
        lambda ws: nightloc.ReferenceMap(STACK, np.zeros((5, 2)), names=["a"] * 5),
        ValueError,
        "repeat",
    ),
    (
        "ReferenceMap size vs params",
        lambda ws: nightloc.ReferenceMap(STACK[:, :, :40].copy(), np.zeros((5, 2))),
        ValueError,
        "params say 48x24",
    ),
    ("map match a stack", lambda ws: ws.map.match(STACK, prepared=True), ValueError, "one frame"),
    ("map match wrong size", lambda ws: ws.map.match(IMG[:10, :10].copy(), prepared=True), ValueError, "10x10"),
    ("map match float frame", lambda ws: ws.map.match(FRAME.astype(float)), TypeError, "uint8 or uint16"),
]


def _npy_bytes():
    import io

    buffer = io.BytesIO()
    np.save(buffer, STACK)
    return buffer.getvalue()


def _npz_bytes():
    import io

    buffer = io.BytesIO()
    np.savez(buffer, a=STACK)
    return buffer.getvalue()


def _map_without_key(ws, key):
    import json

    with np.load(ws.map_file) as archive:
        header = json.loads(archive["header"].tobytes())
    header.pop(key)
    return ws.map_variant(raw_header=json.dumps(header).encode())


def _map_without_checksum(ws, name):
    """A map whose headings were replaced and whose header no longer lists their checksum."""
    import json

    with np.load(ws.map_file) as archive:
        header = json.loads(archive["header"].tobytes())
    del header["checksums"][name]
    return ws.map_variant(raw_header=json.dumps(header).encode(), arrays={name: np.zeros(6)})


ROUTE_REFS = np.random.default_rng(3).integers(0, 256, (30, 24, 48), dtype=np.uint8)


def _route_localizer():
    return route.RouteLocalizer(ROUTE_REFS, prepared=True)


ROUTE = [
    (
        "RouteLocalizer float refs",
        lambda ws: route.RouteLocalizer(ROUTE_REFS.astype(float), prepared=True),
        TypeError,
        "uint8",
    ),
    ("RouteLocalizer one ref", lambda ws: route.RouteLocalizer(ROUTE_REFS[:1], prepared=True), ValueError, "at least"),
    ("RouteLocalizer empty list", lambda ws: route.RouteLocalizer([]), ValueError, "empty"),
    ("RouteLocalizer missing path", lambda ws: route.RouteLocalizer(ws.root / "nope"), DatasetError, "does not exist"),
    (
        "RouteLocalizer bad params",
        lambda ws: route.RouteLocalizer(ROUTE_REFS, 3, prepared=True),
        TypeError,
        "RouteParams",
    ),
    (
        "RouteLocalizer unknown preset",
        lambda ws: route.RouteLocalizer(ROUTE_REFS, preset="fast", prepared=True),
        ValueError,
        "unknown route preset",
    ),
    (
        "RouteLocalizer threads 0",
        lambda ws: route.RouteLocalizer(ROUTE_REFS, prepared=True, threads=0),
        ValueError,
        "threads",
    ),
    (
        "RouteLocalizer.update float frame",
        lambda ws: _route_localizer().update(ROUTE_REFS[0].astype(float), prepared=True),
        TypeError,
        "uint8",
    ),
    (
        "RouteLocalizer.update wrong size",
        lambda ws: _route_localizer().update(ROUTE_REFS[0, :, :40].copy(), prepared=True),
        ValueError,
        "24x40",
    ),
    (
        "RouteLocalizer.update a stack",
        lambda ws: _route_localizer().update(ROUTE_REFS[:2], prepared=True),
        ValueError,
        "2-D",
    ),
    ("RouteLocalizer.update a string", lambda ws: _route_localizer().update("frame.png"), TypeError, "load_traverse"),
    (
        "RouteLocalizer.update a raw stack",
        lambda ws: _route_localizer().update(np.zeros((3, 40, 80, 3), np.uint8)),
        ValueError,
        "one frame",
    ),
    (
        "evaluate_matches lengths differ",
        lambda ws: route.evaluate_matches(np.zeros(3, np.int64), np.zeros(4), route.GroundTruth.from_frames(3, 3, 1)),
        ValueError,
        "one entry per query",
    ),
    (
        "RouteParams search too large",
        lambda ws: route.RouteParams(ds=100000, vmin=0.001, vmax=1000.0),
        ValueError,
        "too large a search",
    ),
    ("RouteParams ds 1", lambda ws: route.RouteParams(ds=1), ValueError, "ds"),
    ("RouteParams vmin NaN", lambda ws: route.RouteParams(vmin=float("nan")), ValueError, "vmin"),
    ("RouteParams vmin > vmax", lambda ws: route.RouteParams(vmin=2.0, vmax=1.0), ValueError, "vmax must be >= vmin"),
    ("RouteParams ds 10**9", lambda ws: route.RouteParams(ds=10**9), ValueError, "ds"),
    (
        "match_prepared one ref",
        lambda ws: route.match_prepared(ROUTE_REFS[:1], ROUTE_REFS[:5]),
        ValueError,
        "at least 2",
    ),
    ("match_prepared float", lambda ws: route.match_prepared(ROUTE_REFS.astype(F32), ROUTE_REFS), TypeError, "uint8"),
    (
        "match_prepared size mismatch",
        lambda ws: route.match_prepared(ROUTE_REFS, ROUTE_REFS[:, :, :40].copy()),
        ValueError,
        "24x40",
    ),
    (
        "match_prepared non-contiguous",
        lambda ws: route.match_prepared(ROUTE_REFS[::2, ::2], ROUTE_REFS),
        ValueError,
        "contiguous",
    ),
    ("match_route empty", lambda ws: route.match_route([], []), ValueError, "empty"),
    (
        "match_route missing folders",
        lambda ws: route.match_route(ws.root / "a", ws.root / "b"),
        DatasetError,
        "does not exist",
    ),
    ("match_route single images", lambda ws: route.match_route(IMG, IMG), ValueError, "several frames"),
    ("enhance_contrast float64", lambda ws: route.enhance_contrast(np.zeros((3, 5))), TypeError, "float32"),
    ("enhance_contrast one column", lambda ws: route.enhance_contrast(np.zeros((3, 1), F32)), ValueError, "at least 2"),
    (
        "trajectory_search too few refs",
        lambda ws: route.trajectory_search(np.zeros((20, 1), F32)),
        ValueError,
        "too few",
    ),
    ("trajectory_search empty", lambda ws: route.trajectory_search(np.zeros((0, 30), F32)), ValueError, "non-empty"),
    (
        "GroundTruth NaN positions",
        lambda ws: route.GroundTruth.from_positions(np.full((3, 2), np.nan), np.zeros((3, 2)), 3.0),
        ValueError,
        "NaN",
    ),
    (
        "GroundTruth negative tolerance",
        lambda ws: route.GroundTruth.from_positions(np.zeros((3, 2)), np.zeros((3, 2)), -1.0),
        ValueError,
        "tolerance",
    ),
    (
        "evaluate_matches refs out of range",
        lambda ws: route.evaluate_matches(
            np.full(3, 99, np.int64), np.zeros(3), route.GroundTruth.from_frames(3, 3, 1)
        ),
        ValueError,
        "refs must lie",
    ),
]

SYNTH = [
    ("SynthScene unknown world", lambda ws: synth.SynthScene("moon"), ValueError, "unknown world"),
    ("SynthScene negative seed", lambda ws: synth.SynthScene("garden", seed=-1), ValueError, "seed"),
    ("SynthScene NaN darkness", lambda ws: synth.SynthScene("garden", darkness=float("nan")), ValueError, "darkness"),
    ("make_dataset unknown world", lambda ws: synth.make_dataset("moon", ws.fresh()), ValueError, "unknown world"),
]


def _localizer(ws, **params):
    localizer = nightloc.Localizer(ws.map, **params)
    localizer.update(ws.frames[0])
    return localizer


LOCALIZER = [
    ("Localizer map path", lambda ws: nightloc.Localizer(str(ws.map_file)), TypeError, "ReferenceMap"),
    ("Localizer params dict", lambda ws: nightloc.Localizer(ws.map, {"seq_len": 3}), TypeError, "LocalizationParams"),
    ("Localizer unknown parameter", lambda ws: nightloc.Localizer(ws.map, seqlen=3), TypeError, "seqlen"),
    ("Localizer seq_len 0", lambda ws: nightloc.Localizer(ws.map, method="paper", seq_len=0), ValueError, "seq_len"),
    (
        "Localizer seq_len 10**9",
        lambda ws: nightloc.Localizer(ws.map, method="paper", seq_len=10**9),
        ValueError,
        "seq_len",
    ),
    (
        "Localizer huge grid",
        lambda ws: nightloc.Localizer(ws.map, grid_width=10**5, grid_height=10**5),
        ValueError,
        "too large",
    ),
    ("Localizer grid 1 cell", lambda ws: nightloc.Localizer(ws.map, grid_width=1), ValueError, "grid_width"),
    ("Localizer margin NaN", lambda ws: nightloc.Localizer(ws.map, margin=float("nan")), ValueError, "margin"),
    (
        "Localizer threads 0",
        lambda ws: nightloc.Localizer(ws.map, threads=0),
        ValueError,
        "threads",
    ),
    ("Localizer.update float frame", lambda ws: _localizer(ws).update(FRAME.astype(float)), TypeError, "uint8"),
    ("Localizer.update a stack", lambda ws: _localizer(ws).update(STACK), ValueError, "one frame"),
    ("Localizer.update None", lambda ws: _localizer(ws).update(None), TypeError, "numpy array"),
    ("Localizer.update empty frame", lambda ws: _localizer(ws).update(np.zeros((0, 0), np.uint8)), ValueError, "empty"),
    (
        "Localizer.update prepared wrong size",
        lambda ws: _localizer(ws).update(IMG[:, :40].copy(), prepared=True),
        ValueError,
        "24x40",
    ),
    (
        "Localizer odometry NaN",
        lambda ws: _localizer(ws).update(ws.frames[1], (float("nan"), 0.0)),
        ValueError,
        "finite",
    ),
    (
        "Localizer odometry inf",
        lambda ws: _localizer(ws).update(ws.frames[1], (0.0, float("inf"))),
        ValueError,
        "finite",
    ),
    (
        "Localizer odometry triple",
        lambda ws: _localizer(ws).update(ws.frames[1], (1.0, 0.0, 0.1)),
        ValueError,
        "RobotMotion",
    ),
    ("Localizer odometry text", lambda ws: _localizer(ws).update(ws.frames[1], "north"), TypeError, "odometry"),
    (
        "Localizer robot motion NaN",
        lambda ws: _localizer(ws).update(ws.frames[1], nightloc.RobotMotion(float("nan"), 0, 0)),
        ValueError,
        "finite",
    ),
    ("Localizer.update_match text", lambda ws: _localizer(ws).update_match("match"), TypeError, "MatchResult"),
    (
        "Localizer.update_match other map",
        lambda ws: _localizer(ws, method="paper").update_match(nightloc.match(IMG, STACK)),
        ValueError,
        "references",
    ),
    (
        "LocalizationParams file seq_len 0",
        lambda ws: nightloc.load_params(
            ws.write("l.toml", "[localization]\nseq_len = 0\n"), nightloc.LocalizationParams
        ),
        NightlocError,
        "seq_len",
    ),
    (
        "evaluate query without poses",
        lambda ws: evaluation.evaluate(ws.map, ws.traverse_variant(remove=["poses.csv"])),
        DatasetError,
        "no poses",
    ),
    (
        "evaluate map path",
        lambda ws: evaluation.evaluate(str(ws.map_file), ws.traverse.root),
        TypeError,
        "ReferenceMap",
    ),
    (
        "EvaluationSettings seq length 0",
        lambda ws: evaluation.EvaluationSettings(seq_lengths=(0,)),
        ValueError,
        "seq_lengths",
    ),
    ("EvaluationSettings noise model 9", lambda ws: evaluation.EvaluationSettings(noise_models=(9,)), ValueError, "9"),
    ("EvaluationSettings repeats 0", lambda ws: evaluation.EvaluationSettings(repeats=0), ValueError, "repeats"),
    (
        "EvaluationSettings no interpolation",
        lambda ws: evaluation.EvaluationSettings(interpolation=()),
        ValueError,
        "interpolation",
    ),
]

REJECTED = CORE + PREPARATION + PARAMS_FILES + TRAVERSES + MAPS + ROUTE + SYNTH + LOCALIZER


@pytest.mark.parametrize("case", REJECTED, ids=[case[0] for case in REJECTED])
def test_rejected_with_a_clear_message(ws, case):
    _, call, error_type, words = case
    with pytest.raises(error_type) as info:
        call(ws)
    message = str(info.value)
    assert words.lower() in message.lower(), f"{type(info.value).__name__}: {message}"
    assert "\n" not in message, "messages are one line"


def test_case_ids_are_unique():
    ids = [case[0] for case in REJECTED]
    assert len(ids) == len(set(ids))


def test_every_nightloc_error_is_a_value_error():
    for error in (NightlocError, DatasetError, MapFormatError):
        assert issubclass(error, ValueError)


# --------------------------------------------------------------------------------------------
# hostile-looking but valid: same answer as the plain input


def _same(a, b):
    np.testing.assert_array_equal(a, b)


def _read_only(array):
    copy = array.copy()
    copy.setflags(write=False)
    return copy


def _strided(frame):
    """The same pixels in a non-contiguous view (every other column of a wider array)."""
    wide = np.repeat(frame, 2, axis=1)
    return wide[:, ::2]


def _misaligned(stack):
    raw = np.zeros(stack.nbytes + 1, np.uint8)[1:]
    view = raw.reshape(stack.shape)
    view[...] = stack
    return view


def _accept_bom_crlf(ws):
    text = "\ufeff" + ws.pose_rows().replace("\n", "\r\n")
    loaded = nightloc.load_traverse(ws.traverse_variant(text))
    _same(loaded.positions, ws.traverse.positions)
    assert loaded.names == ws.traverse.names


def _accept_extra_columns(ws):
    text = "image,x,y,heading,comment\n" + "".join(
        f"{n},{float(x)!r},{float(y)!r},{float(h)!r},note {i}\n"
        for i, (n, (x, y), h) in enumerate(zip(ws.names, ws.positions, ws.headings))
    )
    loaded = nightloc.load_traverse(ws.traverse_variant(text))
    _same(loaded.positions, ws.traverse.positions)


def _accept_toml_bom_crlf(ws):
    path = ws.write("bom.toml", '\ufeff[preparation]\r\nwidth = 32\r\nequalize = "clahe"\r\n')
    assert nightloc.load_params(path) == nightloc.PreparationParams(width=32, equalize="clahe")


def _accept_one_element(ws):
    result = nightloc.match(np.full((1, 1), 7, np.uint8), np.full((1, 1, 1), 9, np.uint8))
    assert (result.index, result.score, result.shift) == (0, 2.0, 0)
    one = nightloc.ReferenceMap(STACK[:1], [[1.0, 2.0]])
    assert one.match(STACK[0], prepared=True).index == 0
    assert nightloc.prepare(np.full((1, 1), 200, np.uint8)).shape == (24, 48)


def _accept_read_only_and_strided(ws):
    refs = nightloc.patch_normalize(STACK)
    _same(nightloc.match(_read_only(refs[2]), _read_only(refs)).scores, nightloc.match(refs[2], refs).scores)
    _same(
        nightloc.difference_matrix(_misaligned(refs), _misaligned(refs))[0], nightloc.difference_matrix(refs, refs)[0]
    )
    for params in (nightloc.PreparationParams(), nightloc.PreparationParams(equalize="clahe")):
        _same(nightloc.prepare(_strided(FRAME), params), nightloc.prepare(FRAME, params))
        _same(nightloc.prepare(_read_only(FRAME), params), nightloc.prepare(FRAME, params))
        _same(
            nightloc.prepare(FRAME[:, :, ::-1], nightloc.PreparationParams(channel_order="rgb")),
            nightloc.prepare(FRAME),
        )
    _same(ws.map.match(_strided(ws.frames[1])).scores, ws.map.match(ws.frames[1]).scores)


def _accept_empty_params_file(ws):
    assert nightloc.load_params(ws.write("empty.toml", "")) == nightloc.PreparationParams()


ACCEPTED = [
    ("BOM and CRLF poses.csv", _accept_bom_crlf),
    ("extra CSV columns", _accept_extra_columns),
    ("BOM and CRLF parameter file", _accept_toml_bom_crlf),
    ("empty parameter file", _accept_empty_params_file),
    ("one-element inputs", _accept_one_element),
    ("read-only, strided, misaligned arrays", _accept_read_only_and_strided),
]


@pytest.mark.parametrize("case", ACCEPTED, ids=[case[0] for case in ACCEPTED])
def test_hostile_looking_valid_input_is_accepted(ws, case):
    case[1](ws)


@pytest.mark.skipif(not hasattr(os, "geteuid") or os.geteuid() == 0, reason="root ignores file permissions")
def test_unwritable_and_unreadable_paths(ws, tmp_path):
    locked = tmp_path / "locked"
    locked.mkdir()
    locked.chmod(0o500)
    unreadable = ws.write("secret.map", ws.map_bytes())
    unreadable.chmod(0)
    try:
        with pytest.raises(PermissionError):
            ws.map.save(locked / "m.map")
        with pytest.raises(PermissionError):
            nightloc.save_traverse(locked / "t", ws.frames)
        with pytest.raises(PermissionError):
            nightloc.ReferenceMap.load(unreadable)
        assert list(locked.iterdir()) == []
    finally:
        locked.chmod(0o700)
        unreadable.chmod(0o600)


def test_messages_name_the_file(ws):
    """Errors about files say which file (and, for CSVs, which line)."""
    root = ws.traverse_variant(_csv(ws) + f"{ws.names[0]},1,2,3\n")
    with pytest.raises(DatasetError) as info:
        nightloc.load_traverse(root)
    assert str(root / "poses.csv") in str(info.value) and "line 8" in str(info.value)
    bad = ws.write("bad.map", b"PK\x03\x04 broken")
    with pytest.raises(MapFormatError, match=str(bad)):
        nightloc.ReferenceMap.load(bad)
