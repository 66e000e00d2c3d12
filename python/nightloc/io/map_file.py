"""The reference map file: a numpy ``.npz`` archive of arrays and a JSON header, read and written.

File format (version 3): a numpy ``.npz`` archive (zip, no pickled objects) with the arrays
``images`` ``(N, Ry, Rx)`` uint8, ``positions`` ``(N, 2)`` float64, optionally ``headings``
``(N,)`` float64 and ``covariances`` ``(N, 3, 3)`` float64 (each pose's marginal covariance of
``x, y, heading``: m², m·rad, rad²), and ``header``: UTF-8 JSON bytes holding ``format``
("nightloc-reference-map"), ``format_version``, the preparation parameters, the frame names,
the source traverse, ``pose_source`` (where the poses came from: :data:`POSE_SOURCES`), the
nightloc version and a SHA-256 checksum of every array. Version 3 adds the default localizer's
map-only tables (``localizer`` in the header and the ``filter_*`` arrays,
:mod:`nightloc.localization.filter_tables`): what firmware without Python needs to run
``nightloc.Localizer(ref_map)``; their checksums are checked on loading (Python computes its own
tables). Version 2 files (no tables) load unchanged; firmware refuses them until they are saved
again. Version 4 is an experience map (a map that learned from its nights,
:mod:`nightloc.experience.learning`): version 3 plus each reference's provenance
(:mod:`nightloc.io.appearances`: the arrays ``appearance_*`` and the header's ``experience``); a map
that learned nothing is still written as version 3. Version 1 files (before the teach run: no
``pose_source``, no covariances) still load, as surveyed maps. Writing goes to a temporary file in
the same folder, renamed over the target, so an interrupted save never leaves a partial map.

This module knows the file: its archive, header, format version and checksums.
:class:`nightloc.ReferenceMap` (:mod:`nightloc.mapping.reference_map`) is what the arrays and the
header mean: it builds the header and checks its contents.
"""

from __future__ import annotations

import hashlib
import json
import os
import zipfile
import zlib
from pathlib import Path
from typing import Any, Union

import numpy as np

from .. import _core
from .._core import __version__
from .._validate import MAX_MAP_EXPANSION as _MAX_MAP_EXPANSION
from ..errors import MapFormatError
from .atomic import atomic_file
from .files import open_regular
from .kinds import ROS1_BAG, ROS2_STORAGE, path_kind
from .video import VIDEO_SUFFIXES

__all__ = [
    "DAY_MAP_FORMAT_VERSION",
    "MAP_FORMAT",
    "MAP_FORMAT_VERSION",
    "MAX_MAP_EXPANSION",
    "POSE_SOURCES",
    "SETTINGS_CHECKSUM",
    "array_checksum",
    "check_map_version",
    "read_map_file",
    "settings_checksum",
    "write_map_file",
]

#: The ``format`` string in every map file's header.
MAP_FORMAT = "nightloc-reference-map"
#: The newest map format version this nightloc reads and the one it writes (the core's
#: ``kMapFormatVersion``, nightloc/map_file.hpp: the firmware's reader reads the same).
MAP_FORMAT_VERSION: int = _core.MAP_FORMAT_VERSION
#: The version a map without learned nights is written as (what older firmware reads; the core's
#: ``kDayMapFormatVersion``).
DAY_MAP_FORMAT_VERSION: int = _core.DAY_MAP_FORMAT_VERSION
#: Where a map's poses came from: a survey (``poses.csv``), the robot's wheel odometry alone, or
#: the teach run's pose graph (odometry corrected by the images; :mod:`nightloc.mapping`).
POSE_SOURCES = ("surveyed", "dead-reckoned", "optimised")
#: A map file is refused when its arrays declare more than this many times the file's size (plus
#: 1 MiB): a small file that would decompress to gigabytes is refused before anything is read.
#: ``np.savez`` stores arrays uncompressed (1x); ``np.savez_compressed`` maps of prepared images
#: compress about 1.1-2x. (Defined with the other bounds in ``nightloc._validate``.)
MAX_MAP_EXPANSION = _MAX_MAP_EXPANSION

