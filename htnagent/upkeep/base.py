"""Keeping a goal's alternative plans valid while the agent acts: what both modes share.

A plan set holds the alternative plans of one goal — the active goal or one
waiting on the stack — and updates them after every event (docs/design.md §2–§3).
:class:`PlanSet` is the interface the agent calls, and what both modes do:

- plan from scratch when nothing is left (:meth:`~PlanSet.ensure`, §2.7: "If a
  goal is left with no plan at all, the agent plans it from scratch; if that
  fails too, the goal fails");
- keep an emptied plan only if the goal is achieved now
  (:meth:`~PlanSet.confirm_achieved`, §2.8: "A goal succeeds only when it is
  achieved now");
- the events — :meth:`~PlanSet.action_succeeded` (§2.1),
  :meth:`~PlanSet.action_failed` (§2.2), :meth:`~PlanSet.belief_changed` (§2.3),
  :meth:`~PlanSet.action_suspended` (§3, Algorithm 1),
  :meth:`~PlanSet.suspension_cleared` — each mode handles in its own way:
  :class:`~htnagent.upkeep.online.OnlinePlanSet` modifies every kept plan,
  :class:`~htnagent.upkeep.naive.NaivePlanSet` keeps only the plan being executed.

Pure and synchronous: the agent runtime calls it; no event loop inside.
"""

from __future__ import annotations

import operator
from abc import ABC, abstractmethod
from typing import Self

from htnagent.model.domain import Domain
from htnagent.model.plans import Done, Plan, replay
from htnagent.model.state import State
from htnagent.model.terms import Atom
from htnagent.planning.planner import PlannerSettings, PlanResult, PlanStatus, achieved_by_nothing, plan
from htnagent.upkeep.repair import SearchMemo, one_plan
from htnagent.upkeep.stats import PlanningStats, Timed
from htnagent.upkeep.validity import changed_predicates, first_failure

_steps = operator.attrgetter("steps")


