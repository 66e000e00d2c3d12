"""Reference maps: the prepared day-time images of a traverse, their poses and parameters.

A robot builds the map once (:meth:`ReferenceMap.build`), saves it (:meth:`ReferenceMap.save`)
and loads it at start-up (:meth:`ReferenceMap.load`), then matches camera frames against it
(:meth:`ReferenceMap.match`), prepared with the very parameters the map was built with. A
traverse without poses but with the drive's wheel odometry is built by a teach run
(:func:`nightloc.mapping.teach_run`).

The file (format version 3, :mod:`nightloc.io.map_file`) holds the images, poses, parameters, the
localizer's settings the map was built with (:attr:`ReferenceMap.settings`: the ``[localization]``
and ``[filter]`` tables) and the localizer's map-only tables made with them
(:mod:`nightloc.localization.filter_tables`), for firmware without Python. The localization stage,
above this one, gives :meth:`ReferenceMap.save` its table maker when it is imported
(:func:`set_localizer_tables`; ``import nightloc`` imports it).
"""

from __future__ import annotations

import dataclasses
import os
from collections.abc import Callable, Mapping, Sequence
from pathlib import Path
from typing import Any, Union

import numpy as np

from .._core import __version__
from .._validate import coordinates, not_masked, uint8_array
from ..config import params_from_dict, params_to_dict, registered_sections
from ..errors import DatasetError, MapFormatError, with_cli_words
from ..io.appearances import APPEARANCE_ARRAYS, Appearances, map_fingerprint
from ..io.map_file import (
    DAY_MAP_FORMAT_VERSION,
    MAP_FORMAT,
    MAP_FORMAT_VERSION,
    MAX_MAP_EXPANSION,
    POSE_SOURCES,
    SETTINGS_CHECKSUM,
    check_map_version,
    read_map_file,
    settings_checksum,
    write_map_file,
)
from ..io.map_file import array_checksum as _sha256
from ..io.poses import finite_headings
from ..io.traverse import Traverse, load_traverse
from ..matching.sad import MatchResult, match
from ..preparation.camera import camera_of, check_frames_fit
from ..preparation.params import PreparationParams
from ..preparation.preparer import Preparer

__all__ = [
    "DAY_MAP_FORMAT_VERSION",
    "LOCALIZER_SECTIONS",
    "MAP_FORMAT",
    "MAP_FORMAT_VERSION",
    "MAX_MAP_EXPANSION",
    "POSE_SOURCES",
    "ReferenceMap",
    "set_localizer_tables",
]

PathLike = Union[str, "os.PathLike[str]"]

#: The parameter tables a map keeps with it (:attr:`ReferenceMap.settings`): the localizer's, which
#: its tables are made with (``[preparation]`` is the map's :attr:`ReferenceMap.params`).
LOCALIZER_SECTIONS = ("localization", "filter")
#: The header's ``localizer`` records its settings checksum seals: the tables above and the core's
#: settings made from them (what the firmware runs).
_SEALED = (*LOCALIZER_SECTIONS, "settings")

#: The default localizer's header section and arrays for a map (``(ref_map) -> (header, arrays)``):
#: :func:`nightloc.localization.filter_tables.filter_tables`, given by :func:`set_localizer_tables`.
_localizer_tables: Callable[[ReferenceMap], tuple[dict[str, Any], dict[str, np.ndarray]]] | None = None


def set_localizer_tables(
    make_tables: Callable[[ReferenceMap], tuple[dict[str, Any], dict[str, np.ndarray]]],
) -> None:
    """Gives :meth:`ReferenceMap.save` the maker of the default localizer's tables; the
    localization stage calls it when it is imported."""
    global _localizer_tables
    _localizer_tables = make_tables


def _checked_frame_size(frame_size: Sequence[int] | None) -> tuple[int, int] | None:
    if frame_size is None:
        return None
    size = tuple(frame_size)
    if len(size) != 2 or not all(isinstance(v, (int, np.integer)) and not isinstance(v, bool) and v > 0 for v in size):
        raise ValueError(f"frame_size must be (width, height) in pixels, got {frame_size!r}")
    return int(size[0]), int(size[1])