PathLike = Union[str, "os.PathLike[str]"]


#: The key of the header's ``localizer`` table holding :func:`settings_checksum` of the settings
#: the map keeps (its ``localization`` and ``filter`` tables and the core's ``settings``): a damaged
#: byte there is refused by Python, as in an array. Maps written before it lack it (nothing to check).
SETTINGS_CHECKSUM = "settings_checksum"


def settings_checksum(localizer: dict[str, Any], sections: tuple[str, ...]) -> str:
    """The SHA-256 (hex) of the ``sections`` of the header's ``localizer`` table as canonical JSON
    (sorted keys; a missing section as null)."""
    chosen = {name: localizer.get(name) for name in sections}
    return hashlib.sha256(json.dumps(chosen, sort_keys=True).encode("ascii")).hexdigest()


def array_checksum(array: np.ndarray) -> str:
    """The SHA-256 of ``array``'s bytes (C order), as the header's ``checksums`` hold it."""
    return hashlib.sha256(np.ascontiguousarray(array).tobytes()).hexdigest()


def _read_member(file: Path, archive: zipfile.ZipFile, info: zipfile.ZipInfo) -> np.ndarray:
    """One ``.npy`` member, its declared size checked against the member's before reading."""
    with archive.open(info) as member:
        version = np.lib.format.read_magic(member)
        if version == (1, 0):
            shape, fortran, dtype = np.lib.format.read_array_header_1_0(member)
        elif version == (2, 0):
            shape, fortran, dtype = np.lib.format.read_array_header_2_0(member)
        else:
            raise MapFormatError(f"{file}: array {info.filename} has .npy format version {version}, not 1.0 or 2.0")
        if dtype.hasobject:
            raise MapFormatError(f"{file}: array {info.filename} holds Python objects (never in a nightloc map)")
        nbytes = int(np.prod(shape, dtype=np.float64)) * dtype.itemsize
        if nbytes > info.file_size:
            raise MapFormatError(
                f"{file}: array {info.filename} declares shape {shape} ({nbytes} bytes) but its member holds "
                f"{info.file_size} bytes (corrupt file)"
            )
        data = member.read(nbytes)
        if len(data) != nbytes:
            raise MapFormatError(f"{file}: array {info.filename} is truncated ({len(data)} of {nbytes} bytes)")
    return np.frombuffer(data, dtype=dtype).reshape(shape, order="F" if fortran else "C").copy()


def _read_archive(file: Path, stream: Any, size: int) -> tuple[Any, dict[str, np.ndarray]]:
    """The header (parsed JSON) and the arrays of an open map file of ``size`` bytes."""
    with zipfile.ZipFile(stream) as archive:
        infos = {info.filename: info for info in archive.infolist()}
        declared = sum(info.file_size for info in infos.values())
        if declared > MAX_MAP_EXPANSION * size + (1 << 20):
            raise MapFormatError(
                f"{file}: its arrays would take {declared} bytes, more than {MAX_MAP_EXPANSION} times the file's "
                f"{size} bytes (MAX_MAP_EXPANSION); a nightloc map is not compressed that far, so the file is "
                f"damaged or not a map"
            )
        if "header.npy" not in infos:
            raise MapFormatError(f"{file} is an .npz archive but not a nightloc reference map (no header)")
        raw_header = _read_member(file, archive, infos["header.npy"])
        header = json.loads(raw_header.tobytes().decode("utf-8"))
        # every array (the default localizer's tables too: a damaged byte anywhere is refused)
        arrays = {
            name[: -len(".npy")]: _read_member(file, archive, info)
            for name, info in infos.items()
            if name.endswith(".npy") and name != "header.npy"
        }
    return header, arrays


