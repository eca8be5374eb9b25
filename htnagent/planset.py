"""Keeping a goal's alternative plans valid while the agent acts (docs/design.md §2–§3).

A plan set holds the alternative plans of one goal — the active goal or one
waiting on the suspension stack — and updates them after every event.  There
are two kinds, one per :class:`Replanning` mode, both :class:`PlanSet`:
``PlanSet(domain, goal, mode)`` makes the one the mode names.

- :class:`OnlinePlanSet` (Dynagent style) keeps up to K plans and modifies them
  instead of planning again:

  - :meth:`~PlanSet.action_succeeded` (§2.1), :meth:`~PlanSet.action_failed`
    (§2.2), :meth:`~PlanSet.action_suspended` (§3, the published Algorithm 1),
    :meth:`~PlanSet.belief_changed` (§2.3), :meth:`~PlanSet.suspension_cleared`
    (a suspended action will not be resumed);
  - each of them re-checks every plan by progressing the belief through it, and
    a :class:`~htnagent.repair.Repairer` repairs a broken plan by re-decomposing
    only the lowest compound task above the failing action that can be
    decomposed again (§2.4, :mod:`htnagent.repair`); plans known to be valid
    (they ran the action that just succeeded, or sit behind an undo that
    provably restores the belief) are flagged so and not walked again;
  - plans removed because a fact was false wait in a
    :class:`~htnagent.revival.Revival` store, indexed by that fact, and come
    back when it becomes true again (§2.5, :mod:`htnagent.revival`);
  - while the goal waits on the stack (``lazy``) its plans follow every event's
    rewrite (§2.1's undo in front, Algorithm 1's resume and rollback) but are
    re-checked only once, when the goal is about to run again;
  - the tidy-up rules run after every update (§2.6);
  - :meth:`~PlanSet.shorten_detours`, at resumption, offers a shorter way than a
    plan's leading undo steps.

- :class:`NaivePlanSet`, kept for comparison, keeps only the plan being
  executed: suspension or failure drops it, and whenever a plan is needed again
  it is made from scratch (§2, last paragraph).

Both plan from scratch when nothing is left (:meth:`~PlanSet.ensure`, §2.7) and
keep an emptied plan only if the goal is achieved now
(:meth:`~PlanSet.confirm_achieved`, §2.8).

Pure and synchronous: the agent runtime calls it; no event loop inside.
"""

from __future__ import annotations

import operator
import time
from collections.abc import Callable, Iterable
from dataclasses import dataclass, replace
from enum import Enum
from typing import ClassVar, NamedTuple

from htnagent.errors import SettingsError
from htnagent.model.actions import RESUME, half_done, resume_action
from htnagent.model.domain import Domain
from htnagent.model.plans import Done, Plan, Step, replay, span, tidy
from htnagent.model.state import State
from htnagent.model.terms import Atom
from htnagent.planning.planner import (
    PlannerSettings,
    PlanResult,
    PlanStatus,
    TaskEntry,
    achieved_by_nothing,
    heuristic,
    plan,
)
from htnagent.repair import LOCAL_BUDGET, Repairer, SearchMemo, one_plan
from htnagent.revival import Revival


class Replanning(Enum):
    """How an agent keeps its plans."""

    ONLINE = "online"
    """Keep every alternative plan and modify it incrementally (Dynagent style)."""
    NAIVE = "naive"
    """Drop kept plans and plan from scratch whenever a plan is needed again."""


@dataclass(slots=True)
class PlanningStats:
    """Counters and wall-clock time of one agent's planning and plan maintenance."""

    rechecks: int = 0
    repairs: int = 0
    failed_repairs: int = 0
    revivals: int = 0
    from_scratch: int = 0
    shortcuts: int = 0
    fresher: int = 0
    removed: int = 0
    expansions: int = 0
    seconds: float = 0.0

    def as_dict(self) -> dict[str, float]:
        """The figures, for traces and benchmarks."""
        return {
            "rechecks": self.rechecks,
            "repairs": self.repairs,
            "failed_repairs": self.failed_repairs,
            "revivals": self.revivals,
            "from_scratch": self.from_scratch,
            "shortcuts": self.shortcuts,
            "fresher": self.fresher,
            "removed": self.removed,
            "expansions": self.expansions,
            "ms": round(self.seconds * 1000, 3),
        }


# -- the plan set: what both modes share -------------------------------------------------------


