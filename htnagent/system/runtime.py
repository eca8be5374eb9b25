"""The runtime: agents, their executors and the clock in one task group.

Embedding API::

    async with Runtime([AgentConfig(...), AgentConfig(...)], robot_factory) as rt:
        outcome = await rt.achieve("guide", parse("goto(n1)"))

Agents are listed parent first; each agent's executor is the next agent, and
the last agent's is the given executor: a factory ``(clock, trace) ->`` an
:class:`~htnagent.runtime.executor.Executor` (the simulated robot, say) or an
:class:`~htnagent.runtime.executor.ExecutorActor`, or a plain ``Executor`` instance
(which acts in the real world, so its runtime keeps wall-clock time: ``speed``
defaults to 1 for it, virtual time otherwise).  Nothing outlives the
``async with``: leaving it cancels every task.  An actor that crashes is
reported (``agent_crashed``), the order it was serving fails, and from then on
it answers every order with a failure; one that fails before it is ready makes
entering the runtime fail with its error.

Works under asyncio and trio (anyio).
"""

from __future__ import annotations

import itertools
from collections import deque
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from types import TracebackType
from typing import Self

import anyio
from anyio.abc import TaskGroup, TaskStatus

from htnagent.agent import Agent, AgentConfig, GoalStatus
from htnagent.errors import RuntimeClosedError, SettingsError, UnknownNameError
from htnagent.model.terms import Atom
from htnagent.runtime.clock import Clock
from htnagent.runtime.events import AgentCrashed
from htnagent.runtime.executor import AdapterActor, Executor, ExecutorActor, must_propagate
from htnagent.runtime.listeners import Listeners
from htnagent.runtime.messages import Clear, Execute, Failure, ParentLost, Resume, Submit, Suspend
from htnagent.runtime.progress import ProgressListener
from htnagent.runtime.trace import EventStream, Observer, Trace

ExecutorFactory = Callable[[Clock, Trace], ExecutorActor | Executor]

CLOSED = "runtime closed"
"""The reason of every goal still open when the runtime is left."""


@dataclass
class GoalOutcome:
    """What became of a submitted goal."""

    ticket: int
    agent: str
    goal: Atom
    emergency: bool
    status: GoalStatus | None = None
    reason: str = ""

    @property
    def done(self) -> bool:
        """Whether the goal has ended."""
        return self.status is not None


class _Started(TaskStatus[None]):
    """Passes ``started`` on, and remembers that it was called."""

    def __init__(self, inner: TaskStatus[None]) -> None:
        self.inner = inner
        self.done = False

    def started(self, value: None = None) -> None:
        self.done = True
        self.inner.started(value)


