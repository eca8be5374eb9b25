"""``python -m bench ipc-interrupt``: each problem's network as one goal, an emergency chosen
from the problem half way through its plan.

The bench runs as users run it, ``python -m bench ipc-interrupt --suite DIR`` in a process
of its own, on the tiny suite of tests/data/ipc-tiny (a Courier and a Keys domain written
for the tests: the command must work on any suite of IPC total-order domains).  How the
emergency is chosen is tested in-process on the package's own
:mod:`htnagent.testing.emergencies`, which the bench calls.
"""

from __future__ import annotations

import functools
import json
import subprocess
import sys
from pathlib import Path
from typing import Any

import anyio
import pytest

from htnagent.model.terms import Atom, parse
from htnagent.planning.planner import plan
from htnagent.scenario import parse_scenario
from htnagent.system.simulation import run_scenario
from htnagent.testing.emergencies import choose_interruption, half_way
from htnagent.upkeep.repair import one_plan
from tests.support import statuses

ROOT = Path(__file__).resolve().parent.parent
TINY = Path(__file__).resolve().parent / "data" / "ipc-tiny"
SUSPENDABLE = {"Courier": ["move"], "Lamps": ["walk"]}


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
    done = bench("--suite", str(TINY), "--domains", "Keys,Lamps", "--runs", "1", "--out", str(out))
    assert done.returncode == 0, done.stderr
    rows: list[dict[str, Any]] = json.loads(out.read_text())
    by = {(r["domain"], r["problem"], r["mode"]): r for r in rows}
    assert set(by) == {(d, "p01.hddl", m) for d in ("Keys", "Lamps") for m in ("online", "naive")}
    for row in rows:
        assert {"resume_ms", "replan_ms", "planning_ms", "cost", "success", "beliefs_match"} <= set(row)
        assert row["success"] is True and row["beliefs_match"] is True and row["reason"] is None
        assert row["replan_ms"] > 0 and row["resume_ms"] > 0
        # The same work on the CPU clock: some, and (one thread) no more than the wall clock's.
        assert 0 < row["planning_cpu_ms"] <= row["planning_ms"] * 1.05 + 0.05
    lamps = by[("Lamps", "p01.hddl", "online")]
    # The plan: walk(s1,s2), switch-on(s2), walk(s2,s3), switch-on(s3); half way is the walk
    # to s3.  The domain's one compound task only lights the lamp where the walker stands:
    # the emergency is one of its actions, a walk back that the rest must be mended after.
    assert (lamps["trigger"], lamps["emergency"], lamps["emergency_kind"]) == (
        "walk(s2,s3)",
        "walk(s2,s1)",
        "breaks",
    )
    keys = by[("Keys", "p01.hddl", "online")]
    # The plan: fetch-crowbar, pry(b1), unlock-door(d1); half way is pry(b1).  Whatever
    # undoes what the rest needs (the key, used on the box) leaves the door shut for good;
    # every other task only does what the rest does next (finish prying the box, open the
    # door).  The emergency is then the first of those, and the table says so: 0 facts.
    assert (keys["trigger"], keys["emergency"], keys["emergency_kind"], keys["actions"]) == (
        "pry(b1)",
        "open-box(b1)",
        "most changes",
        3,
    )
    # Progress: a line per problem; the table: a row per domain, and the fallback named.
    assert "Keys/p01.hddl: 3 actions, emergency open-box(b1) (most changes): online replan" in done.stderr
    table = (tmp_path / "rows.md").read_text()
    assert "| Keys | 1 | 0 | 0/1 | 1/1 | 1/1 |" in table
    assert "| planning CPU on-line / naive |" in table
    assert "| Lamps | 1 | 0 | 1/1 | 1/1 | 1/1 |" in table
    assert "- Keys/p01.hddl: open-box(b1) (0 facts)" in table


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


