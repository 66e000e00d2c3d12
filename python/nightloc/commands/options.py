"""The options and arguments that several commands share, each defined and checked once.

* ``--image-topic``, ``--odometry-topic``, ``--pose-topic``, ``--sync-tolerance``: every command
  that reads a traverse from a ROS bag (which topics, and how far apart a frame and its odometry or
  pose sample may be);
* ``--camera panoramic|forward``: every command that chooses or checks how frames are prepared
  (build-map, localize, evaluate, route);
* ``--shift-window COLUMNS,ROWS``: the translation window of the comparison, on route mode's
  commands (route) and the 2D filter's (localize, evaluate);
* ``--odometry-noise``: a Table III model or ``DIST,HEADING`` (localize, evaluate);
* ``--seed`` and ``--repeats``: the noise draws (evaluate, demo);
* ``REFERENCE``: a traverse to build a map from, or a map file (localize, evaluate);
* ``--odometry FILE``: a log's odometry, or its own (localize, export-log);
* ``--params FILE`` and ``--set SECTION.KEY=VALUE``: parameter tables, a file's and single keys
  on top of it (every command that takes parameters; :class:`nightloc.config.SettingsLayers`).
"""

from __future__ import annotations

import argparse
import dataclasses
import math
import os
import tomllib
from pathlib import Path
from typing import Any

from .._validate import MAX_REPEATS
from ..config import SettingsLayers
from ..errors import DatasetError
from ..io.atomic import check_output_path
from ..io.bag import DEFAULT_SYNC_TOLERANCE_S
from ..io.dataset_record import recorded_camera
from ..io.kinds import bag_kind
from ..io.odometry_csv import ODOMETRY_FILE
from ..io.traverse import Traverse, load_traverse
from ..localization.grid_filter import FilterParams
from ..mapping.reference_map import ReferenceMap
from ..motion.odometry import WHEEL_ODOMETRY_NOISE, NoiseModel, noise_model, traverse_odometry
from ..preparation.camera import CAMERAS, check_panorama_shape, params_for_camera
from ..preparation.params import PreparationParams

__all__ = [
    "add_bag_options",
    "add_camera_option",
    "add_learn_options",
    "add_params_options",
    "add_shift_window_option",
    "bag_options",
    "check_draw_options",
    "check_learn_target",
    "file_wrap",
    "filter_params_with_window",
    "load_reference",
    "log_odometry",
    "parse_noise",
    "parse_shift_window",
    "preparation_for_camera",
    "read_settings",
    "settings_line",
    "traverse_camera",
]

# --- ROS bags: --image-topic, --odometry-topic, --pose-topic, --sync-tolerance


def add_bag_options(parser: argparse.ArgumentParser) -> None:
    """Adds ``--image-topic``, ``--odometry-topic``, ``--pose-topic`` and ``--sync-tolerance``."""
    group = parser.add_argument_group(
        "ROS bags",
        "a traverse may be a ROS 1 or ROS 2 bag; its topics are found by type when there is one of each kind",
    )
    group.add_argument("--image-topic", help="sensor_msgs/Image or CompressedImage topic of the camera")
    group.add_argument(
        "--odometry-topic",
        help="nav_msgs/Odometry topic of the wheel odometry, or /tf (odom -> base_link), or /tf:PARENT:CHILD",
    )
    group.add_argument("--pose-topic", help="PoseStamped, PoseWithCovarianceStamped or Odometry topic of true poses")
    group.add_argument(
        "--sync-tolerance",
        type=float,
        default=DEFAULT_SYNC_TOLERANCE_S,
        help=f"largest time (s) between a frame and its nearest odometry or pose message "
        f"(default {DEFAULT_SYNC_TOLERANCE_S:g})",
    )


def bag_options(args: argparse.Namespace) -> dict[str, Any]:
    """The keyword arguments of :func:`nightloc.load_traverse` that the options give (only
    those set, so that folders and videos are not told about topics)."""
    if not (math.isfinite(args.sync_tolerance) and args.sync_tolerance >= 0):
        raise ValueError(f"--sync-tolerance must be a finite number of seconds >= 0, got {args.sync_tolerance}")
    options: dict[str, Any] = {
        name: getattr(args, name)
        for name in ("image_topic", "odometry_topic", "pose_topic")
        if getattr(args, name) is not None
    }
    if args.sync_tolerance != DEFAULT_SYNC_TOLERANCE_S:
        options["sync_tolerance"] = args.sync_tolerance
    return options


