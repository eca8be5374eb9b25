"""The README stays a page a user reads top to bottom, and its commands stay true.

- Its first code block is the two commands CI runs (install and run the museum; install
  and run the tests), with the pinned constraints.
- At most 200 lines, with no history: no "this week", issue numbers, commit hashes or
  benchmark tables (those live in CHANGELOG.md and on the documentation's benchmark page).
- It states the Python version pyproject requires and the license, and LICENSE says it.
- Every file it links to or names (``docs/...``, ``examples/...``) exists.
"""

from __future__ import annotations

import re
import tomllib
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent
README = (ROOT / "README.md").read_text(encoding="utf-8")
PYPROJECT = tomllib.loads((ROOT / "pyproject.toml").read_text(encoding="utf-8"))

HISTORY = re.compile(
    r"\b(this|last|next) (week|month|run)\b|\byesterday\b|\bissue #?\d+|(?<![\w/])#\d+\b"
    r"|\bcommit\b|\b(?=[0-9a-f]*\d)(?=[0-9a-f]*[a-f])[0-9a-f]{7,40}\b",
    re.I,
)
"""Words that date a page: relative weeks, issue numbers, commits and their hashes."""


def test_the_first_lines_give_the_run_and_test_commands_ci_uses() -> None:
    first_block = README.split("```")[1].strip().splitlines()
    assert len(first_block) == 2
    run, test = first_block
    assert re.match(r"python3? -m venv ", run) and re.match(r"python3? -m venv ", test)
    assert run.endswith("python -m htnagent run scenarios/museum.yaml")
    assert "python -m pytest" in test
    for command in first_block:
        assert "-c constraints.txt" in command, f"{command!r} does not install the pinned versions"
    ci = (ROOT / ".ci" / "run").read_text(encoding="utf-8")
    assert "grep -m1 -E '^python3? -m venv .*python -m pytest' README.md" in ci
    # What .ci/run's grep picks: the first such line, whole.
    picked = re.search(r"^python3? -m venv .*python -m pytest.*$", README, re.M)
    assert picked is not None and picked.group(0) == test


def test_the_readme_is_at_most_200_lines() -> None:
    lines = README.count("\n") + (not README.endswith("\n"))
    assert lines <= 200, f"README.md has {lines} lines; move the rest to the documentation site"


def test_the_readme_has_no_history() -> None:
    dated = [
        f"README.md:{n}: {m.group(0)!r}"
        for n, line in enumerate(README.splitlines(), start=1)
        for m in HISTORY.finditer(line)
    ]
    assert not dated, "history belongs in CHANGELOG.md:\n" + "\n".join(dated)


def test_the_readme_has_no_tables() -> None:
    # Benchmark and reliability tables live on the documentation's benchmark page.
    tables = [n for n, line in enumerate(README.splitlines(), start=1) if line.lstrip().startswith("|")]
    assert not tables, f"README.md has table rows at lines {tables}"


@pytest.mark.parametrize(
    "line",
    ["this week the planner got faster", "see issue 28", "fixed in #12", "as of commit 4b96bc0", "a1b2c3d4"],
)
def test_the_history_check_finds_dated_words(line: str) -> None:
    assert HISTORY.search(line)


@pytest.mark.parametrize(
    "line", ["an agent succeeded", "decided", "museum.yaml", "the cafe added 1234567 facts"]
)
def test_the_history_check_leaves_ordinary_words(line: str) -> None:
    assert not HISTORY.search(line)


def test_the_readme_states_the_python_version_pyproject_requires() -> None:
    required = PYPROJECT["project"]["requires-python"]
    version = re.fullmatch(r">=\s*(3\.\d+)", required)
    assert version is not None, required
    assert f"Python {version.group(1)} or newer" in README


def test_the_readme_and_license_file_state_pyprojects_license() -> None:
    license_name = PYPROJECT["project"]["license"]
    assert license_name == "MIT"
    assert "MIT" in README and "(LICENSE)" in README
    text = (ROOT / "LICENSE").read_text(encoding="utf-8")
    assert text.startswith("MIT License") and "the htnagent authors" in text


def test_every_file_the_readme_links_exists() -> None:
    targets = re.findall(r"\]\(([^)#\s]+)(?:#[^)]*)?\)", README)
    assert targets
    missing = [t for t in targets if "://" not in t and not (ROOT / t).exists()]
    assert not missing, f"README.md links to files that do not exist: {missing}"


def test_the_changelog_starts_with_this_version() -> None:
    from htnagent.version import VERSION

    headings = re.findall(r"^## (\S+)", (ROOT / "CHANGELOG.md").read_text(encoding="utf-8"), re.M)
    if headings[0] == "Unreleased":  # what the next release will bring, above this one
        headings = headings[1:]
    assert headings[0] == VERSION
    assert headings[-1] == "0.1.0"
