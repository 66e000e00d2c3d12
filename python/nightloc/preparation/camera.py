"""Cameras: a 360-degree panorama or a forward-facing camera, and whether frames fit a map's.

The camera decides how frames are prepared and matched (:attr:`PreparationParams.wrap`): a
panorama's patch-normalization window wraps around and every column shift is searched (so the
match also gives the heading); a forward camera's window is clipped at the borders and only shift
0 is compared. A map records its camera (its parameters) and the size of the frames it was built
from; frames of another camera give matches that mean nothing, so the commands refuse them:

* frames whose width/height differs from the map's frames by more than
  :data:`ASPECT_TOLERANCE` come from another camera;
* frames of the map's shape but another size (the same camera at another resolution) are
  refused too, naming both sizes: the map is matched against frames of its recorded size only
  (a map that records no frame size checks the camera alone; two traverses in route mode need
  only the same shape);
* a camera named on the command line (``--camera``) must be the map's.

From its shape alone a frame is taken for a panorama when it is at least
:data:`PANORAMA_MIN_ASPECT` times as wide as high (unwrapped panoramas are 2:1 to 6:1; forward
cameras 4:3 to 16:9); that guess never decides the camera, but frames narrower than that cannot be
360-degree panoramas, so preparing them as panoramas is refused (:func:`check_panorama_shape`).
"""

from __future__ import annotations

import dataclasses
from collections.abc import Sequence

from .params import PreparationParams

__all__ = [
    "ASPECT_TOLERANCE",
    "CAMERAS",
    "PANORAMA_MIN_ASPECT",
    "camera_of",
    "check_frames_fit",
    "check_panorama_shape",
    "params_for_camera",
    "shape_camera",
]

#: The camera kinds, as ``--camera`` names them.
CAMERAS = ("panoramic", "forward")
#: Width/height from which a frame's shape reads as a panorama's (for messages only).
PANORAMA_MIN_ASPECT = 1.9
#: Frames whose width/height differs from the map's frames by more than this fraction are refused.
ASPECT_TOLERANCE = 0.15


def camera_of(params: PreparationParams) -> str:
    """``"panoramic"`` (``wrap=True``) or ``"forward"``."""
    return "panoramic" if params.wrap else "forward"


def params_for_camera(
    params: PreparationParams | None, camera: str | None, file_wrap: bool | None = None, source: str = ""
) -> PreparationParams:
    """``params`` (default: the paper's) set for ``camera`` (None: as they are).

    ``file_wrap`` is the ``wrap`` a parameter file ``source`` sets explicitly (None when it does
    not): a camera that contradicts it is a ValueError naming both, as is an unknown camera."""
    base = PreparationParams() if params is None else params
    if camera is None:
        return base
    if camera not in CAMERAS:
        raise ValueError(f"camera must be one of {', '.join(CAMERAS)}, got {camera!r}")
    wrap = camera == "panoramic"
    if file_wrap is not None and file_wrap != wrap:
        raise ValueError(
            f"--camera {camera} contradicts {source or 'the parameter file'}, whose [preparation] sets wrap = "
            f"{str(file_wrap).lower()} (a {'panoramic' if file_wrap else 'forward'} camera); give one of them"
        )
    return dataclasses.replace(base, wrap=wrap)


def shape_camera(width: int, height: int) -> str:
    """The camera a frame of ``width x height`` pixels looks like it comes from."""
    return "panoramic" if width >= PANORAMA_MIN_ASPECT * height else "forward"


def check_panorama_shape(frame_shape: Sequence[int], frames: str, said_by: str | None) -> None:
    """ValueError naming the fix when frames of ``frame_shape`` (``(H, W[, C])``, from ``frames``,
    e.g. "the traverse day") are to be prepared as 360-degree panoramas but are narrower than
    :data:`PANORAMA_MIN_ASPECT` times their height, which no panorama is (a forward camera's are).
    ``said_by`` names who chose the panoramic camera (e.g. "--camera panoramic"), None when it is
    the default because nothing said which camera took the frames."""
    width, height = _size(frame_shape)
    if shape_camera(width, height) == "panoramic":
        return
    shape = f"{frames} has {width}x{height} frames (width/height {width / height:.2f})"
    if said_by is None:
        raise ValueError(
            f"{shape}, the shape of a forward camera's, and nothing says which camera took them: frames are "
            f"prepared as 360-degree panoramas unless told, and a panorama is at least {PANORAMA_MIN_ASPECT:g} "
            f"times as wide as high; give --camera forward"
        )
    raise ValueError(
        f"{shape}, but {said_by} says they are 360-degree panoramas, and a panorama is at least "
        f"{PANORAMA_MIN_ASPECT:g} times as wide as high: if the camera is forward-facing, give --camera forward"
    )


def _size(shape: Sequence[int]) -> tuple[int, int]:
    return int(shape[1]), int(shape[0])


def check_frames_fit(
    frame_shape: Sequence[int],
    map_frame_size: Sequence[int] | None,
    map_camera: str,
    frames: str,
    map_name: str,
    camera: str | None = None,
    remedy: str = "use a map built from this camera (nightloc build-map --camera {camera})",
    exact_size: bool = True,
) -> None:
    """ValueError, naming both cameras, when frames of ``frame_shape`` (``(H, W[, C])``, from
    ``frames``, e.g. "the log night_run") do not fit the map ``map_name``: another width/height
    than the map's frames (``map_frame_size``, ``(width, height)``, None when the map does not
    record it), or a ``camera`` named for the frames (by ``--camera``, which the message names
    as the cause) that is not ``map_camera``. ``remedy``
    ends the message (``{camera}``: the frames' camera). ``exact_size``: frames of the map's
    shape but another size are refused too, naming both sizes (False: the shape is enough)."""
    width, height = _size(frame_shape)
    looks = shape_camera(width, height)
    if camera is not None and camera != map_camera:
        raise ValueError(
            f"--camera {camera} says that {frames} is from a {camera} camera, but {map_name} is a {map_camera} "
            f"camera's: a map keeps the camera it was built for, so the option is not needed with it; drop "
            f"--camera {camera}, or, if the frames really are a {camera} camera's, {remedy.format(camera=camera)}"
        )
    if map_frame_size is None:
        return
    map_width, map_height = int(map_frame_size[0]), int(map_frame_size[1])
    aspect, map_aspect = width / height, map_width / map_height
    if abs(aspect / map_aspect - 1.0) <= ASPECT_TOLERANCE:
        if exact_size and (width, height) != (map_width, map_height):
            raise ValueError(
                f"{frames} has {width}x{height} frames, but {map_name} was built from {map_width}x{map_height} frames: "
                f"a map is matched against frames of its own size only; resize the frames to {map_width}x{map_height} "
                f"if they are the same camera at another resolution, or build a map from {width}x{height} frames "
                f"(nightloc build-map)"
            )
        return
    said = camera if camera is not None else looks
    advice = f"; {remedy.format(camera=said)}" if remedy else ""
    shaped = "" if camera is not None else " by their shape"
    raise ValueError(
        f"{frames} has {width}x{height} frames (width/height {aspect:.2f}, a {said} camera's{shaped}), but {map_name} "
        f"comes from {map_width}x{map_height} frames of a {map_camera} camera ({map_aspect:.2f}): frames of another "
        f"camera cannot be matched against it{advice}"
    )
