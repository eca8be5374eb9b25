"""The museum guide end to end: the published experiments and the paper's other situations.

Each test runs a scenario on the simulated robot (virtual time, ~50 ms a run)
and reads the trace: the goals' outcomes, the robot's path, and the ``message``
events that carry orders and results between guide → navigator → robot
(docs/design.md §4–§6).
"""

from __future__ import annotations

import functools
import json
import subprocess
import sys
from collections.abc import Iterable
from pathlib import Path
from typing import Any

import anyio
import pytest
import yaml

from htnagent.cli.commands import main
from htnagent.domains.guide_talk import talk_domain
from htnagent.domains.maps import WorldMap
from htnagent.model.terms import atom, parse
from htnagent.planning.planner import plan
from htnagent.runtime.events import GoalResumed, PlanSelected, TraceEvent
from htnagent.scenario import Scenario, load_scenario, parse_scenario
from htnagent.system.runtime import Runtime
from htnagent.system.simulation import RunReport, run_scenario
from tests.support import Event, events_of, half_way_emergency, inline, statuses, summary_of

REPO = Path(__file__).resolve().parents[1]
SCENARIOS = REPO / "scenarios"

# (start, first goal, interrupted on, emergency goal): the published table (docs/design.md §6).
PUBLISHED = [
    ("n40", "n1", "arc59", "n38"),
    ("n40", "n1", "arc59", "n28"),
    ("n40", "n1", "arc59", "n29"),
    ("n1", "n40", "arc5", "n13"),
    ("n1", "n40", "arc5", "n4"),
    ("n1", "n40", "arc5", "n12"),
]
MODES = ["online", "naive"]

Message = tuple[str, str, str, str]  # (from, to, kind, action)


@functools.cache
def scenario_file(name: str) -> Scenario:
    return load_scenario(SCENARIOS / name)


@functools.cache
def report_of(name: str, mode: str | None = None) -> RunReport:
    """The run of a shipped scenario (cached: the runs are deterministic)."""
    return run(scenario_file(name), mode)


def run(scenario: Scenario, mode: str | None = None) -> RunReport:
    return anyio.run(functools.partial(run_scenario, scenario, replanning=mode, keep_events=True))


TWO_LEVELS = [
    {"name": "guide", "domain": "museum.areas", "executor": "navigator"},
    {"name": "navigator", "domain": "museum.nodes", "executor": "robot"},
]


def of(events: Iterable[Event], kind: str, agent: str | None = None) -> list[Event]:
    return [e for e in events if e["event"] == kind and (agent is None or e["agent"] == agent)]


def messages(
    report: RunReport, kinds: Iterable[str] = ("suspend", "suspended", "resume", "clear")
) -> list[Message]:
    wanted = set(kinds)
    return [
        (e["agent"], e["to"], e["kind"], e["action"])
        for e in of(events_of(report), "message")
        if e["kind"] in wanted
    ]


def position(events: list[Event], event: str, **fields: Any) -> int:
    """Where the first ``event`` with these field values is in the trace."""
    return next(
        i
        for i, e in enumerate(events)
        if e["event"] == event and all(e.get(k) == v for k, v in fields.items())
    )


# -- the six published experiments ----------------------------------------------------------


@pytest.mark.parametrize("mode", MODES)
@pytest.mark.parametrize("case", PUBLISHED, ids=lambda c: "_".join(c))
def test_published_experiment_reaches_both_goals_and_resumes_the_first(
    case: tuple[str, str, str, str], mode: str
) -> None:
    start, goal, interrupted_on, emergency = case
    report = report_of(f"paper_{start}_{goal}_{emergency}.yaml", mode)
    summary = summary_of(report)
    assert report.summary.outcomes == (
        ("guide", f"goto({goal})", "success", ""),
        ("guide", f"goto({emergency})", "success", ""),
    )
    assert emergency in summary["visited"]
    assert summary["visited"][0] == start
    assert summary["robot"] == {"at": goal}
    # The emergency came while the robot was on the published arc ...
    suspended = of(events_of(report), "goal_suspended", "guide")
    assert [e["goal"] for e in suspended] == [f"goto({goal})"]
    moving = [e for e in of(events_of(report), "robot_moving") if e["t"] <= suspended[0]["t"]]
    assert moving[-1]["arc"] == interrupted_on
    # ... and afterwards the first goal was resumed, in the run's mode.
    resumed = of(events_of(report), "goal_resumed", "guide")
    assert [(e["goal"], e["replanning"]) for e in resumed] == [(f"goto({goal})", mode)]
    finished = [e["goal"] for e in of(events_of(report), "goal_finished", "guide")]
    assert finished == [f"goto({emergency})", f"goto({goal})"]