class PlanSet:
    """The alternative plans of one goal, cheapest first, kept valid from the belief.

    ``PlanSet(domain, goal, mode, settings, stats)`` makes an
    :class:`OnlinePlanSet` or a :class:`NaivePlanSet` as ``mode`` (a
    :class:`Replanning`, on-line by default) says — as ``pathlib.Path`` makes a
    ``PosixPath`` — so callers choose the mode with a value, not a class.  This
    class holds what both share; the updates on events are each subclass's own.
    ``plans`` is the list of kept plans, cheapest first.
    """

    mode: ClassVar[Replanning]
    """The replanning mode this class implements."""

    def __new__(
        cls, domain: Domain, goal: Atom, mode: Replanning | None = None, *args: object, **kwargs: object
    ) -> PlanSet:
        kind = _KINDS[mode or Replanning.ONLINE] if cls is PlanSet else cls
        return object.__new__(kind)

    def __init__(
        self,
        domain: Domain,
        goal: Atom,
        mode: Replanning | None = None,
        settings: PlannerSettings | None = None,
        stats: PlanningStats | None = None,
    ) -> None:
        if mode is not None and mode is not self.mode:
            raise SettingsError(f"{type(self).__name__} keeps plans {self.mode.value}, not {mode.value}")
        self.domain = domain
        self.goal = goal
        self.settings = settings if settings is not None else PlannerSettings()
        self.stats = stats if stats is not None else PlanningStats()
        self.plans: list[Plan] = []
        self.last_status: PlanStatus | None = None
        """How the last search from scratch ended."""
        self.avoid: tuple[tuple[object, ...], frozenset[Atom]] | None = None
        """Actions the executor has said it cannot do from one belief (a child agent found
        no plan for them): no plan starts with them from that belief."""
        self.lazy = False
        """Set while the goal waits on the stack: its plans follow each event's rewrite of
        them (§2.1, §3) but are not re-checked or repaired then; they are re-checked (and
        repaired, §2.4) once, when the goal is about to run again (prepared or resumed) —
        one walk then (and a repair if it needs one), instead of one per event."""
        self.done: Done | None = None
        """The goal's own steps carried out so far, newest first (repair reads them)."""
        self._checked: State | None = None  # every kept plan is valid from this belief
        self._stale = False  # rewritten unchecked while lazy ...
        self._stale_since: State | None = None  # ... since the last check, from this belief
        self._unsolvable: tuple[object, ...] | None = None  # a belief the goal was found impossible from
        self._fresh_due = False  # the world changed from outside so that a cheaper way may be open

    def __repr__(self) -> str:
        return f"{type(self).__name__}({self.goal}, {len(self.plans)} plans)"

    # -- queries --------------------------------------------------------------

    @property
    def best(self) -> Plan | None:
        """The cheapest kept plan, if any."""
        return self.plans[0] if self.plans else None

    @property
    def finished(self) -> bool:
        """Whether some kept plan has nothing left to do: the goal is achieved."""
        return not all(map(_STEPS, self.plans))  # no generator: asked before every action

    def __len__(self) -> int:
        return len(self.plans)

    def fork(self) -> PlanSet:
        """A copy to update speculatively (the plans themselves are immutable values).

        The copy shares the settings and the statistics.
        """
        forked = object.__new__(type(self))
        forked.__dict__.update(self.__dict__)
        forked.plans = list(self.plans)
        return forked

    def adopt(self, other: PlanSet) -> PlanSet:
        """Take over the state of a fork (a speculation that came true).

        Returns this plan set as it was (sharing its parts), for the caller to let go of
        when it suits: dropping plans kept for long frees every step and record only
        they held, which is not nothing on a large map.
        """
        replaced = object.__new__(type(self))
        replaced.__dict__.update(self.__dict__)
        self.plans = other.plans
        self.done = other.done
        self.last_status = other.last_status
        self._checked = other._checked
        self._unsolvable = other._unsolvable
        self._stale = other._stale
        self._stale_since = other._stale_since
        self._fresh_due = other._fresh_due
        return replaced

    def rebase(self, state: State) -> None:
        """The kept plans were checked from a belief equal to ``state`` (made ahead, for a
        prediction that came true): take ``state`` as that belief, so that the next
        update knows them valid without walking them again."""
        if self._checked is not None and self._checked is not state and self._checked.key() == state.key():
            self._checked = state

    # -- making plans ---------------------------------------------------------

    def make(self, state: State) -> PlanResult:
        """Plan the goal from scratch, replacing whatever was kept."""
        with self._timed():
            return self._from_scratch(state)

    def ensure(self, state: State) -> bool:
        """Make sure there is a plan; plan from scratch if none is kept (§2.7).

        Plans left unchecked while the goal waited (``lazy``) are re-checked and
        repaired from ``state`` first.  Returns False when the goal cannot be planned
        from the belief.
        """
        self._refresh(state)
        if self.plans:
            return True
        if self._unsolvable == state.key():
            # A repair already searched the whole space from this very belief.
            self.last_status = PlanStatus.UNSOLVABLE
            return False
        with self._timed():
            # One plan: alternatives are searched for when an action fails (see widen).
            self._from_scratch(state, one_plan(self.settings))
        return bool(self.plans)

    def _refresh(self, state: State) -> None:
        """Re-check (and repair) the plans rewritten unchecked while the goal waited on the
        stack (see ``lazy``), from the belief ``state``."""

    def widen(self, state: State, *, failed: Atom | None = None) -> None:
        """Add alternative plans (up to K) to the kept ones (§1, §4).

        Called when an action ``failed`` (§2.2): the alternatives are then the plans
        that do not start with it.  ``state`` is the belief the kept plans are valid
        from.  A goal's first plan is one plan; alternatives cost a search of their
        own, so they are looked for only where they are used.
        """
        raise NotImplementedError(f"{type(self).__name__} does not implement widen")

    def cannot_do(self, action: Atom, state: State) -> None:
        """The executor cannot do ``action`` from ``state``: plan around it from there."""
        key = state.key()
        known = self.avoid[1] if self.avoid is not None and self.avoid[0] == key else frozenset()
        self.avoid = (key, known | {action})

    def _avoided(self, state: State) -> frozenset[Atom]:
        if self.avoid is not None and self.avoid[0] == state.key():
            return self.avoid[1]
        return frozenset()

    def drop(self) -> None:
        """Forget every plan (naive mode's "plan needed again")."""
        self.plans = []
        self._fresh_due = False

    def reconsider(self, state: State) -> None:
        """Before the goal acts again, after a change from outside that may have opened a
        cheaper way, make the best plan as good as one made afresh (on-line only: see
        :meth:`OnlinePlanSet.reconsider`)."""

    def confirm_achieved(self, state: State) -> None:
        """At resumption, keep an empty plan only if the goal is achieved now (§2.8).

        A stacked goal's plan can become empty through other goals' actions (an
        emergency walked through its target), and then gain undo steps as the
        emergency walks on; that proves nothing about now.  A plan with no step of
        the goal's own left is kept only if the goal decomposes to nothing where the
        plan ends; otherwise it goes, and the goal is planned again when needed.
        """
        self._refresh(state)
        kept: list[Plan] = []
        for p in self.plans:
            if any(s.record is not None for s in p.steps):
                kept.append(p)
                continue
            # No step of the goal's own is left, only maintenance steps (undo, rollback)
            # or nothing at all: keep the plan only if the goal is achieved where it ends.
            end = replay(self.domain, state, p.actions)
            if end is not None and achieved_by_nothing(self.domain, end, self.goal):
                kept.append(p)
        best_broke = bool(self.plans) and (not kept or kept[0] is not self.plans[0])
        self.plans = kept
        if best_broke and kept:
            self._best_replaced(state)

    def _best_replaced(self, state: State) -> None:
        """The best plan went and another took its place, in the belief ``state``."""
        raise NotImplementedError(f"{type(self).__name__} does not implement _best_replaced")

    def shorten_detours(self, state: State) -> bool:
        """Give a resumed goal the chance of a shorter way than its undo detour.

        Returns whether the best plan was shortened (never, unless on-line: see
        :meth:`OnlinePlanSet.shorten_detours`).
        """
        return False

    def _from_scratch(self, state: State, settings: PlannerSettings | None = None) -> PlanResult:
        self.stats.from_scratch += 1
        settings = settings or self._search_settings()
        result = plan(self.domain, state, [self.goal], settings, avoid=self._avoided(state))
        self.stats.expansions += result.expansions
        self.last_status = result.status
        self.plans = list(result.plans)
        self._checked = state
        self._fresh_due = False
        if result.status is PlanStatus.UNSOLVABLE:
            self._unsolvable = state.key()
        return result

    def _search_settings(self) -> PlannerSettings:
        """The settings of a search from scratch for :meth:`make`."""
        return self.settings

    def _valid(self, p: Plan, state: State) -> bool:
        self.stats.rechecks += 1
        return _first_failure(self.domain, p, state) is None

    def _timed(self) -> _Timed:
        return _Timed(self.stats)

    def _untouched(self, p: Plan, before: State, after: State) -> bool:
        """Whether ``p``, valid from ``before``, is known valid from ``after`` without a walk.

        Only preconditions decide validity, and they read facts: if no step of the
        plan reads a predicate whose facts differ between the two beliefs, every
        step sees what it saw before (issue #12: re-check only what a change can
        touch).
        """
        if before is not self._checked:
            return False
        changed = _changed_predicates(before, after)
        if not changed:
            return True
        compiled = self.domain.actions.compiled
        return not any(lit.atom.name in changed for s in p.steps for lit in compiled(s.action).op.pre)

    # -- events ---------------------------------------------------------------

    def action_succeeded(
        self, action: Atom, before: State, after: State, memo: SearchMemo | None = None
    ) -> None:
        """The executed action finished with success; the belief went ``before`` → ``after`` (§2.1)."""
        raise NotImplementedError(f"{type(self).__name__} does not implement action_succeeded")

    def action_failed(
        self, action: Atom, before: State, after: State, memo: SearchMemo | None = None
    ) -> None:
        """The executed action failed (§2.2)."""
        raise NotImplementedError(f"{type(self).__name__} does not implement action_failed")

    def action_suspended(
        self, action: Atom, before: State, after: State, memo: SearchMemo | None = None
    ) -> None:
        """The running action was stopped half way (§3, Algorithm 1, steps 2–3).

        ``after`` is the belief with the suspension effect (step 1, done by the caller).
        """
        raise NotImplementedError(f"{type(self).__name__} does not implement action_suspended")

    def suspension_cleared(
        self, action: Atom, before: State, after: State, memo: SearchMemo | None = None
    ) -> None:
        """The half-done ``action`` will never be resumed; its half-done facts are gone.

        A kept plan that still meant to ``resume(action)`` does the whole action
        instead (the counterpart of §2.6's rollback(A), A → resume(A)).
        """
        raise NotImplementedError(f"{type(self).__name__} does not implement suspension_cleared")

    def belief_changed(self, before: State, after: State, memo: SearchMemo | None = None) -> None:
        """The world changed from outside (§2.3)."""
        raise NotImplementedError(f"{type(self).__name__} does not implement belief_changed")

    def _whole(self, action: Atom) -> Callable[[Plan], Plan]:
        """The rewrite of a plan that meant to ``resume(action)`` into one doing the whole action."""
        resume = resume_action(action)
        cost = self.domain.actions.cost(action)

        def whole(p: Plan) -> Plan:
            return Plan(tuple(Step(action, cost, s.record) if s.action == resume else s for s in p.steps))

        return whole