def _checked_settings(settings: Any) -> dict[str, dict[str, Any]]:
    """``settings`` (section -> a parameter instance or a table of key = value) as checked tables
    of :data:`LOCALIZER_SECTIONS` (ValueError naming a bad section, key or value)."""
    if settings is None:
        return {}
    if not isinstance(settings, Mapping):
        raise TypeError(f"settings must map a section name to its parameters, got {type(settings).__name__}")
    classes = registered_sections()
    tables: dict[str, dict[str, Any]] = {}
    for section, value in settings.items():
        if section not in LOCALIZER_SECTIONS:
            raise ValueError(
                f"a map keeps the settings {', '.join('[' + s + ']' for s in LOCALIZER_SECTIONS)}, not [{section}]"
            )
        table = params_to_dict(value) if dataclasses.is_dataclass(value) else value
        params_from_dict(classes[section], table, where="the map's settings")  # a ValueError naming the key
        tables[section] = dict(table)
    return tables


def _effective(settings: dict[str, dict[str, Any]]) -> dict[str, dict[str, Any]]:
    """Every key of :data:`LOCALIZER_SECTIONS` with the value the tables give it (a key left out:
    its default): maps that keep the same settings compare equal however they spell them."""
    classes = registered_sections()
    return {s: params_to_dict(params_from_dict(classes[s], settings.get(s, {}))) for s in LOCALIZER_SECTIONS}


def _frozen(array: np.ndarray) -> np.ndarray:
    """A read-only C-contiguous copy of ``array`` backed by an immutable ``bytes`` object, so that
    not even ``setflags(write=True)`` can make it writable: a map shared between threads (or
    handed to callers) cannot be changed under them."""
    contiguous = np.ascontiguousarray(array)
    return np.frombuffer(contiguous.tobytes(), dtype=contiguous.dtype).reshape(contiguous.shape)


