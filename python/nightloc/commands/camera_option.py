"""``--camera panoramic|forward``: the option of every command that chooses or checks how frames
are prepared (build-map, localize, evaluate, route)."""

from __future__ import annotations

import argparse
import tomllib
from pathlib import Path

from ..preparation.camera import CAMERAS, params_for_camera
from ..preparation.params import PreparationParams

__all__ = ["add_camera_option", "file_wrap", "preparation_for_camera"]


def add_camera_option(parser: argparse.ArgumentParser, what: str) -> None:
    """Adds ``--camera``; ``what`` ends its help (what the camera decides in this command)."""
    parser.add_argument(
        "--camera",
        choices=CAMERAS,
        help=f"panoramic: 360-degree panoramas, every column shift searched (heading from the match); forward: a "
        f"forward-facing camera, shift 0 only. {what}",
    )


def file_wrap(params_file: Path | str | None) -> bool | None:
    """The ``wrap`` that ``params_file``'s ``[preparation]`` table sets, or None (no file, no
    table, no key). The file has been read and checked already."""
    if params_file is None:
        return None
    document = tomllib.loads(Path(params_file).read_text(encoding="utf-8-sig"))
    table = document.get("preparation")
    value = table.get("wrap") if isinstance(table, dict) else None
    return value if isinstance(value, bool) else None


def preparation_for_camera(
    preparation: PreparationParams | None, camera: str | None, params_file: Path | str | None
) -> PreparationParams | None:
    """The preparation of ``--params`` set for ``--camera`` (None when neither says anything)."""
    if camera is None:
        return preparation
    return params_for_camera(preparation, camera, file_wrap(params_file), str(params_file or ""))