# -- naive mode ------------------------------------------------------------------------------------


class NaivePlanSet(PlanSet):
    """Naive plan keeping: only the plan being executed, planned afresh when needed again.

    The plan follows the actions it makes; any other event — a failure, a
    suspension, a belief change that breaks it — drops it, and the next
    :meth:`~PlanSet.ensure` plans from scratch (one plan, no alternatives).
    """

    mode = Replanning.NAIVE

    def widen(self, state: State, *, failed: Atom | None = None) -> None:
        """Nothing is kept in naive mode, so nothing is added."""

    def _search_settings(self) -> PlannerSettings:
        return one_plan(self.settings)

    def _best_replaced(self, state: State) -> None:
        """Nothing to compare: a naive plan was made from scratch."""

    def action_succeeded(
        self, action: Atom, before: State, after: State, memo: SearchMemo | None = None
    ) -> None:
        """The plan that ran the action moves on; any other is dropped (§2.1)."""
        with self._timed():
            # A plan valid from ``before`` that ran the action is valid from ``after``.
            trusted = before is self._checked
            ran = [p.rest() for p in self.plans if p.steps and p.steps[0].action == action]
            self.plans = [p for p in ran[:1] if trusted or self._valid(p, after)]
            self._checked = after

    def action_failed(
        self, action: Atom, before: State, after: State, memo: SearchMemo | None = None
    ) -> None:
        """The plan is dropped."""
        with self._timed():
            self.plans = []

    def action_suspended(
        self, action: Atom, before: State, after: State, memo: SearchMemo | None = None
    ) -> None:
        """The plan is dropped."""
        with self._timed():
            self.plans = []

    def suspension_cleared(
        self, action: Atom, before: State, after: State, memo: SearchMemo | None = None
    ) -> None:
        """A ``resume(action)`` in the plan becomes the whole action; the plan stays if still valid."""
        with self._timed():
            whole = self._whole(action)
            self.plans = [p for p in map(whole, self.plans[:1]) if self._valid(p, after)]
            self._checked = after

    def belief_changed(self, before: State, after: State, memo: SearchMemo | None = None) -> None:
        """The plan stays if still valid."""
        with self._timed():
            if self.plans and not self._valid(self.plans[0], after):
                self.plans = []
            self._checked = after


