"""``python -m bench ipc-interrupt``: the last task of a problem's network as an emergency.

A small suite is made here from the shipped courier domain
(``scenarios/courier_hddl_domain.hddl``: four rooms in a ring, hall - kitchen - lab -
office - hall) and problems written below; no IPC file is needed.  Each step runs in
its own process, as on the real suite (a few seconds in all).
"""

from __future__ import annotations

import json
import shutil
from pathlib import Path
from typing import Any

import pytest

from bench import ipc_interrupt
from bench.ipc import Problem

ROOT = Path(__file__).resolve().parent.parent
DOMAIN = ROOT / "scenarios" / "courier_hddl_domain.hddl"

RING = """\
(door hall kitchen) (door kitchen hall) (door kitchen lab) (door lab kitchen)
(door lab office) (door office lab) (door office hall) (door hall office)"""


def problem(name: str, tasks: str, init: str) -> str:
    return f"""\
(define (problem {name}) (:domain courier)
  (:objects r1 - robot p1 p2 - parcel hall kitchen lab office - room)
  (:htn :ordered-subtasks (and {tasks}))
  (:init {init} {RING}))
"""


PROBLEMS = {
    # p1 from the lab to the office (5 actions), then p2 to the hall: the emergency.
    "p1.hddl": problem(
        "two", "(deliver p1 office) (deliver p2 hall)", "(at r1 hall) (in p1 lab) (in p2 office)"
    ),
    # One task: nothing to interrupt.
    "p2.hddl": problem("one", "(deliver p1 office)", "(at r1 hall) (in p1 lab) (in p2 office)"),
    # The others take 3 actions only (p1 is in the hall with the robot, the office next door).
    "p3.hddl": problem(
        "short", "(deliver p1 office) (deliver p2 hall)", "(at r1 hall) (in p1 hall) (in p2 office)"
    ),
}


@pytest.fixture
def suite(tmp_path: Path) -> Path:
    folder = tmp_path / "suite" / "Courier"
    folder.mkdir(parents=True)
    shutil.copy(DOMAIN, folder / "domain.hddl")
    for name, text in PROBLEMS.items():
        (folder / name).write_text(text)
    return tmp_path / "suite"


def run(suite: Path, tmp_path: Path, *extra: str) -> list[dict[str, Any]]:
    out = tmp_path / "rows.json"
    assert ipc_interrupt.main(["--suite", str(suite), "--out", str(out), *extra]) == 0
    rows: list[dict[str, Any]] = json.loads(out.read_text())
    return rows


def test_both_modes_are_measured_and_skips_say_why(
    suite: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    rows = run(suite, tmp_path)
    by = {(r["problem"], r["mode"]): r for r in rows}
    assert set(by) == {("p1.hddl", "online"), ("p1.hddl", "naive"), ("p2.hddl", None), ("p3.hddl", None)}
    for mode in ("online", "naive"):
        row = by[("p1.hddl", mode)]
        assert {"domain", "problem", "mode", "resume_ms", "planning_ms", "cost", "success"} <= set(row)
        assert row["domain"] == "Courier"
        assert row["success"] is True and row["beliefs_match"] is True and row["reason"] is None
        assert row["resume_ms"] > 0 and row["planning_ms"] >= row["resume_ms"]
        assert row["emergency"] == "deliver(p2,hall)" and row["actions"] == 5 and row["runs"] == 5
        # Half way through hall→kitchen→lab, pick, lab→office, drop: the pick in the lab.
        assert row["trigger"] == "pick(r1,p1,lab)"
        # The pick was suspended, p2 taken from the office to the hall (1 move, pick,
        # 1 move, drop), then p1 fetched again from the lab: 2 moves, pick, 1 move, drop.
        assert row["cost"] == 2 + 4 + 5
    assert by[("p2.hddl", None)]["reason"] == (
        "the initial task network has 1 task(s): no other goal to interrupt"
    )
    assert by[("p3.hddl", None)]["reason"] == "the plan of the others has 3 action(s), fewer than 4"
    assert by[("p3.hddl", None)]["success"] is None
    err = capsys.readouterr().err
    assert "[1/3] Courier/p1.hddl: 5 actions, emergency deliver(p2,hall): online resume" in err
    assert "[2/3] Courier/p2.hddl: skipped: the initial task network has 1 task(s)" in err
    table = (tmp_path / "rows.md").read_text()
    assert "| Courier | 3 | 2 | 1/1 | 1/1 |" in table


def test_a_run_past_its_wall_clock_limit_is_a_failure_with_its_reason(suite: Path, tmp_path: Path) -> None:
    rows = run(
        suite, tmp_path, "--domains", "courier", "--problems", "1", "--run-timeout", "0.01", "--grace", "0"
    )
    assert [r["mode"] for r in rows] == ["online", "naive"]
    for row in rows:
        assert row["success"] is False
        assert row["reason"] == "killed at the wall-clock limit of 0.01 s"


def test_a_bad_suite_is_one_line_and_exit_2(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    assert ipc_interrupt.main(["--suite", str(tmp_path / "none")]) == 2
    assert (
        capsys.readouterr().err
        == f"python -m bench ipc-interrupt: error: --suite {tmp_path / 'none'}: no such folder\n"
    )


def test_an_emergency_whose_trigger_never_happens_fails_with_its_reason(suite: Path) -> None:
    folder = suite / "Courier"
    problem = Problem("Courier", folder / "domain.hddl", folder / "p1.hddl")
    data = ipc_interrupt.scenario_data(
        problem, ["deliver(p1,office)"], ["move"], "deliver(p2,hall)", "drop(r1,p1,hall)"
    )
    got = ipc_interrupt.run_agent(problem, data, "naive")
    assert got["success"] is False and got["resume_ms"] is None and got["beliefs_match"] is True
    assert got["reason"] == "deliver(p2,hall): never given: its trigger did not happen"
    assert got["cost"] == 5  # p1 delivered all the same
