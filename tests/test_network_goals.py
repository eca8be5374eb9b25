"""A goal may be a task network (docs/design.md §4): ``tasks: [t1, t2, ...]`` in a scenario, or
``tasks: problem`` for an HDDL problem's own network, planned as one ordered whole.

The Keys domain (tests/data/ipc-tiny/Keys) is the case where the order matters: one key,
a box that opens with it (one action) or with a crowbar (two), and a door that only the
key opens.  Planned task by task, the box takes the key; planned as one, the box is pried
open and the door gets the key.
"""

from __future__ import annotations

import functools
from pathlib import Path
from typing import Any

import anyio
import pytest

from htnagent.errors import ScenarioError
from htnagent.executors.hddl_robot import HddlRobot
from htnagent.model.networks import NETWORK, network_task
from htnagent.model.terms import Atom, parse
from htnagent.runtime.events import ActionFinished, TraceEvent
from htnagent.scenario import Scenario, parse_scenario
from htnagent.system.runtime import Runtime
from htnagent.system.simulation import RunReport, run_scenario
from htnagent.testing.invariants import hddl_belief_differences
from tests.support import summary_of

TINY = Path(__file__).resolve().parent / "data" / "ipc-tiny"
KEYS = TINY / "Keys"
COURIER = TINY / "Courier"
MUSEUM = Path(__file__).resolve().parents[1] / "scenarios"


def hddl_scenario(folder: Path, problem: str, goals: list[dict[str, Any]], **agent: Any) -> Scenario:
    data = {
        "name": f"network {folder.name}",
        "robot": {"durations": {"move": 4}} if folder == COURIER else {},
        "agents": [
            {
                "name": "agent",
                "domain": {"hddl": str(folder / "domain.hddl"), "problem": str(folder / problem)},
                "executor": "robot",
                **agent,
            }
        ],
        "goals": goals,
    }
    return parse_scenario(data, f"<{folder.name}>", folder)


def run_checked(scenario: Scenario, mode: str = "online") -> tuple[RunReport, list[TraceEvent]]:
    """Run ``scenario`` in ``mode``; after every action the agent's belief (the translation's
    own facts left out) must equal the simulated world."""
    runtimes: list[Runtime] = []
    events: list[TraceEvent] = []
    differences: list[str] = []

    def check(event: TraceEvent) -> None:
        events.append(event)
        if isinstance(event, ActionFinished):
            assert isinstance(runtimes[0].bottom_executor, HddlRobot)
            differences.extend(f"after {event.action}, {d}" for d in hddl_belief_differences(runtimes[0]))

    report = anyio.run(
        functools.partial(
            run_scenario, scenario, replanning=mode, observers=[check], on_start=runtimes.append
        )
    )
    assert differences == []
    return report, events


def goal_rows(report: RunReport) -> list[tuple[str, str]]:
    return [(g["goal"], g["status"]) for g in summary_of(report)["goals"]]


# -- a network is planned as one whole ---------------------------------------------------------


def test_keys_planned_task_by_task_fail_and_as_one_network_succeed() -> None:
    # Expect: open-box(b1) alone takes the key (its cheapest way), so open-door(d1) has none.
    separate = hddl_scenario(
        KEYS,
        "p01.hddl",
        [{"agent": "agent", "task": "open-box(b1)"}, {"agent": "agent", "task": "open-door(d1)"}],
    )
    report, _ = run_checked(separate)
    assert goal_rows(report) == [("open-box(b1)", "success"), ("open-door(d1)", "failure")]
    # Expect: the network pries the box open and keeps the key for the door.
    whole = hddl_scenario(KEYS, "p01.hddl", [{"agent": "agent", "tasks": ["open-box(b1)", "open-door(d1)"]}])
    report, events = run_checked(whole)
    assert goal_rows(report) == [("tasks(open-box(b1),open-door(d1))", "success")]
    done = [e.action for e in events if isinstance(e, ActionFinished) and not e.action.startswith("__")]
    assert done == ["fetch-crowbar", "pry(b1)", "unlock-door(d1)"]