# --- --params FILE, --set SECTION.KEY=VALUE


def add_params_options(parser: argparse.ArgumentParser, tables: str) -> None:
    """Adds ``--params FILE`` (``tables``: the TOML tables the command reads, in words) and
    ``--set SECTION.KEY=VALUE`` (repeatable; over the file's)."""
    parser.add_argument("--params", type=Path, help=f"TOML file with {tables}")
    parser.add_argument(
        "--set",
        action="append",
        metavar="SECTION.KEY=VALUE",
        dest="settings",
        help="one parameter, over --params' (repeatable; VALUE as in TOML, e.g. --set filter.uniform_floor=0.05)",
    )


def read_settings(args: argparse.Namespace) -> SettingsLayers:
    """``--params``' tables, then each ``--set`` (checked as a parameter file is: the same errors)."""
    return SettingsLayers().add_file(args.params).add_assignments(getattr(args, "settings", None))


def settings_line(layers: SettingsLayers, sections: tuple[str, ...], lead: str = "settings") -> str:
    """``"settings: SOURCE: [filter] key = value, ...; ...; the rest the defaults"``: where the
    settings of ``sections`` that are not the defaults came from."""
    found = layers.report(sections)
    return f"{lead}: " + ("; ".join(found) + "; the rest the defaults" if found else "the defaults")


# --- --camera panoramic|forward


def add_camera_option(parser: argparse.ArgumentParser, what: str) -> None:
    """Adds ``--camera``; ``what`` ends its help (what the camera decides in this command)."""
    parser.add_argument(
        "--camera",
        choices=CAMERAS,
        help=f"panoramic: 360-degree panoramas, every column shift searched (heading from the match); forward: a "
        f"forward-facing camera, shift 0 only. {what}",
    )


def file_wrap(params_file: Path | str | SettingsLayers | None) -> bool | None:
    """The ``wrap`` that ``params_file``'s ``[preparation]`` table sets (a file, or the
    ``--params``/``--set`` settings), or None (no file, no table, no key). The file has been read
    and checked already."""
    said = _wrap_said(params_file)
    return None if said is None else said[0]


def _wrap_said(params_file: Path | str | SettingsLayers | None) -> tuple[bool, str] | None:
    """The ``[preparation]`` ``wrap`` set and who sets it, or None."""
    if params_file is None:
        return None
    if isinstance(params_file, SettingsLayers):
        value = params_file.table("preparation").get("wrap")
        source = params_file.origin("preparation", "wrap")
        return (value, str(source)) if isinstance(value, bool) else None
    document = tomllib.loads(Path(params_file).read_text(encoding="utf-8-sig"))
    table = document.get("preparation")
    value = table.get("wrap") if isinstance(table, dict) else None
    return (value, str(params_file)) if isinstance(value, bool) else None


def preparation_for_camera(
    preparation: PreparationParams | None, camera: str | None, params_file: Path | str | SettingsLayers | None
) -> PreparationParams | None:
    """The preparation of ``--params`` (and ``--set``) set for ``--camera`` (None when neither says
    anything)."""
    if camera is None:
        return preparation
    said = _wrap_said(params_file)
    return params_for_camera(preparation, camera, None if said is None else said[0], "" if said is None else said[1])


def traverse_camera(
    traverse: Traverse, camera: str | None, params_file: Path | str | SettingsLayers | None
) -> tuple[str | None, str | None]:
    """The camera to prepare ``traverse`` for, and who says so: ``--camera`` (``camera``), the
    ``wrap`` of ``params_file``'s ``[preparation]`` table, or the camera that the traverse's
    dataset description records (:func:`~nightloc.io.dataset_record.recorded_camera`); ``(None,
    None)`` when none says (frames are then prepared as panoramas, the default).

    A recorded camera that ``--camera`` or the parameter file contradicts is a ValueError naming
    both (the two options are checked against each other by :func:`preparation_for_camera`), as
    are frames too narrow for a panorama that would be prepared as one
    (:func:`~nightloc.preparation.camera.check_panorama_shape`): the camera is never guessed."""
    wrap_said = _wrap_said(params_file)
    said: list[tuple[str, str]] = []
    if camera is not None:
        said.append((camera, f"--camera {camera}"))
    if wrap_said is not None:
        wrap, source = wrap_said
        said.append(("panoramic" if wrap else "forward", f"{source} ([preparation] wrap = {str(wrap).lower()})"))
    record = None if traverse.is_bag or traverse.is_video else recorded_camera(traverse.root)
    if record is not None and record.camera in CAMERAS:
        for name, who in said:
            if name != record.camera:
                raise ValueError(
                    f"{who} contradicts {record.source}, which records a {record.camera} camera for the traverse "
                    f"{traverse.root}: drop the option (the recorded camera is used), or correct {record.source}"
                )
        said.append((record.camera, str(record.source)))
    chosen, said_by = said[0] if said else (None, None)
    if chosen in (None, "panoramic"):
        check_panorama_shape(traverse.read(0).shape, f"the traverse {traverse.root}", said_by)
    return chosen, said_by


