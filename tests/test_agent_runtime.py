"""The agent runtime as short stories (docs/design.md §4, published Algorithms 2–4).

Each story builds a :class:`~htnagent.system.runtime.Runtime` with one agent, the
courier, over a :class:`~executors.scripted.ScriptedExecutor` (the robot), gives
it goals at set simulated times and reads the trace back.  The courier's world::

        b            go(X,Y) costs the road's length and takes 1 s unless the
    4 /   \\ 4        script says otherwise.  It is suspendable: the suspension
     a     d         only notes heading(X,Y) (the courier is still at X), and
    5 \\   / 5        resume(go(X,Y)), from X, costs half the road.
        c            scan(X) (at X, cost 1) cannot be suspended.

``goto(d)`` from ``a`` has two plans: ``go(a,b), go(b,d)`` (8) and
``go(a,c), go(c,d)`` (10).  Traces are compared as lines of :func:`story`.
"""

from __future__ import annotations

import asyncio
import functools
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import anyio
import pytest
from anyio.abc import TaskStatus

from htnagent.agent import AgentConfig, GoalStatus
from htnagent.executors.scripted import ScriptedExecutor
from htnagent.model.domain import Domain, Effect, Suspension
from htnagent.model.terms import Atom, atom
from htnagent.runtime.clock import Clock
from htnagent.runtime.events import ActionStarted, GoalFinished, GoalResumed, TraceEvent
from htnagent.runtime.executor import ActionOutcome, Executor, ExecutorActor
from htnagent.runtime.messages import Message
from htnagent.runtime.trace import Trace
from htnagent.system.runtime import GoalOutcome, Runtime
from htnagent.upkeep import Replanning
from tests.support import Event, record

ROADS = {("a", "b"): 4.0, ("b", "d"): 4.0, ("a", "c"): 5.0, ("c", "d"): 5.0}
LENGTH = {**ROADS, **{(y, x): n for (x, y), n in ROADS.items()}}
COURIER = "courier"
GUARD = 5.0  # real seconds: a story that takes longer has hung


def courier_domain() -> Domain:
    d = Domain("courier")

    def length(action: Atom) -> float:
        return LENGTH[(str(action.args[0]), str(action.args[1]))]

    d.operator(
        "go(?x,?y)",
        pre=["at(?x)", "road(?x,?y)"],
        add=["at(?y)"],
        delete=["at(?x)", "heading(?x,?y)"],
        cost=length,
        suspend=Suspension(
            add=("heading(?x,?y)",),
            cleared=("heading(?x,?y)",),  # it only records that go(X,Y) can be resumed
            resume=Effect(
                pre=("heading(?x,?y)", "at(?x)"),
                add=("at(?y)",),
                delete=("at(?x)", "heading(?x,?y)"),
                cost=lambda action: length(action) / 2,
            ),
        ),
        undo="go(?y,?x)",
    )
    d.operator("scan(?x)", pre=["at(?x)"], add=["scanned(?x)"], cost=1.0)
    d.method("goto(?n)", "arrived", when=["at(?n)"], do=[])
    d.method("goto(?n)", "direct", when=["at(?x)", "road(?x,?n)"], do=["go(?x,?n)"])
    d.method(
        "goto(?n)",
        "via",
        when=["at(?x)", "road(?x,?y)", "road(?y,?n)", "not at(?n)"],
        do=["go(?x,?y)", "go(?y,?n)"],
    )
    d.method("inspect(?n)", "go_and_scan", do=["goto(?n)", "scan(?n)"])
    d.method("survey(?x,?y)", "both", do=["inspect(?x)", "inspect(?y)"])
    d.facts = tuple(Atom("road", xy) for xy in LENGTH)
    return d


def courier(at: str = "a", **settings: Any) -> AgentConfig:
    """The courier standing at ``at``; ``settings`` go to its AgentConfig."""
    d = courier_domain()
    return AgentConfig(
        name=COURIER, domain=d, belief=d.initial_state().updated(add=[Atom("at", (at,))]), **settings
    )


def robot(**script: Any) -> Callable[[Clock, Trace], ScriptedExecutor]:
    """A scripted robot factory (``durations``, ``fail``, ``hang``, ``suspendable``)."""
    return lambda clock, trace: ScriptedExecutor("robot", **script)


@dataclass(frozen=True)
class Goal:
    """A goal given to the courier at simulated time ``at``."""

    task: str
    at: float = 0.0
    emergency: bool = False


def emergency(task: str, at: float) -> Goal:
    return Goal(task, at, emergency=True)


