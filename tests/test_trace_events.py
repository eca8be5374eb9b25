"""Trace events: typed records whose JSON form is what ``run --json`` prints, and read back the same."""

from __future__ import annotations

import functools
import json
from pathlib import Path

import anyio
import pytest

from htnagent.errors import TraceFormatError
from htnagent.runtime.events import EVENT_KINDS, GoalRow, ResumeRow, Summary, event_from_dict, fields_of
from htnagent.scenario import load_scenario
from htnagent.system.simulation import run_scenario

SCENARIOS = Path(__file__).resolve().parents[1] / "scenarios"


@pytest.mark.parametrize("name", ["museum.yaml", "nested_emergencies.yaml", "explain_question.yaml"])
def test_every_event_of_a_run_reads_back_as_itself(name: str) -> None:
    report = anyio.run(functools.partial(run_scenario, load_scenario(SCENARIOS / name), keep_events=True))
    kinds = set()
    for event in report.events:
        line = json.dumps(event.as_dict())
        again = event_from_dict(json.loads(line))
        assert type(again) is type(event) and again.as_dict() == event.as_dict()
        kinds.add(event.event)
    # Expect: the run shows the kinds a run with an emergency must have.
    assert {"goal_received", "plan_selected", "goal_suspended", "goal_resumed", "summary"} <= kinds


def test_the_json_form_has_time_agent_and_kind_first_and_leaves_unset_optionals_out() -> None:
    summary = Summary(
        agent="runtime",
        t=3.5,
        goals=(GoalRow("guide", "goto(n1)", "success"), GoalRow("guide", "goto(n9)", "failure", "no plan")),
        robot={"at": "n1"},
        visited=("n40", "n1"),
        distance=12.0,
        planning_ms={"guide": 1.5},
    )
    data = summary.as_dict()
    assert list(data)[:3] == ["t", "agent", "event"]
    never: dict[str, object] = {"emergency": False, "given": None, "started": None, "ended": None}
    never |= {"waited_s": 0.0, "resumes": []}
    assert data["goals"] == [
        {"agent": "guide", "goal": "goto(n1)", "status": "success", **never},
        {"agent": "guide", "goal": "goto(n9)", "status": "failure", "reason": "no plan", **never},
    ]
    assert event_from_dict(data) == summary


def test_a_summary_saved_before_the_goals_had_times_reads_back_with_their_defaults() -> None:
    old = {
        "t": 64.8,
        "agent": "runtime",
        "event": "summary",
        "goals": [{"agent": "guide", "goal": "goto(n1)", "status": "success"}],
        "robot": {"at": "n1"},
        "visited": ["n40", "n1"],
        "distance": 64.8,
        "planning_ms": {"guide": 1.5},
    }
    summary = event_from_dict(old)
    assert isinstance(summary, Summary)
    assert summary.goals == (GoalRow("guide", "goto(n1)", "success"),)
    row = summary.goals[0]
    assert (row.emergency, row.given, row.started, row.ended, row.waited_s, row.resumes) == (
        False,
        None,
        None,
        None,
        0.0,
        (),
    )


def test_a_summary_with_resumptions_reads_back_as_itself() -> None:
    row = GoalRow(
        "guide",
        "goto(n1)",
        "success",
        given=0.0,
        started=0.0,
        ended=64.8,
        waited_s=35.5,
        resumes=(ResumeRow(t=37.5, replan_ms=0.08, window_ms=0.45), ResumeRow(t=50.0, replan_ms=0.1)),
    )
    summary = Summary(agent="runtime", goals=(row,), robot={}, visited=(), distance=0.0, planning_ms={})
    data = json.loads(json.dumps(summary.as_dict()))
    assert data["goals"][0]["resumes"] == [
        {"t": 37.5, "replan_ms": 0.08, "window_ms": 0.45},
        {"t": 50.0, "replan_ms": 0.1, "window_ms": None},
    ]
    assert event_from_dict(data) == summary


def test_each_kind_names_its_fields() -> None:
    assert fields_of("goal_suspended") == ("goal", "stack_depth")
    assert set(EVENT_KINDS) >= {"message", "robot_moving", "events_dropped", "summary"}


@pytest.mark.parametrize(
    ("data", "reason"),
    [
        ([1, 2], "expected an event object"),
        ({"agent": "a"}, "unknown event None"),
        ({"event": "lunch", "agent": "a"}, "unknown event 'lunch'"),
        (
            {"event": "goal_suspended", "agent": "a", "goal": "g"},
            "goal_suspended: stack_depth: Field required",
        ),
        ({"event": "goal_finished", "agent": "a", "goal": "g", "status": "maybe"}, "status: Input should be"),
    ],
)
def test_what_is_not_an_event_is_refused_with_the_reason(data: object, reason: str) -> None:
    with pytest.raises(TraceFormatError, match=reason):
        event_from_dict(data)  # type: ignore[arg-type]