def resumed_and_fresh_costs(scenario: Scenario) -> list[tuple[str, str, float, float]]:
    """Each goal resumed in an on-line run: (agent, goal, cost of the plan it resumes with,
    cost of a plan made from scratch from the belief at that moment)."""
    runtime: list[Runtime] = []
    waiting: dict[str, tuple[str, float]] = {}
    found: list[tuple[str, str, float, float]] = []

    def observe(event: TraceEvent) -> None:
        if isinstance(event, GoalResumed):
            agent = runtime[0].agents[event.agent]
            fresh = plan(agent.domain, agent.belief, [parse(event.goal)])
            waiting[event.agent] = (event.goal, fresh.best.cost if fresh.best else float("inf"))
        elif isinstance(event, PlanSelected) and event.agent in waiting:
            goal, fresh_cost = waiting.pop(event.agent)
            found.append((event.agent, goal if goal == event.goal else "?", event.cost, fresh_cost))

    anyio.run(
        functools.partial(
            run_scenario, scenario, replanning="online", observers=[observe], on_start=runtime.append
        )
    )
    return found


@pytest.mark.parametrize("case", PUBLISHED, ids=lambda c: "_".join(c))
def test_the_published_situations_resume_at_the_cost_of_a_fresh_plan(case: tuple[str, str, str, str]) -> None:
    # §2, §5: the plans kept through the emergency, at both levels, are as good as planning
    # afresh from where the robot is when the first goal resumes.
    start, goal, _, emergency = case
    found = resumed_and_fresh_costs(scenario_file(f"paper_{start}_{goal}_{emergency}.yaml"))
    assert ("guide", f"goto({goal})") in [(agent, g) for agent, g, _, _ in found]
    for agent, resumed_goal, kept, fresh in found:
        assert kept == pytest.approx(fresh, abs=1e-6), (agent, resumed_goal)


@pytest.mark.parametrize("case", PUBLISHED, ids=lambda c: "_".join(c))
def test_online_replanning_travels_no_farther_than_naive(case: tuple[str, str, str, str]) -> None:
    start, goal, _, emergency = case
    name = f"paper_{start}_{goal}_{emergency}.yaml"
    online = report_of(name, "online").summary.distance
    naive = report_of(name, "naive").summary.distance
    assert online <= naive + 1e-9


# -- the message exchange across the levels (the paper's Figures 2 and 6) --------------------

SUSPEND_CASCADE_N40: list[Message] = [
    # Expect: the suspension goes down guide → navigator → robot ...
    ("guide", "navigator", "suspend", "move_area(area8,area7)"),
    ("navigator", "robot", "suspend", "move(n40,n35,arc59)"),
    # ... and "suspended" comes back up robot → navigator → guide.
    ("robot", "navigator", "suspended", "move(n40,n35,arc59)"),
    ("navigator", "guide", "suspended", "move_area(area8,area7)"),
]


def test_suspend_goes_down_and_suspended_comes_back_up_then_resume_goes_down() -> None:
    report = report_of("museum.yaml")
    assert messages(report) == [
        *SUSPEND_CASCADE_N40,
        # The emergency's route to n28 goes on through area7: its plan starts with
        # resume(move_area(area8,area7)), and the resume goes down the same way.
        ("guide", "navigator", "resume", "move_area(area8,area7)"),
        ("navigator", "robot", "resume", "move(n40,n35,arc59)"),
    ]
    events = events_of(report)
    # Each level stacks its goal before it answers "suspended" to the level above,
    # and the guide stacks goto(n1) only once the navigator has answered.
    nav_stacked = position(events, "goal_suspended", agent="navigator")
    nav_answer = position(events, "message", kind="suspended", to="guide")
    guide_stacked = position(events, "goal_suspended", agent="guide")
    assert nav_stacked < nav_answer < guide_stacked
    # The navigator pops its goal (Algorithm 5) before resuming its own action below.
    nav_popped = position(events, "goal_resumed", agent="navigator")
    resume_below = position(events, "message", kind="resume", to="robot")
    assert nav_popped < resume_below
    assert events[nav_popped]["goal"] == "move_area(area8,area7)"