async def play(rt: Runtime, *goals: Goal) -> list[GoalOutcome]:
    """Give the goals at their times and wait until every one has ended."""
    tickets: list[int | None] = [None] * len(goals)
    given = [anyio.Event() for _ in goals]

    def give(i: int, goal: Goal) -> None:
        tickets[i] = rt.submit(COURIER, atom(goal.task), emergency=goal.emergency)
        given[i].set()

    with anyio.fail_after(GUARD):
        for i, goal in enumerate(goals):
            if goal.at == 0.0:
                give(i, goal)
            else:
                rt.clock.call_at(goal.at, functools.partial(give, i, goal))
        outcomes = []
        for i in range(len(goals)):
            await given[i].wait()
            ticket = tickets[i]
            assert ticket is not None
            outcomes.append(await rt.outcome(ticket))
    return outcomes


def story(events: list[Event], agent: str = COURIER) -> list[str]:
    """The agent's events as ``"t event details"`` lines (messages and robot chatter left out)."""
    lines = []
    for e in events:
        if e["agent"] != agent:
            continue
        kind = e["event"]
        if kind == "goal_received":
            detail = e["goal"] + (" EMERGENCY" if e["emergency"] else "")
        elif kind == "plan_selected":
            detail = f"{e['goal']}: {' '.join(e['plan'])}"
        elif kind == "action_started":
            detail = e["action"]
        elif kind == "action_finished":
            detail = f"{e['action']} {e['result']}" + (f" ({e['reason']})" if "reason" in e else "")
        elif kind == "goal_suspended":
            detail = f"{e['goal']} depth {e['stack_depth']}"
        elif kind == "goal_resumed":
            detail = e["goal"]
        elif kind == "goal_finished":
            detail = f"{e['goal']} {e['status']}" + (f" ({e['reason']})" if "reason" in e else "")
        elif kind in ("suspend_refused", "agent_crashed"):
            detail = e.get("action", e.get("error", ""))
        else:
            continue
        lines.append(f"{e['t']:g} {kind} {detail}")
    return lines


def kinds(events: list[Event], kind: str) -> list[Event]:
    return [e for e in events if e["event"] == kind]


def scripted(rt: Runtime) -> ScriptedExecutor:
    executor = rt.bottom_executor
    assert isinstance(executor, ScriptedExecutor)
    return executor


def orders(rt: Runtime) -> list[str]:
    """What the robot was told, as ``"kind action"``."""
    return [f"{kind} {action}" for kind, action in scripted(rt).orders]


async def run(
    config: AgentConfig, executor: Any, *goals: Goal
) -> tuple[Runtime, list[Event], list[GoalOutcome]]:
    """One story: the courier over ``executor`` is given ``goals``; the runtime is closed after."""
    events: list[Event] = []
    rt = Runtime([config], executor)
    rt.subscribe(record(events))
    async with rt:
        outcomes = await play(rt, *goals)
    return rt, events, outcomes


def statuses(outcomes: list[GoalOutcome]) -> list[str]:
    return [o.status.value if o.status else "open" for o in outcomes]


# -- Algorithm 2: plan, select, execute, update ---------------------------------------------


async def test_goal_is_planned_and_its_cheapest_plan_executed_in_order() -> None:
    rt, events, outcomes = await run(courier(), robot(), Goal("goto(d)"))
    # Expect: the cheaper of the two plans (8 against 10), its actions one after the other.
    assert story(events) == [
        "0 goal_received goto(d)",
        "0 plan_selected goto(d): go(a,b) go(b,d)",
        "0 action_started go(a,b)",
        "1 action_finished go(a,b) success",
        "1 action_started go(b,d)",
        "2 action_finished go(b,d) success",
        "2 goal_finished goto(d) success",
    ]
    assert kinds(events, "plan_selected")[0]["cost"] == 8.0
    assert orders(rt) == ["execute go(a,b)", "execute go(b,d)"]
    assert statuses(outcomes) == ["success"]
    # The belief followed the actions.
    belief = rt.agents[COURIER].belief
    assert belief.holds(atom("at(d)")) and not belief.holds(atom("at(a)"))


async def test_failed_action_switches_to_a_kept_alternative() -> None:
    rt, events, outcomes = await run(courier(), robot(fail=["go(a,b)"]), Goal("goto(d)"))
    # Expect: go(a,b) fails; the first plan came alone (K = 1 until a goal is suspended),
    # so the alternatives are looked for now, and the one through c (not starting with
    # the failed action) is taken (§2.2).
    assert story(events) == [
        "0 goal_received goto(d)",
        "0 plan_selected goto(d): go(a,b) go(b,d)",
        "0 action_started go(a,b)",
        "0 action_finished go(a,b) failure (scripted failure)",
        "0 plan_selected goto(d): go(a,c) go(c,d)",
        "0 action_started go(a,c)",
        "1 action_finished go(a,c) success",
        "1 action_started go(c,d)",
        "2 action_finished go(c,d) success",
        "2 goal_finished goto(d) success",
    ]
    assert statuses(outcomes) == ["success"]
    assert rt.agents[COURIER].stats.from_scratch == 2