class ReferenceMap:
    """Prepared reference images with their positions, headings and preparation parameters.

    Immutable and safe to share between threads: the arrays are read-only copies that not even
    ``setflags(write=True)`` can make writable.

    Attributes:
        images: ``(N, Ry, Rx)`` uint8 prepared images (C-contiguous).
        positions: ``(N, 2)`` float64 metres in the map frame.
        headings: ``(N,)`` float64 radians in (-pi, pi], or None.
        names: the N frame names (image file names of the source traverse).
        params: the :class:`PreparationParams` the images were prepared with.
        source: where the images came from (the traverse path), or "".
        frame_size: ``(width, height)`` pixels of the camera frames the map was built from, or
            None (unknown: a map of already prepared images, or written by nightloc < 0.2);
            with :attr:`camera`, what query frames must fit
            (:func:`nightloc.preparation.camera.check_frames_fit`).
        pose_source: where the poses came from, one of :data:`POSE_SOURCES`.
        covariances: ``(N, 3, 3)`` float64 marginal covariance of each pose's ``(x, y, heading)``
            (m², m·rad, rad²), or None (a survey states none).
        appearances: each reference's provenance (day map or learned night,
            :class:`~nightloc.io.appearances.Appearances`), or None: a day map.
        settings: the localizer's settings the map was built with, section -> table
            (:data:`LOCALIZER_SECTIONS`; empty: the defaults), which ``nightloc.Localizer(map)``,
            ``nightloc localize``, the node and the firmware run.
    """

    __slots__ = (
        "_appearances",
        "_covariances",
        "_frame_size",
        "_headings",
        "_images",
        "_names",
        "_params",
        "_pose_source",
        "_positions",
        "_settings",
        "_source",
    )

    def __init__(
        self,
        images: np.ndarray,
        positions: Any,
        headings: Any | None = None,
        names: Sequence[str] | None = None,
        params: PreparationParams | None = None,
        source: str = "",
        frame_size: Sequence[int] | None = None,
        *,
        pose_source: str = "surveyed",
        covariances: Any | None = None,
        appearances: Appearances | None = None,
        settings: Mapping[str, Any] | None = None,
    ):
        """Wraps already prepared images; see :meth:`build` to prepare a traverse.

        ``settings``: the localizer's settings to keep with the map, section (``"localization"``,
        ``"filter"``) -> a parameter instance or a table of its keys.

        Raises TypeError/ValueError for a wrong dtype or shape, sizes that disagree with
        ``params`` (width x height), non-finite positions, headings or covariances, repeated
        names, an unknown ``pose_source``, ``appearances`` of another length, or settings of
        another section or out of range.
        """
        params = PreparationParams() if params is None else params
        if not isinstance(params, PreparationParams):
            raise TypeError(f"params must be a PreparationParams, got {type(params).__name__}")
        stack = uint8_array(images, 3, "images")
        if stack.shape[1:] != (params.height, params.width):
            raise ValueError(
                f"images are {stack.shape[2]}x{stack.shape[1]} (width x height) but params say "
                f"{params.width}x{params.height}: prepare them with these params"
            )
        n = stack.shape[0]
        not_masked(positions, "positions")
        not_masked(headings, "headings")
        try:
            pos = np.array(positions, dtype=np.float64)
        except (TypeError, ValueError) as error:
            raise ValueError(f"positions must be ({n}, 2) numbers (metres): {error}") from None
        if pos.shape != (n, 2):
            raise ValueError(f"positions must be ({n}, 2) metres for {n} images, got shape {pos.shape}")
        coordinates(pos, "positions")
        head = None
        if headings is not None:
            try:
                head = np.array(headings, dtype=np.float64)
            except (TypeError, ValueError) as error:
                raise ValueError(f"headings must be ({n},) numbers (radians): {error}") from None
            if head.shape != (n,):
                raise ValueError(f"headings must be ({n},) radians, got shape {head.shape}")
            head = finite_headings(head)
        name_tuple = _checked_names(names, n)
        if pose_source not in POSE_SOURCES:
            raise ValueError(f"pose_source must be one of {', '.join(POSE_SOURCES)}, got {pose_source!r}")
        cov = None if covariances is None else _checked_covariances(covariances, n)
        self._images = _frozen(stack)
        self._positions = _frozen(pos)
        self._headings = None if head is None else _frozen(head)
        self._names = name_tuple
        self._params = params
        self._source = str(source)
        self._frame_size = _checked_frame_size(frame_size)
        self._pose_source = str(pose_source)
        self._covariances = None if cov is None else _frozen(cov)
        if appearances is not None:
            if not isinstance(appearances, Appearances):
                raise TypeError(f"appearances must be an Appearances, got {type(appearances).__name__}")
            if len(appearances) != n:
                raise ValueError(f"appearances record {len(appearances)} references, the map holds {n}")
        self._appearances = appearances
        self._settings = _checked_settings(settings)

    def __getstate__(self) -> dict:
        return {name: getattr(self, name) for name in self.__slots__}

    def __setstate__(self, state: dict) -> None:
        object.__setattr__(self, "_appearances", None)  # pickled before maps learned: a day map
        object.__setattr__(self, "_settings", {})  # pickled before maps kept their settings: the defaults
        for name, value in state.items():
            if isinstance(value, np.ndarray):
                value = _frozen(value)
            object.__setattr__(self, name, value)

    # --- attributes

    @property
    def images(self) -> np.ndarray:
        """``(N, Ry, Rx)`` uint8 prepared reference images."""
        return self._images

    @property
    def positions(self) -> np.ndarray:
        """``(N, 2)`` float64 positions in metres."""
        return self._positions

    @property
    def headings(self) -> np.ndarray | None:
        """``(N,)`` float64 headings in radians, or None."""
        return self._headings

    @property
    def names(self) -> tuple:
        """Frame names, one per image."""
        return self._names

    @property
    def params(self) -> PreparationParams:
        """The preparation parameters of the images (queries must use the same)."""
        return self._params

    @property
    def source(self) -> str:
        """The traverse the map was built from, or ""."""
        return self._source

    @property
    def pose_source(self) -> str:
        """Where the poses came from: ``"surveyed"``, ``"dead-reckoned"`` or ``"optimised"``."""
        return self._pose_source

    @property
    def covariances(self) -> np.ndarray | None:
        """``(N, 3, 3)`` marginal covariance of each pose's ``(x, y, heading)``, or None."""
        return self._covariances

    @property
    def appearances(self) -> Appearances | None:
        """Each reference's provenance (an experience map), or None (a day map)."""
        return self._appearances

    @property
    def settings(self) -> dict[str, dict[str, Any]]:
        """The localizer's settings the map was built with: section -> ``{key: value}``
        (:data:`LOCALIZER_SECTIONS`; a section or key left out is the default). A copy."""
        return {section: dict(table) for section, table in self._settings.items()}

    def with_settings(self, *params: Any) -> ReferenceMap:
        """This map keeping other settings: each of ``params`` (a ``LocalizationParams`` or a
        ``FilterParams``) replaces its section. The arrays are shared (immutable)."""
        tables = self.settings
        for item in params:
            if item is None:
                continue
            section = getattr(type(item), "__params_section__", None)
            tables[str(section)] = params_to_dict(item)
        clone = object.__new__(ReferenceMap)
        for name in self.__slots__:
            object.__setattr__(clone, name, getattr(self, name))
        object.__setattr__(clone, "_settings", _checked_settings(tables))
        return clone

    @property
    def fingerprint(self) -> str:
        """SHA-256 (hex) of the references and their poses (:func:`~nightloc.io.appearances.map_fingerprint`)."""
        return map_fingerprint(self._images, self._positions, self._headings)

    @property
    def camera(self) -> str:
        """``"panoramic"`` or ``"forward"``: the camera the map's parameters prepare for."""
        return camera_of(self._params)

    @property
    def frame_size(self) -> tuple[int, int] | None:
        """``(width, height)`` of the frames the map was built from, or None when unknown."""
        return self._frame_size

    def check_frames(self, frame_shape: Sequence[int], frames: str, camera: str | None = None) -> None:
        """ValueError naming both cameras (or both sizes) when frames of ``frame_shape`` (``(H,
        W[, C])``, from ``frames``, e.g. "the log night") cannot be matched against this map:
        another size than the map's recorded :attr:`frame_size` (none recorded: not checked), or a
        ``camera`` other than the map's (:func:`check_frames_fit`)."""
        name = f"the map {self._source_name()}"
        check_frames_fit(frame_shape, self._frame_size, self.camera, frames, name, camera)

    def _source_name(self) -> str:
        return f"(built from {self._source})" if self._source else "(of unknown source)"

    @property
    def preparer(self) -> Preparer:
        """A :class:`Preparer` with the map's parameters, for query frames."""
        return Preparer(self._params)

    def __len__(self) -> int:
        return self._images.shape[0]

    def __repr__(self) -> str:
        p = self._params
        return (
            f"ReferenceMap({len(self)} images {p.width}x{p.height}, source={self._source!r}, poses {self._pose_source})"
        )

    def __eq__(self, other: object) -> bool:
        if not isinstance(other, ReferenceMap):
            return NotImplemented
        same_headings = (self._headings is None and other._headings is None) or (
            self._headings is not None
            and other._headings is not None
            and np.array_equal(self._headings, other._headings)
        )
        same_covariances = (self._covariances is None and other._covariances is None) or (
            self._covariances is not None
            and other._covariances is not None
            and np.array_equal(self._covariances, other._covariances)
        )
        return (
            self._params == other._params
            and self._pose_source == other._pose_source
            and same_covariances
            and self._names == other._names
            and np.array_equal(self._images, other._images)
            and np.array_equal(self._positions, other._positions)
            and same_headings
            and self._appearances == other._appearances
            and _effective(self._settings) == _effective(other._settings)
        )

    __hash__ = None  # type: ignore[assignment]

    # --- building and matching

    @classmethod
    def build(
        cls, traverse: Traverse | PathLike, params: PreparationParams | None = None, *, teach: Any = None
    ) -> ReferenceMap:
        """Prepares every frame of a traverse into a map: with its surveyed poses, or by a teach run.

        Args:
            traverse: a :class:`Traverse`, or a path given to :func:`load_traverse`.
            params: preparation parameters (default: the paper's).
            teach: None (default): the traverse's poses, or -- a folder without ``poses.csv`` but
                with ``odometry.csv`` -- a teach run; True or a
                :class:`~nightloc.mapping.TeachParams`: a teach run even when poses exist
                (:func:`nightloc.mapping.teach_run`; GTSAM needed: ``pip install
                "nightloc[mapping]"``).

        Raises:
            DatasetError: the traverse has neither poses nor odometry, or a frame cannot be read.
            MappingError, MissingDependencyError: see :func:`nightloc.mapping.teach_run`.
        """
        if not isinstance(traverse, Traverse):
            traverse = load_traverse(traverse)
        if traverse.is_bag:
            odometry_log = traverse.motions is not None
        else:
            odometry_log = not traverse.is_video and (Path(traverse.root) / "odometry.csv").is_file()
        if (teach is not None and teach is not False) or (traverse.positions is None and odometry_log):
            from .params import TeachParams
            from .teach import teach_run

            return teach_run(traverse, params, teach if isinstance(teach, TeachParams) else None)[0]
        if traverse.positions is None:
            raise DatasetError(
                f"traverse {traverse.root} has no poses; a reference map needs the position of every "
                f"image (add poses.csv with columns image,x,y[,heading]) or the drive's wheel odometry for a "
                f"teach run (odometry.csv with columns image,forward,left,turn)"
            )
        preparer = Preparer(params)
        first = traverse.read(0)  # the camera's frame size, recorded for the queries' check
        images = preparer.prepare(traverse)
        return cls(
            images,
            traverse.positions,
            traverse.headings,
            traverse.names,
            preparer.params,
            str(traverse.root),
            frame_size=(first.shape[1], first.shape[0]),
        )

    def match(self, frame: np.ndarray, *, prepared: bool = False, threads: int | None = None) -> MatchResult:
        """Matches one camera frame against the map (eqs. 2-3).

        Args:
            frame: a raw camera frame (prepared here with the map's parameters), or with
                ``prepared=True`` an already prepared ``(Ry, Rx)`` uint8 image.
            threads: worker threads (default all cores).

        Returns:
            :class:`MatchResult`; ``self.positions[result.index]`` is the best place. Panoramic maps
            (``params.wrap``) search every column shift, others shift 0 only.
        """
        query = frame if prepared else self.preparer.prepare(frame)
        if isinstance(query, np.ndarray) and query.ndim != 2:
            raise ValueError(f"match takes one frame, got a stack of shape {query.shape}; loop over its frames")
        return match(query, self._images, shifts=self._params.shifts, threads=threads)

    # --- files

    def _header(self, localizer: dict[str, Any], tables: dict[str, np.ndarray]) -> dict[str, Any]:
        checksums = {"images": _sha256(self._images), "positions": _sha256(self._positions)}
        if self._headings is not None:
            checksums["headings"] = _sha256(self._headings)
        if self._covariances is not None:
            checksums["covariances"] = _sha256(self._covariances)
        checksums.update((name, _sha256(array)) for name, array in tables.items())
        experience = self._appearances
        if experience is not None:
            checksums.update((name, _sha256(array)) for name, array in experience.to_arrays().items())
        header = {
            "format": MAP_FORMAT,
            "format_version": DAY_MAP_FORMAT_VERSION if experience is None else MAP_FORMAT_VERSION,
            "nightloc_version": __version__,
            "count": len(self),
            "image_shape": [self._params.height, self._params.width],
            "params": params_to_dict(self._params),
            "camera": self.camera,
            "frame_size": None if self._frame_size is None else list(self._frame_size),
            "names": list(self._names),
            "source": self._source,
            "pose_source": self._pose_source,
            "checksums": checksums,
            "localizer": localizer,
        }
        if experience is not None:
            header["experience"] = experience.to_json()
        return header

    def save(self, path: PathLike, *, overwrite: bool = False) -> Path:
        """Writes the map to one file atomically (temporary file in the same folder, then rename).

        Returns the path written. Any suffix works; ``.map`` or ``.npz`` are customary. An
        existing file is replaced only with ``overwrite=True`` (else FileExistsError); the parent
        folder must exist; a symbolic link at ``path`` is followed (the file it points to is
        replaced). Saves of the same path from several threads or processes take turns.

        The file holds the localizer's settings (:attr:`settings`) and its map-only tables made with
        them too (format 3, :mod:`nightloc.localization.filter_tables`), for firmware without Python.
        """
        target = Path(path)
        if target.is_dir():
            raise IsADirectoryError(f"{target} is a folder; give a file name such as {target / 'reference.map'}")
        if _localizer_tables is None:
            raise RuntimeError("the localization stage is not loaded: import nightloc before saving a map")
        localizer, tables = _localizer_tables(self)
        localizer = {**localizer, SETTINGS_CHECKSUM: settings_checksum(localizer, _SEALED)}
        arrays = {"images": self._images, "positions": self._positions}
        if self._headings is not None:
            arrays["headings"] = self._headings
        if self._covariances is not None:
            arrays["covariances"] = self._covariances
        arrays.update(tables)
        if self._appearances is not None:
            arrays.update(self._appearances.to_arrays())
        write_map_file(target, self._header(localizer, tables), arrays, overwrite=overwrite)
        return target

    @classmethod
    def load(cls, path: PathLike, params: PreparationParams | None = None) -> ReferenceMap:
        """Reads a map written by :meth:`save`, checking format, version, shapes and checksums.

        Only a regular file is read (a FIFO, a device, a folder or a link loop is refused at
        once), and its arrays are checked against the file's size before any memory is taken:
        their declared sizes may add up to at most :data:`MAX_MAP_EXPANSION` times the file's
        size (``np.savez`` stores them uncompressed: about 1x).

        Args:
            path: the map file.
            params: the preparation parameters the caller will prepare queries with; when given
                and different from the map's, MapFormatError names the differing fields.

        Raises:
            FileNotFoundError: no such file.
            PermissionError: the file cannot be read.
            MapFormatError: not a regular file, not a nightloc map, truncated or corrupt, arrays
                larger than the file allows, a newer format version, checksum mismatch, or other
                parameters than ``params``.
        """
        file, header, arrays = read_map_file(path)
        return cls._from_parts(file, header, arrays, params)

    @classmethod
    def _from_parts(
        cls, file: Path, header: Any, arrays: dict[str, np.ndarray], params: PreparationParams | None
    ) -> ReferenceMap:
        version = check_map_version(file, header)
        try:
            map_params = params_from_dict(PreparationParams, header["params"], where=f"{file} header")
            names = header["names"]
            checksums = header["checksums"]
            count = header["count"]
        except KeyError as error:
            raise MapFormatError(f"{file}: map header lacks {error}") from None
        except ValueError as error:
            raise MapFormatError(f"{file}: map parameters are invalid: {error}") from None
        if not isinstance(checksums, dict):
            raise MapFormatError(f"{file}: the header's checksums are not a table (corrupt file)")
        if isinstance(count, bool) or not isinstance(count, int) or count < 1:
            raise MapFormatError(f"{file}: the header's image count {count!r} is not a positive integer")
        experience = header.get("experience") if version >= 4 else None
        learned = APPEARANCE_ARRAYS if experience is not None else ()
        optional = tuple(name for name in ("headings", "covariances") if name in checksums or name in arrays)
        optional += learned
        pose_source = header.get("pose_source", "surveyed") if version >= 2 else "surveyed"
        if pose_source not in POSE_SOURCES:
            raise MapFormatError(
                f"{file}: the header's pose_source {pose_source!r} is not one of {', '.join(POSE_SOURCES)}"
            )
        _check_arrays(file, arrays, checksums, optional)
        images = arrays["images"]
        expected = (count, map_params.height, map_params.width)
        if images.dtype != np.uint8 or images.shape != expected:
            raise MapFormatError(f"{file}: images are {images.dtype} {images.shape}, expected uint8 {expected}")
        if not isinstance(names, list) or len(names) != count:
            raise MapFormatError(
                f"{file}: the header lists {len(names) if isinstance(names, list) else '?'} names for {count} images"
            )
        _check_requested_params(file, map_params, params)
        frame_size = header.get("frame_size")
        if frame_size is not None and not (
            isinstance(frame_size, list)
            and len(frame_size) == 2
            and all(isinstance(v, int) and not isinstance(v, bool) and v > 0 for v in frame_size)
        ):
            raise MapFormatError(f"{file}: the header's frame_size {frame_size!r} is not [width, height] pixels")
        camera = header.get("camera", camera_of(map_params))
        if camera != camera_of(map_params):
            raise MapFormatError(
                f"{file}: the header's camera {camera!r} contradicts its parameters (wrap = {map_params.wrap}): corrupt"
            )
        settings = _stored_settings(file, header)
        try:
            appearances = None if experience is None else Appearances.from_file(experience, arrays, count)
            return cls(
                np.ascontiguousarray(images),
                arrays["positions"],
                arrays.get("headings"),
                names,
                map_params,
                str(header.get("source", "")),
                frame_size=frame_size,
                pose_source=pose_source,
                covariances=arrays.get("covariances"),
                appearances=appearances,
                settings=settings,
            )
        except (TypeError, ValueError) as error:
            raise MapFormatError(f"{file}: inconsistent map contents: {error}") from None


