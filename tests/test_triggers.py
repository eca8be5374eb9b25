"""Action triggers (docs/contracts.md: ``when: {action: A, progress: p}``), exactly.

A goal (or a world event) with an action trigger is given once that action has
covered the fraction ``progress`` of its duration.  For the robot's own
actions (moves, ``robot.durations``) that is followed through suspensions,
resumptions and rollbacks; any agent's action may trigger when it has finished
(``progress: 1``).  Triggers that could never fire are refused by ``check``.
Also here: the robot suspends a resumed rest or a rollback as it does a move, and an
``action_timeout`` shorter than the robot's longest action is refused.
"""

from __future__ import annotations

import functools
from collections.abc import Callable
from pathlib import Path
from typing import Any

import anyio
import pytest

from htnagent.errors import ScenarioError
from htnagent.executors.robot import Robot, RobotWorld
from htnagent.model.terms import Atom, parse
from htnagent.runtime.clock import Clock, Mailbox
from htnagent.runtime.executor import AdapterActor
from htnagent.runtime.messages import Execute, Resume, Suspend, Suspended
from htnagent.runtime.trace import Trace
from htnagent.scenario import Scenario, load_scenario, parse_scenario
from htnagent.system.simulation import NEVER_TRIGGERED, RunReport, run_scenario
from tests.support import Event, events_of, half_way_emergency, inline, summary_of

REPO = Path(__file__).resolve().parents[1]
SCENARIOS = REPO / "scenarios"
TALK = "htnagent.domains.guide_talk:talk_domain"
TWO_LEVELS = [
    {"name": "guide", "domain": "museum.areas", "executor": "navigator"},
    {"name": "navigator", "domain": "museum.nodes", "executor": "robot"},
]


def run(scenario: Scenario) -> RunReport:
    return anyio.run(functools.partial(run_scenario, scenario, keep_events=True))


def of(events: list[Event], kind: str, agent: str | None = None) -> list[Event]:
    return [e for e in events if e["event"] == kind and (agent is None or e["agent"] == agent)]


def received(report: RunReport, goal: str) -> list[float]:
    return [e["t"] for e in of(events_of(report), "goal_received") if e["goal"] == goal]


# -- a robot action stopped before the fraction: the trigger waits for the resumed rest ----------

# The guide walks n40 → n38 along arc58 (4 m at 1 m/s) to explain the vase.  Bob is
# greeted at 1 s (a quarter of the way): the walk stops for the 3 s greeting, then
# the last three quarters are walked from 4 s.  Half the walk is covered at 5 s.
WALK = "move(n40,n38,arc58)"
INTERRUPTED_WALK: dict[str, Any] = {
    "robot": {"start": "n40", "speed": 1.0, "durations": {"explain": 30, "greet": 3, "answer": 2}},
    "agents": [{"name": "guide", "domain": TALK, "executor": "robot"}],
    "goals": [
        {"agent": "guide", "task": "present(vase)"},
        {"agent": "guide", "task": "greet(bob)", "emergency": True, "when": {"time": 1.0}},
        {"agent": "guide", "task": "answer(ann)", "when": {"action": WALK, "progress": 0.5}},
    ],
}


def test_a_goal_waits_until_the_resumed_move_has_covered_its_fraction() -> None:
    report = run(inline(INTERRUPTED_WALK))
    assert [g["status"] for g in summary_of(report)["goals"]] == ["success", "success", "success"]
    # Not at 2 s: the walk stood still from 1 s to 4 s.
    assert received(report, "answer(ann)") == [pytest.approx(5.0)]


def test_a_world_event_waits_until_the_resumed_move_has_covered_its_fraction() -> None:
    data = {**INTERRUPTED_WALK, "goals": INTERRUPTED_WALK["goals"][:2]}
    data["events"] = [{"when": {"action": WALK, "progress": 0.75}, "close": "arc1"}]
    report = run(inline(data))
    closed = of(events_of(report), "arc_closed", "world")
    assert [(e["arc"], e["t"]) for e in closed] == [("arc1", pytest.approx(6.0))]


def test_the_robot_reports_how_much_of_a_resumed_move_was_already_done() -> None:
    report = run(inline(INTERRUPTED_WALK))
    walks = [e for e in of(events_of(report), "robot_moving") if e["action"] == WALK]
    assert [(e["t"], e["done"], e["resumed"], e["duration"]) for e in walks] == [
        (0.0, 0.0, False, 4.0),
        (pytest.approx(4.0), pytest.approx(0.25), True, pytest.approx(3.0)),
    ]