async def test_goal_whose_actions_keep_failing_fails_after_the_cap() -> None:
    rt, events, outcomes = await run(courier(), robot(fail=["go(a,b)", "go(a,c)"]), Goal("goto(d)"))
    # Expect 1. go(a,b) fails     -> the alternative not starting with it (found now)
    #        2. go(a,c) fails     -> likewise, the other one, and so on
    #        5. go(a,b) fails     -> its third failure (max_failures = 3): the goal fails
    assert [e["action"] for e in kinds(events, "action_finished")] == [
        "go(a,b)",
        "go(a,c)",
        "go(a,b)",
        "go(a,c)",
        "go(a,b)",
    ]
    assert rt.agents[COURIER].stats.from_scratch == 6  # the first plan, then once per failure
    assert story(events)[-1] == "0 goal_finished goto(d) failure (go(a,b) failed 3 times: scripted failure)"
    assert statuses(outcomes) == ["failure"]
    assert outcomes[0].reason == "go(a,b) failed 3 times: scripted failure"


async def test_failure_cap_comes_from_the_agent_config() -> None:
    rt, _, outcomes = await run(
        courier(max_failures=1), robot(fail=["go(a,b)"]), Goal("goto(d)"), Goal("scan(a)")
    )
    # Expect: one failure is enough; the next goal still runs.
    assert orders(rt) == ["execute go(a,b)", "execute scan(a)"]
    assert statuses(outcomes) == ["failure", "success"]


async def test_goal_with_no_plan_fails_with_a_reason_and_the_agent_goes_on() -> None:
    rt, events, outcomes = await run(courier(), robot(), Goal("goto(z)"), Goal("fly(d)"), Goal("scan(a)"))
    # Expect: nothing is sent to the robot for the two goals that cannot be planned.  Every
    # goal that has arrived is seen before the first one starts (fly(d) fails at once).
    assert story(events) == [
        "0 goal_received goto(z)",
        "0 goal_received fly(d)",
        "0 goal_finished fly(d) failure (courier has no method or operator for fly(d))",
        "0 goal_received scan(a)",
        "0 goal_finished goto(z) failure (no plan for goto(z) (unsolvable))",
        "0 plan_selected scan(a): scan(a)",
        "0 action_started scan(a)",
        "1 action_finished scan(a) success",
        "1 goal_finished scan(a) success",
    ]
    assert orders(rt) == ["execute scan(a)"]
    assert statuses(outcomes) == ["failure", "failure", "success"]
    assert outcomes[0].reason.startswith("no plan for goto(z)")


async def test_resumed_goal_whose_plan_does_not_resume_clears_the_suspended_action() -> None:
    rt, events, outcomes = await run(
        courier(),
        robot(durations={"go(a,b)": 10}, suspendable=["go(a,b)"]),
        Goal("goto(d)"),
        emergency("goto(c)", at=5),
    )
    # Expect 1. go(a,b) is suspended half way; the emergency takes the courier to c.
    #        2. From c the kept plan go(c,d) beats going back to resume go(a,b):
    #           the robot is told to forget the half-done go(a,b) (Algorithm 2's clear).
    assert orders(rt) == [
        "execute go(a,b)",
        "suspend go(a,b)",
        "execute go(a,c)",
        "clear go(a,b)",
        "execute go(c,d)",
    ]
    assert ("clear", atom("go(a,b)")) in scripted(rt).orders
    assert story(events)[-5:] == [
        "6 goal_resumed goto(d)",
        "6 plan_selected goto(d): go(c,d)",
        "6 action_started go(c,d)",
        "7 action_finished go(c,d) success",
        "7 goal_finished goto(d) success",
    ]
    assert statuses(outcomes) == ["success", "success"]
    # The fact that recorded the half-done action went with the clear.
    assert not rt.agents[COURIER].belief.holds(atom("heading(a,b)"))


async def test_resumed_goal_whose_plan_resumes_sends_resume_not_clear() -> None:
    rt, _, outcomes = await run(
        courier(),
        robot(durations={"go(a,b)": 10}, suspendable=["go(a,b)"]),
        Goal("goto(d)"),
        emergency("scan(a)", at=5),
    )
    assert orders(rt) == [
        "execute go(a,b)",
        "suspend go(a,b)",
        "execute scan(a)",
        "resume go(a,b)",
        "execute go(b,d)",
    ]
    assert statuses(outcomes) == ["success", "success"]


