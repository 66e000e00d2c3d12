"""The import graph of python/nightloc: stages in layers, no cycles, io a leaf, thin commands.

Every import counts: module level, inside functions and methods, and under ``TYPE_CHECKING``.
Each module belongs to a *stage*: its first name under ``nightloc`` (``nightloc.io.traverse`` is in
``io``, ``nightloc.config`` is the stage ``config``). The allowed layering, lowest first (a stage
imports only stages of lower layers; stages of one layer do not import each other):

    _core, errors, _validate, progress,    the foundation: compiled core, errors, checks, progress,
    schema                                 the settings tables
    io                                     files: images, poses, videos, bags, traverses, map files
    config                                 TOML parameter files
    preparation
    matching
    motion                                 odometry and wheel noise, shared by the stages above
    mapping                                the reference map and the teach run
    localization, route
    experience                             experience maps
    node                                   the live ROS 2 node: messages, conventions, recordings
    synth
    studies
    figures
    commands                               one module per sub-command, plus shared options
    cli                                    the command line
    __main__, and the package nightloc itself

Besides the layering: no cycle between stages, no cycle between modules except those listed in
``ALLOWED_MODULE_CYCLES``, io imports only the foundation, and no sub-command module imports another.
docs/design.md draws the same layers.
"""

from __future__ import annotations

import ast
import collections
from collections.abc import Iterable
from pathlib import Path

import pytest

PACKAGE = Path(__file__).resolve().parents[1] / "python" / "nightloc"

#: The layers, lowest first.
LAYERS: tuple[tuple[str, ...], ...] = (
    ("_core", "errors", "_validate", "progress", "schema"),
    ("io",),
    ("config",),
    ("preparation",),
    ("matching",),
    ("motion",),
    ("mapping",),
    ("localization", "route"),
    ("experience",),
    ("node",),
    ("synth",),
    ("studies",),
    ("figures",),
    ("commands",),
    ("cli",),
    ("__main__", "nightloc"),
)
FOUNDATION = LAYERS[0]

#: Module cycles that stay, each closed by a function-level import inside one stage, with the reason.
ALLOWED_MODULE_CYCLES = {
    # ReferenceMap.build runs a teach run for a traverse without poses; the teach run makes a ReferenceMap.
    frozenset({"nightloc.mapping.reference_map", "nightloc.mapping.teach"}),
}

#: Modules of commands/ that are not sub-commands: what the sub-commands share.
COMMAND_HELPERS = ("nightloc.commands.options", "nightloc.commands.wording")

Edge = tuple[str, str, int, bool]  # importer, imported module, line, at module level


def module_names(package: Path) -> dict[str, Path]:
    """Dotted name -> file of every module under ``package`` (a package's __init__ is its name)."""
    names = {}
    for file in sorted(package.rglob("*.py")):
        parts = list(file.relative_to(package.parent).with_suffix("").parts)
        if parts[-1] == "__init__":
            parts.pop()
        names[".".join(parts)] = file
    return names


def import_edges(package: Path, compiled: Iterable[str] = ()) -> list[Edge]:
    """Every import of a module of ``package`` by one of its modules, at any depth of the AST.

    ``compiled``: dotted names of extension modules (no .py file) that count as modules.
    ``from a import b`` is an import of ``a.b`` when that is a module, else of ``a``."""
    names = module_names(package)
    known = set(names) | set(compiled)
    root = package.name
    edges: list[Edge] = []
    for name, file in names.items():
        tree = ast.parse(file.read_text(encoding="utf-8"), str(file))
        top_level = {id(node) for node in tree.body}
        here = name if file.name == "__init__.py" else name.rpartition(".")[0]
        for node in ast.walk(tree):
            if isinstance(node, ast.Import):
                targets = [alias.name for alias in node.names]
            elif isinstance(node, ast.ImportFrom):
                if node.level:
                    base = here.split(".")[: len(here.split(".")) - node.level + 1]
                    source = ".".join(base + ([node.module] if node.module else []))
                else:
                    source = node.module or ""
                targets = [
                    f"{source}.{alias.name}" if f"{source}.{alias.name}" in known else source for alias in node.names
                ]
            else:
                continue
            for target in targets:
                if target == root or target.startswith(root + "."):
                    edges.append((name, target, node.lineno, id(node) in top_level))
    return edges


