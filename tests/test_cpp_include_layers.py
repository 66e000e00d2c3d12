"""The C++ core's folders include each other without cycles: ``cpp/src/<stage>/`` files include
internal headers from ``src/``'s root (``"matching/sad_kernels.hpp"``), and the graph of which
folder includes which is acyclic, so each stage can be read (and built) on what lies below it."""

from __future__ import annotations

import re
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
SRC = ROOT / "cpp" / "src"
INCLUDE = re.compile(r'^\s*#\s*include\s+"([^"]+)"', re.M)


def folder_graph(src: Path) -> dict[str, set[str]]:
    """Folder -> the other folders of ``src`` whose headers its files include (sub-folders such
    as ``matching/x86`` count as their stage)."""
    stages = {path.name for path in src.iterdir() if path.is_dir()}
    graph: dict[str, set[str]] = {stage: set() for stage in stages}
    for source in src.rglob("*"):
        if source.suffix not in (".cpp", ".hpp") or not source.is_file():
            continue
        stage = source.relative_to(src).parts[0]
        for included in INCLUDE.findall(source.read_text(encoding="utf-8")):
            target = included.split("/")[0]
            if target in stages and target != stage:
                graph[stage].add(target)
    return graph


def find_cycle(graph: dict[str, set[str]]) -> list[str] | None:
    """One cycle of ``graph`` as a list of nodes (first == last), or None."""
    state: dict[str, int] = {}  # 1: on the path, 2: done
    path: list[str] = []

    def visit(node: str) -> list[str] | None:
        state[node] = 1
        path.append(node)
        for target in sorted(graph[node]):
            if state.get(target) == 1:
                return [*path[path.index(target) :], target]
            if target not in state:
                found = visit(target)
                if found:
                    return found
        state[node] = 2
        path.pop()
        return None

    for node in sorted(graph):
        if node not in state:
            found = visit(node)
            if found:
                return found
    return None


def test_the_cycle_finder_against_known_graphs():
    assert find_cycle({"a": {"b"}, "b": {"c"}, "c": set()}) is None
    assert find_cycle({"a": {"b"}, "b": {"a"}}) == ["a", "b", "a"]
    assert find_cycle({"a": {"b"}, "b": {"c"}, "c": {"b"}, "d": {"a"}}) == ["b", "c", "b"]


def test_the_graph_reads_includes_by_folder(tmp_path):
    for name, text in {
        "common/x.hpp": '#include <vector>\n#include "nightloc/simd.hpp"\n',
        "matching/x86/k.cpp": '#include "common/x.hpp"\n#include "matching/y.hpp"\n',
        "dispatch/t.cpp": ' #  include "matching/y.hpp"\n',
    }.items():
        (tmp_path / name).parent.mkdir(parents=True, exist_ok=True)
        (tmp_path / name).write_text(text)
    assert folder_graph(tmp_path) == {"common": set(), "matching": {"common"}, "dispatch": {"matching"}}


@pytest.mark.skipif(not SRC.is_dir(), reason="needs the source tree (cpp/src beside python/)")
def test_cpp_folders_include_each_other_without_cycles():
    graph = folder_graph(SRC)
    assert find_cycle(graph) is None, f"the cpp/src folders include each other in a circle: {find_cycle(graph)}"
    assert graph["common"] == set(), "common/ is the bottom layer: it includes no other folder"
    assert not any("dispatch" in targets for targets in graph.values()), "no folder includes dispatch/"