# -- on-line mode ----------------------------------------------------------------------------------


class _Timed:
    """Adds the wall-clock time of a ``with`` block to the statistics (a plain class:
    it wraps every plan-set update, so it should cost next to nothing)."""

    __slots__ = ("_started", "_stats")

    def __init__(self, stats: PlanningStats) -> None:
        self._stats = stats
        self._started = 0.0

    def __enter__(self) -> None:
        self._started = time.perf_counter()

    def __exit__(self, *exc: object) -> None:
        self._stats.seconds += time.perf_counter() - self._started


def _unique(plans: Iterable[Plan]) -> list[Plan]:
    """The plans without repeats (the first of equal action sequences), in order."""
    seen: set[tuple[Atom, ...]] = set()
    out: list[Plan] = []
    for p in plans:
        if p.actions not in seen:
            seen.add(p.actions)
            out.append(p)
    return out


def _cost(p: Plan) -> float:
    return p.cost


def _changed_predicates(before: State, after: State) -> frozenset[str]:
    """The names of the facts that differ between two beliefs."""
    names = {f.name for f in before.dynamic ^ after.dynamic}
    if after.static is not before.static:
        names |= {f.name for f in before.static.facts ^ after.static.facts}
    return frozenset(names)


class _Kept(NamedTuple):
    """A plan going into a re-check, and whether it is known valid from the new belief."""

    plan: Plan
    valid: bool