def test_resume_after_the_emergency_goes_down_when_the_first_goal_is_resumed() -> None:
    # To n38 (area8) the navigator rolls back off arc59 itself; when goto(n1) is
    # resumed afterwards the guide's plan starts with resume(move_area(area8,area7)).
    report = report_of("paper_n40_n1_n38.yaml")
    assert messages(report) == [
        *SUSPEND_CASCADE_N40,
        ("guide", "navigator", "resume", "move_area(area8,area7)"),
    ]
    events = events_of(report)
    resumed = position(events, "goal_resumed", agent="guide")
    resume_sent = position(events, "message", kind="resume")
    assert resumed < resume_sent
    # The navigator's half move was already undone by the emergency: nothing to resume below.
    assert "rollback(move(n40,n35,arc59))" in [e["action"] for e in of(events, "action_started", "navigator")]


def test_clear_goes_down_when_the_resumed_plan_does_not_start_with_resume() -> None:
    # From n1 to n40, interrupted on arc5 by n13 (area2): the emergency leaves area1
    # through area2, so resumed goto(n40) goes on from area2 and never resumes
    # move_area(area1,area3): the guide clears it and the navigator drops it.
    report = report_of("paper_n1_n40_n13.yaml")
    assert messages(report) == [
        ("guide", "navigator", "suspend", "move_area(area1,area3)"),
        ("navigator", "robot", "suspend", "move(n1,n6,arc5)"),
        ("robot", "navigator", "suspended", "move(n1,n6,arc5)"),
        ("navigator", "guide", "suspended", "move_area(area1,area3)"),
        # The navigator settles its half move for the emergency itself (rolling it back to
        # n1 ties with finishing it to n6: both 15.66 m to n13), so the guide's clear
        # stops at the navigator: the robot keeps nothing.
        ("guide", "navigator", "clear", "move_area(area1,area3)"),
    ]
    settled = [e["action"] for e in of(events_of(report), "action_started", "navigator")][1]
    assert settled == "rollback(move(n1,n6,arc5))"
    resumed = of(events_of(report), "goal_resumed", "guide")
    plan_after = [e for e in of(events_of(report), "plan_selected", "guide") if e["t"] >= resumed[0]["t"]]
    assert not plan_after[0]["plan"][0].startswith("resume(")
    assert [e["goal"] for e in of(events_of(report), "goal_cleared", "navigator")] == [
        "move_area(area1,area3)"
    ]


# An emergency that cannot be planned at all (area8 is shut) makes no move, so when
# the first goal, unreachable too, is given up, the robot still keeps its half move.
CLEAR_TO_THE_ROBOT = {
    "robot": {"start": "n1", "speed": 1.0},
    "agents": TWO_LEVELS,
    "goals": [
        {"agent": "guide", "task": "goto(n38)"},
        {
            "agent": "guide",
            "task": "goto(n40)",
            "emergency": True,
            "when": {"action": "move(n1,n6,arc5)", "progress": 0.5},
        },
        {"agent": "guide", "task": "goto(n12)"},
    ],
    "events": [{"when": {"time": 1.0}, "close": "arc51"}],
}


