"""The README's examples and commands stay true."""

from __future__ import annotations

import contextlib
import io
import re
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
README = (ROOT / "README.md").read_text()


def test_the_planning_example_prints_what_the_readme_says() -> None:
    block = re.search(r"```python\n(from htnagent import Domain, parse, plan\n.*?)```", README, re.S)
    assert block is not None
    code = block.group(1)
    promised = re.search(r"# (PlanStatus\.SOLVED .*)", code)
    assert promised is not None
    out = io.StringIO()
    with contextlib.redirect_stdout(out):
        exec(compile(code, "README.md", "exec"), {})
    assert out.getvalue().strip() == promised.group(1).strip()


def test_the_first_lines_give_the_run_and_test_commands_ci_uses() -> None:
    first_block = README.split("```")[1].strip().splitlines()
    assert len(first_block) == 2
    run, test = first_block
    assert run.endswith("python -m htnagent run scenarios/museum.yaml")
    assert "python -m pytest" in test
    assert "python -m pytest" in (ROOT / ".ci" / "run").read_text()
