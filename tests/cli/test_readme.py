"""The README's two commands exist, and CI runs the README's test command."""

from __future__ import annotations

import re
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
