"""``--learn NEW_MAP``: ``nightloc localize`` also writes the map plus what the night taught it
(an experience map, :mod:`nightloc.mapping.experience`; docs/experience_maps.md)."""

from __future__ import annotations

import argparse
import os
from pathlib import Path

from ..io.atomic import check_output_path

__all__ = ["add_learn_options", "check_learn_target"]


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


def check_learn_target(target: Path, map_path: Path, out: Path, inputs: tuple, overwrite: bool) -> Path:
    """Fails before any work when NEW_MAP cannot be written: it is MAP (or inside an input), lies
    inside OUT, is a folder, or exists without ``overwrite``."""
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
    if target.resolve().is_relative_to(out.resolve()):
        raise ValueError(f"--learn {target} lies inside --out {out} (replaced as a whole): write it elsewhere")
    return check_output_path(target, overwrite=overwrite, inputs=inputs)