@pytest.mark.parametrize(("mode", "plans_made_at_resume"), [(Replanning.ONLINE, 0), (Replanning.NAIVE, 1)])
async def test_resumed_goal_reuses_kept_plans_online_and_plans_again_naive(
    mode: Replanning, plans_made_at_resume: int
) -> None:
    config = courier(replanning=mode)
    rt = Runtime([config], robot(durations={"go(a,b)": 10}, suspendable=["go(a,b)"]))
    events: list[Event] = []
    made: dict[str, int] = {}

    def count(e: TraceEvent) -> None:
        # Plans made from scratch so far, when the emergency ends and once goto(d) is resumed.
        events.append(e.as_dict())
        if isinstance(e, GoalFinished | GoalResumed) and (e.event, e.goal) in (
            ("goal_finished", "scan(a)"),
            ("goal_resumed", "goto(d)"),
        ):
            made[e.event] = rt.agents[COURIER].stats.from_scratch

    rt.subscribe(count)
    async with rt:
        outcomes = await play(rt, Goal("goto(d)"), emergency("scan(a)", at=5))
    assert made["goal_resumed"] - made["goal_finished"] == plans_made_at_resume
    assert kinds(events, "goal_resumed")[0]["replanning"] == mode.value
    # Either way the resumed goal's plan finishes the half-done go(a,b).
    assert kinds(events, "plan_selected")[-1]["plan"] == ["resume(go(a,b))", "go(b,d)"]
    assert statuses(outcomes) == ["success", "success"]


# -- Algorithm 3: emergencies -------------------------------------------------------------------


async def test_emergency_suspends_the_running_action_and_the_goal_resumes_after_it() -> None:
    _, events, outcomes = await run(
        courier(),
        robot(durations={"go(a,b)": 10}, suspendable=["go(a,b)"]),
        Goal("goto(d)"),
        emergency("scan(a)", at=5),
    )
    # Expect: go(a,b) runs 0-10 and is stopped at 5; scan(a) runs 5-6; the rest of
    #         go(a,b) (5 s) is resumed at 6, then go(b,d).
    assert story(events) == [
        "0 goal_received goto(d)",
        "0 plan_selected goto(d): go(a,b) go(b,d)",
        "0 action_started go(a,b)",
        "5 goal_received scan(a) EMERGENCY",
        "5 action_finished go(a,b) suspended",
        "5 goal_suspended goto(d) depth 1",
        "5 plan_selected scan(a): scan(a)",
        "5 action_started scan(a)",
        "6 action_finished scan(a) success",
        "6 goal_finished scan(a) success",
        "6 goal_resumed goto(d)",
        "6 plan_selected goto(d): resume(go(a,b)) go(b,d)",
        "6 action_started resume(go(a,b))",
        "11 action_finished resume(go(a,b)) success",
        "11 action_started go(b,d)",
        "12 action_finished go(b,d) success",
        "12 goal_finished goto(d) success",
    ]
    # The exchange with the robot: Suspend down, Suspended up.
    messages = [(e["agent"], e["kind"], e["action"]) for e in kinds(events, "message") if e["t"] == 5]
    assert messages[:2] == [("courier", "suspend", "go(a,b)"), ("robot", "suspended", "go(a,b)")]
    assert statuses(outcomes) == ["success", "success"]


async def test_emergency_when_idle_runs_at_once() -> None:
    _, events, outcomes = await run(courier(), robot(), emergency("scan(a)", at=3))
    # Expect: nothing to suspend, nothing to resume.
    assert story(events) == [
        "3 goal_received scan(a) EMERGENCY",
        "3 plan_selected scan(a): scan(a)",
        "3 action_started scan(a)",
        "4 action_finished scan(a) success",
        "4 goal_finished scan(a) success",
    ]
    assert statuses(outcomes) == ["success"]


async def test_action_the_domain_cannot_suspend_finishes_first() -> None:
    rt, events, outcomes = await run(
        courier(),
        robot(durations={"scan(a)": 4}),
        Goal("survey(a,b)"),
        emergency("goto(c)", at=1),
    )
    # Expect: scan(a) (not suspendable) runs 0-4; the robot is never asked to suspend;
    #         the goal is stacked once it ends, with no action to resume.
    assert story(events)[:8] == [
        "0 goal_received survey(a,b)",
        "0 plan_selected survey(a,b): scan(a) go(a,b) scan(b)",
        "0 action_started scan(a)",
        "1 goal_received goto(c) EMERGENCY",
        "4 action_finished scan(a) success",
        "4 goal_suspended survey(a,b) depth 1",
        "4 plan_selected goto(c): go(a,c)",
        "4 action_started go(a,c)",
    ]
    assert "suspend scan(a)" not in orders(rt)
    assert not any(o.startswith(("resume", "clear")) for o in orders(rt))
    assert statuses(outcomes) == ["success", "success"]