class OnlinePlanSet(PlanSet):
    """On-line plan keeping (Dynagent style): up to K plans, modified after every event.

    ``revival_window`` bounds how many updates a removed plan waits for its fact,
    and ``revival_capacity`` how many removed plans are kept at once (see :class:`Revival`).
    """

    mode = Replanning.ONLINE

    def __init__(
        self,
        domain: Domain,
        goal: Atom,
        mode: Replanning | None = None,
        settings: PlannerSettings | None = None,
        stats: PlanningStats | None = None,
        *,
        revival_window: int = 64,
        revival_capacity: int = 32,
    ) -> None:
        super().__init__(domain, goal, mode, settings, stats)
        self.revival = Revival(domain, revival_window, revival_capacity)
        """Plans removed because a fact was false, waiting for it to be true again (§2.5)."""

    def fork(self) -> PlanSet:
        forked = super().fork()
        assert isinstance(forked, OnlinePlanSet)
        forked.revival = self.revival.copy()
        return forked

    def adopt(self, other: PlanSet) -> PlanSet:
        replaced = super().adopt(other)
        assert isinstance(other, OnlinePlanSet)
        self.revival = other.revival
        return replaced

    def drop(self) -> None:
        super().drop()
        self._stale = False
        self.revival.clear()

    def _refresh(self, state: State) -> None:
        if self._stale:
            with self._timed():
                self._recheck_stale(state)

    def _recheck_stale(self, state: State) -> None:
        # §2 step 4, deferred while the goal waited (see ``lazy``): re-check every plan
        # from the belief now, repair the broken ones (§2.4), revive what the changes since
        # the last check bring back (§2.5).
        since = self._stale_since if self._stale_since is not None else state
        self._stale, self._stale_since = False, None
        self._revise(since, state)

    def _follow_lazily(self, change: Callable[[Plan], Plan | None], after: State) -> None:
        """For a goal waiting on the stack (``lazy``): rewrite each kept plan (and each
        plan kept for revival) as the event does — ``change`` gives None for a kept plan
        the event ends (a plan kept for revival is then left as it is) — and leave the
        re-check until the goal is about to run again.

        A goal no longer waiting whose plans were left so is re-checked now, from
        ``after`` (an earlier belief may not be one its plans can be mended from: the
        event may be what makes them good again)."""
        if not self._stale:
            self._stale, self._stale_since = True, self._checked
        self._checked = None
        self.plans = [q for p in self.plans if (q := change(p)) is not None]
        if self.revival:
            self.revival.rewrite(change)
        if not self.lazy:
            self._recheck_stale(after)

    def widen(self, state: State, *, failed: Atom | None = None) -> None:
        self._refresh(state)
        k = self.settings.alternatives
        if k <= 1 or len(self.plans) >= k:
            return
        with self._timed():
            wanted = replace(self.settings, alternatives=k + (failed is not None))
            result = plan(self.domain, state, [self.goal], wanted, avoid=self._avoided(state))
            self.stats.from_scratch += 1
            self.stats.expansions += result.expansions
            seen = {p.actions for p in self.plans}
            extra = [
                p
                for p in result.plans
                if p.actions not in seen and not (failed is not None and p.actions[:1] == (failed,))
            ]
            self.plans = sorted([*self.plans, *extra], key=lambda q: q.cost)[:k]
            self._checked = state

    # -- events ---------------------------------------------------------------

    def action_succeeded(
        self, action: Atom, before: State, after: State, memo: SearchMemo | None = None
    ) -> None:
        """The executed action finished with success; the belief went ``before`` → ``after`` (§2.1)."""
        if self.lazy or self._stale:
            with self._timed():
                self._succeeded_lazily(action, after)
            return
        if len(self.plans) == 1 and not self.revival and before is self._checked:
            # The common case, what the general case below comes to for it: the one plan,
            # valid from ``before``, ran the action; it moves on and is valid from ``after``.
            ran = self.plans[0]
            steps = ran.steps
            if steps and steps[0].action == action:
                with self._timed():
                    self.done = Done(steps[0], self.done)
                    self.plans = [ran.rest()]
                    self._checked = after
                    self.revival.tick()
                return
        with self._timed():
            undo = self.domain.actions.undo_of(action)
            # A plan valid from ``before`` that ran the action is valid from ``after``;
            # so is one behind the undo, when the undo really leads back to ``before``;
            # so is any other when the action changed nothing at all.
            trusted = before is self._checked
            restores: bool | None = None  # whether the undo leads back: worked out when needed
            self._note_done(action)
            kept: list[_Kept] = []
            for p in self.plans:
                if p.steps and p.steps[0].action == action:
                    # §2.1: the plan that ran the action moves on.
                    kept.append(_Kept(p.rest(), trusted))
                elif undo is not None:
                    # §2.1: another plan stays valid by undoing the action first.
                    if restores is None:
                        restores = trusted and _leads_back(self.domain, undo, before, after)
                    kept.append(_Kept(Plan(self._behind(undo, p.steps)), restores))
                else:
                    kept.append(_Kept(p, self._untouched(p, before, after)))

            # §2.5: plans kept for revival follow the same steps, so that a revived plan
            # is valid from where the robot is by then (not from where it was removed).
            if self.revival:
                self.revival.rewrite(self._moved_on(action, undo))
            self._revise(before, after, kept, memo=memo)

    def _note_done(self, action: Atom) -> None:
        """Add the step that did ``action`` to the goal's done steps, if a kept plan made
        it (the cheapest such plan: the one selected)."""
        ran = next((p.steps[0] for p in self.plans if p.steps and p.steps[0].action == action), None)
        if ran is not None:
            self.done = Done(ran, self.done)

    def _moved_on(self, action: Atom, undo: Atom | None) -> Callable[[Plan], Plan | None]:
        """§2.1's rewrite of a plan once ``action`` succeeded: the plan that ran it moves
        on; another goes behind the action's ``undo``; None: the plan stays as it is."""

        def moved_on(p: Plan) -> Plan | None:
            if p.steps and p.steps[0].action == action:
                return p.rest()
            if undo is not None:
                return Plan(self._behind(undo, p.steps))
            return None

        return moved_on

    def _succeeded_lazily(self, action: Atom, after: State) -> None:
        """§2.1's rewrite alone, for a goal waiting on the stack (see ``lazy``)."""
        self._note_done(action)
        moved_on = self._moved_on(action, self.domain.actions.undo_of(action))
        self._follow_lazily(lambda p: moved_on(p) or p, after)

    def _behind(self, undo: Atom, steps: tuple[Step, ...]) -> tuple[Step, ...]:
        """The steps behind the undo of an action another goal made (§2.1), tidied.

        A ``resume(A)`` among them no longer continues from where A was stopped —
        the executor has since done other things — so it is costed as the whole A:
        how much of A is left is not known.
        """
        cost = self.domain.actions.cost
        # The name test first: this runs on every step of every kept plan.
        rest = tuple(
            Step(s.action, cost(inner), s.record)
            if s.action.name == RESUME and (inner := half_done(s.action)) is not None
            else s
            for s in steps
        )
        return tidy(self.domain, (Step(undo, cost(undo), None), *rest), front=True)

    def action_failed(
        self, action: Atom, before: State, after: State, memo: SearchMemo | None = None
    ) -> None:
        """The executed action failed (§2.2): plans starting with it go, the rest are re-checked."""
        if self.lazy or self._stale:
            with self._timed():
                self._follow_lazily(lambda p: None if p.steps and p.steps[0].action == action else p, after)
            return
        with self._timed():
            had = bool(self.plans)
            self.plans = [p for p in self.plans if not (p.steps and p.steps[0].action == action)]
            if had and not self.plans:
                # §2.2 takes a kept alternative at once: the first plan came alone, so
                # find the alternatives now — those that do not start with the failure.
                self.widen(before, failed=action)
            # An alternative that still means to do the failed action later is no better
            # than planning afresh (§2.4).
            broke = bool(self.plans) and action in self.plans[0].actions
            self._revise(before, after, best_broke=broke, memo=memo)

    def action_suspended(
        self, action: Atom, before: State, after: State, memo: SearchMemo | None = None
    ) -> None:
        """The running action was stopped half way (§3, Algorithm 1, steps 2–3).

        ``after`` is the belief with the suspension effect (step 1, done by the caller).
        """
        with self._timed():
            actions = self.domain.actions
            resume = actions.resume_of(action)
            rollback = actions.rollback_of(action) if self.settings.rollbacks else None

            def suspended(p: Plan) -> Plan | None:
                if p.steps and p.steps[0].action == action:
                    if resume is None:
                        return None
                    # Algorithm 1, step 3: resume(A) takes A's place (and its record).
                    first = Step(resume, actions.cost(resume), p.steps[0].record)
                    return Plan((first, *p.steps[1:]))
                if rollback is not None:
                    # Algorithm 1, step 3: undo the half-done A before the other plan.
                    return Plan((Step(rollback, actions.cost(rollback), None), *p.steps))
                return p

            if self.lazy or self._stale:
                self._follow_lazily(suspended, after)  # step 3's rewrite; its re-check waits
                return
            trusted = before is self._checked
            apply_dynamic = actions.apply_dynamic
            # A plan valid from ``before`` stays valid when its new first step ends where the
            # old one would have: resume(A) from ``after`` where A from ``before`` ends, or
            # rollback(A) back at ``before`` itself.  Worked out once, when first needed.
            resumes_alike: bool | None = None
            rolls_back: bool | None = None
            kept: list[_Kept] = []
            for p in self.plans:
                q = suspended(p)
                if q is None:
                    continue
                if q is p:
                    valid = self._untouched(p, before, after)
                elif q.steps[0].action == resume:
                    if resumes_alike is None:
                        same_static = after.static is before.static
                        ended = apply_dynamic(before, action) if trusted and same_static else None
                        resumes_alike = ended is not None and apply_dynamic(after, resume) == ended
                    valid = resumes_alike
                else:
                    if rolls_back is None:
                        assert rollback is not None
                        rolls_back = trusted and _leads_back(self.domain, rollback, before, after)
                    valid = rolls_back
                kept.append(_Kept(q, valid))
            self.revival.rewrite(suspended)
            # Steps 2 and 3's re-check: revive, tidy, re-check and repair every plan
            # (a plan the suspension leaves as it was only if it reads what changed).
            self._revise(before, after, kept, memo=memo)

    def suspension_cleared(
        self, action: Atom, before: State, after: State, memo: SearchMemo | None = None
    ) -> None:
        """The half-done ``action`` will never be resumed; its half-done facts are gone.

        A kept plan that still meant to ``resume(action)`` does the whole action
        instead (the counterpart of §2.6's rollback(A), A → resume(A)); then every
        plan is re-checked as for any belief change (while the goal waits, when it is
        about to run again: see ``lazy``).
        """
        with self._timed():
            whole = self._whole(action)
            if self.lazy or self._stale:
                self._follow_lazily(whole, after)
                return
            resume = resume_action(action)
            kept = [
                _Kept(p, self._untouched(p, before, after))
                if resume not in p.actions
                else _Kept(whole(p), False)
                for p in self.plans
            ]
            self.revival.rewrite(whole)
            self._revise(before, after, kept, memo=memo)

    def belief_changed(self, before: State, after: State, memo: SearchMemo | None = None) -> None:
        """The world changed from outside (§2.3): every plan that reads a changed fact is re-checked.

        A kept plan still valid may no longer be the cheapest when the change opened a
        way (a door opened): the goal is then compared with a plan made afresh before its
        next action, or when it resumes (:meth:`reconsider`), as naive would plan it then.
        """
        with self._timed():
            if self.domain.opens_ways(before, after):
                self._fresh_due = True
            if self.lazy or self._stale:
                self._follow_lazily(lambda p: p, after)
                return
            kept = [_Kept(p, self._untouched(p, before, after)) for p in self.plans]
            self._revise(before, after, kept, memo=memo)

    def shorten_detours(self, state: State) -> bool:
        """Give a resumed goal the chance of a shorter way than its undo detour.

        docs/design.md §2.1 keeps a plan valid by putting the undo of every action
        the emergency made in front of it, so after an emergency the best kept
        plan may walk back first.  At resumption, if it starts with such inserted
        undo steps, it gets a rival: the lowest compound task above its first own
        step, re-decomposed from the current belief (a repair as in §2.4), plus
        what follows that task.  The cheaper of the two is selected.  Returns
        whether the plan was shortened.
        """
        self._refresh(state)
        best = self.best
        if best is None:
            return False
        # The detour: the leading steps that plan maintenance put there (undo steps, a
        # rollback of another goal's action: steps without a record) — not a resume(A)
        # that took its own A's place.
        first = next((i for i, s in enumerate(best.steps) if s.record is not None), len(best.steps))
        if not first:
            return False
        with self._timed():
            return self._rival_from(state, best, first)

    def _rival_from(self, state: State, best: Plan, first: int, repairer: Repairer | None = None) -> bool:
        """Re-decompose the lowest compound task above ``best``'s step ``first`` (the
        goal, if none is left) from ``state``, followed by the rest of ``best``; select the
        rival if it is cheaper (a repair as in §2.4).  Returns whether it was."""
        tasks: list[TaskEntry]
        if first == len(best.steps):
            # Nothing of the goal's own is left, only the way back to where an
            # emergency achieved it (§2.8): the rival is the goal itself.
            tasks, head, fixed = [(self.goal, None)], self.goal, 0.0
        else:
            record = best.steps[first].record
            assert record is not None
            _, end = span(best.steps, record)
            tasks = [(record.task, record.parent)]
            tasks += [(s.action, s.record) for s in best.steps[end + 1 :]]
            head, fixed = record.task, sum(s.cost for s in best.steps[end + 1 :])
        # With admissible estimates nothing can beat a plan that costs no more than
        # the estimate of the rival's tasks: then the search is not worth making.
        if best.cost <= heuristic(self.domain, [head], state) + fixed + 1e-9:
            return False
        rival = (repairer or self._repairer()).search(state, tasks, one_plan(self.settings))
        if rival is None or rival.cost >= best.cost - 1e-9:
            return False
        # The plan it beat is not kept as an alternative: a detour walks back over the
        # emergency's route only to go the way the rival goes, and keeping it valid would
        # cost an undo step more at every action (a goal's plan comes alone, §1, §4;
        # alternatives are looked for when an action fails: see widen).
        shorter = rival  # the planner returns tidy plans
        others = [p for p in self.plans[1:] if p.actions != shorter.actions]
        self.plans = sorted([shorter, *others], key=lambda q: q.cost)[: self.settings.alternatives]
        self.stats.shortcuts += 1
        return True

    # -- the machinery --------------------------------------------------------

    def _repairer(self, memo: SearchMemo | None = None, local_budget: int = 0) -> Repairer:
        return Repairer(self.domain, self.goal, self.settings, self.stats, self._avoided, memo, local_budget)

    def _revise(
        self,
        before: State,
        after: State,
        kept: list[_Kept] | None = None,
        *,
        best_broke: bool = False,
        memo: SearchMemo | None = None,
    ) -> None:
        """Revive (§2.5), tidy (§2.6), re-check and repair (§2.4); cheapest first.

        ``kept`` are the plans with what is known of them (by default ``plans``, none
        known valid).  When the best plan breaks, whatever takes its place must be as
        good as a plan made afresh from the belief (§2.4): the domain's admissible
        estimate proves it, or the goal is planned from scratch and the cheaper one wins.
        """
        self.revival.tick()
        back = self.revival.revive(before, after)
        if kept is None:
            kept = [_Kept(p, False) for p in self.plans]
        elif not best_broke and not back and all(valid for _, valid in kept):
            # Every plan is known valid and nothing comes back: nothing to re-check.
            if len(kept) == 1:
                self.plans = [kept[0].plan]
            else:
                unique = sorted(_unique(p for p, _ in kept), key=_cost)
                self.plans = unique[: max(self.settings.alternatives, 1)]
            self._checked = after
            self.revival.expire()
            return
        revived_from = len(kept)
        candidates = [*kept, *(_Kept(p, False) for p in back)]
        out: list[Plan] = []
        seen: set[tuple[Atom, ...]] = set()
        made: list[Repairer] = []

        def repairer() -> Repairer:
            # Made on first need: most updates re-check nothing or find every plan valid.
            if not made:
                made.append(self._repairer(memo, min(self.settings.budget, LOCAL_BUDGET)))
            return made[0]

        for n, (p, valid) in enumerate(candidates):
            revived = n >= revived_from
            if valid:
                checked: Plan | None = p
            else:
                p = Plan(tidy(self.domain, p.steps))
                # Subtasks are done again (the costliest repair) only while no plan is kept.
                checked = self._recheck(
                    p, after, repairer, allow_repair=not revived, remember=not revived, redo=not out
                )
                if n == 0 and checked is not p:
                    best_broke = True
            if checked is None:
                continue
            if revived:
                self.stats.revivals += 1
            key = checked.actions
            if key not in seen:
                seen.add(key)
                out.append(checked)
        out.sort(key=_cost)
        self.plans = out[: max(self.settings.alternatives, 1)]
        if best_broke:
            self._as_good_as_fresh(after, repairer)
        if made and made[0].unsolvable is not None:
            self._unsolvable = made[0].unsolvable
        self._checked = after
        self.revival.expire()

    def _best_replaced(self, state: State) -> None:
        with self._timed():
            self._as_good_as_fresh(state, self._repairer)

    def reconsider(self, state: State) -> None:
        """§2.4's rule after a change from outside that may have opened a cheaper way (a
        door opened) while the goal waited on the stack, or while its action ran: its best
        plan, still valid, is compared with a plan made afresh (unless the estimate proves
        it optimal) before the goal acts again.  Naive plans afresh at resumption, and
        when its plan breaks; on-line never settles for a longer way than naive."""
        if not self._fresh_due:
            return
        self._fresh_due = False
        self._refresh(state)
        best = self.best
        if best is None:
            return
        with self._timed():
            made: list[Repairer] = []

            def repairer() -> Repairer:
                if not made:
                    made.append(self._repairer())
                return made[0]

            if self._as_good_as_fresh(state, repairer):
                return
            # No plan afresh (the goal's methods may not start again from part of it
            # done): the lowest task above the first step is re-decomposed instead (not
            # the goal itself: that is the search that just found nothing).
            first = next((i for i, s in enumerate(best.steps) if s.record is not None), len(best.steps))
            if first < len(best.steps):
                self._rival_from(state, best, first, repairer())

    def _as_good_as_fresh(self, state: State, repairer: Callable[[], Repairer]) -> bool:
        """§2.4: the best plan took the place of a broken one: it must be no worse than a
        plan made afresh from ``state`` — proven by the estimate, or else compared.
        Returns whether it is known to be now (False: the search for a fresh plan found none).

        The search is shared (``repairer``) with a repair that reached the goal itself.
        Once known, no comparison is due for a way opened earlier (:meth:`reconsider`).
        """
        known = self._fresher_kept(state, repairer)
        if known:
            self._fresh_due = False
        return known

    def _fresher_kept(self, state: State, repairer: Callable[[], Repairer]) -> bool:
        if not self.plans or self._proven_optimal(self.plans[0], state):
            return bool(self.plans)
        goal: list[TaskEntry] = [(self.goal, None)]
        searches = repairer()
        known = searches.known_cost(state, goal)
        if known is not None and known >= self.plans[0].cost - 1e-9:
            return True  # a search this update made for the goal's very task found nothing cheaper
        fresh = searches.search(state, goal, one_plan(self.settings))
        if fresh is None or fresh.cost >= self.plans[0].cost - 1e-9:
            return fresh is not None
        self.stats.fresher += 1
        # The plan it beat goes: a plan worse than one made afresh from the same belief is
        # no alternative worth keeping valid at every action (alternatives come when an
        # action fails, §2.2).
        others = [p for p in self.plans[1:] if p.actions != fresh.actions]
        self.plans = [fresh, *others][: max(self.settings.alternatives, 1)]
        return True

    def _proven_optimal(self, p: Plan, state: State) -> bool:
        """Whether the admissible estimate proves no plan from ``state`` is cheaper."""
        return p.cost <= heuristic(self.domain, [self.goal], state) + 1e-9

    def _recheck(
        self,
        p: Plan,
        state: State,
        repairer: Callable[[], Repairer],
        *,
        allow_repair: bool,
        remember: bool,
        redo: bool = True,
    ) -> Plan | None:
        """The plan if valid, else its repair, else None (and it is kept for revival)."""
        self.stats.rechecks += 1
        failure = _first_failure(self.domain, p, state)
        if failure is None:
            return p
        index, at_failure = failure
        culprit = p.steps[index].action
        if not allow_repair:
            if remember:
                self.stats.removed += 1
                self.revival.keep(p, culprit, at_failure)
            return None
        repaired = repairer().repair(p, index, _states(self.domain, p, state, index), self.done, redo=redo)
        # §2.5: a removed plan, and the plan as it was before a repair, come back if the fact does.
        self.revival.keep(p, culprit, at_failure)
        if repaired is not None:
            self.stats.repairs += 1
            return repaired
        self.stats.failed_repairs += 1
        self.stats.removed += 1
        return None