def _check_arrays(file: Path, arrays: dict[str, np.ndarray], checksums: dict, optional: tuple[str, ...]) -> None:
    """Every array the map needs is there, and every array matches its checksum in the header."""
    for name in dict.fromkeys(("images", "positions", *optional, *checksums)):
        if name not in arrays:
            raise MapFormatError(f"{file}: the map lacks its '{name}' array (corrupt file)")
        if name not in checksums:
            raise MapFormatError(f"{file}: the header has no checksum for '{name}' (corrupt file)")
        if _sha256(arrays[name]) != checksums[name]:
            raise MapFormatError(f"{file}: checksum of '{name}' does not match (the file is corrupt)")


def _check_requested_params(file: Path, map_params: PreparationParams, params: PreparationParams | None) -> None:
    """The preparation parameters asked for (if any) are the map's."""
    if params is not None:
        if not isinstance(params, PreparationParams):
            raise TypeError(f"params must be a PreparationParams, got {type(params).__name__}")
        different = map_params.differences(params)
        if different:
            listing = ", ".join(f"{k}: map {a!r}, requested {b!r}" for k, (a, b) in different.items())
            built = f"{file} was built with other preparation parameters ({listing})"
            raise with_cli_words(
                MapFormatError(
                    f"{built}; rebuild the map with these parameters or load it without params to use the map's"
                ),
                f"{built}; rebuild the map with them (nightloc build-map --params), or leave the [preparation] "
                f"table out of --params to use the map's",
            )


