"""``python -m bench ipc-interrupt``: each problem's network as one goal, an emergency chosen
from the problem half way through its plan.

The bench runs as users run it, ``python -m bench ipc-interrupt --suite DIR`` in a process
of its own, on the tiny suite of tests/data/ipc-tiny (a Courier and a Keys domain written
for the tests: the command must work on any suite of IPC total-order domains).  How the
emergency is chosen is tested in-process on the package's own
:mod:`htnagent.testing.emergencies`, which the bench calls.
"""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path
from typing import Any

import pytest

from htnagent.model.terms import Atom, parse
from htnagent.planning.planner import plan
from htnagent.scenario import parse_scenario
from htnagent.testing.emergencies import choose_interruption, half_way
from htnagent.upkeep.repair import one_plan

ROOT = Path(__file__).resolve().parent.parent
TINY = Path(__file__).resolve().parent / "data" / "ipc-tiny"


def bench(*args: str) -> subprocess.CompletedProcess[str]:
    return subprocess.run(
        [sys.executable, "-m", "bench", "ipc-interrupt", *args],
        cwd=ROOT,
        capture_output=True,
        text=True,
        timeout=120,
        check=False,
    )


def test_every_problem_gets_its_network_and_an_emergency_that_breaks_the_rest(tmp_path: Path) -> None:
    out = tmp_path / "rows.json"
    done = bench("--suite", str(TINY), "--domains", "Keys", "--runs", "1", "--out", str(out))
    assert done.returncode == 0, done.stderr
    rows: list[dict[str, Any]] = json.loads(out.read_text())
    by = {(r["domain"], r["problem"], r["mode"]): r for r in rows}
    assert set(by) == {("Keys", "p01.hddl", m) for m in ("online", "naive")}
    for row in rows:
        assert {"resume_ms", "replan_ms", "planning_ms", "cost", "success", "beliefs_match"} <= set(row)
        assert row["success"] is True and row["beliefs_match"] is True and row["reason"] is None
        assert row["emergency_kind"] == "breaks" and row["replan_ms"] > 0 and row["resume_ms"] > 0
    keys = by[("Keys", "p01.hddl", "online")]
    # The plan: fetch-crowbar, pry(b1), unlock-door(d1); half way is pry(b1).  Opening the
    # door then uses the key the rest of the plan needs for it: the rest is mended (the
    # door is open already, so the network's open-door(d1) has nothing left to do).
    assert (keys["trigger"], keys["emergency"], keys["actions"]) == ("pry(b1)", "open-door(d1)", 3)
    # Progress: a line per problem; the table: a row per domain.
    assert "[1/1] Keys/p01.hddl: 3 actions, emergency open-door(d1) (breaks): online replan" in done.stderr
    table = (tmp_path / "rows.md").read_text()
    assert "| Keys | 1 | 0 | 1/1 | 1/1 | 1/1 |" in table


def test_the_bench_resumes_where_a_stopped_run_left_off(tmp_path: Path) -> None:
    out = tmp_path / "rows.json"
    kept = [
        {"domain": "Courier", "problem": "p01.hddl", "mode": None, "success": None, "reason": "done before"}
    ]
    out.write_text(json.dumps(kept))
    done = bench(
        "--suite", str(TINY), "--domains", "Courier", "--problems", "1", "--resume", "--out", str(out)
    )
    assert done.returncode == 0, done.stderr
    assert json.loads(out.read_text()) == kept  # nothing run again
    assert "1 problems (1 done before, kept)" in done.stderr


def test_a_plan_too_long_for_the_bench_is_skipped_with_its_reason(tmp_path: Path) -> None:
    out = tmp_path / "rows.json"
    done = bench(
        "--suite",
        str(TINY),
        "--domains",
        "Courier",
        "--problems",
        "1",
        "--max-actions",
        "4",
        "--out",
        str(out),
    )
    assert done.returncode == 0, done.stderr
    [row] = json.loads(out.read_text())
    assert row["mode"] is None and row["success"] is None
    assert (
        row["reason"]
        == "its plan has 5 actions, more than the 4 a run of this bench carries out (--max-actions)"
    )


def test_a_bad_suite_is_one_line_and_exit_2(tmp_path: Path) -> None:
    done = bench("--suite", str(tmp_path / "none"))
    assert done.returncode == 2
    assert (
        done.stderr == f"python -m bench ipc-interrupt: error: --suite {tmp_path / 'none'}: no such folder\n"
    )


# -- the choice, in-process ----------------------------------------------------------------------


def scenario_of(folder: str, problem: str) -> Any:
    path = TINY / folder
    data = {
        "name": "choice",
        "robot": {},
        "agents": [
            {
                "name": "agent",
                "domain": {"hddl": str(path / "domain.hddl"), "problem": str(path / problem)},
                "executor": "robot",
                "suspendable": ["move"] if folder == "Courier" else [],
            }
        ],
        "goals": [{"agent": "agent", "tasks": "problem"}],
    }
    return parse_scenario(data, "<choice>", path)


@pytest.mark.parametrize(
    ("folder", "problem"), [("Courier", "p01.hddl"), ("Courier", "p02.hddl"), ("Keys", "p01.hddl")]
)
def test_the_chosen_emergency_breaks_the_rest_of_the_plan_and_is_the_same_every_time(
    folder: str, problem: str
) -> None:
    s = scenario_of(folder, problem)
    domain, state, goal = s.domain_for("agent"), s.initial_state("agent"), s.goal_task(0)
    first = plan(domain, state, [goal], one_plan(s.settings)).best
    assert first is not None
    planning = s.hddl_for("agent")
    chosen = choose_interruption(domain, state, goal, first, planning.hddl, planning.problem, s.settings)
    again = choose_interruption(domain, state, goal, first, planning.hddl, planning.problem, s.settings)
    assert chosen == again
    assert chosen.breaks and chosen.solvable and chosen.emergency is not None and chosen.changed > 0
    # An emergency is a task of the domain, never one of its actions nor the translation's.
    assert chosen.emergency.name in planning.hddl.tasks
    # Replayed after the emergency's plan, the rest of the plan fails somewhere.
    at = first.steps.index(next(s for s in first.steps if s.action == chosen.trigger))
    before = state
    for step in first.steps[:at]:
        nxt = domain.apply(before, step.action)
        assert nxt is not None
        before = nxt
    emergency = plan(domain, before, [chosen.emergency], one_plan(s.settings)).best
    assert emergency is not None
    after = before
    for step in emergency.steps:
        after = domain.progress(after, step.action)
    replayed: Any = after
    for step in first.steps[at:]:
        replayed = domain.apply(replayed, step.action) if replayed is not None else None
    assert replayed is None


def test_half_way_is_the_middle_action_first_met_there() -> None:
    from htnagent.model.plans import Step

    steps = [Step(parse(a), 1.0) for a in ("a", "__done", "b", "a", "c", "d")]
    # Actions a b a c d: index 2 is a, done before: the next new one, c (step 4).
    assert half_way(steps) == (4, 3, 5)
    assert half_way([Step(Atom("x"), 1.0)]) == (0, 0, 1)
    with pytest.raises(ValueError, match="no action"):
        half_way([Step(Atom("__done"), 0.0)])
