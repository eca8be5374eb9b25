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
motions to its :attr:`~htnagent.runtime.executor.ExecutorActor.progress` listeners
(what triggers follow).
"""

from __future__ import annotations

import functools
import random
from collections.abc import Mapping
from dataclasses import dataclass, field

import anyio
from anyio.abc import TaskStatus

from htnagent.domains.maps import WorldMap
from htnagent.model.actions import action_rolled_back_by
from htnagent.model.terms import Atom
from htnagent.runtime.clock import Clock, TimerHandle
from htnagent.runtime.events import RobotActing, RobotMoving
from htnagent.runtime.executor import ExecutorActor
from htnagent.runtime.messages import (
    Clear,
    Elapsed,
    Execute,
    Failure,
    Refused,
    Resume,
    Success,
    Suspend,
    Suspended,
)
from htnagent.runtime.progress import Phase, Progress
from htnagent.runtime.trace import Trace


@dataclass
class Motion:
    """The robot is travelling ``arc`` from fraction ``start`` to ``end`` (0 = ``frm``, 1 = ``to``)."""

    order: Execute | Resume
    arc: str
    frm: str
    to: str
    start: float
    end: float
    started_at: float
    duration: float
    timer: TimerHandle

    def fraction_at(self, now: float) -> float:
        if self.duration <= 0:
            return self.end
        done = min(max((now - self.started_at) / self.duration, 0.0), 1.0)
        return self.start + (self.end - self.start) * done


@dataclass
class Activity:
    """The robot is doing a timed non-move ``action``, from fraction ``start`` to the end."""

    order: Execute | Resume
    action: Atom
    start: float
    started_at: float
    duration: float  # seconds for the part from ``start`` to the end
    timer: TimerHandle

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


class Robot(ExecutorActor):
    """The simulated robot, an executor actor at the bottom of the agent chain."""

    def travelled(self) -> float:
        """Metres travelled so far, including the part of an arc it is on now."""
        motion = self.motion
        if motion is None:
            return self.state.distance
        done = abs(motion.fraction_at(self.clock.now()) - motion.start)
        return self.state.distance + done * self._length(motion.arc)

    def __init__(
        self,
        name: str,
        clock: Clock,
        trace: Trace,
        world: RobotWorld,
        speed: float,
        failure_rate: float = 0.0,
        seed: int = 0,
        durations: Mapping[str, float] | None = None,
    ) -> None:
        super().__init__(name, clock, trace)
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

    async def run(self, *, task_status: TaskStatus[None] = anyio.TASK_STATUS_IGNORED) -> None:
        task_status.started()
        while True:
            message = await self.inbox.receive()
            if isinstance(message, Elapsed):
                if self.activity is not None and self.activity.order.seq == message.seq:
                    self._done(self.activity)
                elif self.motion is not None and self.motion.order.seq == message.seq:
                    self._arrive(self.motion)
                # else: a stale timer of a suspended motion or activity
            elif isinstance(message, Execute):
                self._execute(message)
            elif isinstance(message, Resume):
                self._resume(message)
            elif isinstance(message, Suspend):
                self._suspend(message)
            elif isinstance(message, Clear):
                self._clear(message)

    # -- orders --------------------------------------------------------------------

    def _execute(self, order: Execute) -> None:
        action = order.action
        inner = action_rolled_back_by(action)
        if inner is not None:
            self._rollback(order, inner)
            return
        if action.name != "move" and action.name in self.durations:
            self._act(order, action)
            return
        if action.name != "move" or len(action.args) != 3:
            self._fail(order, f"the robot cannot do {action}")
            return
        frm, to, arc = (str(a) for a in action.args)
        problem = self._check_move(frm, to, arc)
        if problem:
            self._fail(order, problem)
            return
        if self.failure_rate and self._rng.random() < self.failure_rate:
            self._fail(order, "the move failed (simulated fault)")
            return
        self._start(order, arc, frm, to, 0.0, 1.0)

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

    def _resume(self, order: Resume) -> None:
        if order.action in self.kept:
            if self._act(order, order.action, self.kept[order.action]):
                del self.kept[order.action]
            return
        half = self._half(order.action)
        if half is None:
            self._fail(order, f"nothing to resume for {order.action}")
            return
        arc, frm, to, fraction = half
        if arc in self.state.closed:
            self._fail(order, f"{arc} is closed")
            return
        self._start(order, arc, frm, to, fraction, 1.0)

    def _rollback(self, order: Execute, inner: Atom) -> None:
        half = self._half(inner)
        if half is None:
            self._fail(order, f"nothing to roll back for {inner}")
            return
        arc, frm, to, fraction = half
        self._start(order, arc, frm, to, fraction, 0.0)

    def _half(self, action: Atom) -> tuple[str, str, str, float] | None:
        if self.motion is not None or self.activity is not None or self.state.on_arc is None:
            return None
        arc, frm, to, fraction = self.state.on_arc
        if action.name != "move" or tuple(str(a) for a in action.args) != (frm, to, arc):
            return None
        return arc, frm, to, fraction

    def _suspend(self, order: Suspend) -> None:
        if self.activity is not None:
            self._suspend_activity(order, self.activity)
            return
        motion = self.motion
        # A move stops half way wherever it is: a fresh one, the rest of a resumed one
        # (a Resume order, whose action is the move), or a rollback (docs/design.md §4).
        if motion is None or motion.order.seq != order.seq or motion.order.action != order.action:
            self.reply(Refused(action=order.action, seq=order.seq))
            return
        now = self.clock.now()
        fraction = motion.fraction_at(now)
        motion.timer.cancel()
        self.state.distance += abs(fraction - motion.start) * self._length(motion.arc)
        self.motion = None
        self.state.on_arc = (motion.arc, motion.frm, motion.to, fraction)
        self.state.at = None
        self.progress.report(Progress(self.name, order.action, Phase.STOPPED))
        self.reply(Suspended(action=order.action, seq=motion.order.seq))

    def _clear(self, order: Clear) -> None:
        # Forget the resume context; where the robot physically is does not change.
        self.kept.pop(order.action, None)

    # -- timed actions other than moves ------------------------------------------------

    def _act(self, order: Execute | Resume, action: Atom, done: float = 0.0) -> bool:
        """Start the timed action (its part after ``done``); False if the robot is busy."""
        busy = self.motion.order.action if self.motion is not None else None
        busy = self.activity.action if self.activity is not None else busy
        if busy is not None:
            self._fail(order, f"the robot is busy with {busy}")
            return False
        duration = (1.0 - done) * self.durations[action.name]
        now = self.clock.now()
        timer = self.clock.call_at(now + duration, functools.partial(self._timer_done, order.seq))
        activity = Activity(order, action, done, now, duration, timer)
        self.activity = activity
        self.progress.report(Progress(self.name, action, Phase.STARTED, duration, done))
        self.trace.emit(
            RobotActing(
                agent=self.name,
                action=str(action),
                duration=round(duration, 6),
                done=round(done, 6),
                resumed=isinstance(order, Resume),
            )
        )
        return True

    def _suspend_activity(self, order: Suspend, activity: Activity) -> None:
        # As for moves, a fresh action or a resumed rest stops half way.
        if activity.action != order.action or activity.order.seq != order.seq:
            self.reply(Refused(action=order.action, seq=order.seq))
            return
        activity.timer.cancel()
        self.activity = None
        self.kept[activity.action] = activity.fraction_at(self.clock.now())
        self.progress.report(Progress(self.name, order.action, Phase.STOPPED))
        self.reply(Suspended(action=order.action, seq=activity.order.seq))

    def _timer_done(self, seq: int) -> None:
        # The timer names the order, not the motion: a timer holding the motion that
        # holds the timer would be a reference cycle, garbage only the collector frees.
        self.inbox.send(Elapsed(seq=seq))

    def _done(self, activity: Activity) -> None:
        if self.activity is not activity:
            return  # a stale timer of a suspended activity
        self.activity = None
        self.reply(Success(action=activity.order.action, seq=activity.order.seq))

    # -- motion ----------------------------------------------------------------------

    def _length(self, arc: str) -> float:
        return self.state.world.arcs[arc].length

    def _start(self, order: Execute | Resume, arc: str, frm: str, to: str, start: float, end: float) -> None:
        duration = abs(end - start) * self._length(arc) / self.speed
        now = self.clock.now()
        timer = self.clock.call_at(now + duration, functools.partial(self._timer_done, order.seq))
        motion = Motion(order, arc, frm, to, start, end, now, duration, timer)
        self.motion = motion
        self.state.on_arc = (arc, frm, to, start)
        self.state.at = None
        # A resumed move has already covered ``start``; a rollback is a motion of its own.
        resumed = isinstance(order, Resume)
        done = start if resumed else 0.0
        self.progress.report(Progress(self.name, order.action, Phase.STARTED, duration, done))
        self.trace.emit(
            RobotMoving(
                agent=self.name,
                action=str(order.action),
                arc=arc,
                duration=round(duration, 6),
                done=round(done, 6),
                resumed=resumed,
            )
        )

    def _arrive(self, motion: Motion) -> None:
        if self.motion is not motion:
            return  # a stale timer of a suspended motion
        self.motion = None
        self.state.distance += abs(motion.end - motion.start) * self._length(motion.arc)
        node = motion.to if motion.end >= 1.0 else motion.frm
        self.state.on_arc = None
        self.state.at = node
        self.state.arrivals += 1
        if self.state.keep_path:
            self.state.visited.append(node)
        self.reply(Success(action=motion.order.action, seq=motion.order.seq))

    def _fail(self, order: Execute | Resume, reason: str) -> None:
        self.reply(Failure(action=order.action, seq=order.seq, reason=reason))
