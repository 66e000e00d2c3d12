"""Progress bars for long loads and evaluations.

Uses tqdm when it is installed; otherwise a minimal bar on stderr. Bars only draw when stderr is
a terminal (or ``NIGHTLOC_PROGRESS=1``); ``NIGHTLOC_PROGRESS=0`` silences them.
"""

from __future__ import annotations

import os
import sys
import time
from collections.abc import Iterable, Iterator
from typing import TypeVar

T = TypeVar("T")

__all__ = ["progress"]


def _enabled() -> bool:
    setting = os.environ.get("NIGHTLOC_PROGRESS")
    if setting is not None:
        return setting not in ("0", "", "false", "no")
    return sys.stderr.isatty()


def progress(iterable: Iterable[T], total: int | None = None, desc: str = "", unit: str = "it") -> Iterator[T]:
    """Yields the items of ``iterable`` while drawing a progress bar on stderr."""
    if not _enabled():
        yield from iterable
        return
    if total is None and hasattr(iterable, "__len__"):
        total = len(iterable)  # type: ignore[arg-type]
    try:
        from tqdm import tqdm  # optional
    except ImportError:
        tqdm = None
    if tqdm is not None:
        yield from tqdm(iterable, total=total, desc=desc, unit=unit, file=sys.stderr, leave=False)
        return
    start = last = time.monotonic()
    count = 0
    for item in iterable:
        yield item
        count += 1
        now = time.monotonic()
        if now - last >= 0.2 or count == total:
            last = now
            rate = count / max(now - start, 1e-9)
            if total:
                filled = int(30 * count / total)
                bar = "#" * filled + "-" * (30 - filled)
                sys.stderr.write(f"\r{desc} [{bar}] {count}/{total} {unit} ({rate:.1f}/s)")
            else:
                sys.stderr.write(f"\r{desc} {count} {unit} ({rate:.1f}/s)")
            sys.stderr.flush()
    if count:
        sys.stderr.write("\r" + " " * 79 + "\r")
        sys.stderr.flush()