async def test_action_the_executor_refuses_to_suspend_finishes_first() -> None:
    rt, events, outcomes = await run(
        courier(),
        robot(durations={"go(a,b)": 10}, suspendable=[]),
        Goal("goto(d)"),
        emergency("scan(b)", at=5),
    )
    # Expect: Suspend down, Refused up (suspend_refused); go(a,b) ends at 10; the goal is
    #         stacked with no suspended action, so it goes on with go(b,d): no resume, no clear.
    assert story(events) == [
        "0 goal_received goto(d)",
        "0 plan_selected goto(d): go(a,b) go(b,d)",
        "0 action_started go(a,b)",
        "5 goal_received scan(b) EMERGENCY",
        "5 suspend_refused go(a,b)",
        "10 action_finished go(a,b) success",
        "10 goal_suspended goto(d) depth 1",
        "10 plan_selected scan(b): scan(b)",
        "10 action_started scan(b)",
        "11 action_finished scan(b) success",
        "11 goal_finished scan(b) success",
        "11 goal_resumed goto(d)",
        "11 plan_selected goto(d): go(b,d)",
        "11 action_started go(b,d)",
        "12 action_finished go(b,d) success",
        "12 goal_finished goto(d) success",
    ]
    assert orders(rt) == ["execute go(a,b)", "suspend go(a,b)", "execute scan(b)", "execute go(b,d)"]
    assert statuses(outcomes) == ["success", "success"]


async def test_emergency_during_emergency_resumes_both() -> None:
    rt, events, outcomes = await run(
        courier(),
        robot(durations={"go(a,b)": 10, "go(a,c)": 10}, suspendable=["go(a,b)", "go(a,c)"]),
        Goal("goto(d)"),
        emergency("goto(c)", at=2),
        emergency("scan(a)", at=4),
    )
    # Expect 1. [goto(d)]            go(a,b) suspended at 2        stack: goto(d)
    #        2. [goto(c)]            go(a,c) suspended at 4        stack: goto(d), goto(c)
    #        3. [scan(a)]            runs 4-5
    #        4. [goto(c)] resumed    resume(go(a,c)): the 8 s left of it
    #        5. [goto(d)] resumed    from c, go(c,d) (its kept plan through c) beats going
    #                                back for go(a,b), which is therefore cleared
    assert story(events) == [
        "0 goal_received goto(d)",
        "0 plan_selected goto(d): go(a,b) go(b,d)",
        "0 action_started go(a,b)",
        "2 goal_received goto(c) EMERGENCY",
        "2 action_finished go(a,b) suspended",
        "2 goal_suspended goto(d) depth 1",
        "2 plan_selected goto(c): go(a,c)",
        "2 action_started go(a,c)",
        "4 goal_received scan(a) EMERGENCY",
        "4 action_finished go(a,c) suspended",
        "4 goal_suspended goto(c) depth 2",
        "4 plan_selected scan(a): scan(a)",
        "4 action_started scan(a)",
        "5 action_finished scan(a) success",
        "5 goal_finished scan(a) success",
        "5 goal_resumed goto(c)",
        "5 plan_selected goto(c): resume(go(a,c))",
        "5 action_started resume(go(a,c))",
        "13 action_finished resume(go(a,c)) success",
        "13 goal_finished goto(c) success",
        "13 goal_resumed goto(d)",
        "13 plan_selected goto(d): go(c,d)",
        "13 action_started go(c,d)",
        "14 action_finished go(c,d) success",
        "14 goal_finished goto(d) success",
    ]
    assert orders(rt) == [
        "execute go(a,b)",
        "suspend go(a,b)",
        "execute go(a,c)",
        "suspend go(a,c)",
        "execute scan(a)",
        "resume go(a,c)",
        "clear go(a,b)",
        "execute go(c,d)",
    ]
    assert statuses(outcomes) == ["success", "success", "success"]
    assert rt.agents[COURIER].stack == []


async def test_goal_whose_last_action_ends_after_an_emergency_arrived_succeeds_at_once() -> None:
    rt, events, outcomes = await run(
        courier(), robot(durations={"scan(a)": 4}), Goal("scan(a)"), emergency("goto(b)", at=1)
    )
    # Expect: scan(a) (not suspendable) ends at 4 and with it the goal (Algorithm 2: succeed
    #         when a plan is finished); then the emergency; nothing is left to do afterwards.
    assert story(events) == [
        "0 goal_received scan(a)",
        "0 plan_selected scan(a): scan(a)",
        "0 action_started scan(a)",
        "1 goal_received goto(b) EMERGENCY",
        "4 action_finished scan(a) success",
        "4 goal_finished scan(a) success",
        "4 plan_selected goto(b): go(a,b)",
        "4 action_started go(a,b)",
        "5 action_finished go(a,b) success",
        "5 goal_finished goto(b) success",
    ]
    assert orders(rt) == ["execute scan(a)", "execute go(a,b)"]
    assert statuses(outcomes) == ["success", "success"]


