"""The simulated robot of an HDDL agent: it carries out any action of the domain on a world of facts.

The world (:class:`FactWorld`) is the simulation's own copy of the facts, apart
from every agent's belief: it starts as the problem's ``:init`` (with the
translation's static type and equality facts) and changes only by the actions
the robot carries out and the scenario's events (docs/design.md §7.1).

An action takes ``durations[name]`` simulated seconds (else ``default_duration``, 1 s).  Its
precondition is checked against the world when it starts and again when it
ends, and its effects are applied when it ends; a false precondition is a
failure, reported with the literal at fault.  The translation's marker
``__done()`` succeeds at once and changes nothing.

A running action can be suspended half way: it has then had only the effects
its start has (none, unless the scenario's started-effects file gives some), and
the robot keeps the fraction done.  ``resume(A)`` does the rest (its time left)
as the translation's ``resume`` operator says: A's effects, what A needs checked
anew.  ``rollback(A)`` undoes A's start at once; a ``clear`` forgets the half
done -- unless its start changed the world, which then waits for a later
``resume`` or ``rollback``.  With a ``failure_rate``, a fresh action
also fails at random (seeded), as the museum robot's moves do.  Activities are traced as
``robot_acting`` and reported to the progress listeners (what triggers follow),
as the museum robot's timed actions are (:mod:`htnagent.executors.robot`).
"""

from __future__ import annotations

import random
from collections.abc import Iterable, Mapping
from dataclasses import dataclass

from htnagent.model.actions import action_rolled_back_by, resume_action, rollback_action
from htnagent.model.domain import Domain
from htnagent.model.preconditions import satisfiers
from htnagent.model.state import State
from htnagent.model.terms import Atom, substitute, unify
from htnagent.runtime.events import RobotActing
from htnagent.runtime.executor import ActionFailed, ActionOutcome, Alarm, Executor
from htnagent.runtime.progress import Phase

HIDDEN = "__"
"""The prefix of the translation's own predicates and actions (not facts of the HDDL world)."""


class FactWorld:
    """The simulated world's facts, and the actions and events that change them.

    ``domain`` is the HDDL translation's planning domain: what an action requires
    and does is read from its operators, matched against these facts (never against
    a belief).
    """

    def __init__(self, domain: Domain, state: State) -> None:
        self.domain = domain
        self.state = state

    def facts(self) -> frozenset[Atom]:
        """The facts of the HDDL world: the translation's static helper facts left out."""
        return frozenset(f for f in self.state.facts() if not f.name.startswith(HIDDEN))

    def why_not(self, action: Atom) -> str | None:
        """Why ``action`` cannot run in the world now (None: it can)."""
        if self._applied(action) is not None:
            return None
        for op in self.domain.operators.get(action.name, ()):
            b = unify(op.head, action, {})
            if b is None:
                continue
            # The first literal of the (first) operator that fails, as a reason to read.
            for n in range(1, len(op.pre) + 1):
                if next(satisfiers(op.pre[:n], self.state, b), None) is None:
                    lit = op.pre[n - 1]
                    shown = f"{'' if lit.positive else 'not '}{substitute(lit.atom, b)}"
                    return f"the precondition of {action} is false in the world: {shown}"
            break
        return f"the robot cannot do {action}"

    def carry_out(self, action: Atom) -> bool:
        """Apply the action's effects if its precondition holds; whether it did."""
        after = self._applied(action)
        if after is None:
            return False
        self.state = after
        return True

    def suspend(self, action: Atom) -> None:
        """The running action was stopped half way: what its start changed stays (§7.1)."""
        self.state = self.domain.suspend(self.state, action)

    def clear(self, action: Atom) -> bool:
        """The suspended action will never be resumed; whether it is gone from the world
        (False: its start changed the world, so it can still be resumed or rolled back)."""
        self.state = self.domain.clear(self.state, action)
        return self._applied(rollback_action(action)) is None

    def change(self, add: Iterable[Atom], delete: Iterable[Atom]) -> None:
        """A scenario event: facts deleted, then added."""
        self.state = self.state.updated(add, delete)

    def _applied(self, action: Atom) -> State | None:
        found = self.domain.actions.running_way(self.state, action)
        if found is None:
            return None
        op, full = found
        return self.state.with_dynamic(op.effects_on(self.state.dynamic, full))


