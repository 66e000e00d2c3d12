"""Writes docs/settings.md: every parameter table's fields -- TOML key, type, default, range, unit
and meaning -- from the settings schema (nightloc.schema: the core's tables for the fields the
compiled core holds, the dataclasses for Python's own). tests/test_settings_schema.py checks that
the page is what this writes.

    python tools/settings_tables.py            # rewrites docs/settings.md
    python tools/settings_tables.py --check    # exit status 1 when the page is stale
"""

from __future__ import annotations

import argparse
import re
import sys
from pathlib import Path

import nightloc  # noqa: F401  (registers every [section])
from nightloc.config import registered_sections, toml_value
from nightloc.schema import settings_schema

PAGE = Path(__file__).resolve().parents[1] / "docs" / "settings.md"

#: The tables in the page's order, with what each sets.
SECTIONS = {
    "preparation": "how camera frames become the small normalized images (`PreparationParams`)",
    "localization": "the 2D localizer's grid and the paper's sequences (`LocalizationParams`)",
    "filter": "the grid Bayes filter (`FilterParams`)",
    "learning": "what a night may teach a map (`LearningParams`)",
    "route": "route mode (`RouteParams`)",
    "teach": "the teach run (`TeachParams`)",
}


def _cell(text: str) -> str:
    """Docstring text as a Markdown cell: roles (:data:`~x.Y`) and double backquotes as code."""
    text = re.sub(r":[a-z]+:`~?([^`]+)`", lambda m: f"`{m.group(1).rsplit('.', 1)[-1]}`", str(text))
    return text.replace("``", "`").replace("|", "\\|")


def section_table(section: str) -> str:
    """The Markdown table of one ``[section]``."""
    cls = registered_sections()[section]
    lines = ["| key | type | default | values | meaning |", "| --- | --- | --- | --- | --- |"]
    for setting in settings_schema(cls):
        default = "(none)" if setting.default is None else f"`{_cell(toml_value(setting.default))}`"
        values = "" if setting.kind == "value" and setting.range is None else setting.range_text
        held = f" (core: `{setting.core}`)" if setting.core else ""
        lines.append(
            f"| `{setting.name}` | {_cell(setting.type)} | {default} | {_cell(values)} | {_cell(setting.doc)}{held} |"
        )
    return "\n".join(lines)


def page() -> str:
    """docs/settings.md's text."""
    parts = [
        "# Settings: every parameter table",
        "",
        "<!-- Written by tools/settings_tables.py from the settings schema; do not edit by hand. -->",
        "",
        "Each table of a parameter file (`--params FILE`, `nightloc.load_params`) and each key that",
        "`--set SECTION.KEY=VALUE` gives. A field the compiled core holds takes its default, range, unit",
        "and meaning from the core's table (`nightloc/settings.hpp`; named in brackets); the others are",
        "Python's (`nightloc.schema`). A value outside its range is refused with these words, e.g.",
        "`[filter] uniform_floor must be in [0, 1), got 1.5`. How a setting is added:",
        "[design](design.md#the-parameter-path-python--core).",
        "",
    ]
    for section, what in SECTIONS.items():
        parts += [f"## `[{section}]`: {what}", "", section_table(section), ""]
    ours = {name for name, cls in registered_sections().items() if cls.__module__.startswith("nightloc.")}
    missing = sorted(ours - set(SECTIONS))
    if missing:
        raise SystemExit(f"tools/settings_tables.py: sections without a place in the page: {missing}")
    return "\n".join(parts)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--check", action="store_true", help="exit 1 when docs/settings.md is stale")
    args = parser.parse_args(argv)
    text = page()
    if args.check:
        return 0 if PAGE.read_text(encoding="utf-8") == text else 1
    PAGE.write_text(text, encoding="utf-8")
    sys.stdout.write(f"wrote {PAGE}\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())
