"""A scripted executor for tests: answers orders as a script says, in simulated time.

Each action takes ``durations.get(action, default_duration)`` seconds and then
succeeds, unless ``fail`` names it (it fails) or ``hang`` names it (it never
answers).  Actions in ``suspendable`` may be suspended half way and resumed.
Every order it sees is recorded in ``orders`` (``(kind, action)``) so tests can
assert the exchange.  It is an :class:`~htnagent.runtime.executor.Executor` like any
user's (as httpx's ``MockTransport`` is a transport).
"""

from __future__ import annotations

from collections.abc import Iterable

import anyio

from htnagent.model.terms import Atom, atom
from htnagent.runtime.events import RobotMoving
from htnagent.runtime.executor import ActionFailed, ActionOutcome, Alarm, Executor
from htnagent.runtime.progress import Phase


class ScriptedExecutor(Executor):
    """An executor whose answers are given in advance."""

    def __init__(
        self,
        name: str = "executor",
        *,
        default_duration: float = 1.0,
        durations: dict[str, float] | None = None,
        fail: Iterable[str] = (),
        hang: Iterable[str] = (),
        suspendable: Iterable[str] = (),
    ) -> None:
        self.name = name
        self.default_duration = default_duration
        self.durations = {atom(k): v for k, v in (durations or {}).items()}
        self.fail = {atom(a) for a in fail}
        self.hang = {atom(a) for a in hang}
        self.suspendable = {atom(a) for a in suspendable}
        self.orders: list[tuple[str, Atom]] = []
        """``("execute" | "suspend" | "resume" | "clear", action)``, as they came."""
        self._running: tuple[Atom, Alarm] | None = None  # the action started last
        self._kept: dict[Atom, float] = {}  # suspended actions: the seconds left

    async def execute(self, action: Atom) -> ActionOutcome:
        self.orders.append(("execute", action))
        if action in self.fail:
            raise ActionFailed("scripted failure")
        if action in self.hang:
            await anyio.sleep_forever()
        return await self._run(action, self.durations.get(action, self.default_duration))

    async def resume(self, action: Atom) -> ActionOutcome:
        self.orders.append(("resume", action))
        left = self._kept.pop(action, None)
        if left is None:
            raise ActionFailed("nothing to resume")
        return await self._run(action, left)

    async def _run(self, action: Atom, duration: float) -> ActionOutcome:
        context = self.context
        alarm = context.alarm(duration)
        self._running = (action, alarm)
        context.report_progress(action, Phase.STARTED, duration)
        context.emit(RobotMoving(agent=self.name, action=str(action), duration=duration))
        if not await alarm.wait():
            return ActionOutcome.SUSPENDED
        if self._running is not None and self._running[1] is alarm:
            self._running = None
        return ActionOutcome.SUCCESS

    def can_suspend(self, action: Atom) -> bool:
        self.orders.append(("suspend", action))
        running = self._running
        return (
            running is not None
            and running[0] == action
            and action in self.suspendable
            and not running[1].rang
        )

    async def suspend(self, action: Atom) -> None:
        assert self._running is not None  # can_suspend said so
        _, alarm = self._running
        alarm.stop()
        self._running = None
        self._kept[action] = max(alarm.started_at + alarm.seconds - self.context.now(), 0.0)
        self.context.report_progress(action, Phase.STOPPED)

    async def clear(self, action: Atom) -> None:
        self.orders.append(("clear", action))
        self._kept.pop(action, None)
