"""Every goal ends exactly once, whatever crashes, closes or piles up (the runtime's promises).

Each test is a misuse or a fault that lost a goal, hung a waiter or crashed an
agent before; every waiter here is bounded by ``anyio.fail_after``.
"""

from __future__ import annotations

import functools
from pathlib import Path
from typing import Any

import anyio
import anyio.lowlevel
import pytest

from htnagent import ActionOutcome, AgentConfig, Domain, Executor, GoalStatus, Runtime, State, parse
from htnagent.errors import RuntimeClosedError
from htnagent.executors.scripted import ScriptedExecutor
from htnagent.model.domain import Effect, Suspension
from htnagent.model.terms import Atom
from htnagent.runtime.events import EventsDropped, GoalFinished, GoalSuspended, TraceEvent
from htnagent.scenario import parse_scenario
from htnagent.system.simulation import run_scenario
from htnagent.testing.storms import nested_storm_data
from tests.support import Event, record, summary_of

SCENARIOS = Path(__file__).resolve().parents[1] / "scenarios"
GUARD = 10.0  # real seconds: a test that waits longer has hung


def jobs(*, bad: str = "bad") -> Domain:
    """``job(X)`` is one suspendable ``work(X)``; planning ``job(bad)`` raises (a bug)."""
    d = Domain("jobs")
    d.operator(
        "work(?x)",
        add=["done(?x)"],
        cost=1.0,
        suspend=Suspension(
            add=("half(?x)",), resume=Effect(pre=("half(?x)",), add=("done(?x)",), delete=("half(?x)",))
        ),
    )
    d.method("job(?x)", "work", when=["not done(?x)"], do=["work(?x)"])

    def estimate(task: Atom, state: State) -> float:
        if str(task.args[0]) == bad:
            raise RuntimeError(f"a bug in the estimate of {task}")
        return 0.0

    d.estimate("job", estimate)
    return d


def worker(domain: Domain, **settings: Any) -> AgentConfig:
    return AgentConfig("worker", domain, domain.initial_state(), **settings)


def scripted(**script: Any) -> Any:
    return lambda clock, trace: ScriptedExecutor("robot", **script)


# -- a crash fails every goal the agent held ---------------------------------------------------


async def test_an_agent_that_crashes_fails_its_running_stacked_and_waiting_goals() -> None:
    events: list[Event] = []
    rt = Runtime([worker(jobs())], scripted(durations={"work(a)": 10.0}, suspendable=["work(a)"]))
    with anyio.fail_after(GUARD):
        async with rt:
            rt.subscribe(record(events))
            running = rt.submit("worker", parse("job(a)"))
            waiting = rt.submit("worker", parse("job(c)"))

            def urgent() -> None:
                rt.submit("worker", parse("job(bad)"), emergency=True)

            rt.clock.call_at(1.0, urgent)
            outcomes = [await rt.outcome(running), await rt.outcome(waiting)]
            bad = await rt.outcome(3)
    # Expect: planning job(bad) crashes the agent with job(a) stacked and job(c) waiting;
    # all three end, with the crash as their reason, and the waiters are woken.
    assert [e["agent"] for e in events if e["event"] == "agent_crashed"] == ["worker"]
    for outcome in [*outcomes, bad]:
        assert outcome.status is GoalStatus.FAILURE
        assert "worker crashed" in outcome.reason and "a bug in the estimate" in outcome.reason
    finished = [e["goal"] for e in events if e["event"] == "goal_finished"]
    assert sorted(finished) == ["job(a)", "job(bad)", "job(c)"]  # each once


async def test_a_goal_given_to_a_crashed_agent_fails_at_once() -> None:
    rt = Runtime([worker(jobs())], scripted())
    with anyio.fail_after(GUARD):
        async with rt:
            first = await rt.achieve("worker", parse("job(bad)"))
            later = await rt.achieve("worker", parse("job(a)"))
    assert first.status is GoalStatus.FAILURE and later.status is GoalStatus.FAILURE
    assert "worker crashed" in later.reason