def test_tasks_problem_is_the_problems_network_with_its_goal_checked_at_the_end() -> None:
    s = hddl_scenario(KEYS, "p01.hddl", [{"agent": "agent", "tasks": "problem"}])
    assert str(s.goal_task(0)) == "tasks(open-box(b1),open-door(d1),__goal)"
    report, _ = run_checked(s)
    assert goal_rows(report) == [("tasks(open-box(b1),open-door(d1),__goal)", "success")]


def test_the_problems_goal_is_checked_a_network_that_leaves_it_false_fails() -> None:
    # Keys p01's :goal wants both open; a network of the box alone with the goal check after
    # it is not the problem's -- but the same check, given as the problem's network of one
    # task in a problem whose goal needs the door, has no plan.
    problem = KEYS / "p01.hddl"
    text = problem.read_text().replace("(open-box b1) (open-door d1)", "(open-box b1)")
    alone = KEYS.parent.parent / "keys-box-only.hddl"
    try:
        alone.write_text(text)
        s = hddl_scenario(KEYS, str(alone), [{"agent": "agent", "tasks": "problem"}])
        report, _ = run_checked(s)
        assert goal_rows(report) == [("tasks(open-box(b1),__goal)", "failure")]
    finally:
        alone.unlink()


def test_network_task_is_one_compound_task_made_once() -> None:
    s = hddl_scenario(COURIER, "p02.hddl", [{"agent": "agent", "task": "deliver(p1,lab)"}])
    domain = s.domain_for("agent")
    tasks = [parse("deliver(p1,lab)"), parse("deliver(p2,kitchen)")]
    first = network_task(domain, tasks)
    assert first == network_task(domain, tasks)
    assert first == Atom(NETWORK, tuple(tasks))
    assert [m.subtasks for m in domain.methods[NETWORK]] == [tuple(tasks)]


# -- suspension, resumption and plan upkeep work on it as on any goal ------------------------------


@pytest.mark.parametrize("mode", ["online", "naive"])
def test_an_emergency_in_the_middle_of_a_network_suspends_and_resumes_it_whole(mode: str) -> None:
    goals: list[dict[str, Any]] = [
        {"agent": "agent", "tasks": ["deliver(p1,lab)", "deliver(p2,kitchen)"]},
        # The emergency moves p2 away from the hall, where the network's second task was to
        # pick it up: the kept plan must be kept valid (repaired), not merely resumed.
        {
            "agent": "agent",
            "task": "deliver(p2,office)",
            "emergency": True,
            "when": {"action": "move(r1,office,lab)", "progress": 0.5},
        },
    ]
    s = hddl_scenario(COURIER, "p02.hddl", goals, suspendable=["move"])
    report, events = run_checked(s, mode)
    network = "tasks(deliver(p1,lab),deliver(p2,kitchen))"
    assert goal_rows(report) == [(network, "success"), ("deliver(p2,office)", "success")]
    kinds = [
        (e.event, getattr(e, "goal", None)) for e in events if e.event in ("goal_suspended", "goal_resumed")
    ]
    assert kinds == [("goal_suspended", network), ("goal_resumed", network)]
    summary = summary_of(report)
    assert len(summary["goals"][0]["resumes"]) == 1
    # The network is done whole at the end: p1 in the lab, then p2 fetched from the office
    # (where the emergency left it) to the kitchen.
    done = [e.action for e in events if isinstance(e, ActionFinished) and e.result == "success"]
    assert (
        done.index("drop(r1,p2,office)")
        < done.index("pick(r1,p2,office)")
        < done.index("drop(r1,p2,kitchen)")
    )
    assert "drop(r1,p1,lab)" in done


def test_online_and_naive_end_a_network_with_an_emergency_alike() -> None:
    goals: list[dict[str, Any]] = [
        {"agent": "agent", "tasks": "problem"},
        {
            "agent": "agent",
            "task": "deliver(p1,hall)",
            "emergency": True,
            "when": {"action": "move(r1,lab,kitchen)", "progress": 0.5},
        },
    ]
    s = hddl_scenario(COURIER, "p02.hddl", goals, suspendable=["move"])
    outcomes = {mode: goal_rows(run_checked(s, mode)[0]) for mode in ("online", "naive")}
    assert outcomes["online"] == outcomes["naive"]
    assert [status for _, status in outcomes["online"]] == ["success", "success"]