def read_map_file(path: PathLike) -> tuple[Path, Any, dict[str, np.ndarray]]:
    """The path, parsed JSON header and arrays of the map file ``path``.

    Only a regular file is read (a FIFO, a device, a folder or a link loop is refused at once),
    and its arrays are checked against the file's size before any memory is taken: their declared
    sizes may add up to at most :data:`MAX_MAP_EXPANSION` times the file's size.

    Raises:
        FileNotFoundError: no such file.
        PermissionError: the file cannot be read.
        MapFormatError: not a regular file, not an ``.npz`` archive with a header, truncated or
            corrupt, or arrays larger than the file allows.
    """
    file = Path(path)
    if not os.path.lexists(file):
        raise FileNotFoundError(f"reference map {file} does not exist")
    if file.is_dir():
        raise MapFormatError(
            f"{file} is {path_kind(file)}, not a reference map file (build one with nightloc build-map {file} MAP)"
        )
    # An unreadable file raises its own PermissionError; anything but a regular file a MapFormatError.
    with open_regular(file, "reference map", MapFormatError) as stream:
        magic = stream.read(6)
        if magic.startswith(b"\x93NUMPY"):
            raise MapFormatError(f"{file} is a single numpy array, not a nightloc reference map")
        if not magic.startswith(b"PK\x03\x04"):
            kind = path_kind(file)
            if kind in (ROS1_BAG, ROS2_STORAGE) or file.suffix.lower() in VIDEO_SUFFIXES:
                what = f"it is {kind}, a traverse: build a map from it with nightloc build-map {file} MAP"
            elif kind != "a file of another kind":
                what = f"it is {kind}"
            else:
                what = f"not an .npz (zip) archive; it starts with {magic!r}"
            raise MapFormatError(f"{file} is not a nightloc reference map ({what})")
        stream.seek(0)
        try:
            header, arrays = _read_archive(file, stream, os.fstat(stream.fileno()).st_size)
        except MapFormatError:
            raise
        except (OSError, ValueError, EOFError, KeyError, zipfile.BadZipFile, zlib.error) as error:
            raise MapFormatError(
                f"{file} is not a readable nightloc reference map (truncated or corrupt?): {error}"
            ) from None
        except Exception as error:
            # Damaged bytes reach numpy's and zipfile's parsers, which raise many other types: a
            # SyntaxError from an array header (ast.literal_eval), NotImplementedError for zip
            # flag bits, MemoryError for an absurd shape, ...
            raise MapFormatError(
                f"{file} is not a readable nightloc reference map (damaged: {type(error).__name__}: {error})"
            ) from None
    return file, header, arrays


def check_map_version(file: Path, header: Any) -> int:
    """The format version of a map file's parsed ``header``; MapFormatError when it is not a
    nightloc map's header or its version is not one this nightloc reads."""
    if not isinstance(header, dict) or header.get("format") != MAP_FORMAT:
        raise MapFormatError(
            f"{file} is not a nightloc reference map (header format {header.get('format')!r})"
            if isinstance(header, dict)
            else f"{file}: map header is not a JSON object"
        )
    version = header.get("format_version")
    if not isinstance(version, int) or version < 1:
        raise MapFormatError(f"{file}: bad format_version {version!r}")
    if version > MAP_FORMAT_VERSION:
        raise MapFormatError(
            f"{file} has map format version {version}, written by a newer nightloc "
            f"({header.get('nightloc_version')}); this nightloc {__version__} reads version "
            f"{MAP_FORMAT_VERSION}: upgrade nightloc"
        )
    return version


def write_map_file(target: Path, header: dict[str, Any], arrays: dict[str, np.ndarray], *, overwrite: bool) -> None:
    """Writes ``header`` (JSON) and ``arrays`` (in their order, after the header) to the map file
    ``target`` atomically (:func:`nightloc.io.atomic.atomic_file`; ``overwrite`` as there)."""
    # ASCII JSON: names and paths that are not valid UTF-8 (undecodable bytes of a file name,
    # held as lone surrogates) round-trip as \udcXX escapes instead of failing to encode.
    encoded = np.frombuffer(json.dumps(header).encode("ascii"), dtype=np.uint8)
    with atomic_file(target, "wb", overwrite=overwrite) as stream:
        np.savez(stream, header=encoded, **arrays)  # type: ignore[arg-type]  # numpy's stub: allow_pickle
