"""The history of a run read from its trace (htnagent.views.history): hand-checked facts.

``scenarios/nested_emergencies.yaml``: on the way from n40 to n1 the guide is
sent to n28 half way along arc59 (2.061553 s), and to n38 at 10 s.  Read off
its trace by hand (``run --json``): the guide's stack is goto(n1) from 2.06 s,
goto(n1) and goto(n28) from 10 s; goto(n38) ends at 20.88 s, goto(n28) at
59.29 s.  The navigator holds move_area(area8,area7) for its parent for no time
at all (suspended and resumed at 2.06 s), and move_area(area7,area5) from 10 s
to 27.88 s, while the robot rolls back along arc50 from 36.47% of the way.
"""

from __future__ import annotations

import pytest

from htnagent.runtime.events import GoalSuspended
from htnagent.views.history import History
from tests.support import SHIPPED, shipped_run

NESTED = "nested_emergencies.yaml"
FOUR = "four_emergencies.yaml"


def history_of(name: str) -> History:
    scenario, events = shipped_run(name)
    return History.from_events(events, scenario.agent_names)


def spans(history: History, agent: str) -> dict[str, list[tuple[float, float | None]]]:
    return {g.goal: [(s.start, s.end) for s in g.suspended] for g in history.goals_of(agent) if g.suspended}


def test_nested_emergencies_stack_depth_rises_to_two_and_falls_back() -> None:
    h = history_of(NESTED)
    assert h.depth["guide"] == [(0.0, 0), (2.061553, 1), (10.0, 2), (20.876894, 1), (59.287, 0)]
    assert h.depth["navigator"] == [(0.0, 0), (10.0, 1), (27.876894, 0)]


def test_nested_emergencies_suspended_spans_are_kept_even_when_empty() -> None:
    h = history_of(NESTED)
    assert spans(h, "guide") == {"goto(n1)": [(2.061553, 59.287)], "goto(n28)": [(10.0, 20.876894)]}
    # The held goal suspended and resumed in one instant is still a span (of no length).
    assert spans(h, "navigator") == {
        "move_area(area8,area7)": [(2.061553, 2.061553)],
        "move_area(area7,area5)": [(10.0, 27.876894)],
    }


def test_nested_emergencies_goals_end_as_the_trace_says() -> None:
    h = history_of(NESTED)
    guide = [(g.goal, g.emergency, g.received, g.end, g.status) for g in h.goals_of("guide")]
    assert guide == [
        ("goto(n1)", False, 0.0, 86.600709, "success"),
        ("goto(n28)", True, 2.061553, 59.287, "success"),
        ("goto(n38)", True, 10.0, 20.876894, "success"),
    ]
    assert [(m.t, m.kind, m.subject) for m in h.marks] == [
        (2.061553, "emergency", "goto(n28)"),
        (10.0, "emergency", "goto(n38)"),
    ]


def test_at_the_second_emergency_the_stack_goal_plan_and_robot_are_the_traces() -> None:
    now = history_of(NESTED).at(10.0)
    guide, navigator = now.agents["guide"], now.agents["navigator"]
    assert (guide.goal, guide.emergency, guide.stack) == ("goto(n38)", True, ("goto(n1)", "goto(n28)"))
    assert guide.plan == ("move_area(area7,area8)", "goto_node(n38)")
    assert (navigator.goal, navigator.stack) == ("move_area(area7,area8)", ("move_area(area7,area5)",))
    assert navigator.action == "rollback(move(n31,n29,arc50))"
    # Stopped at (10 - 6.123106) / 10.630146 of arc50, about to roll back.
    assert now.robot == {"arc": "arc50", "from": "n31", "to": "n29", "fraction": 0.364708}


def test_between_events_the_robot_is_part_way_and_the_stacks_hold() -> None:
    h = history_of(NESTED)
    later = h.at(12.0)
    assert later.agents["guide"].stack == ("goto(n1)", "goto(n28)")
    # Rolling back: 2 of the 3.876894 s from 36.4708% towards n31.
    assert later.robot is not None and later.robot["arc"] == "arc50"
    assert later.robot["fraction"] == pytest.approx(0.364708 * (1 - 2 / 3.876894), abs=1e-6)
    assert h.at(20.876894).agents["guide"].stack == ("goto(n1)",)
    assert h.at(59.287).agents["guide"].stack == ()
    assert h.at(h.end).robot == {"node": "n1"}


def test_four_nested_emergencies_over_three_agents() -> None:
    h = history_of(FOUR)
    assert h.agents == ("host", "guide", "navigator")
    assert [d for _, d in h.depth["host"]] == [0, 1, 2, 3, 4, 3, 2, 1, 0]
    assert h.at(15.0).agents["host"].stack == ("visit(n1)", "visit(n28)", "visit(n38)", "visit(n33)")
    assert h.at(15.0).agents["guide"].stack == ("goto(n1)", "goto(n28)", "goto(n38)", "goto(n33)")
    assert [m.subject for m in h.marks if m.kind == "emergency"] == [
        "visit(n28)",
        "visit(n38)",
        "visit(n33)",
        "visit(n36)",
    ]


def test_the_order_of_agents_is_read_from_the_trace_without_the_scenario() -> None:
    _, events = shipped_run(FOUR)
    assert History.from_events(events).agents == ("host", "guide", "navigator")


def test_a_failure_keeps_its_reason_and_a_door_is_marked() -> None:
    h = history_of("unreachable_goal.yaml")
    failed = [g for g in h.goals if g.status == "failure"]
    assert [(g.goal, g.reason) for g in failed] == [("goto(n40)", "no plan for goto(n40) (unsolvable)")]
    assert [(m.kind, m.subject) for m in h.marks] == [("arc_closed", "arc51")]


def test_a_timed_activity_is_seen_and_the_robot_stands_still() -> None:
    h = history_of("explain_question.yaml")
    assert [a.action for a in h.activities][:2] == ["explain(statue)", "answer(ann)"]
    first = h.activities[0]
    assert h.at(first.start + 1).activity == "explain(statue)"


@pytest.mark.parametrize("name", SHIPPED)
def test_every_stack_depth_in_the_trace_is_the_models(name: str) -> None:
    scenario, events = shipped_run(name)
    h = History.from_events(events, scenario.agent_names)
    # Read up to each suspension, the model's depth is the one the agent reported.
    for i, e in enumerate(events):
        if isinstance(e, GoalSuspended):
            upto = History.from_events(events[: i + 1], scenario.agent_names)
            assert upto.depth[e.agent][-1] == (e.t, e.stack_depth)
    for steps in h.depth.values():
        for t, _ in steps:
            assert all(len(h.at(t).agents[a].stack) == h.depth_at(a, t) for a in h.agents)
    # Every goal of the summary ends as a bar of the same status; the robot ends where it says.
    summary = h.summary
    assert summary is not None
    for row in summary.goals:
        assert any(g.agent == row.agent and g.goal == row.goal and g.status == row.status for g in h.goals)
    where = h.at(h.end).robot
    if not summary.robot:  # an HDDL agent's robot, on no map (docs/design.md §7.1)
        assert where is None
    elif "at" in summary.robot:
        assert where == {"node": summary.robot["at"]}
    else:
        assert where is not None and where.get("arc") == summary.robot["on"]
    assert all(d == 0 for steps in h.depth.values() for d in [steps[-1][1]])
