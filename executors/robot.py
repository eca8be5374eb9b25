"""The simulated museum robot: travels arcs at its speed, in simulated time.

It serves ``move(From,To,Arc)`` and, for a suspended move, ``resume(...)`` and
``rollback(...)``. A move can be suspended half way: the robot stops on the
arc, keeps what it needs to resume (or roll back) until told to clear it. A
move over a closed arc fails, and so does a move when the robot is not where
the move starts; with a ``failure_rate`` a move also fails at random (seeded).

A guide robot also talks: ``durations`` names its other actions (``explain``,
``answer``, ``greet``, ...) with the simulated seconds each takes, wherever the
robot stands. Such an action can be suspended half way too; ``resume`` then
takes only the time left, and ``clear`` forgets it. Any other action fails.
Moves are traced as ``robot_moving``, the other actions as ``robot_acting``,
each with ``action`` (a resumed move or action is named by the action itself, a
rollback as ``rollback(...)``), for a move the ``arc`` it travels, ``duration``
(seconds of this part), ``done`` (the fraction of the action already done
before this part started) and ``resumed`` (this part finishes a suspended
action). Any of them can be suspended half way — a fresh move or action, a
resumed rest, a rollback — and the robot stops where it is. It reports the same
motions as progress reports (what triggers follow).  It is an
:class:`~htnagent.runtime.executor.Executor` like any user's: its time is its
context's clock.
"""

from __future__ import annotations

import random
from collections.abc import Mapping
from dataclasses import dataclass, field

from htnagent.domains.maps import WorldMap
from htnagent.model.actions import action_rolled_back_by
from htnagent.model.terms import Atom
from htnagent.runtime.events import RobotActing, RobotMoving
from htnagent.runtime.executor import ActionFailed, ActionOutcome, Alarm, Executor
from htnagent.runtime.progress import Phase


@dataclass
class Motion:
    """The robot is travelling ``arc`` from fraction ``start`` to ``end`` (0 = ``frm``, 1 = ``to``)."""

    action: Atom
    """The action in the plan (a resumed move is the move; a rollback, ``rollback(...)``)."""
    arc: str
    frm: str
    to: str
    start: float
    end: float
    started_at: float
    duration: float
    alarm: Alarm

    def fraction_at(self, now: float) -> float:
        if self.duration <= 0:
            return self.end
        done = min(max((now - self.started_at) / self.duration, 0.0), 1.0)
        return self.start + (self.end - self.start) * done


@dataclass
class Activity:
    """The robot is doing a timed non-move ``action``, from fraction ``start`` to the end."""

    action: Atom
    start: float
    started_at: float
    duration: float  # seconds for the part from ``start`` to the end
    alarm: Alarm

    def fraction_at(self, now: float) -> float:
        if self.duration <= 0:
            return 1.0
        done = min(max((now - self.started_at) / self.duration, 0.0), 1.0)
        return self.start + (1.0 - self.start) * done


@dataclass
class RobotWorld:
    """The physical truth the simulation keeps: where the robot is, what is shut."""

    world: WorldMap
    at: str | None
    on_arc: tuple[str, str, str, float] | None = None  # (arc, from, to, fraction from 'from')
    closed: set[str] = field(default_factory=set)
    visited: list[str] = field(default_factory=list)
    """The nodes reached, in order — kept only with ``keep_path`` (a run's summary asks
    for it); a long-lived robot keeps just the count, :attr:`arrivals`."""
    keep_path: bool = False
    arrivals: int = 0
    distance: float = 0.0

    def where(self) -> dict[str, str]:
        """``{"at": node}`` or ``{"on": arc}`` (the summary's ``robot``)."""
        if self.on_arc is not None:
            return {"on": self.on_arc[0]}
        return {"at": self.at or ""}


