"""Each scenario goal's times, read from the trace as the run goes (docs/contracts.md
"Trace events", the `summary`).

:class:`GoalClock` is a trace observer.  For every goal of the scenario it notes when the
goal was given, started (its first plan selected, or its end if it never had one) and
ended, in simulated seconds; how long it waited suspended on its agent's stack; and at each
of its resumptions what the resumption cost, on the wall clock.  The summary of a run
(:mod:`htnagent.system.simulation`) and the benchmarks (``bench/measure.py``) read the same
figures from it, so the two always agree.

Observers run inside :meth:`~htnagent.runtime.trace.Trace.emit`, at the very moment of the
event.  The clock is subscribed twice: before every other observer (:meth:`GoalClock.__call__`,
where an interval ends) and after them (:meth:`GoalClock.seen`, where one starts), so the
time other observers take over the event that starts or ends an interval (printing the
live trace) is not counted; over the events in between, it is.  At a resumption of goal G
by agent A:

- ``replan_ms`` is the agents' own work at that moment: A's ``goal_resumed`` replan_ms,
  plus, for each agent below A, its planning of its first order after it -- from its
  ``goal_received`` to its ``plan_selected`` (its ``goal_finished``, when it ends the
  order without a plan), or its own ``goal_resumed`` replan_ms when the order resumes a
  goal it held for its parent (Algorithm 5);
- ``window_ms`` is the end-to-end window: from the end of the goal A ran before (the
  emergency's ``goal_finished``) to the first order (``execute`` or ``resume``) the lowest
  agent sends its executor after the resumption -- the resumed goal's first order at the
  robot.  It includes the runtime's fixed path (messages, clears of suspended actions)
  both modes pay.  None when no order followed (the goal ended, or was suspended again,
  first), or when no goal of A's had ended since G was suspended.

Nothing here decides anything: the figures are read, never acted on.
"""

from __future__ import annotations

import time
from collections.abc import Callable, Iterable, Sequence
from dataclasses import dataclass, field
from typing import Any, ClassVar

from htnagent.runtime.events import (
    GoalFinished,
    GoalReceived,
    GoalResumed,
    GoalSuspended,
    MessageSent,
    PlanSelected,
    ResumeRow,
    TraceEvent,
)
from htnagent.scenario import Scenario

ORDERS = frozenset({"execute", "resume"})
"""The message kinds that order an action done (a ``clear`` or a ``prepare`` hint does not)."""


@dataclass
class Resumption:
    """One resumption of a goal, as measured (wall-clock figures in milliseconds)."""

    t: float
    """When the goal came off the stack (simulated seconds)."""
    agent: str
    """The agent that resumed it."""
    replan_ms: dict[str, float] = field(default_factory=dict)
    """Each agent's own replanning at this resumption: the resuming agent first, then those
    below it in the order they planned."""
    order_ms: float | None = None
    """From the end of the goal run before to the resuming agent's own first order after it."""
    window_ms: float | None = None
    """From the end of the goal run before to the lowest agent's first order after it."""
    since: float | None = None
    below: tuple[str, ...] = ()
    planning: dict[str, float] = field(default_factory=dict)
    open: bool = True

    @property
    def total_ms(self) -> float:
        """The agents' replanning at this resumption, all levels together."""
        return sum(self.replan_ms.values())

    def awaits(self, agent: str) -> bool:
        """Whether ``agent`` is below the resuming one and has not yet begun its share."""
        return agent in self.below and agent not in self.replan_ms and agent not in self.planning

    def row(self) -> ResumeRow:
        """The resumption as the summary gives it."""
        window = None if self.window_ms is None else round(self.window_ms, 4)
        return ResumeRow(t=round(self.t, 6), replan_ms=round(self.total_ms, 4), window_ms=window)


@dataclass
class GoalTimes:
    """What :class:`GoalClock` noted of one scenario goal."""

    agent: str
    goal: str
    emergency: bool
    given: float | None = None
    started: float | None = None
    ended: float | None = None
    waited_s: float = 0.0
    suspended_at: float | None = None
    resumes: list[Resumption] = field(default_factory=list)


