"""What happened in a run, read from its trace alone: goals, stacks, the robot's way.

:meth:`History.from_events` turns a run's typed events (:mod:`htnagent.runtime.events`,
as ``run --json`` writes them or ``RunReport.events`` keeps them) into the
facts a person asks about afterwards:

- per agent, each goal as a bar from received to finished (``success``,
  ``failure`` with its reason, ``cleared``, or ``open`` if the trace ends
  first), the spans it spent suspended on the agent's stack, and the plans
  selected for it;
- per agent, the stack depth over time and the actions it ordered;
- the robot's motions (from, to, which fraction of the arc at the start and at
  the end) and timed activities;
- marks: emergencies arriving, doors shutting and opening, crashes;
- the run's header (``run_started``: the scenario's name, the replanning mode,
  htnagent's version), when the trace has one (traces saved before it existed
  have none).

:meth:`History.at` answers "what was going on at time t": each agent's current
goal, its stack (bottom first), the selected plan and the action under way,
and where the robot stood.  "At t" means after every event stamped t.

The drawings (:mod:`htnagent.views.timeline`, :mod:`htnagent.views.report`) read only this
model; nothing here imports the runtime or draws.  The runtime never reads it
(docs/style.md "Concurrency": behaviour never depends on the trace).
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Sequence
from dataclasses import dataclass, field
from typing import Literal

from htnagent.errors import TextFormError, TraceFormatError
from htnagent.model.terms import Atom, parse
from htnagent.runtime.events import (
    ActionFinished,
    ActionStarted,
    AgentCrashed,
    ArcClosed,
    ArcOpened,
    GoalCleared,
    GoalFinished,
    GoalReceived,
    GoalResumed,
    GoalSuspended,
    JSONValue,
    MessageSent,
    PlanSelected,
    RobotActing,
    RobotMoving,
    RunStarted,
    Summary,
    TraceEvent,
)

ROBOT = "robot"
"""The simulated robot's name in the trace (it is no planning agent: no lane of its own)."""

_NOT_AGENTS = frozenset({ROBOT, "world", "runtime"})

GoalStatus = Literal["success", "failure", "cleared", "open"]
"""How a goal's bar ends: ``open`` when the trace ends before the goal does."""

MarkKind = Literal["emergency", "arc_closed", "arc_opened", "crash"]

_DIGITS = 6
"""Times and fractions are rounded to the microsecond, as the trace gives them."""


@dataclass(slots=True)
class Span:
    """From ``start`` to ``end`` (simulated seconds); ``end`` None while still open."""

    start: float
    end: float | None = None

    def holds(self, t: float) -> bool:
        """``t`` is inside: after the events stamped ``start``, before those stamped ``end``."""
        return self.start <= t and (self.end is None or t < self.end)


@dataclass(frozen=True, slots=True)
class PlanChoice:
    """A plan selected at ``t``: its actions' text forms and its cost."""

    t: float
    plan: tuple[str, ...]
    cost: float


@dataclass(slots=True)
class GoalBar:
    """One goal of one agent, from received to finished, with its suspensions and plans."""

    agent: str
    goal: str
    emergency: bool
    received: float
    ticket: int | None = None
    end: float | None = None
    status: GoalStatus = "open"
    reason: str = ""
    suspended: list[Span] = field(default_factory=list)
    plans: list[PlanChoice] = field(default_factory=list)

    def open_at(self, t: float) -> bool:
        """Received, not yet finished."""
        return self.received <= t and (self.end is None or t < self.end)

    def suspended_at(self, t: float) -> bool:
        """On the stack at ``t``."""
        return any(s.holds(t) for s in self.suspended)

    @property
    def on_stack(self) -> bool:
        """Suspended now, at the end of the events read so far."""
        return bool(self.suspended) and self.suspended[-1].end is None

    def first_stop(self, end: float) -> float:
        """When the goal first sat on the stack for a while (a suspension resumed in the same
        instant draws nothing), else ``end``: how far its bar is drawn plain."""
        return next((s.start for s in self.suspended if s.end is None or s.end > s.start), end)

    @property
    def labels(self) -> tuple[str, ...]:
        """What a drawing may write in the goal's bar, longest first: its name, then the
        task's name with the arguments left out (``move_area(…)``), for a short bar."""
        head, paren, _ = self.goal.partition("(")
        return (self.goal, f"{head}(…)") if paren else (self.goal,)


@dataclass(slots=True)
class ActionSpan:
    """An action an agent ordered, from the order to its executor's answer (``result``)."""

    start: float
    action: str
    end: float | None = None
    result: str = ""