def test_clear_cascades_down_to_the_robot_when_the_half_move_is_still_kept() -> None:
    report = run(inline(CLEAR_TO_THE_ROBOT))
    assert messages(report)[:6] == [
        ("guide", "navigator", "suspend", "move_area(area1,area3)"),
        ("navigator", "robot", "suspend", "move(n1,n6,arc5)"),
        ("robot", "navigator", "suspended", "move(n1,n6,arc5)"),
        ("navigator", "guide", "suspended", "move_area(area1,area3)"),
        # goto(n40) fails at once, goto(n38) has no plan left: clear, guide → navigator → robot.
        ("guide", "navigator", "clear", "move_area(area1,area3)"),
        ("navigator", "robot", "clear", "move(n1,n6,arc5)"),
    ]
    assert statuses(report)[:2] == ["failure", "failure"]
    assert [e["goal"] for e in of(events_of(report), "goal_cleared", "navigator")] == [
        "move_area(area1,area3)"
    ]


def test_a_goal_after_a_cleared_suspension_starts_from_where_the_robot_stopped() -> None:
    # Clearing forgets how to resume, not where the robot is: half way along arc5,
    # goto(n12) (area3) is still reached.
    report = run(inline(CLEAR_TO_THE_ROBOT))
    assert statuses(report) == ["failure", "failure", "success"]
    assert summary_of(report)["robot"] == {"at": "n12"}
    assert_never_travels_a_closed_arc(events_of(report))


def test_a_resumed_goal_whose_plan_starts_with_rollback_is_reached() -> None:
    # The navigator alone, from n40 to n35 along arc59.  Half way an emergency that
    # cannot be planned (area8 is cut off) arrives; arc59 is shut meanwhile, so the
    # resumed goal must roll back to n40 and go round by n38.
    scenario = inline(half_way_emergency(close=["arc51", "arc59"]))
    report = run(scenario)
    assert statuses(report) == ["success", "failure"]
    started = [e["action"] for e in of(events_of(report), "action_started", "navigator")]
    assert started[:2] == ["move(n40,n35,arc59)", "rollback(move(n40,n35,arc59))"]
    # The rollback needs what the robot kept: nothing is cleared before it.
    assert "clear" not in [m[2] for m in messages(report)]
    assert summary_of(report)["robot"] == {"at": "n35"}
    assert summary_of(report)["visited"] == ["n40", "n40", "n38", "n35"]


# -- nested emergencies at the parent -----------------------------------------------------------


@pytest.mark.parametrize("mode", MODES)
def test_an_emergency_during_an_emergency_stacks_two_goals_and_all_succeed(mode: str) -> None:
    report = report_of("nested_emergencies.yaml", mode)
    events = events_of(report)
    assert statuses(report) == ["success", "success", "success"]
    # Expect 1. goto(n1) under goto(n28)   2. goto(n28) under goto(n38)
    suspended = of(events, "goal_suspended", "guide")
    assert [(e["goal"], e["stack_depth"]) for e in suspended] == [("goto(n1)", 1), ("goto(n28)", 2)]
    assert suspended[1]["t"] == pytest.approx(10.0)
    # The innermost emergency ends first; each goal below is resumed in turn.
    assert [e["goal"] for e in of(events, "goal_finished", "guide")] == ["goto(n38)", "goto(n28)", "goto(n1)"]
    assert [e["goal"] for e in of(events, "goal_resumed", "guide")] == ["goto(n28)", "goto(n1)"]
    visited = summary_of(report)["visited"]
    assert visited.index("n38") < visited.index("n28") < len(visited) - 1
    assert summary_of(report)["robot"] == {"at": "n1"}


# -- the world changes while the robot works ------------------------------------------------------


def closed_intervals(events: list[Event]) -> dict[str, list[tuple[float, float]]]:
    """When each arc was closed: ``[from, until)`` intervals (until inf if never opened)."""
    out: dict[str, list[tuple[float, float]]] = {}
    since: dict[str, float] = {}
    for e in events:
        if e["event"] == "arc_closed":
            since.setdefault(e["arc"], e["t"])
        elif e["event"] == "arc_opened" and e["arc"] in since:
            out.setdefault(e["arc"], []).append((since.pop(e["arc"]), e["t"]))
    for arc, t in since.items():
        out.setdefault(arc, []).append((t, float("inf")))
    return out


def assert_never_travels_a_closed_arc(events: list[Event]) -> None:
    closed = closed_intervals(events)
    for e in of(events, "robot_moving"):
        for start, end in closed.get(e["arc"], []):
            assert not start <= e["t"] < end, f"the robot set off along closed {e['arc']} at {e['t']}"


