"""The executor side of the message protocol, and the interface for writing executors.

Whatever carries out an agent's actions — the simulated robot, a scripted
executor in tests, a child agent, a real robot — is an *executor actor*: it
reads orders (:class:`~htnagent.runtime.messages.Execute`, ``Suspend``, ``Resume``,
``Clear``) from its mailbox and answers each order with one result on its
parent's mailbox.

Most users need not speak messages: subclass :class:`Executor` (small, like an
httpx transport) and the runtime wraps it in an :class:`AdapterActor`.  The
shipped executors (:mod:`htnagent.executors`) are written so too.  Through its
:attr:`Executor.context` an executor reads the runtime's clock (and waits in
simulated time), reports how far its actions have got (what scenario triggers
follow) and emits trace events.
"""

from __future__ import annotations

import asyncio
from abc import ABC, abstractmethod
from enum import Enum
from types import TracebackType
from typing import Self

import anyio
from anyio.abc import TaskGroup, TaskStatus

from htnagent.model.domain import Domain
from htnagent.model.terms import Atom
from htnagent.runtime.clock import Clock, Mailbox, TimerHandle
from htnagent.runtime.events import ExecutorError, MessageSent, TraceEvent
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
from htnagent.runtime.progress import Phase, Progress, ProgressListeners
from htnagent.runtime.trace import Trace


class ActionOutcome(Enum):
    """How an executor's action ended."""

    SUCCESS = "success"
    """The action was carried out."""
    FAILURE = "failure"
    """The action could not be carried out; nothing else changed."""
    SUSPENDED = "suspended"
    """The action was stopped half way by :meth:`Executor.suspend`."""


class ActionFailed(Exception):
    """Raised by an executor's ``execute`` or ``resume``: the action failed, for the reason given.

    The parent sees a failure with exactly this text as its reason (any other
    exception is a failure too, named as the executor's error).
    """


class Alarm:
    """A wait of some simulated seconds, which the executor may end early (:meth:`stop`).

    How it keeps virtual time honest: the clock moves only when no work is in
    flight.  When the alarm rings (or is stopped) while a task waits on it, that
    task counts as work until it runs on, so the clock cannot move past the
    instant before the executor has answered; the code an executor runs between
    two awaits of its context therefore happens at one instant.  Awaiting
    anything else (a real sleep, a socket) holds nothing: simulated time may
    move on meanwhile, as it should while a real robot acts.  An alarm nobody
    waits on holds no work at all.
    """

    __slots__ = ("_clock", "_event", "_handle", "_waiters", "rang", "seconds", "started_at")

    def __init__(self, clock: Clock, seconds: float) -> None:
        self._clock = clock
        self._event = clock.new_event()
        self._waiters = 0
        self.rang = False
        """Whether the time ran out (False: not yet, or stopped early)."""
        self.started_at = clock.now()
        self.seconds = seconds
        self._handle: TimerHandle = clock.call_later(seconds, self._ring)

    def _ring(self) -> None:
        self.rang = True
        self._wake()

    def stop(self) -> None:
        """End the wait now: :meth:`wait` returns False (no effect once it has rung)."""
        if not self._event.is_set():
            self._handle.cancel()
            self._wake()

    def _wake(self) -> None:
        if self._waiters:
            self._clock.add_work(self._waiters)  # released by each waiter as it runs on
        self._event.set()

    async def wait(self) -> bool:
        """Wait until the time is up (True) or the alarm is stopped (False)."""
        if not self._event.is_set():
            self._waiters += 1
            try:
                await self._event.wait()
            finally:
                if self._event.is_set():
                    self._clock.done_work()  # counted when it rang: this waiter runs on now
                else:
                    self._waiters -= 1  # cancelled while waiting
        return self.rang


class ExecutorContext:
    """What the runtime lends an :class:`Executor` it carries: time, progress, the trace."""

    __slots__ = ("_actor", "clock", "name")

    def __init__(self, actor: AdapterActor) -> None:
        self._actor = actor
        self.name = actor.name
        """The executor's name in the trace and in progress reports."""
        self.clock: Clock = actor.clock
        """The runtime's clock (simulated time, or paced to the wall clock)."""

    def now(self) -> float:
        """The runtime's time in seconds."""
        return self.clock.now()

    def alarm(self, seconds: float) -> Alarm:
        """An :class:`Alarm` that rings ``seconds`` from now, in the runtime's time."""
        return Alarm(self.clock, seconds)

    async def sleep(self, seconds: float) -> None:
        """Wait ``seconds`` of the runtime's time (simulated: no real waiting)."""
        await Alarm(self.clock, seconds).wait()

    def report_progress(self, action: Atom, phase: Phase, duration: float = 0.0, done: float = 0.0) -> None:
        """Tell the runtime's progress listeners (what scenario triggers follow) how far
        ``action`` has got: a motion of ``duration`` seconds starts now with the fraction
        ``done`` already covered (``Phase.STARTED``), or it was stopped half way."""
        self._actor.progress.report(Progress(self.name, action, phase, duration, done))

    def emit(self, event: TraceEvent) -> None:
        """Publish a trace event now (stamped with the time)."""
        self._actor.trace.emit(event)