# -- Algorithm 4: normal goals ----------------------------------------------------------------


async def test_normal_goals_run_one_at_a_time_in_fifo_order() -> None:
    _, events, outcomes = await run(courier(), robot(), Goal("goto(b)"), Goal("scan(b)"), Goal("goto(a)"))
    # Expect: each goal is planned only when the one before has finished (scan(b) could
    #         not even be planned from the belief at time 0, when the courier is at a).
    assert [e["goal"] for e in kinds(events, "goal_received") if e["t"] == 0] == [
        "goto(b)",
        "scan(b)",
        "goto(a)",
    ]
    assert [line for line in story(events) if "plan_selected" in line or "goal_finished" in line] == [
        "0 plan_selected goto(b): go(a,b)",
        "1 goal_finished goto(b) success",
        "1 plan_selected scan(b): scan(b)",
        "2 goal_finished scan(b) success",
        "2 plan_selected goto(a): go(b,a)",
        "3 goal_finished goto(a) success",
    ]
    assert statuses(outcomes) == ["success", "success", "success"]


async def test_normal_goal_given_during_an_emergency_waits_until_the_stack_is_empty() -> None:
    _, events, outcomes = await run(
        courier(),
        robot(durations={"go(a,b)": 10, "scan(a)": 3}, suspendable=["go(a,b)"]),
        Goal("goto(d)"),
        emergency("scan(a)", at=5),
        Goal("scan(d)", at=6),
    )
    # Expect: scan(d) arrives at 6 while scan(a) runs and goto(d) is on the stack; it
    #         starts only once goto(d), resumed at 8, has finished at 14.
    assert [line for line in story(events) if "goal_" in line] == [
        "0 goal_received goto(d)",
        "5 goal_received scan(a) EMERGENCY",
        "5 goal_suspended goto(d) depth 1",
        "6 goal_received scan(d)",
        "8 goal_finished scan(a) success",
        "8 goal_resumed goto(d)",
        "14 goal_finished goto(d) success",
        "15 goal_finished scan(d) success",
    ]
    assert kinds(events, "plan_selected")[-1] == {
        "t": 14.0,
        "agent": COURIER,
        "event": "plan_selected",
        "goal": "scan(d)",
        "plan": ["scan(d)"],
        "cost": 1.0,
    }
    assert statuses(outcomes) == ["success", "success", "success"]


# -- Structured concurrency --------------------------------------------------------------------


async def test_no_task_outlives_the_runtime() -> None:
    before = asyncio.all_tasks()
    async with Runtime([courier()], robot()) as rt:
        assert len(asyncio.all_tasks()) > len(before)  # the clock, the robot, the courier
        outcome = await rt.achieve(COURIER, atom("goto(d)"))
    assert outcome.status is GoalStatus.SUCCESS
    assert asyncio.all_tasks() == before


async def test_cancelling_the_body_mid_action_stops_everything_and_is_not_swallowed() -> None:
    before = asyncio.all_tasks()
    events: list[Event] = []
    reached_the_end = False
    # Paced at 100 simulated seconds per real second, go(a,b) would take 10 real seconds.
    with anyio.fail_after(GUARD), anyio.move_on_after(0.2) as scope:
        async with Runtime([courier()], robot(durations={"go(a,b)": 1000}), speed=100.0) as rt:
            rt.subscribe(record(events))
            await rt.achieve(COURIER, atom("goto(d)"))
            reached_the_end = True
    assert scope.cancelled_caught
    assert not reached_the_end
    assert story(events)[-1] == "0 action_started go(a,b)"
    # Nothing can end the goal any more: it failed when the runtime closed.
    assert (rt.outcomes[1].status, rt.outcomes[1].reason) == (GoalStatus.FAILURE, "runtime closed")
    assert asyncio.all_tasks() == before


async def test_cancelling_the_task_that_holds_the_runtime_raises_cancelled_there() -> None:
    before = asyncio.all_tasks()
    moving = asyncio.Event()

    async def hold() -> None:
        async with Runtime([courier()], robot(durations={"go(a,b)": 1000}), speed=1.0) as rt:
            rt.subscribe(lambda e: moving.set() if isinstance(e, ActionStarted) else None)
            await rt.achieve(COURIER, atom("goto(d)"))

    task = asyncio.get_running_loop().create_task(hold())
    with anyio.fail_after(GUARD):
        await moving.wait()
        task.cancel()
        with pytest.raises(asyncio.CancelledError):
            await task
    assert asyncio.all_tasks() == before


async def test_an_error_in_the_body_comes_out_of_the_runtime_as_it_is() -> None:
    before = asyncio.all_tasks()
    with pytest.raises(LookupError, match="from the body"):
        async with Runtime([courier()], robot(durations={"go(a,b)": 1000})) as rt:
            rt.submit(COURIER, atom("goto(d)"))
            raise LookupError("from the body")
    assert asyncio.all_tasks() == before


