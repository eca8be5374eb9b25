"""The executor side of the message protocol, and the interface for writing executors.

Whatever carries out an agent's actions — the simulated robot, a scripted
executor in tests, a child agent, a real robot — is an *executor actor*: it
reads orders (:class:`~htnagent.runtime.messages.Execute`, ``Suspend``, ``Resume``,
``Clear``) from its mailbox and answers each order with one result on its
parent's mailbox.

Most users need not speak messages: subclass :class:`Executor` (small, like an
httpx transport) and the runtime wraps it in an :class:`AdapterActor`.
"""

from __future__ import annotations

import asyncio
from abc import ABC, abstractmethod
from enum import Enum
from types import TracebackType
from typing import Self

import anyio
from anyio.abc import TaskStatus

from htnagent.model.domain import Domain
from htnagent.model.terms import Atom
from htnagent.runtime.clock import Clock, Mailbox
from htnagent.runtime.events import ExecutorError, MessageSent
from htnagent.runtime.messages import (
    Clear,
    Execute,
    Failure,
    Message,
    Order,
    ParentLost,
    Refused,
    Result,
    Resume,
    Success,
    Suspend,
    Suspended,
)
from htnagent.runtime.progress import ProgressListeners
from htnagent.runtime.trace import Trace


class ActionOutcome(Enum):
    """How an executor's action ended."""

    SUCCESS = "success"
    """The action was carried out."""
    FAILURE = "failure"
    """The action could not be carried out; nothing else changed."""
    SUSPENDED = "suspended"
    """The action was stopped half way by :meth:`Executor.suspend`."""


class Executor(ABC):
    """What carries out actions; subclass it to connect a real robot or service.

    ``execute`` returns when the action is over.  If ``can_suspend`` says yes,
    ``suspend`` must make the running ``execute`` return ``ActionOutcome.SUSPENDED``;
    later ``resume`` finishes the action, or ``clear`` forgets it.
    """

    def can_suspend(self, action: Atom) -> bool:
        """Whether the running ``action`` may be stopped half way."""
        return False

    @abstractmethod
    async def execute(self, action: Atom) -> ActionOutcome:
        """Carry out the action."""

    async def suspend(self, action: Atom) -> None:  # pragma: no cover - default refuses
        """Stop the running action half way (only called if ``can_suspend``)."""
        raise RuntimeError(f"{type(self).__name__} cannot suspend {action}")

    async def resume(self, action: Atom) -> ActionOutcome:
        """Finish a suspended action."""
        return ActionOutcome.FAILURE

    async def clear(self, action: Atom) -> None:  # noqa: B027 - an optional hook
        """Forget a suspended action."""

    async def aclose(self) -> None:  # noqa: B027 - an optional hook
        """Release what the executor holds."""

    async def __aenter__(self) -> Self:
        return self

    async def __aexit__(
        self, exc_type: type[BaseException] | None, exc: BaseException | None, tb: TracebackType | None
    ) -> None:
        await self.aclose()


def stray_cancellation(exc: BaseException) -> bool:
    """Whether ``exc`` is a ``CancelledError`` that no cancellation of this task sent.

    Under asyncio any code may raise one (a user's executor, say); taken for a
    cancellation it would end the task that serves the executor quietly, and nothing
    would answer the orders waiting for it.  A real cancellation is under way when the
    task is being cancelled (``Task.cancelling``), and must go on up, never swallowed.
    """
    if not isinstance(exc, asyncio.CancelledError):
        return False
    try:
        task = asyncio.current_task()
    except RuntimeError:  # not under asyncio (trio): asyncio's CancelledError cancels nothing
        return True
    return task is not None and task.cancelling() == 0


def must_propagate(exc: BaseException) -> bool:
    """Whether ``exc``, raised by code the runtime calls (a user's executor), must go on up:
    a real cancellation, an interrupt, an exit.  Anything else is that code's failure."""
    if isinstance(exc, KeyboardInterrupt | SystemExit | BaseExceptionGroup):
        return True
    if isinstance(exc, anyio.get_cancelled_exc_class() | asyncio.CancelledError):
        return not stray_cancellation(exc)
    return False