@dataclass(slots=True)
class Motion:
    """The robot travelling ``arc`` from fraction ``f0`` to ``f1`` of the way ``frm`` → ``to``.

    ``end`` and ``f1`` are where it stopped: on arrival, or part way when suspended.
    """

    start: float
    end: float
    action: str
    arc: str
    frm: str
    to: str
    f0: float
    f1: float

    def fraction_at(self, t: float) -> float:
        """How far along ``frm`` → ``to`` the robot was at ``t`` (inside the motion)."""
        if self.end <= self.start:
            return self.f1
        share = min(1.0, max(0.0, (t - self.start) / (self.end - self.start)))
        return self.f0 + (self.f1 - self.f0) * share


@dataclass(slots=True)
class Activity:
    """A timed action of the robot other than a move (``explain(statue)``), fresh or resumed."""

    start: float
    end: float
    action: str


@dataclass(frozen=True, slots=True)
class Mark:
    """A moment worth a vertical line: an emergency arriving, a door, a crash."""

    t: float
    kind: MarkKind
    agent: str
    subject: str
    """The emergency's goal, the door's arc, the crash's error."""

    @property
    def label(self) -> str:
        """A few words for a picture."""
        if self.kind == "emergency":
            return f"! {self.agent}: {self.subject}"
        if self.kind == "crash":
            return f"{self.agent} crashed: {self.subject}"
        return f"{self.subject} {'closed' if self.kind == 'arc_closed' else 'opened'}"


Position = dict[str, str | float]
"""Where the robot is: ``{"node": n}``, or ``{"arc", "from", "to", "fraction"}`` on the way."""


@dataclass(frozen=True, slots=True)
class AgentNow:
    """One agent at a moment: its current goal, its stack (bottom first), plan and action."""

    goal: str | None
    emergency: bool
    """The current goal is an emergency."""
    stack: tuple[str, ...]
    plan: tuple[str, ...] | None
    action: str | None

    def as_json(self) -> dict[str, JSONValue]:
        return {
            "goal": self.goal,
            "emergency": self.emergency,
            "stack": list(self.stack),
            "plan": None if self.plan is None else list(self.plan),
            "action": self.action,
        }


@dataclass(frozen=True, slots=True)
class Moment:
    """What :meth:`History.at` answers."""

    t: float
    agents: dict[str, AgentNow]
    robot: Position | None
    activity: str | None

    def as_json(self) -> dict[str, JSONValue]:
        """The same object the report page's ``stateAt`` computes."""
        return {
            "t": self.t,
            "agents": {name: now.as_json() for name, now in self.agents.items()},
            "robot": None if self.robot is None else dict(self.robot),
            "activity": self.activity,
        }