@pytest.mark.parametrize("mode", MODES)
def test_a_door_shut_on_the_route_is_planned_around(mode: str) -> None:
    report = report_of("door_shut.yaml", mode)
    events = events_of(report)
    assert statuses(report) == ["success"]
    assert summary_of(report)["robot"] == {"at": "n1"}
    shut = of(events, "arc_closed")
    assert [e["arc"] for e in shut] == ["arc22"]
    t = shut[0]["t"]
    # When the door shut the robot was heading for it: the navigator's plan crossed it.
    nav_plan = [e for e in of(events, "plan_selected", "navigator") if e["t"] <= t][-1]
    assert "move(n18,n12,arc22)" in nav_plan["plan"]
    assert [e for e in of(events, "robot_moving") if e["t"] <= t][-1]["arc"] == "arc38"
    # The guide gave up the door and went round: no plan after it crosses area5 → area3.
    after = [e for e in of(events, "plan_selected", "guide") if e["t"] > t]
    assert after
    assert all("move_area(area5,area3)" not in e["plan"] for e in after)
    assert_never_travels_a_closed_arc(events)
    assert "arc22" not in [e["arc"] for e in of(events, "robot_moving")]


def test_an_arc_shut_ahead_of_the_navigator_is_repaired_around() -> None:
    # The navigator alone plans the whole route; arc38 is on it, ahead of the robot.
    scenario = inline(
        {
            "robot": {"start": "n40", "speed": 1.0},
            "agents": [{"name": "navigator", "domain": "museum.nodes", "executor": "robot"}],
            "goals": [{"agent": "navigator", "task": "goto_node(n1)"}],
            "events": [{"when": {"time": 10.0}, "close": "arc38"}, {"when": {"time": 40.0}, "open": "arc38"}],
        }
    )
    report = run(scenario)
    events = events_of(report)
    assert statuses(report) == ["success"]
    assert "move(n22,n18,arc38)" in of(events, "plan_selected", "navigator")[0]["plan"]
    assert "arc38" not in [e["arc"] for e in of(events, "robot_moving")]
    assert_never_travels_a_closed_arc(events)
    assert summary_of(report)["robot"] == {"at": "n1"}


@pytest.mark.parametrize("mode", MODES)
def test_a_goal_that_becomes_unreachable_fails_and_the_next_goal_runs(mode: str) -> None:
    report = report_of("unreachable_goal.yaml", mode)
    first, second = summary_of(report)["goals"]
    assert first["goal"] == "goto(n40)" and first["status"] == "failure"
    assert "goto(n40)" in first["reason"]
    assert (second["agent"], second["goal"], second["status"]) == ("guide", "goto(n12)", "success")
    # Both given at 0; the second waits its turn (Algorithm 4): it starts as the first ends.
    assert first["given"] == second["given"] == 0.0
    assert second["started"] == first["ended"] > 0 and second["ended"] > second["started"]
    assert first["waited_s"] == second["waited_s"] == 0.0
    assert summary_of(report)["robot"] == {"at": "n12"}
    failed = [e for e in of(events_of(report), "goal_finished", "guide") if e["status"] == "failure"]
    assert [e["goal"] for e in failed] == ["goto(n40)"]
    assert failed[0]["reason"]
    assert_never_travels_a_closed_arc(events_of(report))


def test_run_exits_1_when_a_goal_fails() -> None:
    path = SCENARIOS / "unreachable_goal.yaml"
    done = subprocess.run(
        [sys.executable, "-m", "htnagent", "run", "--json", str(path)],
        capture_output=True,
        text=True,
        cwd=REPO,
        timeout=60,
    )
    assert done.returncode == 1, done.stderr
    assert done.stderr == ""
    summary = json.loads(done.stdout.splitlines()[-1])
    assert summary["event"] == "summary"
    assert [g["status"] for g in summary["goals"]] == ["failure", "success"]


# -- the guide talks (htnagent.domains.guide_talk) --------------------------------------------------