# --- --shift-window COLUMNS,ROWS


def add_shift_window_option(parser: argparse.ArgumentParser, what: str) -> None:
    """Adds ``--shift-window``; ``what`` is its help (what the window means in this command)."""
    parser.add_argument("--shift-window", metavar="COLUMNS,ROWS", help=what)


def parse_shift_window(text: str | None) -> tuple[int, int] | None:
    """``--shift-window COLUMNS,ROWS`` as a pair of ints >= 0 (None when not given)."""
    if text is None:
        return None
    parts = str(text).split(",")
    try:
        values = tuple(int(part) for part in parts)
    except ValueError:
        values = ()
    if len(values) != 2 or min(values) < 0:
        raise ValueError(f"--shift-window {text!r}: expected COLUMNS,ROWS, two integers >= 0 such as 8,2")
    return (values[0], values[1])


def filter_params_with_window(
    filter_params: FilterParams | None, window: tuple[int, int] | None, camera: str, image_shape: tuple[int, int]
) -> FilterParams | None:
    """``filter_params`` (None: the defaults) with ``--shift-window``'s columns as its
    ``forward_window`` and its rows as its ``row_window``; unchanged when ``window`` is None.

    ``camera`` is the map's (``"panoramic"`` or ``"forward"``), ``image_shape`` its prepared
    images' ``(rows, columns)`` in pixels. A panorama is already compared at every column shift, so
    its window has no columns; a forward camera's column window is how the filter tells headings
    apart, so it has at least one column and fewer than the image's width; rows fewer than the
    image's height. Raises ValueError naming the option."""
    if window is None:
        return filter_params
    columns, rows = window
    height, width = image_shape
    if rows >= height:
        raise ValueError(
            f"--shift-window {columns},{rows}: at most {height - 1} rows (the map's images are {height} rows high; "
            f"a tilting robot needs 1 or 2)"
        )
    if camera == "panoramic" and columns != 0:
        raise ValueError(
            f"--shift-window {columns},{rows}: the map is panoramic, compared at every column shift already; "
            f"give it rows only: --shift-window 0,{rows}"
        )
    if camera == "forward" and not 1 <= columns < width:
        raise ValueError(
            f"--shift-window {columns},{rows}: a forward camera's column window must be 1..{width - 1} columns "
            f"(its images are {width} wide; the filter's default is a quarter of that, {max(1, width // 4)})"
        )
    base = filter_params if filter_params is not None else FilterParams()
    forward_window = columns if camera == "forward" else base.forward_window
    return dataclasses.replace(base, forward_window=forward_window, row_window=rows)


# --- --odometry-noise, --seed, --repeats


def parse_noise(text: str, option: str = "--odometry-noise") -> int | NoiseModel:
    """``"3"`` -> Table III model 3; ``"0.2,0.05"`` -> NoiseModel(0.2 m, 0.05 rad); ``"wheel"`` ->
    :data:`~nightloc.motion.odometry.WHEEL_ODOMETRY_NOISE`; raises ValueError."""
    if str(text).strip().lower() == "wheel":
        return WHEEL_ODOMETRY_NOISE
    parts = [p.strip() for p in str(text).split(",")]
    if len(parts) == 1:
        try:
            model = int(parts[0])
        except ValueError:
            raise ValueError(
                f"{option}: {text!r} is not a model number 0-3, 'wheel' or DIST,HEADING (e.g. 0.2,0.05)"
            ) from None
        noise_model(model)  # checks the range
        return model
    if len(parts) != 2:
        raise ValueError(f"{option}: {text!r} must be a model number 0-3 or DIST,HEADING (metres,radians)")
    try:
        values = [float(p) for p in parts]
    except ValueError:
        raise ValueError(f"{option}: {text!r} must be two numbers DIST,HEADING (metres,radians)") from None
    if not all(math.isfinite(v) and v >= 0 for v in values):
        raise ValueError(f"{option}: {text!r}: standard deviations must be finite and >= 0")
    return NoiseModel(*values)


