"""Image preparation: camera frames to the small patch-normalized images the core matches.

The steps (``docs/design.md``, paper section III-A), each set by :class:`~nightloc.PreparationParams`:

1. **crop** (pixels or fractions of the frame, e.g. to remove the robot or the lens mount);
2. **greyscale** from BGR, RGB (``channel_order``), BGRA or grey; 8- or 16-bit;
3. **histogram equalization** of the full-resolution grey image: ``cv2.equalizeHist``
   (``"global"``), CLAHE (``"clahe"``) or none;
4. **area downsample** to ``width x height`` (48x24): every output pixel is the exact mean of the
   input area it covers, rounded to the nearest grey level (``cv2.INTER_AREA`` semantics;
   non-integer factors go through an integral image, faster than ``cv2.resize`` there);
5. **patch normalization**, eq. (1), by the compiled core (:func:`nightloc.patch_normalize`).

16-bit frames: ``"global"`` equalization maps the 65 536 grey levels straight to 8 bits (the
same formula as ``cv2.equalizeHist``); ``"clahe"`` first stretches the frame's own min..max range
to 8 bits; ``"none"`` scales by 255/65535 after downsampling.

Stacks are prepared one frame at a time, so preparing a traverse of thousands of full-size
frames holds only a few of them in memory (:meth:`Traverse.frames` reads ahead a few frames).

**Engines.** 8-bit frames with ``equalize`` ``"global"`` or ``"none"`` that are at least
``width x height`` after cropping are prepared by the compiled core in one call
(``nightloc::prepare_frame``: two passes over the frame, SIMD, the GIL released), bit for bit
the same as the OpenCV formulation of steps 1-4 (:meth:`Preparer.downsample_opencv`), which
prepares everything else: CLAHE, 16-bit frames and frames smaller than the output.
"""

from __future__ import annotations

from collections.abc import Iterable, Iterator

import cv2
import numpy as np

from .. import _core, _validate
from ..io.traverse import Traverse
from .downsample import area_downsample_opencv, equalize_hist16, packed
from .normalize import patch_normalize
from .params import PreparationParams

__all__ = ["Preparer", "prepare"]

ImageInput = np.ndarray | Iterable[np.ndarray] | Traverse

_GREY_CODES = {
    ("bgr", 3): cv2.COLOR_BGR2GRAY,
    ("rgb", 3): cv2.COLOR_RGB2GRAY,
    ("bgr", 4): cv2.COLOR_BGRA2GRAY,
    ("rgb", 4): cv2.COLOR_RGBA2GRAY,
}


#: (ndim or channels, channel_order) -> the core's pixel order
_CORE_ORDERS = {
    (2, "bgr"): "grey",
    (2, "rgb"): "grey",
    (3, "bgr"): "bgr",
    (3, "rgb"): "rgb",
    (4, "bgr"): "bgra",
    (4, "rgb"): "rgba",
}


def _crop_pixels(value: int | float, size: int) -> int:
    return int(round(value * size)) if isinstance(value, float) else int(value)


def _checked_frame(image: object, name: str) -> np.ndarray:
    return _validate.camera_frame(
        image,
        name,
        dtype_hint="prepare takes uint8 or uint16 frames (floats in [0, 1]: numpy.rint(x * 255).astype(numpy.uint8))",
        shape_hint="; a stack is (N, H, W) or (N, H, W, 3)",
    )


# --------------------------------------------------------------------------------------------
# the preparer