# -- Faults ---------------------------------------------------------------------------------------


class JammedWheels(Executor):
    """A user's executor: scanning works, driving raises."""

    def __init__(self) -> None:
        self.done: list[str] = []
        self.closed = False

    async def execute(self, action: Atom) -> ActionOutcome:
        await anyio.lowlevel.checkpoint()
        if action.name == "go":
            raise RuntimeError(f"wheels jammed on {action}")
        self.done.append(str(action))
        return ActionOutcome.SUCCESS

    async def aclose(self) -> None:
        self.closed = True


async def test_executor_that_raises_fails_the_action_and_the_agent_goes_on() -> None:
    wheels = JammedWheels()
    _, events, outcomes = await run(courier(max_failures=1), wheels, Goal("goto(b)"), Goal("scan(a)"))
    # Expect: the exception becomes the failure's reason; the next goal runs.
    assert story(events) == [
        "0 goal_received goto(b)",
        "0 goal_received scan(a)",
        "0 plan_selected goto(b): go(a,b)",
        "0 action_started go(a,b)",
        "0 action_finished go(a,b) failure (executor raised RuntimeError('wheels jammed on go(a,b)'))",
        "0 goal_finished goto(b) failure (go(a,b) failed once: "
        "executor raised RuntimeError('wheels jammed on go(a,b)'))",
        "0 plan_selected scan(a): scan(a)",
        "0 action_started scan(a)",
        "0 action_finished scan(a) success",
        "0 goal_finished scan(a) success",
    ]
    assert statuses(outcomes) == ["failure", "success"]
    assert wheels.done == ["scan(a)"]
    assert wheels.closed  # the runtime closed the user's executor on the way out


async def test_hanging_executor_times_out_in_virtual_time() -> None:
    rt, events, outcomes = await run(
        courier(action_timeout=5.0), robot(hang=["go(a,b)"]), Goal("goto(d)"), Goal("scan(d)")
    )
    # Expect: no answer to go(a,b) by 5 (simulated) s: it failed; the robot is told to
    #         forget it, and the kept plan through c is taken.
    assert story(events)[4:7] == [
        "5 action_finished go(a,b) failure (timeout: no answer within 5.0 s)",
        "5 plan_selected goto(d): go(a,c) go(c,d)",
        "5 action_started go(a,c)",
    ]
    assert orders(rt)[:3] == ["execute go(a,b)", "clear go(a,b)", "execute go(a,c)"]
    assert statuses(outcomes) == ["success", "success"]
    assert rt.clock.now() == 8.0


async def test_hanging_executor_with_no_way_round_fails_the_goal_and_the_run_ends() -> None:
    _, events, outcomes = await run(courier(action_timeout=5.0), robot(hang=["go(a,b)"]), Goal("goto(b)"))
    # Expect: three timeouts (the cap), 5 s apart; the goal fails.
    assert [(e["t"], e["reason"]) for e in kinds(events, "action_finished")] == [
        (5.0, "timeout: no answer within 5.0 s"),
        (10.0, "timeout: no answer within 5.0 s"),
        (15.0, "timeout: no answer within 5.0 s"),
    ]
    assert statuses(outcomes) == ["failure"]
    assert outcomes[0].reason.startswith("go(a,b) failed 3 times: timeout")


class CrashingRobot(ExecutorActor):
    """An executor actor that crashes on its first order (an :class:`Executor` that raises
    only fails the action: an actor's own crash is what the runtime must survive)."""

    def __init__(self, clock: Clock, trace: Trace) -> None:
        super().__init__("robot", clock, trace)
        self.orders: list[Message] = []

    async def run(self, *, task_status: TaskStatus[None] = anyio.TASK_STATUS_IGNORED) -> None:
        task_status.started()
        order = await self.inbox.receive()
        self.orders.append(order)
        raise RuntimeError(f"robot crashed on {order.action}")  # type: ignore[union-attr]