class StubbornResume(Executor):
    """Suspends when asked, but every resume stops again at once by itself."""

    def __init__(self) -> None:
        self.stop = anyio.Event()

    def can_suspend(self, action: Atom) -> bool:
        return True

    async def execute(self, action: Atom) -> ActionOutcome:
        if action.name == "work":
            await self.stop.wait()
            return ActionOutcome.SUSPENDED
        return ActionOutcome.SUCCESS

    async def suspend(self, action: Atom) -> None:
        self.stop.set()

    async def resume(self, action: Atom) -> ActionOutcome:
        return ActionOutcome.SUSPENDED


async def test_an_executor_whose_resume_keeps_returning_suspended_fails_the_goal() -> None:
    d = jobs()
    d.operator("ping(?x)", add=["pinged(?x)"])
    with anyio.fail_after(GUARD):
        async with Runtime([worker(d)], StubbornResume(), speed=1000.0) as rt:
            first = rt.submit("worker", parse("job(a)"))
            await anyio.sleep(0.01)
            urgent = await rt.achieve("worker", parse("ping(x)"), emergency=True)
            outcome = await rt.outcome(first)
    # Expect: the emergency runs; resume(work(a)) comes back suspended unasked, three times:
    # the goal fails with that reason instead of looping for ever.
    assert urgent.status is GoalStatus.SUCCESS
    assert outcome.status is GoalStatus.FAILURE
    assert outcome.reason == "resume(work(a)) failed 3 times: the executor stopped it unasked"


# -- closing the runtime -----------------------------------------------------------------------


async def test_closing_the_runtime_fails_the_goals_still_open_and_wakes_their_waiters() -> None:
    rt = Runtime([worker(jobs())], scripted(hang=["work(a)"]))
    seen: list[Any] = []

    async def wait_for(ticket: int) -> None:
        seen.append(await rt.outcome(ticket))

    with anyio.fail_after(GUARD):
        async with anyio.create_task_group() as tg, rt:
            ticket = rt.submit("worker", parse("job(a)"))
            tg.start_soon(wait_for, ticket)
            await anyio.lowlevel.checkpoint()
    assert [(o.status, o.reason) for o in seen] == [(GoalStatus.FAILURE, "runtime closed")]
    # A settled goal's outcome is there at once; a new goal is refused with a clear error.
    assert (await rt.outcome(ticket)).reason == "runtime closed"
    with pytest.raises(RuntimeClosedError, match=r"cannot give job\(b\) to worker: the runtime is closed"):
        rt.submit("worker", parse("job(b)"))


async def test_a_goal_given_before_the_runtime_is_entered_is_refused() -> None:
    rt = Runtime([worker(jobs())], scripted())
    with pytest.raises(RuntimeClosedError, match="has not been entered"):
        rt.submit("worker", parse("job(a)"))


async def test_ended_outcomes_are_kept_up_to_a_bound() -> None:
    with anyio.fail_after(GUARD):
        async with Runtime([worker(jobs())], scripted(), keep_outcomes=3) as rt:
            for name in "abcdef":
                await rt.achieve("worker", parse(f"job({name})"))
    assert sorted(rt.outcomes) == [4, 5, 6]
    with pytest.raises(KeyError, match="ticket 1"):
        await rt.outcome(1)


# -- events() never grows without bound --------------------------------------------------------


async def test_an_event_stream_nobody_reads_keeps_only_the_latest_events() -> None:
    with anyio.fail_after(GUARD):
        async with Runtime([worker(jobs())], scripted()) as rt:
            stream = rt.events(limit=5)
            for name in "abcdefgh":
                await rt.achieve("worker", parse(f"job({name})"))
            first = await stream.receive()
            rest = [await stream.receive() for _ in range(5)]
    # Expect: the reader is told how many it missed, then gets the newest five.
    assert isinstance(first, EventsDropped) and first.count == stream.dropped > 0
    last = rest[-1]
    assert isinstance(last, GoalFinished) and last.goal == "job(h)"
    with pytest.raises(anyio.EndOfStream):
        await stream.receive()


# -- KeyboardInterrupt from user code reaches the caller as itself -----------------------------------