class Executor(ABC):
    """What carries out actions; subclass it to connect a real robot or service.

    ``execute`` returns when the action is over (or raises :class:`ActionFailed`).
    If ``can_suspend`` says yes, ``suspend`` must make the running ``execute``
    return ``ActionOutcome.SUSPENDED``; later ``resume`` finishes the action, or
    ``clear`` forgets it.  Once a runtime carries the executor, :attr:`context`
    gives its clock, progress reports and trace.
    """

    name: str = "executor"
    """The executor's name in the trace (the sender of its answers)."""
    _context: ExecutorContext | None = None

    @property
    def context(self) -> ExecutorContext:
        """The runtime's clock, progress reports and trace, once a runtime carries the executor."""
        if self._context is None:
            raise RuntimeError(f"{type(self).__name__} is not connected to a runtime")
        return self._context

    def connect(self, context: ExecutorContext) -> None:
        """Called by the runtime when it takes the executor on."""
        self._context = context

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
    """Runs an :class:`Executor` behind the message protocol.

    An executor that raises becomes a :class:`~htnagent.runtime.messages.Failure` with
    the exception's text; the actor goes on serving.
    """

    def __init__(self, name: str, clock: Clock, trace: Trace, executor: Executor) -> None:
        super().__init__(name, clock, trace)
        self.executor = executor
        self._running: dict[int, Atom] = {}  # orders being carried out, by seq
        self._idle: list[anyio.Event] = []  # tasks done with their order, waiting for a turn to read
        executor.connect(ExecutorContext(self))

    async def run(self, *, task_status: TaskStatus[None] = anyio.TASK_STATUS_IGNORED) -> None:
        async with self.executor, anyio.create_task_group() as tg:
            # Two readers wait from the start: an order met while one action runs (a suspend,
            # then the emergency's first action) is read at once, never after spawning a task.
            for _ in range(2):
                turn = self.clock.new_event()
                self._idle.append(turn)
                tg.start_soon(self._serve, tg, turn)
            task_status.started()
            await self._serve(tg)

    async def _serve(self, tg: TaskGroup, turn: anyio.Event | None = None) -> None:
        """Read orders (once ``turn`` is set); carry out one that must be awaited, handing
        the mailbox on to another task meanwhile.

        The task that reads an ``Execute``, ``Resume`` or ``Suspend`` carries it out
        itself, at once — the executor's code up to its first await runs just when the
        order arrives, as an actor's would — and another task reads the orders after
        it (a user's suspend that never returns keeps nothing waiting, nor time from
        passing: an action timeout then ends the action).  That task wakes only when
        an order comes; done, a task waits in :attr:`_idle` for its next turn to read,
        so the robot's orders alternate between two tasks and none is spawned.
        """
        while True:
            if turn is not None:
                await turn.wait()
            order = await self.inbox.receive()
            if isinstance(order, Execute | Resume | Suspend):
                follower = self._idle.pop() if self._idle else None
                if follower is None:
                    follower = self.clock.new_event()
                    tg.start_soon(self._serve, tg, follower)
                # The order counts as handled from now: the executor's code up to its first
                # await runs before anything else can, so time stands still meanwhile.
                self.inbox.hand_over(follower)
                if isinstance(order, Suspend):
                    await self._suspend(order)
                else:
                    self._running[order.seq] = order.action
                    await self._carry_out(order)
                turn = self.clock.new_event()
                self._idle.append(turn)
            else:
                turn = None
                if isinstance(order, Clear):
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
        # The adapter holds no work while the executor awaits anything but its context's
        # clock: time may pass meanwhile (see Alarm).
        try:
            if isinstance(order, Resume):
                outcome = await self.executor.resume(order.action)
            else:
                outcome = await self.executor.execute(order.action)
        except ActionFailed as exc:
            self.reply(Failure(action=order.action, seq=order.seq, reason=str(exc)))
            return
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