class Runtime:
    """A stratified chain of agents over one executor, run in one task group."""

    def __init__(
        self,
        agents: Sequence[AgentConfig],
        executor: ExecutorFactory | Executor,
        *,
        speed: float | None = None,
        keep_outcomes: int | None = 10_000,
        clock: Clock | None = None,
    ) -> None:
        """``keep_outcomes`` bounds how many ended goals' outcomes are kept (the oldest go
        first; None keeps all): a runtime that lives long must not grow without bound.

        ``clock``: a clock shared by many runtimes (a fleet of robots in one process):
        simulated time then moves for all of them together, and one task keeps it —
        run ``clock.keep_time()`` yourself, once, beside the runtimes.
        """
        if not agents:
            raise SettingsError("a runtime needs at least one agent")
        if clock is not None and speed is not None:
            raise SettingsError("a shared clock has its own speed: give speed to the Clock")
        if isinstance(executor, Executor) and speed is None and clock is None:
            # A user's executor acts in the real world: its time is the wall clock's.
            speed = 1.0
        self._own_clock = clock is None
        self.clock = clock if clock is not None else Clock(speed)
        self.trace = Trace(self.clock)
        made = executor if isinstance(executor, Executor) else executor(self.clock, self.trace)
        if isinstance(made, Executor):
            bottom: ExecutorActor = AdapterActor(made.name, self.clock, self.trace, made)
        else:
            bottom = made
        self.executor = bottom
        """The actor at the bottom of the chain (for an :class:`Executor`, the one carrying it)."""
        self.agents: dict[str, Agent] = {}
        below: ExecutorActor = bottom
        chain: list[Agent] = []
        for config in reversed(agents):
            agent = Agent(config, self.clock, self.trace, below, self._resolve)
            chain.append(agent)
            below = agent
        for agent in reversed(chain):
            self.agents[agent.name] = agent
        self._parents: dict[str, Agent] = {}
        names = list(self.agents)
        for i, name in enumerate(names):
            below_name = names[i + 1] if i + 1 < len(names) else bottom.name
            self._parents[below_name] = self.agents[name]
        self._tickets = itertools.count(1)
        self.outcomes: dict[int, GoalOutcome] = {}
        """Every goal given, by ticket: open ones, and the latest ``keep_outcomes`` ended ones."""
        self.keep_outcomes = keep_outcomes
        self._ended: deque[int] = deque()
        self._resolved: dict[int, anyio.Event] = {}
        self._tg: TaskGroup | None = None
        self._state = "new"
        self._streams: list[EventStream] = []
        self._end_callbacks: Listeners[GoalOutcome] = Listeners("goal-end callback")

    # -- lifetime -------------------------------------------------------------------

    async def __aenter__(self) -> Self:
        if self._state != "new":
            raise RuntimeClosedError("a runtime can be entered once")
        tg = anyio.create_task_group()
        await tg.__aenter__()
        self._tg = tg
        self._state = "running"
        try:
            if self._own_clock:
                tg.start_soon(self.clock.keep_time)
            await tg.start(self._guard, self.executor)
            for agent in reversed(list(self.agents.values())):
                await tg.start(self._guard, agent)
        except BaseException:
            tg.cancel_scope.cancel()
            try:
                await tg.__aexit__(None, None, None)
            except BaseExceptionGroup as group:
                raise _unwrapped(group) from None
            finally:
                self._tg = None
                self._close()
            raise
        return self

    async def __aexit__(
        self, exc_type: type[BaseException] | None, exc: BaseException | None, tb: TracebackType | None
    ) -> bool | None:
        assert self._tg is not None
        self._tg.cancel_scope.cancel()
        try:
            if isinstance(exc, Exception):
                # The body's own error: stop the tasks, then let it propagate as it is,
                # not wrapped in the internal task group's ExceptionGroup.
                await self._tg.__aexit__(None, None, None)
                return None
            return await self._tg.__aexit__(exc_type, exc, tb)
        except BaseExceptionGroup as group:
            # KeyboardInterrupt or SystemExit from user code reaches the caller as itself.
            raise _unwrapped(group) from None
        finally:
            self._tg = None
            self._close()

    def _close(self) -> None:
        self._state = "closed"
        for actor in [*self.agents.values(), self.executor]:
            actor.inbox.close()
        # Nothing will end the goals still open: they fail, and whoever waits is woken.
        self.fail_unfinished(CLOSED)
        # No more events: every events() stream ends.
        for stream in self._streams:
            stream.close()
        self._streams.clear()

    async def _guard(
        self, actor: ExecutorActor, *, task_status: TaskStatus[None] = anyio.TASK_STATUS_IGNORED
    ) -> None:
        started = _Started(task_status)
        try:
            await actor.run(task_status=started)
        except BaseException as exc:  # a crashed actor becomes failures, never a hang
            if must_propagate(exc):
                raise  # a cancellation (the runtime closing), KeyboardInterrupt, SystemExit
            if not started.done:
                raise  # it never served: the runtime cannot start (tg.start raises it)
            reason = f"{actor.name} crashed: {exc!r}"
            self.trace.emit(AgentCrashed(agent=actor.name, error=repr(exc)))
            self._after_crash(actor, reason)
            await self._serve_dead(actor, reason)

    def _after_crash(self, actor: ExecutorActor, reason: str) -> None:
        parent = self._parents.get(actor.name)
        if parent is not None:
            parent.executor_crashed(reason)
        if isinstance(actor, Agent):
            tickets = [e.ticket for e in actor.unfinished() if e.ticket is not None]
            try:
                # Every goal it held ends, with the crash as its reason.
                actor.fail_all(reason)
            finally:
                for ticket in tickets:  # even if its own bookkeeping is what broke
                    self._resolve(ticket, GoalStatus.FAILURE, reason)
                if actor.executor.agent_domain is not None:
                    # Nobody will resume or await what the child does for the dead parent.
                    actor.order(actor.executor, ParentLost())

    async def _serve_dead(self, actor: ExecutorActor, reason: str) -> None:
        while True:
            message = await actor.inbox.receive()
            if isinstance(message, Execute | Resume | Suspend):
                actor.reply(Failure(action=message.action, seq=message.seq, reason=reason))
            elif isinstance(message, Clear):
                continue
            elif isinstance(message, Submit):
                self._resolve(message.ticket, GoalStatus.FAILURE, reason)

    # -- goals ----------------------------------------------------------------------------

    def submit(self, agent: str, goal: Atom, *, emergency: bool = False) -> int:
        """Give a goal to an agent now; returns its ticket.

        Raises :class:`~htnagent.errors.RuntimeClosedError` outside ``async with``.
        """
        if agent not in self.agents:
            raise UnknownNameError(f"no agent named {agent!r}; agents: {', '.join(self.agents)}")
        if self._state != "running":
            when = "has not been entered" if self._state == "new" else "is closed"
            raise RuntimeClosedError(f"cannot give {goal} to {agent}: the runtime {when} (use async with)")
        ticket = next(self._tickets)
        self.outcomes[ticket] = GoalOutcome(ticket, agent, goal, emergency)
        self._resolved[ticket] = anyio.Event()
        self.agents[agent].submit(goal, ticket, emergency)
        return ticket

    async def outcome(self, ticket: int) -> GoalOutcome:
        """Wait until the goal has ended (at once if it has)."""
        outcome = self.outcomes.get(ticket)
        if outcome is None:
            raise UnknownNameError(f"no goal with ticket {ticket} (never given, or ended long ago)")
        if not outcome.done:
            await self._resolved[ticket].wait()
        return outcome

    async def achieve(self, agent: str, goal: Atom, *, emergency: bool = False) -> GoalOutcome:
        """Submit a goal and wait for its outcome."""
        return await self.outcome(self.submit(agent, goal, emergency=emergency))

    def _resolve(self, ticket: int, status: GoalStatus, reason: str) -> None:
        outcome = self.outcomes.get(ticket)
        if outcome is None or outcome.done:
            return
        outcome.status = status
        outcome.reason = reason
        self._resolved.pop(ticket).set()
        self._ended.append(ticket)
        if self.keep_outcomes is not None:
            while len(self._ended) > self.keep_outcomes:
                self.outcomes.pop(self._ended.popleft(), None)
        self._end_callbacks.report(outcome)

    def fail_unfinished(self, reason: str) -> None:
        """End every goal that has not ended, as a failure (the run is over)."""
        for ticket, outcome in list(self.outcomes.items()):
            if not outcome.done:
                self._resolve(ticket, GoalStatus.FAILURE, reason)

    # -- observing --------------------------------------------------------------------------

    @property
    def bottom_executor(self) -> Executor | None:
        """The :class:`Executor` at the bottom of the chain (the robot), if it is one (None
        for an actor, such as the link to agents served by another process)."""
        bottom = self.executor
        return bottom.executor if isinstance(bottom, AdapterActor) else None

    def on_progress(self, listener: ProgressListener) -> Callable[[], None]:
        """Call ``listener`` with every actor's progress reports (see :mod:`htnagent.runtime.progress`);
        returns the function that removes it."""
        removers = [actor.progress.add(listener) for actor in [*self.agents.values(), self.executor]]

        def remove() -> None:
            for remover in removers:
                remover()

        return remove

    def on_goal_end(self, callback: Callable[[GoalOutcome], None]) -> Callable[[], None]:
        """Call ``callback`` with each goal's outcome as the goal ends; returns the remover.

        A callback that raises is dropped (with a warning in the log); the runtime goes on.
        """
        return self._end_callbacks.add(callback)

    def subscribe(self, observer: Observer) -> Callable[[], None]:
        """Call ``observer`` with every trace event; returns the unsubscribe function."""
        return self.trace.subscribe(observer)

    def events(self, limit: int = 10_000) -> EventStream:
        """A stream of every trace event from now on; it ends when the runtime closes.

        A reader that falls ``limit`` events behind loses the oldest ones and is told
        so by an ``events_dropped`` event (see :class:`~htnagent.runtime.trace.EventStream`);
        close it (``aclose``) to stop reading.
        """
        stream = EventStream(self.trace, limit)
        if self._state == "closed":
            stream.close()
        else:
            self._streams.append(stream)
        return stream


def _unwrapped(group: BaseExceptionGroup[BaseException]) -> BaseException:
    """The KeyboardInterrupt or SystemExit inside a task group's exception group, else the group."""
    for kind in (KeyboardInterrupt, SystemExit):
        match, _ = group.split(kind)
        if match is not None:
            first = match.exceptions[0]
            while isinstance(first, BaseExceptionGroup):
                first = first.exceptions[0]
            return first
    return group