def test_a_network_goal_of_the_museum_guide() -> None:
    data = {
        "name": "museum network",
        "map": str(MUSEUM / "museum_map.yaml"),
        "robot": {"start": "n40", "speed": 1.0},
        "agents": [
            {"name": "guide", "domain": "museum.areas", "executor": "navigator"},
            {"name": "navigator", "domain": "museum.nodes", "executor": "robot"},
        ],
        "goals": [{"agent": "guide", "tasks": ["goto(n38)", "goto(n1)"]}],
    }
    report = anyio.run(functools.partial(run_scenario, parse_scenario(data, "<museum>", MUSEUM)))
    summary = summary_of(report)
    assert goal_rows(report) == [("tasks(goto(n38),goto(n1))", "success")]
    assert summary["visited"][-1] == "n1" and "n38" in summary["visited"]


# -- hostile values ------------------------------------------------------------------------


HOSTILE = [
    ({"tasks": []}, "goals[0].tasks", "an empty task network: give at least one task"),
    ({"tasks": ["open-box(b1)", "fly(b1)"]}, "goals[0].tasks[1]", "has no task fly"),
    ({"tasks": ["open-box(b1,d1)"]}, "goals[0].tasks[0]", "open-box takes 1 argument in keys, not 2"),
    ({"tasks": ["open-box(b9)"]}, "goals[0].tasks[0]", "'b9' is not an object of problem keys-1"),
    ({"tasks": ["open-box(b1"]}, "goals[0].tasks", "[0]:"),
    ({"tasks": "all"}, "goals[0].tasks", "expected a list of tasks [t1, t2, ...] or 'problem'"),
    ({"tasks": 7}, "goals[0].tasks", "expected a list of tasks [t1, t2, ...], got"),
    ({"tasks": [["open-box(b1)"]]}, "goals[0].tasks", "[0]: expected text like name(arg,...)"),
    ({"task": "open-box(b1)", "tasks": ["open-door(d1)"]}, "goals[0]", "not both"),
    ({}, "goals[0]", "give exactly one of task (one task) and tasks (a task network), got neither"),
    ({"tasks": ["__top"]}, "goals[0].tasks[0]", "has no task __top"),
]


@pytest.mark.parametrize(("goal", "where", "reason"), HOSTILE)
def test_hostile_tasks_values_are_one_clear_error(goal: dict[str, Any], where: str, reason: str) -> None:
    with pytest.raises(ScenarioError) as caught:
        hddl_scenario(KEYS, "p01.hddl", [{"agent": "agent", **goal}])
    assert caught.value.where == where
    assert reason in caught.value.reason


def test_tasks_problem_needs_an_hddl_agent() -> None:
    data = {
        "name": "museum problem",
        "map": str(MUSEUM / "museum_map.yaml"),
        "robot": {"start": "n40", "speed": 1.0},
        "agents": [{"name": "navigator", "domain": "museum.nodes", "executor": "robot"}],
        "goals": [{"agent": "navigator", "tasks": "problem"}],
    }
    with pytest.raises(ScenarioError) as caught:
        parse_scenario(data, "<museum>", MUSEUM)
    assert caught.value.where == "goals[0].tasks"
    assert "is not HDDL" in caught.value.reason


def test_a_domain_with_its_own_task_named_tasks_cannot_take_a_network() -> None:
    s = hddl_scenario(KEYS, "p01.hddl", [{"agent": "agent", "task": "open-box(b1)"}])
    domain = s.domain_for("agent")
    domain.method("tasks(?x)", "mine", do=[])
    with pytest.raises(Exception, match="has a task of its own named tasks"):
        network_task(domain, [parse("open-box(b1)")])


def test_check_tells_a_bad_network_in_one_line(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    from htnagent.cli.commands import main

    scenario = tmp_path / "keys.yaml"
    scenario.write_text(
        "name: keys\nrobot: {}\n"
        f"agents: [{{name: agent, domain: {{hddl: {KEYS / 'domain.hddl'}, problem: {KEYS / 'p01.hddl'}}}, "
        "executor: robot}]\n"
        "goals: [{agent: agent, task: open-box(b1), tasks: [open-door(d1)]}]\n"
    )
    assert main(["check", str(scenario)]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "Traceback" not in err
    assert (
        f"{scenario}: goals[0]: give exactly one of task (one task) and tasks (a task network), not both"
        in err
    )