def scenario_of(
    folder: str,
    problem: str,
    suspendable: list[str] | None = None,
    emergency: Any = None,
    search: str = "astar",
) -> Any:
    """One agent on a tiny domain's problem, its network the goal; ``emergency``'s task (an
    :class:`Interruption`) given half way through its trigger, as the bench gives it."""
    path = TINY / folder
    goals: list[dict[str, Any]] = [{"agent": "agent", "tasks": "problem"}]
    if emergency is not None:
        when = {"action": str(emergency.trigger), "progress": 0.5}
        goals.append({"agent": "agent", "task": str(emergency.emergency), "emergency": True, "when": when})
    data = {
        "name": "choice",
        "robot": {},
        "planner": {"search": search},
        "agents": [
            {
                "name": "agent",
                "domain": {"hddl": str(path / "domain.hddl"), "problem": str(path / problem)},
                "executor": "robot",
                "suspendable": suspendable if suspendable is not None else SUSPENDABLE.get(folder, []),
            }
        ],
        "goals": goals,
    }
    return parse_scenario(data, "<choice>", path)


def succeeds_with(folder: str, problem: str, chosen: Any, mode: str) -> bool:
    """Whether every goal succeeds when the network runs with ``chosen``'s emergency."""
    scenario = scenario_of(folder, problem, emergency=chosen)
    report = anyio.run(functools.partial(run_scenario, scenario, replanning=mode))
    return all(status == "success" for status in statuses(report))


@pytest.mark.parametrize(
    ("folder", "problem", "kind"),
    [("Courier", "p01.hddl", "tasks"), ("Courier", "p02.hddl", "tasks"), ("Lamps", "p01.hddl", "actions")],
)
def test_the_chosen_emergency_breaks_the_rest_of_the_plan_and_is_the_same_every_time(
    folder: str, problem: str, kind: str
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
    # A compound task of the domain where one will do; one of its actions only where none does.
    assert chosen.emergency.name in getattr(planning.hddl, kind)
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
    # ... and the agent finishes the network after it (a run of its own: the emergency comes
    # as the bench gives it).
    assert succeeds_with(folder, problem, chosen, "online")


def test_an_emergency_that_only_does_what_the_rest_does_next_is_the_last_resort() -> None:
    every = ["unlock-box", "fetch-crowbar", "pry", "unlock-door"]
    s = scenario_of("Keys", "p01.hddl", suspendable=every, search="dfs")
    domain, state, goal = s.domain_for("agent"), s.initial_state("agent"), s.goal_task(0)
    first = plan(domain, state, [goal], one_plan(s.settings)).best
    assert first is not None
    planning = s.hddl_for("agent")
    chosen = choose_interruption(domain, state, goal, first, planning.hddl, planning.problem, s.settings)
    # Every action suspendable, depth-first search (as the bench runs Keys): struck half way
    # through pry(b1), each emergency's plan finishes it first.  Opening the box then does
    # nothing more, opening the door is the rest's own next step (the kept plan moves past
    # it, §2.1): neither changes anything beyond what the rest does next.  Taking the key
    # for the box breaks the rest beyond repair.  The emergency is the first that changes
    # nothing and leaves the network finishable, not the one that leaves it unfinishable.
    assert chosen.emergency == parse("open-box(b1)")
    assert (chosen.breaks, chosen.solvable, chosen.changed) == (False, True, 0)
    assert succeeds_with("Keys", "p01.hddl", chosen, "online")


def test_half_way_is_the_middle_action_first_met_there() -> None:
    from htnagent.model.plans import Step

    steps = [Step(parse(a), 1.0) for a in ("a", "__done", "b", "a", "c", "d")]
    # Actions a b a c d: index 2 is a, done before: the next new one, c (step 4).
    assert half_way(steps) == (4, 3, 5)
    assert half_way([Step(Atom("x"), 1.0)]) == (0, 0, 1)
    with pytest.raises(ValueError, match="no action"):
        half_way([Step(Atom("__done"), 0.0)])