@pytest.mark.parametrize("mode", MODES)
def test_a_question_suspends_the_explanation_which_then_resumes_where_it_stopped(mode: str) -> None:
    report = report_of("explain_question.yaml", mode)
    events = events_of(report)
    assert statuses(report) == ["success", "success"]
    # Expect: explain(statue) 40% said → suspended → answer(ann) → resume says the last 60%.
    said = [(e["t"], e["action"], e["done"], e["duration"]) for e in of(events, "robot_acting")]
    walk = of(events, "robot_moving")[0]["duration"]  # n1 → n4
    assert said == [
        (pytest.approx(walk), "explain(statue)", 0.0, 60.0),
        (pytest.approx(walk + 24), "answer(ann)", 0.0, 8.0),
        (pytest.approx(walk + 32), "explain(statue)", pytest.approx(0.4), pytest.approx(36.0)),
    ]
    guide = [
        (e["event"], e.get("action") or e.get("goal"), e.get("result") or e.get("status"))
        for e in events
        if e["agent"] == "guide" and e["event"] in ("action_started", "action_finished", "goal_finished")
        if "move" not in str(e.get("action"))
    ]
    assert guide == [
        ("action_started", "explain(statue)", None),
        ("action_finished", "explain(statue)", "suspended"),
        ("action_started", "answer(ann)", None),
        ("action_finished", "answer(ann)", "success"),
        ("goal_finished", "answer(ann)", "success"),
        ("action_started", "resume(explain(statue))", None),
        ("action_finished", "resume(explain(statue))", "success"),
        ("goal_finished", "present(statue)", "success"),
    ]
    assert messages(report) == [
        ("guide", "robot", "suspend", "explain(statue)"),
        ("robot", "guide", "suspended", "explain(statue)"),
        ("guide", "robot", "resume", "explain(statue)"),
    ]
    assert of(events, "goal_finished", "guide")[-1]["t"] == pytest.approx(walk + 60 + 8)


def test_a_resumed_explanation_is_suspended_again_by_a_second_question() -> None:
    data = scenario_file("explain_question.yaml").model_dump(mode="json")
    data["goals"].append({"agent": "guide", "task": "answer(bob)", "emergency": True, "when": {"time": 50.0}})
    report = run(parse_scenario(data, "two_questions.yaml", SCENARIOS))
    events = events_of(report)
    assert statuses(report) == ["success", "success", "success"]
    # docs/design.md §4: resume(explain(statue)) can be suspended wherever explain can: bob
    # is answered at once, then the rest of the rest is said.
    kinds = [m[2] for m in messages(report)]
    assert kinds == ["suspend", "suspended", "resume", "suspend", "suspended", "resume"]
    assert of(events, "goal_received", "guide")[-1]["t"] == 50.0
    said = [(e["action"], e["t"]) for e in of(events, "robot_acting")]
    explain, ann, bob = "explain(statue)", "answer(ann)", "answer(bob)"
    assert [a for a, _ in said] == [explain, ann, explain, bob, explain]
    assert said[3][1] == pytest.approx(50.0)
    finished = [e["goal"] for e in of(events, "goal_finished", "guide")]
    assert finished == ["answer(ann)", "answer(bob)", "present(statue)"]
    assert [e["goal"] for e in of(events, "goal_resumed", "guide")] == ["present(statue)", "present(statue)"]
    # 60 s of explanation in all, whatever the interruptions: 24 + 8 (ann) + 18 + 8 (bob) + 18.
    walk = of(events, "robot_acting")[0]["t"]
    assert of(events, "goal_finished", "guide")[-1]["t"] == pytest.approx(walk + 60 + 8 + 8)


@pytest.mark.parametrize("mode", MODES)
def test_a_visitor_is_greeted_at_once_and_the_walk_goes_on(mode: str) -> None:
    report = report_of("greeting.yaml", mode)
    events = events_of(report)
    assert statuses(report) == ["success", "success"]
    received = of(events, "goal_received", "guide")[1]
    assert (received["goal"], received["emergency"]) == ("greet(bob)", True)
    # The walk stops on arc58 and the greeting starts at that very moment.
    assert messages(report) == [
        ("guide", "robot", "suspend", "move(n40,n38,arc58)"),
        ("robot", "guide", "suspended", "move(n40,n38,arc58)"),
        ("guide", "robot", "resume", "move(n40,n38,arc58)"),
    ]
    greet = of(events, "robot_acting")[0]
    assert (greet["action"], greet["t"]) == ("greet(bob)", received["t"])
    started = [e["action"] for e in of(events, "action_started", "guide")]
    assert started == ["move(n40,n38,arc58)", "greet(bob)", "resume(move(n40,n38,arc58))", "explain(vase)"]
    # Only the rest of the arc is walked after the greeting.
    assert summary_of(report)["distance"] == pytest.approx(4.0)
    assert summary_of(report)["robot"] == {"at": "n38"}


