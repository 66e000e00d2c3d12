"""Image files: which suffixes are images, listing a folder in natural order, decoding and encoding.

Decoding goes through OpenCV (``cv2.imdecode`` on the file's bytes, so non-ASCII paths work) and
returns frames as stored: grey ``(H, W)`` or BGR ``(H, W, 3)``, uint8 or uint16. Problems raise
:class:`~nightloc.errors.DatasetError` naming the file.
"""

from __future__ import annotations

import os
import re
from pathlib import Path
from typing import Union

import cv2
import numpy as np

from ..errors import DatasetError
from .files import check_regular, open_regular

__all__ = ["IMAGE_SUFFIXES", "list_images", "natural_key", "read_image_file", "write_image_file"]

PathLike = Union[str, "os.PathLike[str]"]

#: File suffixes (lower case) treated as images when a folder is listed: every format OpenCV
#: decodes to 8- or 16-bit pixels (whether a given build has the codec, e.g. AVIF, shows when a
#: file is read). Frames named in ``poses.csv`` are decoded by content, whatever their suffix.
IMAGE_SUFFIXES = frozenset(
    {
        ".png",
        ".jpg",
        ".jpeg",
        ".jpe",
        ".bmp",
        ".dib",
        ".tif",
        ".tiff",
        ".webp",
        ".pgm",
        ".ppm",
        ".pbm",
        ".pnm",
        ".pxm",
        ".sr",
        ".ras",
        ".jp2",
        ".gif",
        ".apng",
        ".avif",
        ".pam",
    }
)


def natural_key(name: str) -> tuple[object, ...]:
    """Sort key comparing runs of digits as numbers: ``img2.png`` < ``img10.png``."""
    parts = re.split(r"(\d+)", name)
    return tuple((0, int(part), part) if part.isdigit() else (1, part.lower(), part) for part in parts)


def list_images(folder: Path) -> list[str]:
    """Names of the image files in ``folder`` (not hidden, suffix in :data:`IMAGE_SUFFIXES`), in
    natural order.

    Raises DatasetError for an entry with an image suffix that is not a regular file (a named
    pipe, a device, a socket, a symbolic link loop or a dangling link): it could not be read
    later, so it is named now. Sub-folders are not entries of the listing.
    """
    names: list[str] = []
    odd: list[str] = []
    with os.scandir(folder) as entries:
        for entry in entries:
            if entry.name.startswith(".") or Path(entry.name).suffix.lower() not in IMAGE_SUFFIXES:
                continue
            try:
                if entry.is_dir():
                    continue
                regular = entry.is_file()
            except OSError:  # a symbolic link loop
                regular = False
            (names if regular else odd).append(entry.name)
    for name in sorted(odd, key=natural_key):
        check_regular(Path(folder) / name, "image", DatasetError)  # raises, naming what it is
    return sorted(names, key=natural_key)


def _decode_error_hint(path: Path) -> str:
    try:
        size = path.stat().st_size
    except OSError as error:
        return f"cannot be read ({error.strerror or error})"
    if size == 0:
        return "is empty (0 bytes)"
    return f"is not an image OpenCV can decode ({size} bytes; truncated, corrupt or another file type)"


def _jpeg_truncated(data: np.ndarray) -> bool:
    """True when a JPEG stream has no end-of-image marker after its last scan.

    Entropy-coded data never contains ``FF D9`` (0xFF bytes are stuffed), so a JPEG cut inside
    its last scan lacks the marker; older OpenCV builds decode such files with a grey fill.
    """
    raw = data.tobytes()
    if not raw.startswith(b"\xff\xd8"):
        return False
    last_scan = raw.rfind(b"\xff\xda")
    return last_scan >= 0 and raw.find(b"\xff\xd9", last_scan) < 0


def read_image_file(path: PathLike, context: str = "") -> np.ndarray:
    """Decodes one image file as stored: grey ``(H, W)`` or BGR ``(H, W, 3)``, uint8 or uint16.

    An alpha channel is dropped. Raises :class:`DatasetError` (with ``context``, e.g. the
    ``poses.csv`` line naming the file) for a missing, empty, truncated or undecodable file, or a
    float image.
    """
    file = Path(path)
    where = f" ({context})" if context else ""
    try:
        with open_regular(file, "image", DatasetError) as stream:
            data = np.frombuffer(stream.read(), dtype=np.uint8)
    except DatasetError as error:
        raise DatasetError(f"{error}{where}") from None
    except OSError as error:
        raise DatasetError(f"image {file}{where} cannot be read: {error.strerror or error}") from error
    image = cv2.imdecode(data, cv2.IMREAD_ANYCOLOR | cv2.IMREAD_ANYDEPTH) if data.size else None
    if image is None:
        raise DatasetError(f"image {file}{where} {_decode_error_hint(file)}")
    if file.suffix.lower() in (".jpg", ".jpeg", ".jpe") and _jpeg_truncated(data):
        raise DatasetError(f"image {file}{where} is a truncated JPEG (no end-of-image marker after its last scan)")
    if image.dtype not in (np.uint8, np.uint16):
        raise DatasetError(
            f"image {file}{where} has {image.dtype} pixels; nightloc reads 8- or 16-bit images "
            f"(convert it, e.g. to 16-bit PNG)"
        )
    if image.ndim == 3:
        channels = image.shape[2]
        if channels in (1, 2):  # grey, grey + alpha
            image = image[:, :, 0]
        elif channels == 4:
            image = cv2.cvtColor(image, cv2.COLOR_BGRA2BGR)
        elif channels != 3:
            raise DatasetError(f"image {file}{where} has {channels} channels; expected 1 to 4")
    return np.ascontiguousarray(image)


def write_image_file(file: Path, image: np.ndarray, index: int) -> None:
    """Encodes ``image`` (uint8, or uint16 for PNG/TIFF/PNM) into ``file`` by its suffix; JPEG at quality 95.

    ``index`` names the frame in error messages (``images[index]``).
    """
    suffix = file.suffix.lower()
    if image.dtype == np.uint16 and suffix not in (".png", ".tif", ".tiff", ".pgm", ".ppm", ".pnm"):
        raise ValueError(f"images[{index}] is 16-bit; {suffix} stores 8-bit images only (use png or tiff)")
    options: list = []
    if suffix in (".jpg", ".jpeg", ".jpe"):
        options = [cv2.IMWRITE_JPEG_QUALITY, 95]
    ok, encoded = cv2.imencode(suffix, image, options)
    if not ok:
        raise ValueError(f"OpenCV could not encode images[{index}] as {suffix}")
    encoded.tofile(file)
