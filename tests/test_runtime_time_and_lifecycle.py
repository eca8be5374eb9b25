"""Runtime time and lifecycle: executors on the wall clock, start-up failures, pacing, run end, timeouts."""

from __future__ import annotations

import time
from pathlib import Path
from types import TracebackType
from typing import Self

import anyio
import pytest
import yaml

from htnagent import AgentConfig, Domain, GoalStatus, Runtime, parse
from htnagent.executors.scripted import ScriptedExecutor
from htnagent.model.terms import Atom
from htnagent.runtime.executor import ActionOutcome, Executor
from htnagent.scenario import parse_scenario
from htnagent.system.simulation import run_scenario
from tests.support import summary_of

ROOT = Path(__file__).resolve().parent.parent


def _one_action_domain() -> Domain:
    d = Domain("t")
    d.operator("a", cost=1.0)
    d.operator("b", cost=1.0)
    d.method("g", "m", do=["a"])
    d.method("h", "m", do=["b"])
    return d


class _Slow(Executor):
    async def execute(self, action: Atom) -> ActionOutcome:
        await anyio.sleep(0.05)  # real hardware takes a little real time
        return ActionOutcome.SUCCESS


async def test_a_users_executor_runs_in_wall_clock_time_and_does_not_time_out() -> None:
    d = _one_action_domain()
    with anyio.fail_after(5):
        async with Runtime([AgentConfig("agent", d, d.initial_state(), action_timeout=60.0)], _Slow()) as rt:
            outcome = await rt.achieve("agent", parse("g"))
    # Expect: success, not three timeouts in a virtual minute each.
    assert outcome.status is GoalStatus.SUCCESS
    assert rt.clock.speed == 1.0 and rt.clock.now() < 1.0


class _Broken(Executor):
    async def execute(self, action: Atom) -> ActionOutcome:  # pragma: no cover - never reached
        return ActionOutcome.SUCCESS

    async def __aenter__(self) -> Self:
        raise ConnectionError("robot unreachable")

    async def __aexit__(
        self, exc_type: type[BaseException] | None, exc: BaseException | None, tb: TracebackType | None
    ) -> None:
        pass


async def test_an_executor_that_cannot_start_makes_entering_the_runtime_fail() -> None:
    d = _one_action_domain()
    with anyio.fail_after(5), pytest.raises(ConnectionError, match="robot unreachable"):
        async with Runtime([AgentConfig("agent", d, d.initial_state())], _Broken()):
            pass  # pragma: no cover - never entered


async def test_pacing_is_not_restarted_by_a_goal_given_meanwhile() -> None:
    d = _one_action_domain()
    factory = lambda clock, trace: ScriptedExecutor("robot", default_duration=1.0)  # noqa: E731
    async with Runtime([AgentConfig("agent", d, d.initial_state())], factory, speed=1.0) as rt:
        started = time.monotonic()

        async def later() -> None:
            await anyio.sleep(0.6)
            rt.submit("agent", parse("h"))

        async with anyio.create_task_group() as tg:
            tg.start_soon(later)
            outcome = await rt.achieve("agent", parse("g"))
        took = time.monotonic() - started
    # Expect: the 1-second action takes one second of wall time, not 1.6.
    assert outcome.status is GoalStatus.SUCCESS
    assert took < 1.4


async def test_a_run_ends_when_its_goals_are_done_not_at_its_last_event() -> None:
    data = yaml.safe_load((ROOT / "scenarios" / "navigator_only.yaml").read_text())
    data["map"] = str(ROOT / "scenarios" / "museum_map.yaml")
    data["goals"] = [{"agent": "navigator", "task": "goto_node(n38)"}]
    data["events"] = [{"when": {"time": 5000}, "close": "arc1"}]
    report = await run_scenario(parse_scenario(data, "late_event.yaml"), keep_events=True)
    assert report.succeeded
    assert summary_of(report)["t"] < 100


async def test_the_action_timeout_applies_where_actions_meet_the_executor_not_between_agents() -> None:
    parent = Domain("parent")
    parent.operator("errand", add=["done"])
    parent.method("g", "m", do=["errand"])
    child = Domain("child")
    child.operator("walk", add=["walked"])
    child.method("errand", "m", do=["walk"])
    factory = lambda clock, trace: ScriptedExecutor("robot", default_duration=5.0)  # noqa: E731
    configs = [
        AgentConfig("parent", parent, parent.initial_state(), action_timeout=1.0),
        AgentConfig("child", child, child.initial_state(), action_timeout=10.0),
    ]
    with anyio.fail_after(5):
        async with Runtime(configs, factory) as rt:
            outcome = await rt.achieve("parent", parse("g"))
    # Expect: the parent's order to the child is a whole goal (5 s of walking), not timed out.
    assert outcome.status is GoalStatus.SUCCESS
    assert rt.clock.now() == 5.0


@pytest.mark.parametrize("backend", ["asyncio", "trio"])
def test_a_clock_makes_the_running_backends_own_events_and_its_mailboxes_wake_with_them(backend: str) -> None:
    # The runtime makes an event for nearly every message a mailbox waits for: made from
    # the backend's own class, found once, not through anyio.Event()'s look-up each time.
    from htnagent.runtime.clock import Clock, Mailbox

    got: list[int] = []

    async def main() -> None:
        clock = Clock()
        assert clock.new_event is type(anyio.Event())
        mailbox: Mailbox[int] = Mailbox(clock, "m")

        async def receive() -> None:
            got.append(await mailbox.receive())
            got.append(await mailbox.receive())

        async with anyio.create_task_group() as tg:
            tg.start_soon(receive)
            await anyio.wait_all_tasks_blocked()
            mailbox.send(1)  # wakes the receiver waiting on one of the clock's events
            await anyio.wait_all_tasks_blocked()
            mailbox.send(2)

    anyio.run(main, backend=backend)
    assert got == [1, 2]
