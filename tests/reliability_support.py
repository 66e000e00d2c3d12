"""Shared pieces of the reliability tests: a small on-disk workspace of good and broken files.

:class:`Workspace` writes one small traverse (6 BGR frames of 30x60 pixels with poses and
headings) and its reference map once, and makes broken variants of them on demand: a CSV with a
missing column, a zero-byte image, a truncated map, a map with other parameters or another
format version, ... Every variant lives in its own folder, so cases never disturb each other.
"""

from __future__ import annotations

import json
import shutil
from collections.abc import Iterable
from pathlib import Path

import numpy as np

import nightloc

FRAMES = 6
FRAME_SHAPE = (30, 60, 3)


def random_frames(n: int, seed: int = 0, shape=FRAME_SHAPE) -> list:
    """``n`` smooth random BGR frames (uint8), distinct enough to match to themselves."""
    rng = np.random.default_rng(seed)
    frames = []
    for _ in range(n):
        coarse = rng.integers(0, 256, (shape[0] // 5 + 1, shape[1] // 5 + 1, *tuple(shape[2:])), dtype=np.uint8)
        frames.append(
            np.ascontiguousarray(
                np.kron(coarse, np.ones((5, 5) + (1,) * (len(shape) - 2), np.uint8))[: shape[0], : shape[1]]
            )
        )
    return frames


class Workspace:
    """A folder of good inputs and a factory of broken ones (see the module docstring)."""

    def __init__(self, root: Path):
        self.root = Path(root)
        self.frames = random_frames(FRAMES)
        rng = np.random.default_rng(1)
        self.positions = rng.uniform(0, 5, (FRAMES, 2))
        self.headings = rng.uniform(-3, 3, FRAMES)
        self.traverse = nightloc.save_traverse(self.root / "trav", self.frames, self.positions, self.headings)
        self.map = nightloc.ReferenceMap.build(self.traverse)
        self.map_file = self.map.save(self.root / "good.map")
        self.names = list(self.traverse.names)
        self.text_file = self.root / "notes.txt"
        self.text_file.write_text("not an image, not a map\n")
        self._count = 0

    # --- names

    def fresh(self, stem: str = "case") -> Path:
        """A path that does not exist yet, inside the workspace."""
        self._count += 1
        return self.root / f"{stem}_{self._count}"

    def write(self, name: str, data: str | bytes) -> Path:
        """Writes ``data`` to a new file named like ``name``; returns its path."""
        path = self.fresh(Path(name).stem).with_suffix(Path(name).suffix)
        path.write_bytes(data.encode("utf-8") if isinstance(data, str) else data)
        return path

    # --- traverses

    def pose_rows(self, header: str = "image,x,y,heading") -> str:
        rows = [header] + [
            f"{n},{float(x)!r},{float(y)!r},{float(h)!r}"
            for n, (x, y), h in zip(self.names, self.positions, self.headings)
        ]
        return "\n".join(rows) + "\n"

    def traverse_variant(
        self,
        csv: str | bytes | None = None,
        images: dict[str, bytes] | None = None,
        remove: Iterable[str] = (),
    ) -> Path:
        """A copy of the good traverse with ``poses.csv`` replaced, image files overwritten and
        entries (relative paths) removed."""
        root = self.fresh("trav")
        shutil.copytree(self.traverse.root, root)
        if csv is not None:
            (root / "poses.csv").write_bytes(csv.encode("utf-8") if isinstance(csv, str) else csv)
        for name, data in (images or {}).items():
            (root / "images" / name).write_bytes(data)
        for relative in remove:
            entry = root / relative
            shutil.rmtree(entry) if entry.is_dir() else entry.unlink()
        return root

    # --- maps

    def map_bytes(self) -> bytes:
        return self.map_file.read_bytes()

    def map_variant(
        self,
        header_changes: dict | None = None,
        arrays: dict | None = None,
        raw_header: bytes | None = None,
        drop: Iterable[str] = (),
    ) -> Path:
        """A copy of the good map with header fields changed, arrays replaced or dropped."""
        with np.load(self.map_file) as archive:
            members = {name: archive[name] for name in archive.files}
        header = json.loads(members["header"].tobytes())
        header.update(header_changes or {})
        members["header"] = np.frombuffer(
            raw_header if raw_header is not None else json.dumps(header).encode(), dtype=np.uint8
        )
        members.update(arrays or {})
        for name in drop:
            members.pop(name)
        path = self.fresh("map").with_suffix(".map")
        with open(path, "wb") as stream:
            np.savez(stream, **members)
        return path