def check_draw_options(args: argparse.Namespace) -> None:
    """ValueError unless ``--seed`` and ``--repeats`` (the noise draws) are in range."""
    if args.seed < 0:
        raise ValueError(f"--seed must be non-negative, got {args.seed}")
    if not 1 <= args.repeats <= MAX_REPEATS:
        raise ValueError(f"--repeats must be in 1..{MAX_REPEATS} (MAX_REPEATS), got {args.repeats}")


# --- REFERENCE: a traverse or a map file


def load_reference(
    path: Path,
    preparation: PreparationParams | None,
    camera: str | None = None,
    params_file: Path | SettingsLayers | None = None,
    bag: dict | None = None,
) -> ReferenceMap:
    """The map of a reference traverse (a folder or a bag; prepared for ``camera`` when given),
    or a map file (anything but a regular file is refused, naming what it is; its camera is
    checked against the frames by :meth:`ReferenceMap.check_frames`). ``bag``: the topics of a bag
    (:func:`bag_options`)."""
    if path.is_dir() or bag_kind(path) is not None:
        options = (bag or {}) if bag_kind(path) is not None else {}
        traverse = load_traverse(path, **options)
        camera, _ = traverse_camera(traverse, camera, params_file)
        return ReferenceMap.build(traverse, preparation_for_camera(preparation, camera, params_file))
    return ReferenceMap.load(path, preparation)


# --- --learn NEW_MAP: localize also writes the map plus what the night taught it


def add_learn_options(parser: argparse.ArgumentParser) -> None:
    """Adds ``--learn NEW_MAP`` and ``--overwrite``."""
    parser.add_argument(
        "--learn",
        type=Path,
        metavar="NEW_MAP",
        help="also write NEW_MAP: the map plus the frames of this night localized confidently, as further "
        "appearances of its places or new places where it has gaps (MAP is never changed; [learning] in --params "
        "sets the thresholds)",
    )
    parser.add_argument("--overwrite", action="store_true", help="--learn: replace NEW_MAP when it exists")


def check_learn_target(target: Path, map_path: Path, out: Path | None, inputs: tuple, overwrite: bool) -> Path:
    """Fails before any work when NEW_MAP cannot be written: it is MAP (or inside an input), lies
    inside OUT (None: the command has no output folder), is a folder, or exists without
    ``overwrite``."""
    same = target.resolve() == map_path.resolve()
    if not same and os.path.lexists(target) and os.path.lexists(map_path):
        try:
            same = os.path.samefile(target, map_path)
        except OSError:
            same = False
    if same:
        raise ValueError(
            f"--learn {target} is the map itself: the map is never changed; write the learned map to a new file "
            f"(e.g. --learn {target.with_name(target.stem + '-learned' + target.suffix)})"
        )
    if out is not None and target.resolve().is_relative_to(out.resolve()):
        raise ValueError(f"--learn {target} lies inside --out {out} (replaced as a whole): write it elsewhere")
    return check_output_path(target, overwrite=overwrite, inputs=inputs)


# --- --odometry FILE: a log's odometry


def log_odometry(log: Traverse, option: str | None, without: str) -> list:
    """The log's odometry, one motion per frame: ``--odometry FILE``, or the log's own (its
    ``odometry.csv``, a bag's odometry topic). A missing one is a DatasetError saying how to name
    one and, ``without``, what the command can do without it."""
    if option is None and log.is_bag:
        return traverse_odometry(log)  # the bag's own odometry topic (or names what is missing)
    if option is None and not log.is_video and not os.path.lexists(Path(log.root) / ODOMETRY_FILE):
        raise DatasetError(
            f"the log {log.root} has no {ODOMETRY_FILE} (its wheel odometry, one row per frame: "
            f"image,forward,left,turn or image,dx,dy); name one with --odometry FILE"
            + (f", or {without}" if without else "")
        )
    try:
        return traverse_odometry(log, None if option is None else Path(option))
    except DatasetError as error:
        if log.is_video and option is None:
            raise DatasetError(f"{error}: --odometry FILE" + (f", or {without}" if without else "")) from None
        raise