@dataclass
class History:
    """A run as read from its trace; build it with :meth:`from_events`."""

    agents: tuple[str, ...]
    """Planning agents, parent first."""
    goals: list[GoalBar]
    """In the order received."""
    depth: dict[str, list[tuple[float, int]]]
    """Per agent, the stack depth after each change: ``(t, depth)``, starting ``(0, 0)``."""
    actions: dict[str, list[ActionSpan]]
    motions: list[Motion]
    activities: list[Activity]
    marks: list[Mark]
    start: str | None
    """The node the robot stood on first, if the trace shows it."""
    end: float
    """The time of the last event (the summary's)."""
    summary: Summary | None
    run: RunStarted | None = None
    """The trace's header: scenario name, mode (``online``/``naive``), version; None without one."""

    @property
    def mode(self) -> str | None:
        """The replanning mode the run used, if the trace says."""
        return None if self.run is None else self.run.mode

    @property
    def scenario_name(self) -> str | None:
        """The name of the scenario the run ran, if the trace says."""
        return None if self.run is None else self.run.scenario

    # -- building ---------------------------------------------------------------------------

    @classmethod
    def from_events(cls, events: Iterable[TraceEvent], agents: Sequence[str] = ()) -> History:
        """The history of a run's events (in the order published).

        ``agents``: the planning agents parent first (a scenario's order); by default
        the order is read from who orders whom (``execute`` messages).  Raises
        :class:`~htnagent.errors.TraceFormatError` for a trace no run could write
        (time running backwards, a robot action that is no text form).
        """
        reader = _Reader()
        for event in events:
            reader.read(event)
        return reader.history(tuple(agents))

    # -- questions --------------------------------------------------------------------------

    def goals_of(self, agent: str) -> list[GoalBar]:
        """The agent's goals, in the order received."""
        return [g for g in self.goals if g.agent == agent]

    def goal_rows(self, agent: str) -> list[tuple[GoalBar, int]]:
        """The agent's goals, each with its row in the agent's lane (for drawing).

        Goals that overlap in time (an emergency over a suspended goal) take
        separate rows, the earliest free one; a goal still open ends at :attr:`end`.
        """
        free_from: list[float] = []
        out: list[tuple[GoalBar, int]] = []
        for goal in self.goals_of(agent):
            end = self.end if goal.end is None else goal.end
            row = next((i for i, f in enumerate(free_from) if f <= goal.received), len(free_from))
            if row == len(free_from):
                free_from.append(end)
            else:
                free_from[row] = end
            out.append((goal, row))
        return out

    def depth_at(self, agent: str, t: float) -> int:
        """The agent's stack depth at ``t``."""
        depth = 0
        for when, d in self.depth.get(agent, []):
            if when > t:
                break
            depth = d
        return depth

    def at(self, t: float) -> Moment:
        """Each agent's goal, stack, plan and action, and the robot's place, at ``t``."""
        agents = {name: self._agent_at(name, t) for name in self.agents}
        return Moment(t=t, agents=agents, robot=self.robot_at(t), activity=self._activity_at(t))

    def _agent_at(self, agent: str, t: float) -> AgentNow:
        live = [g for g in self.goals_of(agent) if g.open_at(t)]
        stacked = [g for g in live if g.suspended_at(t)]
        stacked.sort(key=lambda g: _last_start(g, t))
        running = [g for g in live if not g.suspended_at(t)]
        current = _current(running, t)
        plan = _plan_at(current, t) if current is not None else None
        action = None
        for span in self.actions.get(agent, []):
            if span.start <= t and (span.end is None or t < span.end):
                action = span.action
        return AgentNow(
            goal=None if current is None else current.goal,
            emergency=current is not None and current.emergency,
            stack=tuple(g.goal for g in stacked),
            plan=plan,
            action=action,
        )

    def robot_at(self, t: float) -> Position | None:
        """Where the robot was at ``t``; None if the trace never shows it."""
        last: Motion | None = None
        for motion in self.motions:
            if motion.start > t:
                break
            last = motion
        if last is None:
            return None if self.start is None else {"node": self.start}
        if t < last.end:
            return _on(last, last.fraction_at(t))
        return _on(last, last.f1)

    def _activity_at(self, t: float) -> str | None:
        for activity in self.activities:
            if activity.start <= t < activity.end:
                return activity.action
        return None

    # -- the JSON form ------------------------------------------------------------------------

    def as_json(self) -> dict[str, JSONValue]:
        """Everything above as plain JSON values (the report page's data)."""
        return {
            "agents": list(self.agents),
            "start": self.start,
            "end": self.end,
            "goals": [
                {
                    "agent": g.agent,
                    "goal": g.goal,
                    "emergency": g.emergency,
                    "received": g.received,
                    "ticket": g.ticket,
                    "end": g.end,
                    "status": g.status,
                    "reason": g.reason,
                    "suspended": [[s.start, s.end] for s in g.suspended],
                    "plans": [{"t": p.t, "plan": list(p.plan), "cost": p.cost} for p in g.plans],
                }
                for g in self.goals
            ],
            "depth": {a: [[t, d] for t, d in steps] for a, steps in self.depth.items()},
            "actions": {
                a: [{"start": s.start, "end": s.end, "action": s.action, "result": s.result} for s in spans]
                for a, spans in self.actions.items()
            },
            "motions": [
                {
                    "start": m.start,
                    "end": m.end,
                    "action": m.action,
                    "arc": m.arc,
                    "from": m.frm,
                    "to": m.to,
                    "f0": m.f0,
                    "f1": m.f1,
                }
                for m in self.motions
            ],
            "activities": [{"start": a.start, "end": a.end, "action": a.action} for a in self.activities],
            "marks": [
                {"t": m.t, "kind": m.kind, "agent": m.agent, "subject": m.subject, "label": m.label}
                for m in self.marks
            ],
            "summary": None if self.summary is None else self.summary.as_dict(),
            "run": None
            if self.run is None
            else {"scenario": self.run.scenario, "mode": self.run.mode, "version": self.run.version},
        }


def _last_start(goal: GoalBar, t: float) -> float:
    return max(s.start for s in goal.suspended if s.holds(t))


def _current(running: list[GoalBar], t: float) -> GoalBar | None:
    """The goal the agent works on: the one whose plan was selected last.

    Goals received but not started (a normal goal waits behind the running one)
    have no plan yet; when no live goal has one, the earliest received is current.
    """
    best: GoalBar | None = None
    best_t = -math.inf
    for goal in running:
        chosen = [p.t for p in goal.plans if p.t <= t]
        when = chosen[-1] if chosen else -math.inf
        if best is None or when > best_t:
            best, best_t = goal, when
    return best


