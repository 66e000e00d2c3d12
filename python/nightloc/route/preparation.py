"""Image preparation for route mode: OpenSeqSLAM's (exact) or the paper's (nightloc).

OpenSeqSLAM's preparation (``RouteParams.preparation = "openseqslam"``), as its
``doPreprocessing.m`` runs under GNU Octave with the image package:

1. grey with Octave's ``rgb2gray`` (:func:`octave_rgb2gray`): ITU-R BT.601 luma in double
   precision, ``0.298936021293775 R + 0.587043074451121 G + 0.114020904255103 B``, rounded half
   away from zero to uint8 (OpenCV's ``cvtColor`` uses fixed-point weights and differs by one
   grey level on some pixels, which changes the matches);
2. no resize, no crop (the OpenSeqSLAM defaults for already small images such as the 64x32
   Nordland frames);
3. block normalization (:func:`nightloc.block_normalize`, bit-exact with ``patchNormalize.m``).

Grey frames pass step 1 unchanged; 16-bit frames are scaled to 8 bits (``round(v * 255 / 65535)``)
after step 1, a nightloc choice (OpenSeqSLAM stores uint8). The ``"nightloc"`` preparation is
:class:`nightloc.Preparer` with the route's :class:`~nightloc.params.PreparationParams`.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Iterable, Iterator
from typing import Literal

import numpy as np

from ..io.traverse import Traverse
from ..preparation.normalize import block_normalize
from ..preparation.params import PreparationParams
from ..preparation.preparer import Preparer
from .params import RouteParams, default_preparation

__all__ = ["RoutePreparer", "octave_rgb2gray"]

#: Octave's rgb2gray weights (R, G, B), as its image package writes them.
OCTAVE_GREY_WEIGHTS = (0.298936021293775, 0.587043074451121, 0.114020904255103)

ImageInput = np.ndarray | Iterable[np.ndarray] | Traverse


def octave_rgb2gray(image: np.ndarray, channel_order: str = "bgr") -> np.ndarray:
    """Grey like GNU Octave's ``rgb2gray``: BT.601 weights in double, rounded half away from zero.

    Args:
        image: ``(H, W)`` grey (returned unchanged) or ``(H, W, 3|4)`` colour, uint8 or uint16
            (an alpha channel is ignored).
        channel_order: ``"bgr"`` (OpenCV's ``imread``, :meth:`Traverse.read`) or ``"rgb"``.

    Returns:
        ``(H, W)`` of the input's dtype.
    """
    array = np.asarray(image)
    if array.dtype not in (np.uint8, np.uint16):
        raise TypeError(f"image must be uint8 or uint16, got {array.dtype}")
    if array.ndim == 2:
        return array
    if array.ndim != 3 or array.shape[2] not in (3, 4):
        raise ValueError(f"image must be (H, W) grey or (H, W, 3|4) colour, got shape {array.shape}")
    if channel_order not in ("bgr", "rgb"):
        raise ValueError(f"channel_order must be 'bgr' or 'rgb', got {channel_order!r}")
    r_index, b_index = (2, 0) if channel_order == "bgr" else (0, 2)
    red = array[..., r_index].astype(np.float64)
    green = array[..., 1].astype(np.float64)
    blue = array[..., b_index].astype(np.float64)
    w_red, w_green, w_blue = OCTAVE_GREY_WEIGHTS
    grey = w_red * red + w_green * green + w_blue * blue  # left to right, in double, no FMA
    top = 255.0 if array.dtype == np.uint8 else 65535.0
    return np.clip(np.floor(grey + 0.5), 0.0, top).astype(array.dtype)


def _to_uint8(grey: np.ndarray) -> np.ndarray:
    if grey.dtype == np.uint8:
        return grey
    return np.floor(grey.astype(np.float64) * (255.0 / 65535.0) + 0.5).astype(np.uint8)


class RoutePreparer:
    """Prepares frames for route mode as :class:`RouteParams` says; callable.

    Args:
        params: the route parameters (its ``preparation`` field picks the method).
        preparation: parameters of the ``"nightloc"`` preparation (default:
            :func:`~nightloc.route.params.default_preparation`); ignored for ``"openseqslam"``.
        channel_order: colour order of the frames given, ``"bgr"`` (OpenCV) or ``"rgb"``.
    """

    def __init__(
        self,
        params: RouteParams,
        preparation: PreparationParams | None = None,
        channel_order: Literal["bgr", "rgb"] = "bgr",
    ):
        if not isinstance(params, RouteParams):
            raise TypeError(f"params must be a RouteParams, got {type(params).__name__}")
        if channel_order not in ("bgr", "rgb"):
            raise ValueError(f"channel_order must be 'bgr' or 'rgb', got {channel_order!r}")
        self.params = params
        self.channel_order = channel_order
        if params.preparation == "nightloc":
            chosen = preparation if preparation is not None else default_preparation(params)
            if chosen.channel_order != channel_order:
                chosen = dataclasses.replace(chosen, channel_order=channel_order)
            self._preparer: Preparer | None = Preparer(chosen)
        else:
            self._preparer = None

    @property
    def preparation(self) -> PreparationParams | None:
        """The :class:`PreparationParams` in use (None for OpenSeqSLAM's preparation)."""
        return None if self._preparer is None else self._preparer.params

    def grey(self, image: np.ndarray) -> np.ndarray:
        """OpenSeqSLAM's step 1 on one frame: ``(H, W)`` uint8."""
        array = np.asarray(image)
        if array.ndim not in (2, 3) or 0 in array.shape:
            raise ValueError(f"a frame must be (H, W) or (H, W, 3|4), got shape {array.shape}")
        return _to_uint8(octave_rgb2gray(array, self.channel_order))

    def _openseqslam_stack(self, frames: Iterator[np.ndarray]) -> np.ndarray:
        greys: list[np.ndarray] = []
        for index, frame in enumerate(frames):
            try:
                grey = self.grey(frame)
            except (TypeError, ValueError) as error:
                raise type(error)(f"frame {index}: {error}") from None
            if greys and grey.shape != greys[0].shape:
                raise ValueError(
                    f"frame {index} is {grey.shape[0]}x{grey.shape[1]} pixels but frame 0 is "
                    f"{greys[0].shape[0]}x{greys[0].shape[1]}: OpenSeqSLAM's preparation does not resize; "
                    f"use preparation='nightloc' or resize the images"
                )
            greys.append(grey)
        if not greys:
            raise ValueError("no frames to prepare")
        return block_normalize(np.ascontiguousarray(np.stack(greys)), self.params.block_side)

    def prepare(self, images: ImageInput) -> np.ndarray:
        """Prepares one frame ``(H, W[, C])`` -> ``(h, w)`` or many (a stack ``(N, H, W[, C])``,
        an iterable of frames or a :class:`Traverse`, read lazily) -> ``(N, h, w)`` uint8."""
        if self._preparer is not None:
            return self._preparer.prepare(images)
        if isinstance(images, np.ndarray) and (images.ndim == 2 or (images.ndim == 3 and images.shape[2] in (3, 4))):
            return self._openseqslam_stack(iter([images]))[0]
        if isinstance(images, Traverse):
            frames: Iterator[np.ndarray] = (
                frame for _, frame in images.frames(batch_size=8, progress_desc=f"preparing {images.root.name}")
            )
        elif isinstance(images, np.ndarray):
            if images.ndim not in (3, 4):
                raise ValueError(f"a stack must be (N, H, W) or (N, H, W, 3|4), got shape {images.shape}")
            frames = iter(images)
        elif isinstance(images, (str, bytes)) or not isinstance(images, Iterable):
            raise TypeError(
                f"images must be a numpy array, an iterable of frames or a Traverse, got {type(images).__name__} "
                f"(load a folder with nightloc.load_traverse)"
            )
        else:
            frames = iter(images)
        return self._openseqslam_stack(frames)

    __call__ = prepare
