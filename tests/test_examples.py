"""Every program in ``examples/`` runs as a user runs it, and says what it promises.

Each example is started as its own process from the repository root (the way
``examples/README.md`` says to run it), all at once so that the file costs a few
seconds; each test then reads its example's exit code and a key line of its output.
The examples use the public names only (``from htnagent import ...``), and the
README lists every one.
"""

from __future__ import annotations

import ast
import json
import subprocess
import sys
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path

import pytest

import htnagent

ROOT = Path(__file__).resolve().parents[1]
EXAMPLES = ROOT / "examples"
OWN_MAP = "examples/own_map/scenario.yaml"
WITHIN = 50.0
"""Seconds an example may take on a loaded machine (each takes about one, mostly imports)."""

COMMANDS: dict[str, list[str]] = {
    "embed_asyncio": [sys.executable, "examples/embed_asyncio.py"],
    "embed_trio": [sys.executable, "examples/embed_trio.py"],
    "own_domain": [sys.executable, "examples/own_domain.py"],
    "hddl_agent": [sys.executable, "examples/hddl_agent.py"],
    "own_map check": [sys.executable, "-m", "htnagent", "check", OWN_MAP],
    "own_map run": [sys.executable, "-m", "htnagent", "run", OWN_MAP, "--json"],
}


@dataclass
class Done:
    """An example's run: its exit code and what it printed."""

    code: int
    out: str
    err: str

    @property
    def lines(self) -> list[str]:
        return self.out.splitlines()


@pytest.fixture(scope="module")
def runs() -> Iterator[dict[str, Done]]:
    started = {
        name: subprocess.Popen(cmd, cwd=ROOT, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
        for name, cmd in COMMANDS.items()
    }
    done: dict[str, Done] = {}
    try:
        for name, process in started.items():
            out, err = process.communicate(timeout=WITHIN)
            done[name] = Done(process.returncode, out, err)
        yield done
    finally:
        for process in started.values():
            if process.poll() is None:
                process.kill()
                process.communicate()


def succeeded(runs: dict[str, Done], name: str) -> Done:
    run = runs[name]
    assert run.code == 0, f"{name} exited {run.code}:\n{run.out}\n{run.err}"
    assert "Traceback" not in run.err, run.err
    return run


# -- embedding ----------------------------------------------------------------------------------


@pytest.mark.parametrize("name", ["embed_asyncio", "embed_trio"])
def test_embedding_resumes_the_goal_an_emergency_suspended(runs: dict[str, Done], name: str) -> None:
    lines = succeeded(runs, name).lines
    # Expect: the emergency comes half way along the robot's first move (arc59, 4.1 s),
    #         suspends the tour, succeeds; the tour is resumed and succeeds after it.
    assert "t=   2.1s  guide: EMERGENCY goto(n28) received" in lines
    assert "t=   2.1s  guide: goto(n1) suspended (stack depth 1)" in lines
    story = [line.split("guide: ")[1] for line in lines if "guide: " in line]
    assert story == [
        "goal goto(n1) received",
        "EMERGENCY goto(n28) received",
        "goto(n1) suspended (stack depth 1)",
        "goto(n28) ended: success",
        "goto(n1) resumed (online re-planning)",
        "goto(n1) ended: success",
    ]
    assert lines[-2:] == ["emergency goto(n28): success", "goal goto(n1): suspended, resumed, success"]


# -- a domain of one's own ------------------------------------------------------------------------


def test_the_own_domain_plans_and_runs_on_the_users_executor(runs: dict[str, Done]) -> None:
    lines = succeeded(runs, "own_domain").lines
    assert lines[0] == (
        "deliver(letter,office): SOLVED [pick(letter,mailroom), walk(mailroom,hall),"
        " walk(hall,office), drop(letter,office)] cost 16"
    )
    # From half way along a walk, the planner walks back (the rollback costs half the walk).
    assert lines[1] == (
        "goto(kitchen) from half way to the office: [rollback(walk(hall,office)), walk(hall,kitchen)] cost 9"
    )
    # Expect: the emergency half way along hall -> office (8 m at 1 m/s), the walk rolled
    #         back, the urgent letter delivered, then the first one from where the robot is.
    assert "t= 11.0s  goal_received  deliver(urgent,lab)  (emergency)" in lines
    assert "t= 11.0s    rollback(walk(hall,office))" in lines
    assert "t= 29.0s  goal_resumed   deliver(letter,office)" in lines
    assert lines[-2:] == ["the robot is at office", "both letters delivered, the first one resumed"]


# -- an HDDL agent ----------------------------------------------------------------------------------


def test_the_hddl_agent_resumes_its_walk_and_delivers_both(runs: dict[str, Done]) -> None:
    lines = succeeded(runs, "hddl_agent").lines
    assert lines[0].startswith("plan for bring(medicine,ward-b): walk(porter1,hall,pharmacy), load(")
    assert "t=  7.0s  porter: EMERGENCY bring(defibrillator,ward-a)" in lines
    assert "t=  7.0s  porter:    resume(walk(porter1,pharmacy,hall))" in lines
    assert "t= 23.0s  porter: bring(medicine,ward-b) resumed" in lines
    assert lines[-2:] == ["bring(medicine,ward-b): success", "bring(defibrillator,ward-a): success"]


# -- a scenario on one's own map -----------------------------------------------------------------


def test_the_own_map_scenario_checks(runs: dict[str, Done]) -> None:
    assert succeeded(runs, "own_map check").out == "ok\n"


def test_the_own_map_scenario_runs_its_emergency_and_resumes(runs: dict[str, Done]) -> None:
    events = [json.loads(line) for line in succeeded(runs, "own_map run").lines]
    summary = events[-1]
    assert summary["event"] == "summary"
    assert [(g["goal"], g["status"]) for g in summary["goals"]] == [
        ("goto(mosaic)", "success"),
        ("goto(pond)", "success"),
    ]
    assert summary["robot"] == {"at": "mosaic"}
    guide = [e for e in events if e["agent"] == "guide" and e["event"].startswith("goal_")]
    assert [(e["event"], e["goal"]) for e in guide] == [
        ("goal_received", "goto(mosaic)"),
        ("goal_received", "goto(pond)"),
        ("goal_suspended", "goto(mosaic)"),
        ("goal_finished", "goto(pond)"),
        ("goal_resumed", "goto(mosaic)"),
        ("goal_finished", "goto(mosaic)"),
    ]


# -- what the examples are made of --------------------------------------------------------------


def example_files() -> list[Path]:
    return sorted(EXAMPLES.rglob("*.py"))


def test_every_example_is_run_here() -> None:
    ran = {Path(cmd[1]).name for cmd in COMMANDS.values() if cmd[1].startswith("examples/")}
    assert ran == {p.name for p in example_files()}


@pytest.mark.parametrize("path", example_files(), ids=lambda p: p.name)
def test_an_example_imports_only_the_public_names(path: Path) -> None:
    tree = ast.parse(path.read_text(encoding="utf-8"))
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            assert not [a.name for a in node.names if a.name.startswith("htnagent.")], ast.unparse(node)
        elif isinstance(node, ast.ImportFrom) and (node.module or "").startswith("htnagent"):
            assert node.module == "htnagent", ast.unparse(node)
            assert {a.name for a in node.names} <= set(htnagent.__all__), ast.unparse(node)


def test_the_readme_lists_every_example_with_its_command() -> None:
    readme = (EXAMPLES / "README.md").read_text(encoding="utf-8")
    for path in example_files():
        assert f"python examples/{path.name}" in readme, path.name
    assert f"python -m htnagent run {OWN_MAP}" in readme