def test_a_timed_action_stopped_before_the_fraction_triggers_on_its_resumed_rest() -> None:
    # explain(statue) takes 60 s; a question at a sixth of it is answered in 8 s, then
    # the rest is said.  Half the explanation is said 20 s into the rest, not at 30 s.
    base = load_scenario(SCENARIOS / "explain_question.yaml").model_dump(mode="json")
    data = {**base, "goals": [base["goals"][0]]}
    report = run(parse_scenario(data, "walk.yaml", SCENARIOS))
    walk = of(events_of(report), "robot_acting")[0]["t"]  # when the explanation starts
    data["goals"] += [
        {"agent": "guide", "task": "answer(ann)", "emergency": True, "when": {"time": walk + 10}},
        {"agent": "guide", "task": "answer(bob)", "when": {"action": "explain(statue)", "progress": 0.5}},
    ]
    report = run(parse_scenario(data, "question.yaml", SCENARIOS))
    assert [g["status"] for g in summary_of(report)["goals"]] == ["success"] * 3
    assert received(report, "answer(bob)") == [pytest.approx(walk + 10 + 8 + 20)]


def test_a_trigger_at_the_very_moment_of_the_suspension_fires_then() -> None:
    # The emergency's own trigger stops the walk at half way; another trigger at half
    # way fires at that same moment, not after the greeting.
    data = {
        **INTERRUPTED_WALK,
        "goals": [
            INTERRUPTED_WALK["goals"][0],
            {
                "agent": "guide",
                "task": "greet(bob)",
                "emergency": True,
                "when": {"action": WALK, "progress": 0.5},
            },
            {"agent": "guide", "task": "answer(ann)", "when": {"action": WALK, "progress": 0.5}},
        ],
    }
    report = run(inline(data))
    assert received(report, "greet(bob)") == [pytest.approx(2.0)]
    assert received(report, "answer(ann)") == [pytest.approx(2.0)]


# The navigator alone, n40 → n35 along arc59.  Half way an emergency that cannot be
# planned arrives and arc59 is shut meanwhile, so the walk is rolled back to n40.
ROLLED_BACK = half_way_emergency(
    then=[
        {
            "agent": "navigator",
            "task": "goto_node(n38)",
            "when": {"action": "move(n40,n35,arc59)", "progress": 0.8},
        }
    ],
    close=["arc51", "arc59"],
)


def test_a_move_rolled_back_before_the_fraction_never_fires_its_trigger() -> None:
    report = run(inline(ROLLED_BACK))
    started = [e["action"] for e in of(events_of(report), "action_started", "navigator")]
    assert started[:2] == ["move(n40,n35,arc59)", "rollback(move(n40,n35,arc59))"]
    rollback = [e for e in of(events_of(report), "robot_moving") if e["action"].startswith("rollback(")]
    assert [(e["done"], e["resumed"]) for e in rollback] == [(0.0, False)]
    never = summary_of(report)["goals"][2]
    assert (never["agent"], never["goal"], never["status"]) == ("navigator", "goto_node(n38)", "failure")
    assert never["reason"] == NEVER_TRIGGERED and never["given"] is None
    assert received(report, "goto_node(n38)") == []


# -- any agent's action, once finished ---------------------------------------------------------


def museum_with(goal: dict[str, Any]) -> Scenario:
    data = load_scenario(SCENARIOS / "museum.yaml").model_dump(mode="json")
    data["goals"].append(goal)
    return parse_scenario(data, "museum.yaml", SCENARIOS)


def finished_at(report: RunReport, agent: str, action: str) -> list[float]:
    return [
        e["t"]
        for e in of(events_of(report), "action_finished", agent)
        if e["action"] == action and e["result"] == "success"
    ]


def test_a_planning_agents_action_triggers_when_it_has_finished() -> None:
    trigger = {"action": "move_area(area7,area5)", "progress": 1}
    report = run(museum_with({"agent": "navigator", "task": "goto_node(n38)", "when": trigger}))
    [t] = finished_at(report, "guide", "move_area(area7,area5)")
    assert received(report, "goto_node(n38)") == [t]


def test_a_suspended_planning_action_triggers_when_its_resume_has_finished() -> None:
    # In museum.yaml the emergency suspends the guide's move_area(area8,area7); it is
    # finished later by resume(move_area(area8,area7)).
    trigger = {"action": "move_area(area8,area7)", "progress": 1}
    report = run(museum_with({"agent": "navigator", "task": "goto_node(n38)", "when": trigger}))
    assert finished_at(report, "guide", "move_area(area8,area7)") == []
    [t] = finished_at(report, "guide", "resume(move_area(area8,area7))")
    assert received(report, "goto_node(n38)") == [t]