async def test_crashing_executor_is_reported_and_fails_its_orders() -> None:
    crashing: list[CrashingRobot] = []

    def factory(clock: Clock, trace: Trace) -> CrashingRobot:
        crashing.append(CrashingRobot(clock, trace))
        return crashing[-1]

    _, events, outcomes = await run(courier(), factory, Goal("goto(d)"), Goal("scan(a)"))
    crash = "robot crashed: RuntimeError('robot crashed on go(a,b)')"
    # Expect: agent_crashed; the order it was serving fails with the crash as reason; from
    #         then on every order fails (the alternative, the plan from scratch, the next goal).
    assert [(e["agent"], e["error"]) for e in kinds(events, "agent_crashed")] == [
        ("robot", "RuntimeError('robot crashed on go(a,b)')")
    ]
    assert [line for line in story(events) if "action_finished" in line or "goal_finished" in line] == [
        f"0 action_finished go(a,b) failure ({crash})",
        f"0 action_finished go(a,c) failure ({crash})",
        f"0 action_finished go(a,b) failure ({crash})",
        f"0 action_finished go(a,c) failure ({crash})",
        f"0 action_finished go(a,b) failure ({crash})",
        f"0 goal_finished goto(d) failure (go(a,b) failed 3 times: {crash})",
        f"0 action_finished scan(a) failure ({crash})",
        f"0 action_finished scan(a) failure ({crash})",
        f"0 action_finished scan(a) failure ({crash})",
        f"0 goal_finished scan(a) failure (scan(a) failed 3 times: {crash})",
    ]
    # The robot saw one order only: every later one was answered by the runtime for it.
    assert [f"{o.kind} {o.action}" for o in crashing[0].orders] == ["execute go(a,b)"]  # type: ignore[union-attr]
    assert statuses(outcomes) == ["failure", "failure"]
    assert outcomes[1].reason == f"scan(a) failed 3 times: {crash}"


# -- Algorithm 5: an agent as its parent's executor -----------------------------------------------


def dispatcher(at: str = "a") -> AgentConfig:
    """A parent over the courier: ``check(N)`` is ``goto(N), scan(N)``, both done by the courier."""
    d = Domain("dispatcher")
    d.operator(
        "goto(?n)",
        pre=["at(?x)"],
        add=["at(?n)"],
        delete=["at(?x)", "sent(?n)"],
        suspend=Suspension(
            add=("sent(?n)",),
            resume=Effect(
                pre=("sent(?n)", "at(?x)"), add=("at(?n)",), delete=("at(?x)", "sent(?n)"), cost=0.5
            ),
        ),
    )
    d.operator("scan(?x)", pre=["at(?x)"], add=["scanned(?x)"])
    d.method("check(?n)", "go_and_scan", do=["goto(?n)", "scan(?n)"])
    return AgentConfig(name="boss", domain=d, belief=d.initial_state().updated(add=[Atom("at", (at,))]))


async def test_child_agent_stacks_its_goal_while_the_parent_handles_an_emergency() -> None:
    events: list[Event] = []
    rt = Runtime([dispatcher(), courier()], robot(durations={"go(a,b)": 10}, suspendable=["go(a,b)"]))
    rt.subscribe(record(events))
    async with rt:
        with anyio.fail_after(GUARD):
            first = rt.submit("boss", atom("check(d)"))

            def alarm() -> None:
                rt.submit("boss", atom("check(a)"), emergency=True)

            rt.clock.call_at(5.0, alarm)
            await rt.outcome(first)
    # Expect: the boss's suspend reaches the robot through the courier, which stacks its goal
    #         goto(d) and answers suspended; the courier serves the boss's emergency actions
    #         meanwhile; the boss's resume(goto(d)) makes the courier pop goto(d) and resume go(a,b).
    assert story(events, "boss") == [
        "0 goal_received check(d)",
        "0 plan_selected check(d): goto(d) scan(d)",
        "0 action_started goto(d)",
        "5 goal_received check(a) EMERGENCY",
        "5 action_finished goto(d) suspended",
        "5 goal_suspended check(d) depth 1",
        "5 plan_selected check(a): goto(a) scan(a)",
        "5 action_started goto(a)",
        "5 action_finished goto(a) success",
        "5 action_started scan(a)",
        "6 action_finished scan(a) success",
        "6 goal_finished check(a) success",
        "6 goal_resumed check(d)",
        "6 plan_selected check(d): resume(goto(d)) scan(d)",
        "6 action_started resume(goto(d))",
        "12 action_finished resume(goto(d)) success",
        "12 action_started scan(d)",
        "13 action_finished scan(d) success",
        "13 goal_finished check(d) success",
    ]
    assert [line for line in story(events) if "goal_" in line] == [
        "0 goal_received goto(d)",
        "5 goal_suspended goto(d) depth 1",
        "5 goal_received goto(a)",
        "5 goal_finished goto(a) success",  # already there: the suspension left it at a
        "5 goal_received scan(a)",
        "6 goal_finished scan(a) success",
        "6 goal_resumed goto(d)",
        "12 goal_finished goto(d) success",
        "12 goal_received scan(d)",
        "13 goal_finished scan(d) success",
    ]
    assert orders(rt) == [
        "execute go(a,b)",
        "suspend go(a,b)",
        "execute scan(a)",
        "resume go(a,b)",
        "execute go(b,d)",
        "execute scan(d)",
    ]
    assert all(o.status is GoalStatus.SUCCESS for o in rt.outcomes.values())