class Interrupting(Executor):
    async def execute(self, action: Atom) -> ActionOutcome:
        raise KeyboardInterrupt


@pytest.mark.parametrize("backend", ["asyncio", "trio"])
def test_a_keyboard_interrupt_from_an_executor_is_not_wrapped(backend: str) -> None:
    # Run outside pytest's own event loop: asyncio lets a KeyboardInterrupt in any task
    # through the loop itself.
    async def body() -> None:
        with anyio.fail_after(GUARD):
            async with Runtime([worker(jobs())], Interrupting(), speed=1000.0) as rt:
                await rt.achieve("worker", parse("job(a)"))

    with pytest.raises(KeyboardInterrupt):
        anyio.run(body, backend=backend)


# -- emergencies nest without recursion, up to a bound ----------------------------------------------


def test_hundreds_of_nested_emergencies_all_end() -> None:
    # (python -m bench reliability nests them 1,000 deep.)
    scenario = parse_scenario(nested_storm_data(300), "storm.yaml", SCENARIOS)
    depth = [0]

    def watch(event: TraceEvent) -> None:
        if isinstance(event, GoalSuspended):
            depth[0] = max(depth[0], event.stack_depth)

    report = anyio.run(functools.partial(run_scenario, scenario, observers=[watch]))
    statuses = [g["status"] for g in summary_of(report)["goals"]]
    # Expect: they nest hundreds deep (no RecursionError), and every one of them ends.
    assert depth[0] > 200
    assert statuses.count("success") == len(statuses)


def test_an_emergency_beyond_the_maximum_depth_fails_at_once() -> None:
    scenario = parse_scenario(nested_storm_data(8), "storm.yaml", SCENARIOS)
    configs: list[AgentConfig] = []

    async def go() -> Any:
        from htnagent.system.simulation import build_runtime

        runtime, _ = build_runtime(scenario)
        for agent in runtime.agents.values():
            agent.config.max_depth = 5
            configs.append(agent.config)
        events: list[Event] = []
        runtime.subscribe(record(events))
        async with runtime:
            tickets = [runtime.submit("navigator", parse("goto_node(n1)"))]
            for _ in range(8):
                tickets.append(runtime.submit("navigator", parse("goto_node(n38)"), emergency=True))
                await anyio.lowlevel.checkpoint()
            with anyio.fail_after(GUARD):
                return [await runtime.outcome(t) for t in tickets]

    outcomes = anyio.run(go)
    refused = [o for o in outcomes if o.status is GoalStatus.FAILURE]
    assert refused and all("too many nested goals" in o.reason for o in refused)
    assert all(o.done for o in outcomes)


# -- a scenario whose only goal waits for a trigger ends ----------------------------------------------


def test_a_run_with_only_a_trigger_that_never_fires_ends() -> None:
    data = {
        "name": "waits",
        "map": "museum_map.yaml",
        "robot": {"start": "n40", "speed": 1.0},
        "agents": [{"name": "navigator", "domain": "museum.nodes", "executor": "robot"}],
        "goals": [
            {
                "agent": "navigator",
                "task": "goto_node(n1)",
                "when": {"action": "move(n40,n35,arc59)", "progress": 0.5},
            }
        ],
    }
    scenario = parse_scenario(data, "waits.yaml", SCENARIOS)

    async def go() -> Any:
        with anyio.fail_after(GUARD):
            return await run_scenario(scenario)

    report = anyio.run(go)
    assert summary_of(report)["goals"][0]["reason"] == "never given: its trigger did not happen"


# -- a parent that crashes leaves nothing held in its child ------------------------------------------


@pytest.mark.parametrize("seed", [511, 882])
def test_a_child_drops_what_its_crashed_parent_ordered(seed: int) -> None:
    from htnagent.testing.storms import crash_run

    _, lost, crashed, violations = anyio.run(crash_run, seed)
    # Expect: the guide crashes with orders held by the navigator; they are dropped, so
    # every stack ends empty and no goal is lost.
    assert crashed and lost == 0 and violations == []