class ExecutorActor(ABC):
    """An executor that speaks the message protocol directly.

    Its mailbox holds :data:`~htnagent.runtime.messages.Message`: orders from the parent,
    and whatever else the actor sends itself (timers); it reports how far a timed
    action has got to :attr:`progress` (what scenario triggers follow).
    """

    def __init__(self, name: str, clock: Clock, trace: Trace) -> None:
        self.name = name
        self.clock = clock
        self.trace = trace
        self.inbox: Mailbox[Message] = Mailbox(clock, name)
        self.reply_to: Mailbox[Message] | None = None
        self.progress = ProgressListeners()
        self.agent_domain: Domain | None = None
        """The domain of the planning agent behind this executor, if it is one (a child agent,
        here or in another process): an order is then a whole goal (docs/design.md §5)."""

    def levels_below(self) -> int:
        """How many executors an order passes on its way to the robot, this one included
        (a child agent adds its own executor's)."""
        return 1

    def connect(self, reply_to: Mailbox[Message]) -> None:
        """Send results to this mailbox (the parent agent's)."""
        self.reply_to = reply_to

    def reply(self, message: Result) -> None:
        """Send a result up."""
        if self.reply_to is not None:
            self.trace.emit(
                MessageSent(
                    agent=self.name, to=self.reply_to.name, kind=message.kind, action=str(message.action)
                )
            )
            self.reply_to.send(message)

    def order(self, below: ExecutorActor, message: Order) -> None:
        """Send an order down to ``below``."""
        action = str(message.action) if not isinstance(message, ParentLost) else ""
        self.trace.emit(MessageSent(agent=self.name, to=below.name, kind=message.kind, action=action))
        below.inbox.send(message)

    @abstractmethod
    async def run(self, *, task_status: TaskStatus[None] = anyio.TASK_STATUS_IGNORED) -> None:
        """Serve orders until cancelled; report ``started`` once the mailbox exists."""


class AdapterActor(ExecutorActor):
    """Runs a user's :class:`Executor` behind the message protocol.

    An executor that raises becomes a :class:`~htnagent.runtime.messages.Failure` with
    the exception's text; the actor goes on serving.
    """

    def __init__(self, name: str, clock: Clock, trace: Trace, executor: Executor) -> None:
        super().__init__(name, clock, trace)
        self.executor = executor
        self._running: dict[int, Atom] = {}  # orders being carried out, by seq

    async def run(self, *, task_status: TaskStatus[None] = anyio.TASK_STATUS_IGNORED) -> None:
        async with self.executor, anyio.create_task_group() as tg:
            task_status.started()
            while True:
                order = await self.inbox.receive()
                if isinstance(order, Execute | Resume):
                    self._running[order.seq] = order.action
                    tg.start_soon(self._carry_out, order)
                elif isinstance(order, Suspend):
                    # In a task of its own: a user's suspend that never returns must not keep
                    # the orders after it waiting (nor time from passing: an action timeout
                    # then ends the action).
                    tg.start_soon(self._suspend, order)
                elif isinstance(order, Clear):
                    try:
                        await self.executor.clear(order.action)
                    except BaseException as exc:  # a faulty executor must not stop the runtime
                        if must_propagate(exc):
                            raise
                        self.trace.emit(ExecutorError(agent=self.name, error=f"clear: {exc!r}"))

    async def _suspend(self, order: Suspend) -> None:
        try:
            running = self._running.get(order.seq) == order.action
            ok = running and self.executor.can_suspend(order.action)
            if ok:
                await self.executor.suspend(order.action)
                return  # the running execute answers Suspended
        except BaseException as exc:
            if must_propagate(exc):
                raise
            self.trace.emit(ExecutorError(agent=self.name, error=f"suspend: {exc!r}"))
        self.reply(Refused(action=order.action, seq=order.seq))

    async def _carry_out(self, order: Execute | Resume) -> None:
        # The adapter holds no work while the user's code runs: time may pass meanwhile.
        try:
            if isinstance(order, Resume):
                outcome = await self.executor.resume(order.action)
            else:
                outcome = await self.executor.execute(order.action)
        except BaseException as exc:
            if must_propagate(exc):
                raise  # a cancellation (the runtime closing), KeyboardInterrupt, SystemExit
            self.reply(Failure(action=order.action, seq=order.seq, reason=f"executor raised {exc!r}"))
            return
        finally:
            self._running.pop(order.seq, None)
        if outcome is ActionOutcome.SUCCESS:
            self.reply(Success(action=order.action, seq=order.seq))
        elif outcome is ActionOutcome.SUSPENDED:
            self.reply(Suspended(action=order.action, seq=order.seq))
        else:
            self.reply(Failure(action=order.action, seq=order.seq, reason="the executor reported failure"))
