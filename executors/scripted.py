"""A scripted executor for tests: answers orders as a script says, in simulated time.

Each action takes ``durations.get(action, default_duration)`` seconds and then
succeeds, unless ``fail`` names it (it fails) or ``hang`` names it (it never
answers).  Actions in ``suspendable`` may be suspended half way and resumed.
Every order received is recorded in ``orders`` so tests can assert the exchange.
"""

from __future__ import annotations

from collections.abc import Iterable

import anyio
from anyio.abc import TaskStatus

from htnagent.model.terms import Atom, atom
from htnagent.runtime.clock import Clock, TimerHandle
from htnagent.runtime.events import RobotMoving
from htnagent.runtime.executor import ExecutorActor
from htnagent.runtime.messages import (
    Clear,
    Elapsed,
    Execute,
    Failure,
    Message,
    Refused,
    Resume,
    Success,
    Suspend,
    Suspended,
)
from htnagent.runtime.progress import Phase, Progress
from htnagent.runtime.trace import Trace


class ScriptedExecutor(ExecutorActor):
    """An executor whose answers are given in advance."""

    def __init__(
        self,
        name: str,
        clock: Clock,
        trace: Trace,
        *,
        default_duration: float = 1.0,
        durations: dict[str, float] | None = None,
        fail: Iterable[str] = (),
        hang: Iterable[str] = (),
        suspendable: Iterable[str] = (),
        crash_on: Iterable[str] = (),
    ) -> None:
        super().__init__(name, clock, trace)
        self.default_duration = default_duration
        self.durations = {atom(k): v for k, v in (durations or {}).items()}
        self.fail = {atom(a) for a in fail}
        self.hang = {atom(a) for a in hang}
        self.suspendable = {atom(a) for a in suspendable}
        self.crash_on = {atom(a) for a in crash_on}
        self.orders: list[Message] = []
        self._running: tuple[Execute | Resume, TimerHandle, float] | None = None
        self._kept: dict[Atom, float] = {}

    async def run(self, *, task_status: TaskStatus[None] = anyio.TASK_STATUS_IGNORED) -> None:
        task_status.started()
        while True:
            message = await self.inbox.receive()
            if isinstance(message, Elapsed):
                self._finish(message.seq)
                continue
            self.orders.append(message)
            if isinstance(message, Execute):
                if message.action in self.crash_on:
                    raise RuntimeError(f"{self.name} crashed on {message.action}")
                if message.action in self.fail:
                    self.reply(Failure(action=message.action, seq=message.seq, reason="scripted failure"))
                elif message.action not in self.hang:
                    self._start(message, self.durations.get(message.action, self.default_duration))
            elif isinstance(message, Resume):
                left = self._kept.pop(message.action, None)
                if left is None:
                    self.reply(Failure(action=message.action, seq=message.seq, reason="nothing to resume"))
                else:
                    self._start(message, left)
            elif isinstance(message, Suspend):
                self._suspend(message)
            elif isinstance(message, Clear):
                self._kept.pop(message.action, None)

    def _start(self, order: Execute | Resume, duration: float) -> None:
        seq = order.seq
        timer = self.clock.call_later(duration, lambda: self.inbox.send(Elapsed(seq=seq)))
        self._running = (order, timer, self.clock.now() + duration)
        self.progress.report(Progress(self.name, order.action, Phase.STARTED, duration))
        self.trace.emit(RobotMoving(agent=self.name, action=str(order.action), duration=duration))

    def _finish(self, seq: int) -> None:
        if self._running is None or self._running[0].seq != seq:
            return
        order = self._running[0]
        self._running = None
        self.reply(Success(action=order.action, seq=order.seq))

    def _suspend(self, message: Suspend) -> None:
        running = self._running
        if running is None or running[0].action != message.action or message.action not in self.suspendable:
            self.reply(Refused(action=message.action, seq=message.seq))
            return
        order, timer, ends = running
        timer.cancel()
        self._running = None
        self._kept[order.action] = max(ends - self.clock.now(), 0.0)
        self.progress.report(Progress(self.name, order.action, Phase.STOPPED))
        self.reply(Suspended(action=order.action, seq=order.seq))
