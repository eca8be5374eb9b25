"""``python -m htnagent plan --hddl``: a fast start (only what planning needs is imported),
and the same answers as the full command line gives."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import pytest

HERE = Path(__file__).resolve().parent / "hddl"
ROOT = Path(__file__).resolve().parent.parent
DOMAIN, PROBLEM = str(HERE / "courier-domain.hddl"), str(HERE / "courier.hddl")
HEAVY = ("pydantic", "matplotlib", "anyio", "rich", "yaml", "htnagent.scenario", "htnagent.runtime")

PROBE = """\
import atexit, json, os, sys
watched = json.loads(sys.argv[1])
def said():
    heavy = [m for m in watched if m in sys.modules]
    sys.stderr.write("LOADED " + json.dumps(heavy) + "\\n")
    sys.stderr.flush()
atexit.register(said)
exit_now = os._exit
def said_and_exit(code):  # plan --hddl ends the process at once, without atexit
    said()
    sys.stderr.write(f"ENDED AT ONCE {code}\\n")
    sys.stderr.flush()
    exit_now(code)
os._exit = said_and_exit
sys.argv = ["htnagent", *sys.argv[2:]]
from htnagent.cli.launch import run
run()
"""


def _probe(*args: str) -> tuple[subprocess.CompletedProcess[str], list[str]]:
    done = subprocess.run(
        [sys.executable, "-c", PROBE, json.dumps(HEAVY), *args],
        capture_output=True,
        text=True,
        cwd=ROOT,
        timeout=60,
    )
    lines = [line for line in done.stderr.splitlines() if line.startswith("LOADED ")]
    assert lines, done.stderr
    return done, json.loads(lines[-1].removeprefix("LOADED "))


@pytest.mark.parametrize(
    "options", [["--format", "ipc"], ["--format", "json", "--tree"], ["--timeout", "30", "--search", "gbfs"]]
)
def test_plan_hddl_imports_only_what_planning_needs(options: list[str]) -> None:
    done, loaded = _probe("plan", "--hddl", DOMAIN, PROBLEM, *options)
    assert done.returncode == 0, done.stderr
    assert loaded == []


@pytest.mark.parametrize(("problem", "code"), [(PROBLEM, 0), (str(HERE / "courier-held.hddl"), 1)])
def test_plan_hddl_ends_its_process_at_once_its_answer_printed(problem: str, code: int) -> None:
    # No shutdown that frees a long search's objects one by one, past --timeout: the answer
    # is flushed, then the process ends (os._exit) with the command's code.
    done, _ = _probe("plan", "--hddl", DOMAIN, problem, "--format", "json")
    assert done.returncode == code
    assert f"ENDED AT ONCE {code}" in done.stderr
    if code == 0:
        assert json.loads(done.stdout)["plan"]
    # Other commands end as Python ends them.
    done, _ = _probe("check", "--hddl", DOMAIN, PROBLEM)
    assert done.returncode == 0 and "ENDED AT ONCE" not in done.stderr


def test_a_mistake_in_plan_hddl_is_worded_by_the_full_command_line() -> None:
    # Not the fast parser's own words: the full parser's, as before (and it may load the rest).
    done, _ = _probe("plan", "--hddl", DOMAIN, PROBLEM, "--format", "pddl")
    assert done.returncode == 2
    assert "htnagent: error: argument --format: invalid choice: 'pddl'" in done.stderr
    done, _ = _probe("plan", "--hddl", DOMAIN, PROBLEM, "--agent", "x")
    assert done.returncode == 2
    assert "plan --hddl takes no --agent or --task" in done.stderr


def test_the_fast_start_and_the_full_command_line_print_the_same() -> None:
    fast = subprocess.run(
        [sys.executable, "-m", "htnagent", "plan", "--hddl", DOMAIN, PROBLEM, "--format", "ipc"],
        capture_output=True,
        text=True,
        cwd=ROOT,
        timeout=60,
    )
    assert fast.returncode == 0, fast.stderr
    full_main = "import sys; from htnagent.cli.commands import main; sys.exit(main())"
    full = subprocess.run(
        [sys.executable, "-c", full_main, "plan", "--hddl", DOMAIN, PROBLEM, "--format", "ipc"],
        capture_output=True,
        text=True,
        cwd=ROOT,
        timeout=60,
    )
    assert full.returncode == 0, full.stderr
    assert fast.stdout == full.stdout
    assert fast.stdout.startswith("==>\n")


def test_a_bad_hddl_file_is_one_line_on_the_fast_path(tmp_path: Path) -> None:
    bad = tmp_path / "bad.hddl"
    bad.write_text("(define (domain d) (:action a :parameters (?x)")
    done, loaded = _probe("plan", "--hddl", str(bad), PROBLEM)
    assert done.returncode == 2
    errors = [line for line in done.stderr.splitlines() if not line.startswith(("LOADED ", "ENDED AT ONCE "))]
    assert len(errors) == 1 and errors[0].startswith(f"htnagent: error: {bad}:")
    assert "Traceback" not in done.stderr
    assert loaded == []