def stage_of(module: str) -> str:
    """``nightloc.io.traverse`` -> ``io``; ``nightloc`` -> ``nightloc``."""
    parts = module.split(".")
    return parts[1] if len(parts) > 1 else parts[0]


def cycles(graph: dict[str, set[str]]) -> list[list[str]]:
    """The strongly connected components of more than one node (Tarjan), each sorted."""
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    on_stack: set[str] = set()
    found: list[list[str]] = []

    def visit(node: str) -> None:
        index[node] = low[node] = len(index)
        stack.append(node)
        on_stack.add(node)
        for other in sorted(graph.get(node, ())):
            if other not in index:
                visit(other)
                low[node] = min(low[node], low[other])
            elif other in on_stack:
                low[node] = min(low[node], index[other])
        if low[node] == index[node]:
            component = []
            while True:
                top = stack.pop()
                on_stack.discard(top)
                component.append(top)
                if top == node:
                    break
            if len(component) > 1:
                found.append(sorted(component))

    for node in sorted(set(graph) | {n for targets in graph.values() for n in targets}):
        if node not in index:
            visit(node)
    return found


def stage_graph(edges: list[Edge]) -> dict[str, set[str]]:
    graph: dict[str, set[str]] = collections.defaultdict(set)
    for importer, imported, _, _ in edges:
        if stage_of(importer) != stage_of(imported):
            graph[stage_of(importer)].add(stage_of(imported))
    return graph


def module_graph(edges: list[Edge]) -> dict[str, set[str]]:
    graph: dict[str, set[str]] = collections.defaultdict(set)
    for importer, imported, _, _ in edges:
        # a package's __init__ importing its own modules is how packages are made, not a cycle
        if importer != imported and not imported.startswith(importer + "."):
            graph[importer].add(imported)
    return graph


def layering_violations(edges: list[Edge], layers: tuple[tuple[str, ...], ...]) -> list[str]:
    """Each import of a stage that is not in a lower layer, as ``file:line importer -> imported``."""
    rank = {stage: level for level, members in enumerate(layers) for stage in members}
    wrong = []
    for importer, imported, line, _ in edges:
        a, b = stage_of(importer), stage_of(imported)
        if a == b:
            continue
        if a not in rank or b not in rank:
            wrong.append(f"{importer}:{line} -> {imported} (stage {a if a not in rank else b} is in no layer)")
        elif rank[b] >= rank[a]:
            wrong.append(f"{importer}:{line} -> {imported} ({a} may not import {b})")
    return wrong


def _edges_between(edges: list[Edge], members: list[str], key) -> list[str]:
    inside = set(members)
    return [
        f"{i}:{line} -> {t}" for i, t, line, _ in edges if key(i) in inside and key(t) in inside and key(i) != key(t)
    ]


@pytest.fixture(scope="module")
def edges() -> list[Edge]:
    return import_edges(PACKAGE, compiled=["nightloc._core"])


def test_every_stage_is_in_a_layer(edges):
    stages = {stage_of(module) for module in module_names(PACKAGE)} | {"_core"}
    placed = {stage for layer in LAYERS for stage in layer}
    assert stages <= placed, f"stages in no layer of LAYERS: {sorted(stages - placed)}"


def test_stages_import_only_lower_layers(edges):
    assert layering_violations(edges, LAYERS) == []


def test_no_cycle_between_stages(edges):
    found = cycles(stage_graph(edges))
    assert found == [], "\n".join(f"{cycle}: {_edges_between(edges, cycle, stage_of)}" for cycle in found)


def test_no_cycle_between_modules(edges):
    found = [cycle for cycle in cycles(module_graph(edges)) if frozenset(cycle) not in ALLOWED_MODULE_CYCLES]
    assert found == [], "\n".join(f"{cycle}: {_edges_between(edges, cycle, lambda m: m)}" for cycle in found)