# -- helpers -----------------------------------------------------------------------------------------


_STEPS = operator.attrgetter("steps")

_KINDS: dict[Replanning, type[PlanSet]] = {Replanning.ONLINE: OnlinePlanSet, Replanning.NAIVE: NaivePlanSet}
"""The plan-set class of each replanning mode (``PlanSet(..., mode)`` picks from it)."""


def _first_failure(domain: Domain, p: Plan, state: State) -> tuple[int, State] | None:
    """Progress the belief through the plan: the first step that cannot run, and the state there."""
    current = state
    compiled = domain.actions.compiled
    for i, s in enumerate(p.steps):
        dynamic = compiled(s.action).apply_dynamic(current)
        if dynamic is None:
            return i, current
        if dynamic is not current.dynamic:
            current = current.with_dynamic(dynamic)
    return None


def _states(domain: Domain, p: Plan, state: State, upto: int) -> list[State]:
    """The belief before each of the first ``upto + 1`` steps (all applicable)."""
    apply = domain.actions.apply
    states = [state]
    for s in p.steps[:upto]:
        nxt = apply(states[-1], s.action)
        assert nxt is not None
        states.append(nxt)
    return states


def _leads_back(domain: Domain, undo: Atom, before: State, after: State) -> bool:
    """Whether doing ``undo`` in ``after`` gives back exactly the belief ``before``."""
    if after.static is not before.static:
        return False
    dynamic = domain.actions.apply_dynamic(after, undo)
    return dynamic is not None and dynamic == before.dynamic


__all__ = [
    "NaivePlanSet",
    "OnlinePlanSet",
    "PlanSet",
    "PlanningStats",
    "Repairer",
    "Replanning",
    "Revival",
    "SearchMemo",
]