def test_a_robot_move_with_progress_one_triggers_at_its_end() -> None:
    report = run(
        museum_with(
            {
                "agent": "navigator",
                "task": "goto_node(n38)",
                "when": {"action": "move(n35,n31,arc51)", "progress": 1},
            }
        )
    )
    [t] = finished_at(report, "navigator", "move(n35,n31,arc51)")
    assert received(report, "goto_node(n38)") == [pytest.approx(t)]


# -- triggers that could never fire are refused -------------------------------------------------


def museum_data() -> dict[str, Any]:
    return load_scenario(SCENARIOS / "museum.yaml").model_dump(mode="json")


def with_goal_trigger(when: dict[str, Any]) -> Callable[[], dict[str, Any]]:
    def make() -> dict[str, Any]:
        data = museum_data()
        data["goals"][1]["when"] = when
        return data

    return make


def with_event_trigger(when: dict[str, Any]) -> Callable[[], dict[str, Any]]:
    def make() -> dict[str, Any]:
        data = museum_data()
        data["events"] = [{"when": when, "close": "arc1"}]
        return data

    return make


REFUSED = [
    (
        "planning-action-part-way",
        with_goal_trigger({"action": "move_area(area8,area7)", "progress": 0.5}),
        "goals[1].when.progress",
        "move_area(area8,area7) is agent guide's action, not the robot's: its duration is not known",
    ),
    (
        "planning-goto-node-part-way",
        with_goal_trigger({"action": "goto_node(n5)", "progress": 0.99}),
        "goals[1].when.progress",
        "only trigger when it has finished (progress: 1), not at 0.99",
    ),
    (
        "resume",
        with_goal_trigger({"action": "resume(move(n40,n35,arc59))", "progress": 1}),
        "goals[1].when.action",
        "a trigger names the action itself (move(n40,n35,arc59)), not its resume",
    ),
    (
        "rollback",
        with_goal_trigger({"action": "rollback(move(n40,n35,arc59))", "progress": 0.5}),
        "goals[1].when.action",
        "not its rollback",
    ),
    (
        "event-planning-action-part-way",
        with_event_trigger({"action": "move_area(area8,area7)", "progress": 0.5}),
        "events[0].when.progress",
        "duration is not known in advance",
    ),
    (
        "event-resume",
        with_event_trigger({"action": "resume(move_area(area8,area7))", "progress": 1}),
        "events[0].when.action",
        "not its resume",
    ),
]


@pytest.mark.parametrize(("make", "where", "reason"), [c[1:] for c in REFUSED], ids=[c[0] for c in REFUSED])
def test_a_trigger_that_could_never_fire_is_refused(
    make: Callable[[], dict[str, Any]], where: str, reason: str
) -> None:
    with pytest.raises(ScenarioError) as info:
        parse_scenario(make(), "museum.yaml", SCENARIOS)
    assert info.value.where == where
    assert reason in str(info.value)
    assert "\n" not in str(info.value)


def test_a_talk_action_the_robot_has_no_duration_for_is_refused_as_a_trigger() -> None:
    data = load_scenario(SCENARIOS / "explain_question.yaml").model_dump(mode="json")
    data["robot"]["durations"] = {"answer": 8}
    with pytest.raises(ScenarioError, match="the robot cannot do explain") as info:
        parse_scenario(data, "talk.yaml", SCENARIOS)
    assert info.value.where == "goals[1].when.action"


@pytest.mark.parametrize(
    "when",
    [
        {"action": "move_area(area8,area7)", "progress": 1},
        {"action": "goto_node(n1)", "progress": 1.0},
        {"action": "move(n40,n35,arc59)", "progress": 0.25},
    ],
)
def test_triggers_that_can_fire_are_accepted(when: dict[str, Any]) -> None:
    for make in (with_goal_trigger(when), with_event_trigger(when)):
        parse_scenario(make(), "museum.yaml", SCENARIOS)


# -- the robot: a resumed rest or a rollback can be suspended too ---------------------------------


async def robot_answers(orders: list[tuple[float, Any]], until: int) -> list[tuple[float, Any]]:
    """Give the robot (at n40 on the museum map) timed orders; its first ``until`` answers."""
    scenario = load_scenario(SCENARIOS / "museum.yaml")
    clock = Clock()
    trace = Trace(clock)
    robot = AdapterActor("robot", clock, trace, Robot(RobotWorld(scenario.world, at="n40"), 1.0))
    up: Mailbox[Any] = Mailbox(clock, "test")
    robot.connect(up)
    answers: list[tuple[float, Any]] = []
    async with anyio.create_task_group() as tg:
        tg.start_soon(clock.keep_time)
        await tg.start(robot.run)
        for when, order in orders:
            clock.call_at(when, functools.partial(robot.inbox.send, order))
        while len(answers) < until:
            answer = await up.receive()
            answers.append((clock.now(), answer))
        tg.cancel_scope.cancel()
    up.close()
    robot.inbox.close()
    return answers


