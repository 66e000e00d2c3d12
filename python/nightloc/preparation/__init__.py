"""Image preparation (paper III-A, eq. 1): camera frames to small patch-normalized images.

* :mod:`~nightloc.preparation.params` — :class:`PreparationParams` (paper Table II defaults);
* :mod:`~nightloc.preparation.normalize` — :func:`patch_normalize` (eq. 1), :func:`block_normalize`;
* :mod:`~nightloc.preparation.downsample` — exact area downsampling, 16-bit equalization;
* :mod:`~nightloc.preparation.preparer` — :class:`Preparer` / :func:`prepare`: the whole chain.
"""

from __future__ import annotations

from .normalize import DEFAULT_PATCH_SCALE, MAX_PATCH_RADIUS, block_normalize, patch_normalize
from .params import PreparationParams
from .preparer import Preparer, prepare

__all__ = [
    "DEFAULT_PATCH_SCALE",
    "MAX_PATCH_RADIUS",
    "PreparationParams",
    "Preparer",
    "block_normalize",
    "patch_normalize",
    "prepare",
]