def _plan_at(goal: GoalBar, t: float) -> tuple[str, ...] | None:
    plan = None
    for choice in goal.plans:
        if choice.t <= t:
            plan = choice.plan
    return plan


def _on(motion: Motion, fraction: float) -> Position:
    fraction = round(fraction, _DIGITS)
    if fraction >= 1.0:
        return {"node": motion.to}
    if fraction <= 0.0:
        return {"node": motion.frm}
    return {"arc": motion.arc, "from": motion.frm, "to": motion.to, "fraction": fraction}


class _Reader:
    """Reads events one by one into the pieces of a :class:`History`."""

    def __init__(self) -> None:
        self.goals: list[GoalBar] = []
        self.depth: dict[str, list[tuple[float, int]]] = {}
        self.actions: dict[str, list[ActionSpan]] = {}
        self.motions: list[Motion] = []
        self.activities: list[Activity] = []
        self.marks: list[Mark] = []
        self.seen: list[str] = []
        self.parent: dict[str, str] = {}
        self.summary: Summary | None = None
        self.run: RunStarted | None = None
        self.now = 0.0
        self.moving: Motion | None = None
        self.planned_end = 0.0
        self.place: tuple[str, str, str, float] | None = None
        """The robot stopped part way: (arc, from, to, fraction)."""

    def read(self, event: TraceEvent) -> None:
        if not math.isfinite(event.t) or event.t < self.now - 1e-9:
            raise TraceFormatError(f"{event.event}: t: time {event.t!r} runs backwards (after {self.now})")
        self.now = event.t
        if event.agent not in _NOT_AGENTS and event.agent not in self.seen:
            self.seen.append(event.agent)
        t = round(event.t, _DIGITS)
        match event:
            case GoalReceived():
                self._received(event, t)
            case PlanSelected():
                goal = self._find(event.agent, event.goal, running=True)
                if goal is not None:
                    goal.plans.append(PlanChoice(t, event.plan, event.cost))
            case GoalSuspended():
                goal = self._find(event.agent, event.goal, running=True)
                if goal is not None and not goal.on_stack:
                    goal.suspended.append(Span(t))
                    self._depth_changed(event.agent, t)
            case GoalResumed():
                goal = self._find(event.agent, event.goal, running=False)
                if goal is not None and goal.on_stack:
                    goal.suspended[-1].end = t
                    self._depth_changed(event.agent, t)
            case GoalCleared():
                goal = self._find(event.agent, event.goal, running=False)
                if goal is not None:
                    self._ended(goal, t, "cleared", "")
            case GoalFinished():
                goal = self._finished(event)
                if goal is not None:
                    self._ended(goal, t, event.status, event.reason)
            case ActionStarted():
                self.actions.setdefault(event.agent, []).append(ActionSpan(t, event.action))
            case ActionFinished():
                for span in reversed(self.actions.get(event.agent, [])):
                    if span.end is None and span.action == event.action:
                        span.end, span.result = t, event.result
                        break
            case MessageSent() if event.agent == ROBOT:
                self._robot_answered(event, t)
            case MessageSent() if event.kind == "execute":
                self.parent.setdefault(event.to, event.agent)
            case RobotMoving():
                self._moving(event, t)
            case RobotActing():
                self._stop_motion(t)
                self.activities.append(Activity(t, round(t + event.duration, _DIGITS), event.action))
            case ArcClosed():
                self.marks.append(Mark(t, "arc_closed", event.agent, event.arc))
            case ArcOpened():
                self.marks.append(Mark(t, "arc_opened", event.agent, event.arc))
            case AgentCrashed():
                self.marks.append(Mark(t, "crash", event.agent, event.error))
            case Summary():
                self.summary = event
            case RunStarted() if self.run is None:
                self.run = event
            case _:
                pass

    # -- goals --------------------------------------------------------------------------------

    def _received(self, event: GoalReceived, t: float) -> None:
        self.goals.append(GoalBar(event.agent, event.goal, event.emergency, t, event.ticket))
        self.depth.setdefault(event.agent, [(0.0, 0)])
        if event.emergency:
            self.marks.append(Mark(t, "emergency", event.agent, event.goal))

    def _find(self, agent: str, goal: str, *, running: bool) -> GoalBar | None:
        """The latest open goal of that name: running (not stacked) or stacked."""
        for bar in reversed(self.goals):
            if bar.agent == agent and bar.goal == goal and bar.end is None and bar.on_stack != running:
                return bar
        return None

    def _finished(self, event: GoalFinished) -> GoalBar | None:
        if event.ticket is not None:
            for bar in self.goals:
                if bar.agent == event.agent and bar.ticket == event.ticket and bar.end is None:
                    return bar
        # Usually the running goal ends; a stacked one can fail (a door shut its way).
        running = self._find(event.agent, event.goal, running=True)
        return running if running is not None else self._find(event.agent, event.goal, running=False)

    def _ended(self, goal: GoalBar, t: float, status: GoalStatus, reason: str) -> None:
        goal.end, goal.status, goal.reason = t, status, reason
        if goal.on_stack:
            goal.suspended[-1].end = t
            self._depth_changed(goal.agent, t)

    def _depth_changed(self, agent: str, t: float) -> None:
        depth = sum(1 for g in self.goals if g.agent == agent and g.on_stack)
        steps = self.depth.setdefault(agent, [(0.0, 0)])
        if steps[-1][0] == t and len(steps) > 1:
            steps.pop()  # a suspension and a resumption in one instant: one step, or none
        if steps[-1][1] != depth:
            steps.append((t, depth))

    # -- the robot ------------------------------------------------------------------------------

    def _moving(self, event: RobotMoving, t: float) -> None:
        self._stop_motion(t)
        move = _move(event.action)
        if move is None or event.arc is None:
            return  # the scripted executor's moves name no arc: nothing to place
        rolling_back, frm, to, arc = move
        if rolling_back:
            f0 = self.place[3] if self.place is not None and self.place[0] == arc else 1.0
            f1 = 0.0
        else:
            f0, f1 = (event.done if event.resumed else 0.0), 1.0
        planned = round(t + event.duration, _DIGITS)
        self.moving = Motion(t, planned, event.action, arc, frm, to, round(f0, _DIGITS), f1)
        self.motions.append(self.moving)

    def _robot_answered(self, event: MessageSent, t: float) -> None:
        motion = self.moving
        if motion is None or event.kind not in ("success", "suspended", "failure"):
            return
        action = _move(event.action)
        if action is None or action[1:] != (motion.frm, motion.to, motion.arc):
            return
        if event.kind == "suspended":
            self._stop_motion(t)
        else:
            self.moving = None
            self.place = None

    def _stop_motion(self, t: float) -> None:
        """The motion under way stops at ``t`` if it has not arrived (suspended, or superseded)."""
        motion = self.moving
        if motion is None:
            return
        self.moving = None
        if t >= motion.end:
            self.place = None
            return
        fraction = round(motion.fraction_at(t), _DIGITS)
        motion.end, motion.f1 = t, fraction
        self.place = (motion.arc, motion.frm, motion.to, fraction)

    # -- the end ----------------------------------------------------------------------------------

    def history(self, agents: tuple[str, ...]) -> History:
        order = agents or self._chain()
        for name in self.seen:
            if name not in order:
                order = (*order, name)
        start = None
        if self.motions:
            first = self.motions[0]
            start = first.frm if first.f0 == 0.0 else None
        for name in order:
            self.depth.setdefault(name, [(0.0, 0)])
        return History(
            agents=order,
            goals=self.goals,
            depth={name: self.depth[name] for name in order},
            actions={name: self.actions.get(name, []) for name in order},
            motions=self.motions,
            activities=self.activities,
            marks=self.marks,
            start=start,
            end=round(self.now, _DIGITS),
            summary=self.summary,
            run=self.run,
        )

    def _chain(self) -> tuple[str, ...]:
        """Agents parent first: by how many parents order each, then by first appearance."""

        def level(name: str) -> int:
            n, seen = 0, {name}
            while name in self.parent and self.parent[name] not in seen:
                name = self.parent[name]
                seen.add(name)
                n += 1
            return n

        agents = [a for a in self.seen if a not in _NOT_AGENTS]
        return tuple(sorted(agents, key=lambda a: (level(a), self.seen.index(a))))


def _move(action: str) -> tuple[bool, str, str, str] | None:
    """``move(From,To,Arc)`` or ``rollback(move(...))`` read: (rolling back, from, to, arc)."""
    try:
        atom = parse(action)
    except TextFormError:
        return None
    rolling_back = atom.name == "rollback" and len(atom.args) == 1 and isinstance(atom.args[0], Atom)
    if rolling_back:
        inner = atom.args[0]
        assert isinstance(inner, Atom)
        atom = inner
    if atom.name != "move" or len(atom.args) != 3 or not all(isinstance(a, str) for a in atom.args):
        return None
    frm, to, arc = (str(a) for a in atom.args)
    return rolling_back, frm, to, arc