def _stored_settings(file: Path, header: Any) -> dict:
    """The localizer settings the map keeps (its LOCALIZER_SECTIONS tables), their checksum checked."""
    localizer = header.get("localizer")
    sealed = isinstance(localizer, dict) and SETTINGS_CHECKSUM in localizer
    if sealed and settings_checksum(localizer, _SEALED) != localizer[SETTINGS_CHECKSUM]:
        raise MapFormatError(f"{file}: checksum of the localizer's settings does not match (the file is corrupt)")
    stored = (
        {s: localizer[s] for s in LOCALIZER_SECTIONS if isinstance(localizer.get(s), dict)}
        if isinstance(localizer, dict)
        else {}
    )
    try:
        settings = _checked_settings(stored)
    except ValueError as error:
        raise MapFormatError(
            f"{file}: the localizer settings it keeps are not this nightloc's ({error}); it was written by "
            f"nightloc {header.get('nightloc_version')}"
        ) from None
    return settings


def _checked_names(names: Sequence[str] | None, n: int) -> tuple[str, ...]:
    """The references' ``n`` distinct names (default ``000000``, ``000001``, ...)."""
    if names is None:
        return tuple(f"{i:06d}" for i in range(n))
    if isinstance(names, str):
        raise TypeError("names must be a sequence of strings, not one string")
    name_tuple = tuple(names)
    if len(name_tuple) != n or not all(isinstance(name, str) for name in name_tuple):
        raise ValueError(f"names must be {n} strings, got {len(name_tuple)} items")
    if len(set(name_tuple)) != n:
        raise ValueError("names must not repeat")
    return name_tuple


def _checked_covariances(covariances: Any, n: int) -> np.ndarray:
    """``(n, 3, 3)`` float64 covariances: finite, symmetric, non-negative variances."""
    not_masked(covariances, "covariances")
    try:
        cov = np.array(covariances, dtype=np.float64)
    except (TypeError, ValueError) as error:
        raise ValueError(f"covariances must be ({n}, 3, 3) numbers: {error}") from None
    if cov.shape != (n, 3, 3):
        raise ValueError(f"covariances must be ({n}, 3, 3) (x, y, heading per pose), got shape {cov.shape}")
    if not np.isfinite(cov).all():
        raise ValueError("covariances hold NaN or infinity")
    diagonal = np.diagonal(cov, axis1=1, axis2=2)
    if (diagonal < 0).any():
        raise ValueError("covariances have negative variances")
    if not np.allclose(cov, np.swapaxes(cov, 1, 2), rtol=1e-6, atol=1e-12):
        raise ValueError("covariances must be symmetric")
    return cov