class PlanSet(ABC):
    """The alternative plans of one goal, cheapest first, kept valid from the belief.

    This class holds what both modes share; the updates on events are each
    subclass's own (:class:`~htnagent.upkeep.online.OnlinePlanSet`,
    :class:`~htnagent.upkeep.naive.NaivePlanSet`; a caller picks one, or lets
    :func:`~htnagent.upkeep.kinds.new_plan_set` pick it for a mode): the abstract
    methods below are the events each mode answers in its own way.  ``plans`` is
    the list of kept plans, cheapest first.
    """

    def __init__(
        self,
        domain: Domain,
        goal: Atom,
        settings: PlannerSettings | None = None,
        stats: PlanningStats | None = None,
    ) -> None:
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
        """Set while the goal waits on the stack: each event's rewrite of its plans (§2.1, §3)
        is kept, not re-checked or repaired then (on-line mode logs it and makes it when the
        plans are next needed: read ``plans`` of a waiting goal only after
        :meth:`~htnagent.upkeep.online.OnlinePlanSet.catch_up`); they are re-checked (and
        repaired, §2.4) once, when the goal is about to run again (prepared or resumed) —
        one walk then (and a repair if it needs one), instead of one per event."""
        self.scratch_expansions: int | None = None
        """Expansions the goal's last search from scratch took to find its plan: what planning
        it afresh is known to cost (§2.4's comparison is given no more than a few times it)."""
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
        return not all(map(_steps, self.plans))  # no generator: asked before every action

    def __len__(self) -> int:
        return len(self.plans)

    def fork(self) -> Self:
        """A copy to update speculatively (the plans themselves are immutable values).

        The copy shares the settings and the statistics.
        """
        forked = object.__new__(type(self))
        forked.__dict__.update(self.__dict__)
        forked.plans = list(self.plans)
        return forked

    def adopt(self, other: PlanSet) -> Self:
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
        self.scratch_expansions = other.scratch_expansions
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

    def ensure(self, state: State, memo: SearchMemo | None = None) -> bool:
        """Make sure there is a plan; plan from scratch if none is kept (§2.7: "If a goal
        is left with no plan at all, the agent plans it from scratch").

        Plans left unchecked while the goal waited (``lazy``) are re-checked and
        repaired from ``state`` first (sharing ``memo``'s searches).  Returns False when
        the goal cannot be planned from the belief.
        """
        self._refresh(state, memo)
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

    def _refresh(self, state: State, memo: SearchMemo | None = None) -> None:
        """Re-check (and repair) the plans rewritten unchecked while the goal waited on the
        stack (see ``lazy``), from the belief ``state``."""
        return  # naive keeps no plan unchecked; the on-line plan set re-checks them

    @abstractmethod
    def widen(self, state: State, *, failed: Atom | None = None) -> None:
        """Add alternative plans (up to K) to the kept ones (§1, §4).

        Called when an action ``failed`` (§2.2): the alternatives are then the plans
        that do not start with it.  ``state`` is the belief the kept plans are valid
        from.  A goal's first plan is one plan; alternatives cost a search of their
        own, so they are looked for only where they are used.
        """

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

    def reconsider(self, state: State, memo: SearchMemo | None = None) -> None:
        """Before the goal acts again, after a change from outside that may have opened a
        cheaper way, make the best plan as good as one made afresh (on-line only: see
        :meth:`~htnagent.upkeep.online.OnlinePlanSet.reconsider`)."""
        return  # naive plans afresh whenever it needs a plan: nothing to weigh

    def confirm_achieved(self, state: State, memo: SearchMemo | None = None) -> None:
        """At resumption, keep an empty plan only if the goal is achieved now (§2.8).

        A stacked goal's plan can become empty through other goals' actions (an
        emergency walked through its target), and then gain undo steps as the
        emergency walks on; that proves nothing about now.  A plan with no step of
        the goal's own left is kept only if the goal decomposes to nothing where the
        plan ends; otherwise it goes, and the goal is planned again when needed.
        """
        self._refresh(state, memo)
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
            self._best_replaced(state, memo)

    @abstractmethod
    def _best_replaced(self, state: State, memo: SearchMemo | None = None) -> None:
        """The best plan went and another took its place, in the belief ``state``."""

    def shorten_detours(self, state: State, memo: SearchMemo | None = None) -> bool:
        """Give a resumed goal the chance of a shorter way than its undo detour.

        Returns whether the best plan was shortened (never, unless on-line: see
        :meth:`~htnagent.upkeep.online.OnlinePlanSet.shorten_detours`).
        """
        return False

    def _from_scratch(self, state: State, settings: PlannerSettings | None = None) -> PlanResult:
        self.stats.from_scratch += 1
        settings = settings or self._search_settings()
        result = plan(self.domain, state, [self.goal], settings, avoid=self._avoided(state))
        self.stats.expansions += result.expansions
        self.last_status = result.status
        if result.plans:
            self.scratch_expansions = result.expansions
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
        return first_failure(self.domain, p, state) is None

    def _timed(self) -> Timed:
        return Timed(self.stats)

    def _untouched(self, p: Plan, before: State, after: State) -> bool:
        """Whether ``p``, valid from ``before``, is known valid from ``after`` without a walk.

        Only preconditions decide validity, and they read facts: if no step of the
        plan reads a predicate whose facts differ between the two beliefs, every
        step sees what it saw before (re-check only what a change can touch).
        """
        if before is not self._checked:
            return False
        changed = changed_predicates(before, after)
        if not changed:
            return True
        compiled = self.domain.actions.compiled
        return not any(lit.atom.name in changed for s in p.steps for lit in compiled(s.action).op.pre)

    # -- events ---------------------------------------------------------------

    @abstractmethod
    def action_succeeded(
        self, action: Atom, before: State, after: State, memo: SearchMemo | None = None
    ) -> None:
        """The executed action finished with success; the belief went ``before`` → ``after`` (§2.1)."""

    @abstractmethod
    def action_failed(
        self, action: Atom, before: State, after: State, memo: SearchMemo | None = None
    ) -> None:
        """The executed action failed (§2.2)."""

    @abstractmethod
    def action_suspended(
        self, action: Atom, before: State, after: State, memo: SearchMemo | None = None
    ) -> None:
        """The running action was stopped half way (§3, Algorithm 1, steps 2–3).

        ``after`` is the belief with the suspension effect (step 1, done by the caller).
        """

    @abstractmethod
    def suspension_cleared(
        self, action: Atom, before: State, after: State, memo: SearchMemo | None = None
    ) -> None:
        """The half-done ``action`` will never be resumed; its half-done facts are gone.

        A kept plan that still meant to ``resume(action)`` does the whole action
        instead (the counterpart of §2.6's rollback(A), A → resume(A)).
        """

    @abstractmethod
    def belief_changed(self, before: State, after: State, memo: SearchMemo | None = None) -> None:
        """The world changed from outside (§2.3)."""


__all__ = ["PlanSet"]