@dataclass
class _Running:
    action: Atom
    step: Atom  # what is done in the world at the end: the action, or resume(action)
    fresh: bool  # a fresh action (not the rest of a resumed one)
    start: float  # the fraction done before this part
    started_at: float
    duration: float  # seconds for the part from ``start`` to the end
    alarm: Alarm

    def fraction_at(self, now: float) -> float:
        if self.duration <= 0:
            return 1.0
        done = min(max((now - self.started_at) / self.duration, 0.0), 1.0)
        return self.start + (1.0 - self.start) * done


class HddlRobot(Executor):
    """The simulated robot at the bottom of an HDDL agent's chain (see the module's docstring)."""

    def __init__(
        self,
        world: FactWorld,
        durations: Mapping[str, float] | None = None,
        markers: Iterable[str] = (),
        default_duration: float = 1.0,
        failure_rate: float = 0.0,
        seed: int = 0,
        *,
        name: str = "robot",
    ) -> None:
        self.name = name
        self.world = world
        self.durations = dict(durations or {})
        self.markers = frozenset(markers)
        self.default_duration = default_duration
        self.failure_rate = failure_rate
        self._rng = random.Random(seed)
        self.running: _Running | None = None
        self.kept: dict[Atom, float] = {}  # suspended actions: the fraction already done

    def duration(self, action: Atom) -> float:
        """The simulated seconds the whole action takes."""
        return self.durations.get(action.name, self.default_duration)

    # -- orders ------------------------------------------------------------------------

    async def execute(self, action: Atom) -> ActionOutcome:
        inner = action_rolled_back_by(action)
        if inner is not None:
            # Rolling back undoes what the action's start changed (if anything), at once.
            if inner not in self.kept:
                raise ActionFailed(f"nothing to roll back for {inner}")
            if not self.world.carry_out(action):
                raise ActionFailed(self.world.why_not(action) or f"the robot cannot do {action}")
            del self.kept[inner]
            return ActionOutcome.SUCCESS
        if action.name in self.markers:
            return ActionOutcome.SUCCESS  # the translation's no-op
        if self.failure_rate and self._rng.random() < self.failure_rate:
            raise ActionFailed(f"{action} failed (simulated fault)")
        return await self._run(self._start(action, 0.0, action, fresh=True))

    async def resume(self, action: Atom) -> ActionOutcome:
        done = self.kept.get(action)
        if done is None:
            raise ActionFailed(f"nothing to resume for {action}")
        # What is done stays kept until the resume succeeds: a resume that fails leaves
        # the action half done, to be rolled back or resumed again.
        outcome = await self._run(self._start(action, done, resume_action(action), fresh=False))
        if outcome is ActionOutcome.SUCCESS:
            del self.kept[action]
        return outcome

    def _start(self, action: Atom, done: float, step: Atom, *, fresh: bool) -> _Running:
        """Start (the rest of) the action; a failure if it cannot.

        ``step`` is what happens in the world at the end.
        """
        if self.running is not None:
            raise ActionFailed(f"the robot is busy with {self.running.action}")
        why = self.world.why_not(step)
        if why is not None:
            raise ActionFailed(why)
        context = self.context
        duration = (1.0 - done) * self.duration(action)
        running = _Running(action, step, fresh, done, context.now(), duration, context.alarm(duration))
        self.running = running
        context.report_progress(action, Phase.STARTED, duration, done)
        context.emit(
            RobotActing(
                agent=self.name,
                action=str(action),
                duration=round(duration, 6),
                done=round(done, 6),
                resumed=not fresh,
            )
        )
        return running

    async def _run(self, running: _Running) -> ActionOutcome:
        if not await running.alarm.wait():
            return ActionOutcome.SUSPENDED
        self.running = None
        # The world may have changed while the action ran (an event): checked again.
        why = self.world.why_not(running.step)
        if why is not None or not self.world.carry_out(running.step):
            raise ActionFailed(why or f"the precondition of {running.step} does not hold in the world")
        return ActionOutcome.SUCCESS

    def can_suspend(self, action: Atom) -> bool:
        running = self.running
        return running is not None and running.action == action and not running.alarm.rang

    async def suspend(self, action: Atom) -> None:
        running = self.running
        assert running is not None  # can_suspend said so
        # Stopped half way, the action has had only what its start does (docs/design.md §7.1);
        # a resume stopped again leaves the world as the first stop did.
        running.alarm.stop()
        self.running = None
        if running.fresh:
            self.world.suspend(running.action)
        self.kept[running.action] = running.fraction_at(self.context.now())
        self.context.report_progress(action, Phase.STOPPED)

    async def clear(self, action: Atom) -> None:
        # What the action's start changed stays in the world, and with it what is done.
        if self.world.clear(action):
            self.kept.pop(action, None)


__all__ = ["FactWorld", "HddlRobot"]
