"""The README's two commands exist, and CI runs the README's test command."""

from __future__ import annotations

import re
import textwrap
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]


def test_readme_has_the_two_commands_and_ci_uses_the_test_command():
    readme = (ROOT / "README.md").read_text()
    blocks = re.findall(r"```bash\n(.*?)```", readme, flags=re.S)
    commands = [line for block in blocks for line in block.splitlines() if line.startswith("pip install")]
    main_command = "pip install . && nightloc demo"
    test_command = 'pip install ".[test]" && python -m pytest tests benchmarks --benchmark-disable'
    assert main_command in commands and test_command in commands
    ci = (ROOT / ".ci" / "run").read_text()
    assert "grep -m1 '^pip install \"\\.\\[test\\]\"' README.md" in ci
    assert 'eval "$test_command"' in ci


def test_readme_python_examples_run_as_written(tmp_path, monkeypatch):
    """Every ```python block of the README runs as written (on the synthetic default data)."""
    readme = (ROOT / "README.md").read_text()
    blocks = [textwrap.dedent(block) for block in re.findall(r"```python\n(.*?)```", readme, flags=re.S)]
    assert len(blocks) >= 2
    monkeypatch.chdir(tmp_path)
    for number, block in enumerate(blocks):
        exec(compile(block, f"README.md python block {number}", "exec"), {"__name__": "readme_example"})


def test_readme_links_resolve_inside_the_repository():
    """Links of the README and docs/ point at files of the repository (no paths outside it)."""
    for page in [ROOT / "README.md", *sorted((ROOT / "docs").glob("*.md"))]:
        text = page.read_text()
        assert "../shared" not in text, page
        for target in re.findall(r"\]\(([^)#:]+)(?:#[^)]*)?\)", text):
            assert (page.parent / target).exists(), f"{page.name} links to a missing {target}"