class Preparer:
    """Prepares frames with fixed :class:`PreparationParams`; callable like :func:`prepare`.

    Example::

        preparer = nightloc.Preparer(nightloc.PreparationParams(equalize="clahe"))
        refs = preparer(traverse)          # (N, 24, 48) uint8
        query = preparer(camera_frame)     # (24, 48) uint8
    """

    def __init__(self, params: PreparationParams | None = None):
        if params is None:
            params = PreparationParams()
        if not isinstance(params, PreparationParams):
            raise TypeError(f"params must be a PreparationParams, got {type(params).__name__}")
        self._params = params
        #: The core's settings by (crop in pixels, normalize): read-only once made.
        self._core_settings: dict[tuple[tuple[int, int, int, int], bool], _core.PrepareSettings] = {}

    @property
    def params(self) -> PreparationParams:
        """The parameters this preparer applies."""
        return self._params

    def __repr__(self) -> str:
        return f"Preparer({self._params!r})"

    def __getstate__(self) -> dict:
        return {"_params": self._params}  # pickle and copy: the core's settings are made again

    def __setstate__(self, state: dict) -> None:
        self.__init__(state["_params"])  # type: ignore[misc]

    # --- steps 1-4 on one frame

    def crop_pixels(self, height: int, width: int) -> tuple[int, int, int, int]:
        """Step 1's ``(top, bottom, left, right)`` in pixels for a ``height x width`` frame.

        Raises ValueError when the crop removes the whole frame.
        """
        top, bottom, left, right = self._params.crop
        t, b = _crop_pixels(top, height), _crop_pixels(bottom, height)
        lt, r = _crop_pixels(left, width), _crop_pixels(right, width)
        if t + b >= height or lt + r >= width:
            raise ValueError(
                f"crop (top, bottom, left, right) = {self._params.crop} removes the whole {height}x{width} frame "
                f"({t}+{b} rows, {lt}+{r} columns)"
            )
        return t, b, lt, r

    def crop(self, image: np.ndarray) -> np.ndarray:
        """Step 1: the frame without its cropped borders (a view, no copy)."""
        h, w = image.shape[:2]
        t, b, lt, r = self.crop_pixels(h, w)
        return image[t : h - b, lt : w - r]

    def grey(self, image: np.ndarray) -> np.ndarray:
        """Step 2: grey (H, W) of the same dtype."""
        if image.ndim == 2:
            return image
        return cv2.cvtColor(image, _GREY_CODES[(self._params.channel_order, image.shape[2])])

    def equalize(self, grey: np.ndarray) -> np.ndarray:
        """Step 3: histogram equalization (uint8 out), or the input unchanged for ``"none"``."""
        mode = self._params.equalize
        if mode == "none":
            return grey
        if grey.dtype == np.uint16:
            if mode == "global":
                return equalize_hist16(grey)
            low, high = int(grey.min()), int(grey.max())
            span = max(high - low, 1)
            grey = cv2.convertScaleAbs(grey, alpha=255.0 / span, beta=-low * 255.0 / span)
        if mode == "global":
            return cv2.equalizeHist(grey)
        clahe = cv2.createCLAHE(clipLimit=self._params.clahe_clip_limit, tileGridSize=self._params.clahe_tiles)
        return clahe.apply(np.ascontiguousarray(grey))

    def downsample(self, image: np.ndarray) -> np.ndarray:
        """Steps 1-4 on one frame: the ``(height, width)`` uint8 grey image, not yet normalized.

        8-bit frames with ``"global"`` or ``"none"`` equalization go through the compiled core,
        the others through :meth:`downsample_opencv` (the same bytes where both apply).
        """
        frame = _checked_frame(image, "image")
        small = self._core_prepare(frame, normalize=False)
        return self._downsample_opencv(frame) if small is None else small

    def downsample_opencv(self, image: np.ndarray) -> np.ndarray:
        """:meth:`downsample` with OpenCV and numpy only: ``cv2.cvtColor``, ``cv2.equalizeHist``
        / CLAHE / :func:`equalize_hist16`, :func:`area_downsample_opencv` (the reference the
        core is tested against)."""
        return self._downsample_opencv(_checked_frame(image, "image"))

    def _downsample_opencv(self, frame: np.ndarray) -> np.ndarray:
        grey = self.equalize(self.grey(self.crop(frame)))
        small = area_downsample_opencv(grey, self._params.width, self._params.height)
        if small.dtype == np.uint16:
            small = np.rint(small * (255.0 / 65535.0)).astype(np.uint8)
        return small

    def _core_prepare(self, frame: np.ndarray, normalize: bool) -> np.ndarray | None:
        """Steps 1-4 (and 5 when ``normalize``) in the core, or None where it does not apply."""
        p = self._params
        if frame.dtype != np.uint8 or p.equalize not in ("global", "none"):
            return None
        h, w = frame.shape[:2]
        crop = self.crop_pixels(h, w)
        if h - crop[0] - crop[1] < p.height or w - crop[2] - crop[3] < p.width:
            return None  # upsampling: OpenCV's INTER_AREA
        if not packed(frame):
            frame = np.ascontiguousarray(frame[crop[0] : h - crop[1], crop[2] : w - crop[3]])
            crop = (0, 0, 0, 0)
        order = _CORE_ORDERS[(2 if frame.ndim == 2 else frame.shape[2], p.channel_order)]
        key = (crop, normalize)
        settings = self._core_settings.get(key)
        if settings is None:  # one per crop (frame size) and step: the frames of a traverse share it
            settings = self._core_settings[key] = p.core_settings(crop, normalize and p.patch_normalize)
        return _core.prepare_frame(frame, order, settings)

    def normalize(self, small: np.ndarray) -> np.ndarray:
        """Step 5 on ``(H, W)`` or ``(N, H, W)`` uint8: patch normalization, or a copy when off."""
        p = self._params
        if not p.patch_normalize:
            return np.ascontiguousarray(small)
        return patch_normalize(np.ascontiguousarray(small), radius=p.radius, wrap=p.wrap, scale=p.scale)

    # --- whole inputs

    def iter_downsampled(self, images: ImageInput) -> Iterator[np.ndarray]:
        """Yields steps 1-4 of each frame of a stack, an iterable or a :class:`Traverse`."""
        if isinstance(images, Traverse):
            for _, frame in images.frames(batch_size=4, progress_desc=f"preparing {images.root.name}"):
                yield self.downsample(frame)
            return
        if isinstance(images, np.ndarray):
            if images.ndim not in (3, 4):
                raise ValueError(f"a stack must be (N, H, W) or (N, H, W, 3), got shape {images.shape}")
            source: Iterable[np.ndarray] = images
        elif isinstance(images, (str, bytes)) or not isinstance(images, Iterable):
            raise TypeError(
                f"images must be a numpy array, an iterable of arrays or a Traverse, got {type(images).__name__} "
                f"(load a folder with nightloc.load_traverse)"
            )
        else:
            source = images
        for index, frame in enumerate(source):
            try:
                yield self.downsample(frame)
            except (TypeError, ValueError) as error:
                raise type(error)(f"images[{index}]: {error}") from None

    def prepare(self, images: ImageInput) -> np.ndarray:
        """Prepares one frame or many.

        Args:
            images: one frame (grey ``(H, W)`` or ``(H, W, 1)``, grey + alpha ``(H, W, 2)``,
                colour ``(H, W, 3|4)``; uint8 or uint16; alpha is ignored), a stack ``(N, H, W)``
                / ``(N, H, W, 2|3|4)`` (a 3-D array whose last axis is 1 to 4 long is one frame),
                any iterable of frames (lists, generators; the frames may differ in size), or a
                :class:`Traverse` (read lazily with a progress bar). Masked arrays are refused.

        Returns:
            ``(height, width)`` uint8 for one frame, ``(N, height, width)`` uint8 otherwise.
        """
        _validate.not_masked(images, "images")
        if isinstance(images, np.ndarray) and (
            images.ndim == 2 or (images.ndim == 3 and images.shape[2] in (1, 2, 3, 4))
        ):
            frame = _checked_frame(images, "image")
            prepared = self._core_prepare(frame, normalize=True)
            if prepared is not None:
                return prepared
            return self.normalize(self._downsample_opencv(frame))
        smalls = list(self.iter_downsampled(images))
        if not smalls:
            raise ValueError("images is empty: nothing to prepare")
        return self.normalize(np.stack(smalls))

    __call__ = prepare


def prepare(images: ImageInput, params: PreparationParams | None = None) -> np.ndarray:
    """Prepares frames for matching with ``params`` (default: the paper's, Table II).

    Crop, greyscale, histogram equalization, area downsample to 48x24, patch normalization; see
    :class:`Preparer` and :mod:`nightloc.preparation`.

    Returns:
        ``(height, width)`` uint8 for one frame, ``(N, height, width)`` uint8 for a stack, an
        iterable of frames or a :class:`Traverse`.
    """
    return Preparer(params).prepare(images)