class Robot(Executor):
    """The simulated robot, the executor at the bottom of the agent chain."""

    def __init__(
        self,
        world: RobotWorld,
        speed: float,
        failure_rate: float = 0.0,
        seed: int = 0,
        durations: Mapping[str, float] | None = None,
        *,
        name: str = "robot",
    ) -> None:
        self.name = name
        self.state = world
        self.speed = speed
        self.failure_rate = failure_rate
        self._rng = random.Random(seed)
        self.motion: Motion | None = None
        self.durations = dict(durations or {})
        self.activity: Activity | None = None
        self.kept: dict[Atom, float] = {}  # suspended activities: the fraction already done
        if world.keep_path and world.at is not None and not world.visited:
            world.visited.append(world.at)

    def travelled(self) -> float:
        """Metres travelled so far, including the part of an arc it is on now."""
        motion = self.motion
        if motion is None:
            return self.state.distance
        done = abs(motion.fraction_at(self.context.now()) - motion.start)
        return self.state.distance + done * self._length(motion.arc)

    # -- orders --------------------------------------------------------------------

    async def execute(self, action: Atom) -> ActionOutcome:
        inner = action_rolled_back_by(action)
        if inner is not None:
            frm, to, arc, fraction = self._half(inner, "roll back")
            return await self._travel(self._start(action, arc, frm, to, fraction, 0.0, resumed=False))
        if action.name != "move" and action.name in self.durations:
            return await self._act(self._begin_act(action, 0.0, resumed=False))
        if action.name != "move" or len(action.args) != 3:
            raise ActionFailed(f"the robot cannot do {action}")
        frm, to, arc = (str(a) for a in action.args)
        problem = self._check_move(frm, to, arc)
        if problem:
            raise ActionFailed(problem)
        if self.failure_rate and self._rng.random() < self.failure_rate:
            raise ActionFailed("the move failed (simulated fault)")
        return await self._travel(self._start(action, arc, frm, to, 0.0, 1.0, resumed=False))

    def _check_move(self, frm: str, to: str, arc: str) -> str | None:
        world = self.state.world
        if self.motion is not None:
            return "the robot is already moving"
        if self.activity is not None:
            return f"the robot is busy with {self.activity.action}"
        if self.state.on_arc is not None:
            return f"the robot is on {self.state.on_arc[0]}, not at {frm}"
        if self.state.at != frm:
            return f"the robot is at {self.state.at}, not at {frm}"
        known = world.arcs.get(arc)
        if known is None or {known.a, known.b} != {frm, to}:
            return f"{arc} does not join {frm} and {to}"
        if arc in self.state.closed:
            return f"{arc} is closed"
        return None

    async def resume(self, action: Atom) -> ActionOutcome:
        if action in self.kept:
            activity = self._begin_act(action, self.kept[action], resumed=True)
            del self.kept[action]
            return await self._act(activity)
        frm, to, arc, fraction = self._half(action, "resume")
        if arc in self.state.closed:
            raise ActionFailed(f"{arc} is closed")
        return await self._travel(self._start(action, arc, frm, to, fraction, 1.0, resumed=True))

    def _half(self, action: Atom, what: str) -> tuple[str, str, str, float]:
        """The half-done move ``action`` the robot stands on: ``(from, to, arc, fraction)``."""
        half = None
        if self.motion is None and self.activity is None and self.state.on_arc is not None:
            arc, frm, to, fraction = self.state.on_arc
            if action.name == "move" and tuple(str(a) for a in action.args) == (frm, to, arc):
                half = frm, to, arc, fraction
        if half is None:
            raise ActionFailed(f"nothing to {what} for {action}")
        return half

    def can_suspend(self, action: Atom) -> bool:
        # Any running move or action stops half way: a fresh one, the rest of a resumed one
        # (named by the action itself), or a rollback (docs/design.md §4).
        running = self.activity or self.motion
        return running is not None and running.action == action and not running.alarm.rang

    async def suspend(self, action: Atom) -> None:
        now = self.context.now()
        activity = self.activity
        if activity is not None:
            activity.alarm.stop()
            self.activity = None
            self.kept[activity.action] = activity.fraction_at(now)
        else:
            motion = self.motion
            assert motion is not None  # can_suspend said so
            fraction = motion.fraction_at(now)
            motion.alarm.stop()
            self.state.distance += abs(fraction - motion.start) * self._length(motion.arc)
            self.motion = None
            self.state.on_arc = (motion.arc, motion.frm, motion.to, fraction)
            self.state.at = None
        self.context.report_progress(action, Phase.STOPPED)

    async def clear(self, action: Atom) -> None:
        # Forget the resume context; where the robot physically is does not change.
        self.kept.pop(action, None)

    # -- timed actions other than moves ------------------------------------------------

    def _begin_act(self, action: Atom, done: float, *, resumed: bool) -> Activity:
        """Start the timed action (its part after ``done``); a failure if the robot is busy."""
        busy = self.motion.action if self.motion is not None else None
        busy = self.activity.action if self.activity is not None else busy
        if busy is not None:
            raise ActionFailed(f"the robot is busy with {busy}")
        context = self.context
        duration = (1.0 - done) * self.durations[action.name]
        activity = Activity(action, done, context.now(), duration, context.alarm(duration))
        self.activity = activity
        context.report_progress(action, Phase.STARTED, duration, done)
        context.emit(
            RobotActing(
                agent=self.name,
                action=str(action),
                duration=round(duration, 6),
                done=round(done, 6),
                resumed=resumed,
            )
        )
        return activity

    async def _act(self, activity: Activity) -> ActionOutcome:
        if not await activity.alarm.wait():
            return ActionOutcome.SUSPENDED
        self.activity = None
        return ActionOutcome.SUCCESS

    # -- motion ----------------------------------------------------------------------

    def _length(self, arc: str) -> float:
        return self.state.world.arcs[arc].length

    def _start(
        self, action: Atom, arc: str, frm: str, to: str, start: float, end: float, *, resumed: bool
    ) -> Motion:
        context = self.context
        duration = abs(end - start) * self._length(arc) / self.speed
        motion = Motion(action, arc, frm, to, start, end, context.now(), duration, context.alarm(duration))
        self.motion = motion
        self.state.on_arc = (arc, frm, to, start)
        self.state.at = None
        # A resumed move has already covered ``start``; a rollback is a motion of its own.
        done = start if resumed else 0.0
        context.report_progress(action, Phase.STARTED, duration, done)
        context.emit(
            RobotMoving(
                agent=self.name,
                action=str(action),
                arc=arc,
                duration=round(duration, 6),
                done=round(done, 6),
                resumed=resumed,
            )
        )
        return motion

    async def _travel(self, motion: Motion) -> ActionOutcome:
        if not await motion.alarm.wait():
            return ActionOutcome.SUSPENDED  # suspend has left the robot on the arc
        self.motion = None
        self.state.distance += abs(motion.end - motion.start) * self._length(motion.arc)
        node = motion.to if motion.end >= 1.0 else motion.frm
        self.state.on_arc = None
        self.state.at = node
        self.state.arrivals += 1
        if self.state.keep_path:
            self.state.visited.append(node)
        return ActionOutcome.SUCCESS