class GoalClock:
    """A trace observer noting each scenario goal's times and resumptions.

    ``chain``: the agents, parent first (the lowest one's orders reach the robot);
    ``goals``: the scenario's goals as ``(agent, goal, emergency)``, in file order.  Tell it
    each goal's ticket as soon as it is given (:meth:`given`): the ticket names the goal in
    the trace.
    """

    EVENTS: ClassVar[frozenset[str]] = frozenset(
        kind.event
        for kind in (GoalReceived, PlanSelected, GoalSuspended, GoalResumed, GoalFinished, MessageSent)
    )
    """The events it reads (by name): a process serving agents below must relay them."""

    def __init__(self, chain: Sequence[str], goals: Iterable[tuple[str, str, bool]]) -> None:
        self.chain = tuple(chain)
        self.goals = [GoalTimes(agent, goal, emergency) for agent, goal, emergency in goals]
        self._by_ticket: dict[int, GoalTimes] = {}
        self._running: dict[str, GoalTimes] = {}
        self._last_end: dict[str, float] = {}
        self._open: list[Resumption] = []
        self._noted: list[tuple[TraceEvent, float, bool]] = []
        self._handlers: dict[type[TraceEvent], Callable[[Any, float], None]] = {
            GoalReceived: self._received,
            PlanSelected: self._plan_selected,
            GoalSuspended: self._suspended,
            GoalResumed: self._resumed,
            GoalFinished: self._finished,
            MessageSent: self._ordered,
        }

    @classmethod
    def of(cls, scenario: Scenario) -> GoalClock:
        """A clock for the goals of ``scenario``, its agents in their chain."""
        return cls(
            scenario.agent_names,
            ((g.agent, str(scenario.goal_task(i)), g.emergency) for i, g in enumerate(scenario.goals)),
        )

    def given(self, index: int, ticket: int) -> None:
        """The scenario's goal ``index`` was submitted with ``ticket``."""
        self._by_ticket[ticket] = self.goals[index]

    def resumptions(self, agent: str | None = None) -> list[Resumption]:
        """Every resumption of a scenario goal (by ``agent`` only, if given), in time order."""
        self._catch_up()
        found = [r for g in self.goals for r in g.resumes if agent is None or r.agent == agent]
        return sorted(found, key=lambda r: r.t)

    def close(self, now: float) -> None:
        """The run is over at ``now``: a goal still suspended waited until then."""
        self._catch_up()
        for g in self.goals:
            if g.suspended_at is not None:
                g.waited_s += now - g.suspended_at
                g.suspended_at = None

    def __call__(self, event: TraceEvent) -> None:
        """Subscribe first: an event's own time, read before the other observers.

        This runs on the agents' own path, at every event of the run (the windows it
        measures include it): it only notes the event and the time; the bookkeeping is
        done once the run is over (:meth:`close`).
        """
        if event.__class__ in self._handlers:
            if isinstance(event, MessageSent) and event.kind not in ORDERS:
                return  # a result, a clear, a hint: no order
            self._noted.append((event, time.perf_counter(), False))

    def seen(self, event: TraceEvent) -> None:
        """Subscribe last: every observer has seen the event; the intervals it starts start now."""
        kind = event.__class__
        if kind is GoalFinished or kind is GoalReceived:
            self._noted.append((event, time.perf_counter(), True))

    def _catch_up(self) -> None:
        """Do the bookkeeping of every event noted so far, in the order they came."""
        noted, self._noted = self._noted, []
        for event, now, after in noted:
            if after:
                self._after(event, now)
            else:
                self._handlers[event.__class__](event, now)

    def _after(self, event: TraceEvent, now: float) -> None:
        if isinstance(event, GoalFinished):
            self._last_end[event.agent] = now
        else:
            for r in self._open:
                if r.awaits(event.agent):
                    r.planning[event.agent] = now

    # -- one function an event kind ----------------------------------------------------------

    def _received(self, event: GoalReceived, now: float) -> None:
        mine = self._by_ticket.get(event.ticket) if event.ticket is not None else None
        if mine is not None and mine.given is None:
            mine.given = event.t

    def _plan_selected(self, event: PlanSelected, now: float) -> None:
        self._planned(event.agent, now)
        running = self._running.get(event.agent)
        if running is not None and running.goal == event.goal:
            return
        waiting = self._find(event.agent, event.goal, lambda g: g.given is not None and g.started is None)
        if waiting is not None:
            waiting.started = event.t
            self._running[event.agent] = waiting

    def _suspended(self, event: GoalSuspended, now: float) -> None:
        # What ends from now on at this agent is what ran above the suspended goal.
        self._last_end.pop(event.agent, None)
        running = self._running.get(event.agent)
        if running is not None and running.goal == event.goal:
            goal: GoalTimes | None = self._running.pop(event.agent)
        else:
            goal = self._find(
                event.agent, event.goal, lambda g: g.started is not None and g.suspended_at is None
            )
        if goal is not None:
            goal.suspended_at = event.t
            self._close(goal)

    def _resumed(self, event: GoalResumed, now: float) -> None:
        for r in self._open:
            if r.awaits(event.agent):
                r.replan_ms[event.agent] = event.replan_ms
        stacked = [
            g
            for g in self.goals
            if g.agent == event.agent and g.goal == event.goal and g.suspended_at is not None
        ]
        if not stacked:
            return
        goal = max(stacked, key=lambda g: g.suspended_at or 0.0)  # the latest pushed comes off first
        assert goal.suspended_at is not None
        goal.waited_s += event.t - goal.suspended_at
        goal.suspended_at = None
        self._running[event.agent] = goal
        level = self.chain.index(event.agent) if event.agent in self.chain else len(self.chain)
        resumption = Resumption(
            t=event.t,
            agent=event.agent,
            replan_ms={event.agent: event.replan_ms},
            since=self._last_end.get(event.agent),
            below=self.chain[level + 1 :],
        )
        goal.resumes.append(resumption)
        self._open.append(resumption)

    def _finished(self, event: GoalFinished, now: float) -> None:
        self._planned(event.agent, now)
        goal = self._by_ticket.get(event.ticket) if event.ticket is not None else None
        if goal is None:
            return
        if goal.ended is None:
            goal.ended = event.t
        if goal.started is None:
            goal.started = event.t
        if goal.suspended_at is not None:
            goal.waited_s += event.t - goal.suspended_at
            goal.suspended_at = None
        if self._running.get(event.agent) is goal:
            del self._running[event.agent]
        self._close(goal)

    def _ordered(self, event: MessageSent, now: float) -> None:
        lowest = bool(self.chain) and event.agent == self.chain[-1]
        for r in self._open:
            if r.since is None:
                continue
            if event.agent == r.agent and r.order_ms is None:
                r.order_ms = (now - r.since) * 1000
            if lowest:
                r.window_ms = (now - r.since) * 1000
        if lowest:
            for r in self._open:
                r.open = False
            self._open.clear()

    # -- helpers -------------------------------------------------------------------------------

    def _planned(self, agent: str, now: float) -> None:
        """An agent below a resumption has its plan for the order it got (or ended it)."""
        for r in self._open:
            started = r.planning.get(agent)
            if started is not None and agent not in r.replan_ms:
                r.replan_ms[agent] = (now - started) * 1000

    def _find(self, agent: str, goal: str, fits: Callable[[GoalTimes], bool]) -> GoalTimes | None:
        for g in self.goals:
            if g.agent == agent and g.goal == goal and g.ended is None and fits(g):
                return g
        return None

    def _close(self, goal: GoalTimes) -> None:
        """The goal ended or was suspended again: its open resumption gets no window."""
        for r in goal.resumes:
            if r.open:
                r.open = False
                if r in self._open:
                    self._open.remove(r)