def test_the_allowed_module_cycles_exist_and_close_inside_functions(edges):
    """An allowed cycle that is gone is taken off the list; the one import that closes it is a
    function-level import inside its stage."""
    found = {frozenset(cycle) for cycle in cycles(module_graph(edges))}
    for allowed in ALLOWED_MODULE_CYCLES:
        assert allowed in found, f"{sorted(allowed)} is no longer a cycle: take it off ALLOWED_MODULE_CYCLES"
        assert len({stage_of(module) for module in allowed}) == 1
        inner = [(i, t, top) for i, t, _, top in edges if i in allowed and t in allowed and i != t]
        assert any(not top for _, _, top in inner), inner


def test_io_imports_no_other_stage(edges):
    wrong = [
        f"{importer}:{line} -> {imported}"
        for importer, imported, line, _ in edges
        if stage_of(importer) == "io" and stage_of(imported) not in ("io", *FOUNDATION)
    ]
    assert wrong == []


def test_no_command_imports_another(edges):
    from nightloc.cli import COMMAND_MODULES

    helpers_and_commands = {m for m in module_names(PACKAGE) if stage_of(m) == "commands" and m.count(".") == 2}
    assert helpers_and_commands == set(COMMAND_MODULES) | set(COMMAND_HELPERS), "a module of commands/ is neither"
    wrong = [
        f"{importer}:{line} -> {imported}"
        for importer, imported, line, _ in edges
        if importer in COMMAND_MODULES and imported != importer and imported in COMMAND_MODULES
    ]
    assert wrong == []


def test_the_helpers_import_no_command(edges):
    from nightloc.cli import COMMAND_MODULES

    wrong = [f"{i}:{line} -> {t}" for i, t, line, _ in edges if i in COMMAND_HELPERS and t in COMMAND_MODULES]
    assert wrong == []


# --- the checks themselves, on a small made-up package


def _write(root: Path, files: dict[str, str]) -> Path:
    for name, text in files.items():
        path = root / "nightloc" / name
        path.parent.mkdir(parents=True, exist_ok=True)
        path.write_text(text)
    return root / "nightloc"


def test_the_checks_find_a_function_level_cycle_and_an_io_import(tmp_path):
    package = _write(
        tmp_path,
        {
            "__init__.py": "",
            "io/__init__.py": "",
            "io/files.py": "def read():\n    from ..matching.sad import match\n    return match\n",
            "matching/__init__.py": "",
            "matching/sad.py": "from ..io.files import read\n\ndef match():\n    pass\n",
            "matching/simd.py": "from typing import TYPE_CHECKING\nif TYPE_CHECKING:\n    from .sad import match\n",
        },
    )
    edges = import_edges(package)
    assert ("nightloc.io.files", "nightloc.matching.sad", 2, False) in edges
    assert ("nightloc.matching.sad", "nightloc.io.files", 1, True) in edges
    assert ("nightloc.matching.simd", "nightloc.matching.sad", 3, False) in edges
    assert cycles(stage_graph(edges)) == [["io", "matching"]]
    assert cycles(module_graph(edges)) == [["nightloc.io.files", "nightloc.matching.sad"]]
    layers = (("io",), ("matching",))
    assert layering_violations(edges, layers) == [
        "nightloc.io.files:2 -> nightloc.matching.sad (io may not import matching)"
    ]


def test_the_checks_pass_a_layered_package_and_resolve_from_imports(tmp_path):
    package = _write(
        tmp_path,
        {
            "__init__.py": "from . import matching\nfrom .io import files\n",
            "io/__init__.py": "from .files import read\n",
            "io/files.py": "import os\n\ndef read():\n    return os\n",
            "matching/__init__.py": "from .. import io\nfrom ..io import read\n",
        },
    )
    edges = import_edges(package)
    assert {(i, t) for i, t, _, _ in edges} == {
        ("nightloc", "nightloc.matching"),
        ("nightloc", "nightloc.io.files"),
        ("nightloc.io", "nightloc.io.files"),
        ("nightloc.matching", "nightloc.io"),
    }
    assert cycles(stage_graph(edges)) == [] and cycles(module_graph(edges)) == []
    assert layering_violations(edges, (("io",), ("matching",), ("nightloc",))) == []
    assert layering_violations(edges, (("matching",), ("io",), ("nightloc",))) != []
