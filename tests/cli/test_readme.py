"""The README's two commands exist, and CI runs the README's test command."""

from __future__ import annotations

import re
import subprocess
import sys
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


def test_readme_python_examples_run_as_written(tmp_path):
    """Every ```python block of the README runs as written, alone in a fresh interpreter (as a
    reader pastes it; an import made by another block must not hide a missing one)."""
    readme = (ROOT / "README.md").read_text()
    blocks = [textwrap.dedent(block) for block in re.findall(r"```python\n(.*?)```", readme, flags=re.S)]
    assert len(blocks) >= 2
    for number, block in enumerate(blocks):
        script = tmp_path / f"readme_block_{number}.py"
        script.write_text(block)
        done = subprocess.run(
            [sys.executable, str(script)], cwd=tmp_path, capture_output=True, text=True, timeout=600, check=False
        )
        assert done.returncode == 0, f"README.md python block {number} failed:\n{block}\n{done.stderr[-3000:]}"


def test_readme_links_resolve_inside_the_repository():
    """Links of the README and docs/ point at files of the repository (no paths outside it)."""
    for page in [ROOT / "README.md", *sorted((ROOT / "docs").glob("*.md"))]:
        text = page.read_text()
        assert "../shared" not in text, page
        for target in re.findall(r"\]\(([^)#:]+)(?:#[^)]*)?\)", text):
            assert (page.parent / target).exists(), f"{page.name} links to a missing {target}"
