"""The runtime: agents, their executors and the clock in one task group.

Embedding API::

    async with Runtime([AgentConfig(...), AgentConfig(...)], robot_factory) as rt:
        outcome = await rt.achieve("guide", parse("goto(n1)"))

Agents are listed parent first; each agent's executor is the next agent, and
the last agent's is the given executor: an :class:`~htnagent.executor.ExecutorActor`
factory ``(clock, trace) -> actor`` or a plain :class:`~htnagent.executor.Executor`
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
import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from types import TracebackType
from typing import Any

import anyio
from anyio.abc import TaskGroup, TaskStatus
from anyio.streams.memory import MemoryObjectReceiveStream, MemoryObjectSendStream

from htnagent.agent import Agent, AgentConfig, GoalStatus
from htnagent.clock import Clock
from htnagent.executor import AdapterActor, Executor, ExecutorActor
from htnagent.messages import Clear, Execute, Failure, Resume, Suspend
from htnagent.terms import Atom
from htnagent.trace import Event, Observer, Trace

ExecutorFactory = Callable[[Clock, Trace], ExecutorActor]


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
    ) -> None:
        if not agents:
            raise ValueError("a runtime needs at least one agent")
        if isinstance(executor, Executor) and speed is None:
            # A user's executor acts in the real world: its time is the wall clock's.
            speed = 1.0
        self.clock = Clock(speed)
        self.trace = Trace(self.clock)
        if isinstance(executor, Executor):
            bottom: ExecutorActor = AdapterActor("executor", self.clock, self.trace, executor)
        else:
            bottom = executor(self.clock, self.trace)
        self.executor = bottom
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
        self._resolved: dict[int, anyio.Event] = {}
        self._tg: TaskGroup | None = None
        self._streams: list[MemoryObjectSendStream[Event]] = []

    # -- lifetime -------------------------------------------------------------------

    async def __aenter__(self) -> Runtime:
        tg = anyio.create_task_group()
        await tg.__aenter__()
        self._tg = tg
        try:
            tg.start_soon(self.clock.keep_time)
            await tg.start(self._guard, self.executor)
            for agent in reversed(list(self.agents.values())):
                await tg.start(self._guard, agent)
        except BaseException:
            tg.cancel_scope.cancel()
            try:
                await tg.__aexit__(None, None, None)
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
        finally:
            self._tg = None
            self._close()

    def _close(self) -> None:
        for actor in [*self.agents.values(), self.executor]:
            actor.inbox.close()
        # No more events: every events() stream ends.
        for send in self._streams:
            send.close()
        self._streams.clear()

    async def _guard(
        self, actor: ExecutorActor, *, task_status: TaskStatus[None] = anyio.TASK_STATUS_IGNORED
    ) -> None:
        started = _Started(task_status)
        try:
            await actor.run(task_status=started)
        except Exception as exc:  # a crashed actor becomes failures, never a hang
            if not started.done:
                raise  # it never served: the runtime cannot start (tg.start raises it)
            reason = f"{actor.name} crashed: {exc!r}"
            self.trace.emit(actor.name, "agent_crashed", error=repr(exc))
            self._after_crash(actor, reason)
            await self._serve_dead(actor, reason)

    def _after_crash(self, actor: ExecutorActor, reason: str) -> None:
        parent = self._parents.get(actor.name)
        if parent is not None and parent.running is not None:
            parent.inbox.send(Failure(action=parent.running.action, seq=parent.running.seq, reason=reason))
        if isinstance(actor, Agent):
            tickets = [e.ticket for e in actor.unfinished() if e.ticket is not None]
            try:
                # Every goal it held ends, with the crash as its reason.
                actor.fail_all(reason)
            finally:
                for ticket in tickets:  # even if its own bookkeeping is what broke
                    self._resolve(ticket, GoalStatus.FAILURE, reason)

    async def _serve_dead(self, actor: ExecutorActor, reason: str) -> None:
        while True:
            message: Any = await actor.inbox.receive()
            if isinstance(message, Execute | Resume | Suspend):
                actor.reply(Failure(action=message.action, seq=message.seq, reason=reason))
            elif isinstance(message, Clear):
                continue
            elif hasattr(message, "ticket"):
                self._resolve(message.ticket, GoalStatus.FAILURE, reason)

    # -- goals ----------------------------------------------------------------------------

    def submit(self, agent: str, goal: Atom, *, emergency: bool = False) -> int:
        """Give a goal to an agent now; returns its ticket."""
        if agent not in self.agents:
            raise KeyError(f"no agent named {agent!r}; agents: {', '.join(self.agents)}")
        ticket = next(self._tickets)
        self.outcomes[ticket] = GoalOutcome(ticket, agent, goal, emergency)
        self._resolved[ticket] = anyio.Event()
        self.agents[agent].submit(goal, ticket, emergency)
        return ticket

    async def outcome(self, ticket: int) -> GoalOutcome:
        """Wait until the goal has ended."""
        await self._resolved[ticket].wait()
        return self.outcomes[ticket]

    async def achieve(self, agent: str, goal: Atom, *, emergency: bool = False) -> GoalOutcome:
        """Submit a goal and wait for its outcome."""
        return await self.outcome(self.submit(agent, goal, emergency=emergency))

    def _resolve(self, ticket: int, status: GoalStatus, reason: str) -> None:
        outcome = self.outcomes.get(ticket)
        if outcome is None or outcome.done:
            return
        outcome.status = status
        outcome.reason = reason
        self._resolved[ticket].set()

    def fail_unfinished(self, reason: str) -> None:
        """End every goal that has not ended, as a failure (the run is over)."""
        for ticket, outcome in self.outcomes.items():
            if not outcome.done:
                self._resolve(ticket, GoalStatus.FAILURE, reason)

    # -- observing --------------------------------------------------------------------------

    def subscribe(self, observer: Observer) -> Callable[[], None]:
        """Call ``observer`` with every trace event; returns the unsubscribe function."""
        return self.trace.subscribe(observer)

    def events(self) -> MemoryObjectReceiveStream[Event]:
        """A stream of every trace event from now on; it ends when the runtime closes (close it to stop)."""
        send, receive = anyio.create_memory_object_stream[Event](math.inf)
        self._streams.append(send)

        def forward(event: Event) -> None:
            try:
                send.send_nowait(event)
            except (anyio.ClosedResourceError, anyio.BrokenResourceError):
                unsubscribe()
                send.close()

        unsubscribe = self.trace.subscribe(forward)
        return receive
