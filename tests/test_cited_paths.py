"""Every repository path that code, tests, tools, benchmarks, docs and the README cite exists
(comments and docstrings included): a moved or renamed file leaves no stale pointer behind."""

from __future__ import annotations

import re
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
#: The folders whose files are read, and the top-level folders a cited path starts with.
SCANNED = ("python", "cpp", "tests", "tools", "benchmarks", "docs")
#: Files read besides, from the root.
SCANNED_FILES = ("README.md",)
#: Files not read: the changelog records what was, with the paths of its day.
NOT_SCANNED = ("docs/changelog.md",)
TOP = ("docs", "cpp", "python", "tests", "tools", "benchmarks", ".ci")
SUFFIXES = {".py", ".pyi", ".cpp", ".hpp", ".txt", ".toml", ".cmake", ".md", ".sh"}
#: A path from the repository's root (``docs/<name>.md``, ``cpp/src/<stage>/<name>.cpp``), or from
#: the citing file's folder (CMake lists name their sources from cpp/).
_TOPS = "|".join(re.escape(t) for t in TOP)
CITED = re.compile(
    rf"(?<![\w./-])((?:{_TOPS})/[\w./-]*\w\.(?:md|py|pyi|cpp|hpp|txt|toml|csv|json|npz|png|sh|cmake))(?![\w/])"
)
#: ``nightloc/grid_filter.hpp`` in C++ comments: a public header under cpp/include.
HEADER = re.compile(r"(?<![\w./-])(nightloc/\w+\.hpp)\b")


def cited_paths(text: str) -> set[str]:
    """The repository paths ``text`` cites (public headers as their path under cpp/include)."""
    paths = set(CITED.findall(text))
    paths |= {f"cpp/include/{h}" for h in HEADER.findall(text)}
    return paths


def scanned_files() -> list[Path]:
    files = [ROOT / name for name in SCANNED_FILES]
    for folder in SCANNED:
        for path in sorted((ROOT / folder).rglob("*")):
            if path.is_file() and path.suffix in SUFFIXES and "__pycache__" not in path.parts:
                files.append(path)
    return [path for path in files if path.relative_to(ROOT).as_posix() not in NOT_SCANNED]


def test_the_pattern_finds_paths_and_skips_what_is_not_one():
    text = (
        "see docs/localization.md and cpp/src/route/route_filter.cpp; nightloc/heatmap.hpp; "
        "OUT/docs/x.md is an output, https://example.org/docs/a.md a link, and docs/ a folder"
    )
    assert cited_paths(text) == {
        "docs/localization.md",
        "cpp/src/route/route_filter.cpp",
        "cpp/include/nightloc/heatmap.hpp",
    }


@pytest.mark.skipif(not (ROOT / "cpp").is_dir(), reason="needs the source tree (cpp/ beside python/)")
def test_every_cited_repository_path_exists():
    stale = []
    for path in scanned_files():
        text = path.read_text(encoding="utf-8", errors="replace")
        for cited in sorted(cited_paths(text)):
            if not (ROOT / cited).exists() and not (path.parent / cited).exists():
                stale.append(f"{path.relative_to(ROOT)} cites {cited}")
    assert stale == []