def test_a_half_explanation_is_resumed_not_restarted_until_it_is_cleared(museum_map: WorldMap) -> None:
    d = talk_domain(museum_map)
    explain = atom("explain(statue)")
    at_statue = d.initial_state("n4")
    half = d.suspend(at_statue, explain)
    assert d.apply(half, explain) is None  # no restart while the half is kept ...
    assert d.apply(half, atom("resume(explain(statue))")) is not None  # ... only the rest
    cleared = d.clear(half, explain)
    assert d.apply(cleared, atom("resume(explain(statue))")) is None
    assert d.apply(cleared, explain) is not None  # forgotten: explain it again from the start


def test_a_talk_action_the_robot_has_no_duration_for_fails() -> None:
    data = scenario_file("greeting.yaml").model_dump(mode="json")
    data["robot"]["durations"] = {"explain": 30}
    report = run(parse_scenario(data, "no_greet.yaml", SCENARIOS))
    first, second = summary_of(report)["goals"]
    assert first["status"] == "success"
    assert second["status"] == "failure"
    assert "the robot cannot do greet(bob)" in second["reason"]


@pytest.mark.parametrize("name", ["explain_question.yaml", "greeting.yaml"])
def test_the_talk_scenarios_check_and_run_with_exit_0(name: str, capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["check", str(SCENARIOS / name)]) == 0
    assert capsys.readouterr().out == "ok\n"
    assert main(["run", "--json", str(SCENARIOS / name)]) == 0
    lines = capsys.readouterr().out.splitlines()
    assert json.loads(lines[-1])["event"] == "summary"


@pytest.mark.parametrize(
    ("durations", "where", "reason"),
    [
        ({"move": 5}, "robot.durations.move", "moves take their arc's length"),
        ({"sing": 5}, "robot.durations.sing", "has no action sing"),
        ({"greet": 0}, "robot.durations.greet", "greater than 0"),
    ],
)
def test_a_bad_robot_duration_is_a_one_line_error(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], durations: dict[str, Any], where: str, reason: str
) -> None:
    data = scenario_file("greeting.yaml").model_dump(mode="json")
    data["robot"]["durations"] = durations
    data["map"] = str(SCENARIOS / "museum_map.yaml")
    path = tmp_path / "bad.yaml"
    path.write_text(yaml.safe_dump(data))
    assert main(["check", str(path)]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "Traceback" not in err
    assert err.startswith(f"htnagent: error: {path}: {where}: ")
    assert reason in err


# -- --plot -------------------------------------------------------------------------------------------


def test_plot_draws_the_run_into_a_png(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    target = tmp_path / "run.png"
    assert main(["run", str(SCENARIOS / "museum.yaml"), "--plot", str(target)]) == 0
    out, err = capsys.readouterr()
    assert err == ""
    assert "picture saved to" in out
    assert target.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


@pytest.mark.parametrize(
    ("target", "reason"),
    [("run.jpg", "give one of .png, .svg, .pdf"), ("no/such/folder/run.png", "does not exist")],
)
def test_a_bad_plot_target_is_a_one_line_error_before_the_run(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], target: str, reason: str
) -> None:
    path = tmp_path / target
    assert main(["run", str(SCENARIOS / "museum.yaml"), "--plot", str(path)]) == 2
    out, err = capsys.readouterr()
    assert out == ""  # refused before anything ran
    assert err.count("\n") == 1 and "Traceback" not in err
    assert err.startswith(f"htnagent: error: {path}: ")
    assert reason in err
    assert not path.exists()