MOVE = parse("move(n40,n35,arc59)")
MOVE_LENGTH = 4.123105625617661  # arc59, in metres (seconds at 1 m/s)


def kinds(answers: list[tuple[float, Any]]) -> list[tuple[str, int]]:
    return [(type(a).__name__, a.seq) for _, a in answers]


def test_the_robot_suspends_a_resumed_move_and_resumes_it_again() -> None:
    orders = [
        (0.0, Execute(action=MOVE, seq=1)),
        (1.0, Suspend(action=MOVE, seq=1)),
        (2.0, Resume(action=MOVE, seq=2)),
        (2.5, Suspend(action=MOVE, seq=2)),
        (3.0, Resume(action=MOVE, seq=3)),
    ]
    answers = anyio.run(robot_answers, orders, 3)
    # docs/design.md §4: resume(A) can be suspended wherever A can; A is left suspended
    # with less to do.
    assert kinds(answers) == [("Suspended", 1), ("Suspended", 2), ("Success", 3)]
    assert answers[1][0] == pytest.approx(2.5)
    # 1 s walked, 1 s standing, 0.5 s walked, 0.5 s standing, then the remaining 2.623 s.
    assert answers[2][0] == pytest.approx(3.0 + MOVE_LENGTH - 1.5)


def test_the_robot_suspends_a_rollback_nearer_the_start() -> None:
    back = Atom("rollback", (MOVE,))
    orders = [
        (0.0, Execute(action=MOVE, seq=1)),
        (1.0, Suspend(action=MOVE, seq=1)),
        (2.0, Execute(action=back, seq=2)),
        (2.5, Suspend(action=MOVE, seq=2)),  # not what order 2 is doing: refused
        (2.6, Suspend(action=back, seq=2)),
        (3.0, Execute(action=back, seq=3)),
    ]
    answers = anyio.run(robot_answers, orders, 4)
    assert kinds(answers) == [("Suspended", 1), ("Refused", 2), ("Suspended", 2), ("Success", 3)]
    assert answers[2][0] == pytest.approx(2.6)
    # 1 s walked out, 0.6 s walked back, so 0.4 s are left to walk back from 3.0.
    assert answers[3][0] == pytest.approx(3.4)


def test_the_robot_still_suspends_a_fresh_move() -> None:
    orders = [(0.0, Execute(action=MOVE, seq=1)), (1.0, Suspend(action=MOVE, seq=1))]
    answers = anyio.run(robot_answers, orders, 1)
    assert isinstance(answers[0][1], Suspended) and answers[0][0] == pytest.approx(1.0)


# -- action_timeout must leave the robot time for its longest action ------------------------------


def test_an_action_timeout_shorter_than_the_longest_move_is_refused() -> None:
    data = museum_data()
    data["action_timeout"] = 10.0  # arc50 is 10.63 m long, at 1 m/s
    with pytest.raises(ScenarioError) as info:
        parse_scenario(data, "museum.yaml", SCENARIOS)
    assert info.value.where == "action_timeout"
    assert "a move over arc50 (10.6301 m at 1 m/s) takes 10.6301 s; give more than 10.6301 s" in str(
        info.value
    )
    assert "\n" not in str(info.value)


def test_an_action_timeout_shorter_than_the_longest_timed_action_is_refused() -> None:
    data = load_scenario(SCENARIOS / "explain_question.yaml").model_dump(mode="json")
    data["action_timeout"] = 59.0  # explain takes 60 s
    with pytest.raises(ScenarioError, match=r"explain \(robot.durations\) takes 60 s; give more than 60 s"):
        parse_scenario(data, "talk.yaml", SCENARIOS)
    data["action_timeout"] = 60.0  # exactly as long is too short as well: the robot ends just then
    with pytest.raises(ScenarioError, match="give more than 60 s"):
        parse_scenario(data, "talk.yaml", SCENARIOS)


def test_an_action_timeout_at_a_slow_robot_counts_its_speed() -> None:
    data = museum_data()
    data["action_timeout"] = 15.0
    parse_scenario(data, "museum.yaml", SCENARIOS)
    data["robot"]["speed"] = 0.5  # arc50 now takes 21.26 s
    with pytest.raises(ScenarioError, match=r"give more than 21\.2603 s"):
        parse_scenario(data, "museum.yaml", SCENARIOS)
    data["action_timeout"] = 21.5
    parse_scenario(data, "museum.yaml", SCENARIOS)
