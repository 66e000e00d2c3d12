"""The registries answer, and nobody restates them: the route motion models, the SIMD paths, the
summary and errors columns, the ROS image encodings and the constants shared with the core.

Code, tests and docstrings name a registry's entries through it; a line that lists two or more
entries of one (``"window", "speed"``, ``sse2, avx2``, ``median_m,mean_m``) outside the places that
define them fails here. The user's pages (README.md, docs/) may list them, and are checked equal.
"""

from __future__ import annotations

import re
from pathlib import Path

import pytest

import nightloc
from nightloc import _core
from nightloc.io.bag import IMAGE_ENCODINGS
from nightloc.io.map_file import DAY_MAP_FORMAT_VERSION, MAP_FORMAT_VERSION
from nightloc.localization.evaluation import ERRORS_HEADER, SUMMARY_HEADER
from nightloc.matching.simd import ALL_BACKENDS, SIMD_PATHS
from nightloc.route.params import DISTANCE_MOTIONS, MOTION_MODELS, ODOMETRY_MOTION

ROOT = Path(__file__).resolve().parents[1]

#: Registry -> its entries.
REGISTRIES = {
    "route motion models": MOTION_MODELS,
    "SIMD paths": ALL_BACKENDS,
    "summary columns": SUMMARY_HEADER,
    "errors columns": ERRORS_HEADER,
    "image encodings": tuple(IMAGE_ENCODINGS),
}

#: Files that define a registry, or hold an independent model of one, and why.
DEFINED_IN = {
    "python/nightloc/io/bag.py": "IMAGE_ENCODINGS",
    "python/nightloc/localization/evaluation.py": "ERRORS_COLUMNS, SUMMARY_COLUMNS",
    "tests/route_oracle.py": "the numpy oracle's own models (MOTIONS), checked against the registry",
    "tests/test_registries.py": "this file",
    "python/nightloc/_core.pyi": "Literal choices, checked against the tables (tests/test_settings_schema.py)",
}


def _entries_in(line: str, entries: tuple[str, ...]) -> list[str]:
    """The entries named in ``line`` as words (quoted or bare, separated by , | or spaces)."""
    found = []
    for entry in entries:
        if len(entry) < 4:
            continue  # too short to tell from prose ("n")
        if re.search(rf"(?<![\w-]){re.escape(entry)}(?![\w-])", line):
            found.append(entry)
    return found


def _listing(line: str, entries: tuple[str, ...]) -> bool:
    """Whether ``line`` lists entries of one registry: two quoted ones joined by a comma
    (``"window", "speed"``), two joined by ``,`` or ``|`` without spaces (``median_m,mean_m``,
    ``window|speed``), or three in a row in prose (``sse2, avx2, avx512bw``)."""
    named = _entries_in(line, entries)
    if len(named) < 2:
        return False
    alternatives = "|".join(re.escape(e) for e in sorted(named, key=len, reverse=True))
    word = rf"(?<![\w-])(?:{alternatives})(?![\w-])"
    quoted = rf"([\"'`])(?:{alternatives})\1"
    return bool(
        re.search(rf"{quoted}\s*,\s*{quoted}", line)
        or re.search(rf"{word}[,|]{word}", line)
        or re.search(rf"{word}, {word}, (?:or |and )?{word}", line)
    )


@pytest.mark.parametrize("tree", ["python", "tests", "benchmarks", "tools"])
def test_no_registry_is_restated_in_code_tests_or_docstrings(tree):
    restated = []
    for path in sorted((ROOT / tree).rglob("*.py*")):
        relative = str(path.relative_to(ROOT))
        if path.suffix not in (".py", ".pyi") or relative in DEFINED_IN:
            continue
        for number, line in enumerate(path.read_text(encoding="utf-8").splitlines(), 1):
            for name, entries in REGISTRIES.items():
                if _listing(line, entries):
                    restated.append(f"{relative}:{number}: {name}: {line.strip()}")
    assert not restated, "ask the registry instead:\n" + "\n".join(restated)


def test_the_listing_finder_against_known_lines():
    assert _listing('choices=("window", "speed", "odometry")', MOTION_MODELS)
    assert _listing("--motion window|speed|odometry", MOTION_MODELS)
    assert _listing("seq_len,noise_model,interpolation", SUMMARY_HEADER)
    assert not _listing("the speed model moves by the distance travelled (odometry)", MOTION_MODELS)
    assert not _listing('motion = "speed"', MOTION_MODELS)
    assert not _listing("errors(seq_len=n, noise_model=m, interpolation=i, query=q)", ERRORS_HEADER)
    assert _listing("sse2, avx2, avx512bw", ALL_BACKENDS)


def _stated(text: str, after: str) -> tuple[str, ...]:
    """The comma-separated names in backquotes that follow ``after`` in ``text``."""
    match = re.search(re.escape(after) + r"`?[^`]*`([a-z_0-9]+(?:,[a-z_0-9]+)+)`", text)
    assert match, after
    return tuple(match.group(1).split(","))


@pytest.mark.parametrize("page", ["README.md", "docs/localization.md"])
def test_the_users_pages_state_the_columns_of_the_registry(page):
    text = (ROOT / page).read_text(encoding="utf-8")
    assert _stated(text, "errors.csv") == ERRORS_HEADER
    assert _stated(text, "summary.csv") == SUMMARY_HEADER


def test_the_route_page_names_the_registrys_models():
    text = (ROOT / "docs" / "route_mode.md").read_text(encoding="utf-8")
    for usage in re.findall(r"--motion ([a-z|]+)", text):
        if "|" in usage:
            assert tuple(usage.split("|")) == MOTION_MODELS


def test_the_registries_answer():
    models = _core.route_motion_models()
    assert tuple(m["name"] for m in models) == MOTION_MODELS == tuple(_core.route_motion_names())
    assert {m["name"] for m in models if m["needs_distances"]} == DISTANCE_MOTIONS
    assert ODOMETRY_MOTION in DISTANCE_MOTIONS
    assert tuple(p.name for p in SIMD_PATHS) == ALL_BACKENDS
    available = set(nightloc.available_simd_backends())
    assert {p.name for p in SIMD_PATHS if p.supported} == available
    assert all(p.compiled for p in SIMD_PATHS if p.supported)
    assert {p.architecture for p in SIMD_PATHS} <= {"any", "x86-64", "aarch64"}
    assert SIMD_PATHS[0].name == "scalar" == nightloc.available_simd_backends()[0]


def test_constants_shared_with_the_core_are_the_cores():
    assert (MAP_FORMAT_VERSION, DAY_MAP_FORMAT_VERSION) == (_core.MAP_FORMAT_VERSION, _core.DAY_MAP_FORMAT_VERSION)
    assert DAY_MAP_FORMAT_VERSION < MAP_FORMAT_VERSION
    noise = nightloc.WHEEL_ODOMETRY_NOISE
    assert (noise.distance_std, noise.heading_std, noise.distance_per_metre, noise.heading_per_radian) == tuple(
        _core.WHEEL_ODOMETRY_NOISE
    )
