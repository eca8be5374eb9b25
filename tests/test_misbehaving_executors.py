"""A user's executor that misbehaves becomes failed actions, never a hang or a dead agent.

Found by an outside check of the embedding API (docs/howto/embedding.md, docs/howto/executor.md):

| the user's executor                               | was                     | is                      |
|---------------------------------------------------|-------------------------|-------------------------|
| execute() raises CancelledError (no cancellation) | a hang                  | a failed action         |
| suspend() never returns                           | the whole runtime hung  | the goals go on         |
| says SUSPENDED, unasked, of an unstoppable action | the agent dead for good | a failed action         |

A real cancellation still goes through: cancelling the caller cancels the runtime.
"""

from __future__ import annotations

import asyncio
from collections.abc import Mapping

import anyio
import pytest

from htnagent import AgentConfig, Domain, Effect, GoalStatus, Runtime, Suspension, parse
from htnagent.model.terms import Atom
from htnagent.runtime.executor import ActionOutcome, Executor

GUARD = 10.0  # real seconds: a test that takes longer has hung


def corridor(suspendable: bool) -> AgentConfig:
    """a - b - c; moving may be stopped half way (between two places) if ``suspendable``."""
    d = Domain("corridor")
    suspension = (
        Suspension(
            add=("between(?f,?t)",),
            delete=("at(?f)",),
            resume=Effect(pre=("between(?f,?t)",), add=("at(?t)",), delete=("between(?f,?t)",)),
            rollback=Effect(pre=("between(?f,?t)",), add=("at(?f)",), delete=("between(?f,?t)",)),
        )
        if suspendable
        else None
    )
    d.operator(
        "move(?f,?t)",
        pre=["at(?f)", "link(?f,?t)"],
        add=["at(?t)"],
        delete=["at(?f)"],
        cost=1.0,
        undo="move(?t,?f)",
        suspend=suspension,
    )
    d.method("reach(?n)", "here", when=["at(?n)"], do=[])
    d.method(
        "reach(?n)", "step", when=["not at(?n)", "at(?x)", "link(?x,?y)"], do=["move(?x,?y)", "reach(?n)"]
    )
    d.facts = tuple(parse(f) for f in ["link(a,b)", "link(b,a)", "link(b,c)", "link(c,b)"])
    return AgentConfig("agent", d, d.initial_state().updated(add=[parse("at(a)")]), action_timeout=5.0)


async def test_a_suspend_that_never_returns_holds_up_nothing_else() -> None:
    class Deaf(Executor):
        def can_suspend(self, action: Atom) -> bool:
            return True

        async def execute(self, action: Atom) -> ActionOutcome:
            await anyio.sleep(0.05)
            return ActionOutcome.SUCCESS

        async def suspend(self, action: Atom) -> None:
            await anyio.sleep_forever()  # the robot never acknowledges the stop

    with anyio.fail_after(GUARD):
        async with Runtime([corridor(True)], Deaf()) as rt:
            first = rt.submit("agent", parse("reach(c)"))
            await anyio.sleep(0.01)
            emergency = rt.submit("agent", parse("reach(a)"), emergency=True)
            assert (await rt.outcome(emergency)).status is GoalStatus.SUCCESS
            assert (await rt.outcome(first)).status is GoalStatus.SUCCESS


async def test_an_action_stopped_unasked_that_cannot_be_suspended_failed_and_the_agent_goes_on() -> None:
    class Jerky(Executor):
        def __init__(self) -> None:
            self.calls = 0

        async def execute(self, action: Atom) -> ActionOutcome:
            self.calls += 1
            # A safety stop, once: the domain says a move cannot be stopped half way.
            return ActionOutcome.SUSPENDED if self.calls == 1 else ActionOutcome.SUCCESS

    events: list[Mapping[str, object]] = []
    with anyio.fail_after(GUARD):
        async with Runtime([corridor(False)], Jerky()) as rt:
            rt.subscribe(lambda e: events.append(e.as_dict()))
            first = await rt.achieve("agent", parse("reach(c)"))
            second = await rt.achieve("agent", parse("reach(a)"))
    assert first.status is second.status is GoalStatus.SUCCESS
    assert not [e for e in events if e["event"] == "agent_crashed"]
    failed = [e for e in events if e["event"] == "action_finished" and e["result"] == "failure"]
    assert len(failed) == 1 and "cannot be suspended" in str(failed[0]["reason"])


async def test_cancelling_the_caller_still_cancels_a_runtime_whose_executor_is_busy() -> None:
    class Slow(Executor):
        async def execute(self, action: Atom) -> ActionOutcome:
            await anyio.sleep_forever()
            return ActionOutcome.SUCCESS

    with anyio.fail_after(GUARD):
        with anyio.move_on_after(0.2) as scope:
            async with Runtime([corridor(False)], Slow()) as rt:
                await rt.achieve("agent", parse("reach(c)"))
    assert scope.cancelled_caught


@pytest.mark.parametrize("backend", ["asyncio", "trio"])
def test_a_cancelled_error_raised_by_the_executor_is_a_failed_action(backend: str) -> None:
    # Its own CancelledError, not a cancellation of anything (under trio, asyncio's
    # CancelledError cancels nothing at all).
    async def main() -> str:
        class Raising(Executor):
            async def execute(self, action: Atom) -> ActionOutcome:
                raise asyncio.CancelledError

        with anyio.fail_after(GUARD):
            async with Runtime([corridor(False)], Raising()) as rt:
                return (await rt.achieve("agent", parse("reach(c)"))).reason

    assert "executor raised CancelledError()" in anyio.run(main, backend=backend)


class _Odd(BaseException):
    """A user's own BaseException subclass."""


@pytest.mark.parametrize("raised", [_Odd("odd"), GeneratorExit()])
async def test_an_executor_raising_another_base_exception_fails_the_action(raised: BaseException) -> None:
    # It tore the whole runtime down (an exception group out of `async with`).
    class Raising(Executor):
        async def execute(self, action: Atom) -> ActionOutcome:
            raise raised

    with anyio.fail_after(GUARD):
        async with Runtime([corridor(False)], Raising()) as rt:
            outcome = await rt.achieve("agent", parse("reach(c)"))
    assert outcome.status is GoalStatus.FAILURE
    assert "executor raised" in outcome.reason
