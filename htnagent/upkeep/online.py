"""On-line plan keeping, Dynagent style (docs/design.md §2–§3).

An :class:`OnlinePlanSet` keeps up to K plans of its goal and modifies them
after every event instead of planning again; each rule is a module of its own:

- an action succeeded (§2.1, :mod:`~htnagent.upkeep.success`), failed (§2.2,
  :mod:`~htnagent.upkeep.failure`), was suspended (§3, Algorithm 1,
  :mod:`~htnagent.upkeep.suspension`); the belief changed from outside (§2.3,
  here: every plan that reads a changed fact is re-checked);
- after each, every plan is tidied (§2.6, :func:`htnagent.model.plans.tidy`), re-checked
  and, where broken, repaired (§2.4, :mod:`~htnagent.upkeep.recheck`,
  :mod:`~htnagent.upkeep.repair`); plans known to be valid (they ran the action
  that just succeeded, or sit behind an undo that provably restores the belief)
  are not walked again;
- the best plan is never worse than one made afresh (§2.4,
  :mod:`~htnagent.upkeep.quality`);
- plans removed because a fact was false come back when it is true again (§2.5,
  :mod:`~htnagent.upkeep.revival`);
- while the goal waits on the stack (``lazy``) the rewrite each event makes of its
  plans is logged, and made -- with the actions that succeeded one after another taken
  in one pass -- when the goal is about to run again, and re-checked then;
- :meth:`~OnlinePlanSet.shorten_detours`, at resumption, offers a shorter way
  than a plan's leading undo steps.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import replace
from itertools import groupby
from typing import Self

from htnagent.model.actions import resume_action
from htnagent.model.domain import Domain
from htnagent.model.plans import Done, Plan
from htnagent.model.state import State
from htnagent.model.terms import Atom
from htnagent.planning.planner import PlannerSettings, plan
from htnagent.upkeep.base import PlanSet
from htnagent.upkeep.failure import means_it_again, new_alternatives, starts_with, without_failed
from htnagent.upkeep.quality import (
    cheaper_rival,
    comparison_budget,
    first_own_step,
    fresher_kept,
    proven_optimal,
    rival_from,
    take_rival,
)
from htnagent.upkeep.recheck import recheck_all
from htnagent.upkeep.repair import LOCAL_BUDGET, LOCAL_MIN, LOCAL_SHARE, OnDemand, Repairer, SearchMemo
from htnagent.upkeep.revival import Revival
from htnagent.upkeep.stats import PlanningStats
from htnagent.upkeep.success import MovedOn, followed, kept_after_success, moved_on, ran
from htnagent.upkeep.suspension import Suspension, whole
from htnagent.upkeep.validity import Kept, by_cost, unique


class OnlinePlanSet(PlanSet):
    """On-line plan keeping (Dynagent style): up to K plans, modified after every event.

    ``revival_window`` bounds how many updates a removed plan waits for its fact,
    and ``revival_capacity`` how many removed plans are kept at once (see :class:`Revival`).
    """

    def __init__(
        self,
        domain: Domain,
        goal: Atom,
        settings: PlannerSettings | None = None,
        stats: PlanningStats | None = None,
        *,
        revival_window: int = 64,
        revival_capacity: int = 32,
    ) -> None:
        super().__init__(domain, goal, settings, stats)
        self.revival = Revival(domain, revival_window, revival_capacity)
        """Plans removed because a fact was false, waiting for it to be true again (§2.5)."""
        self._logged: list[Callable[[Plan], Plan | None]] = []
        """The rewrites of the plans the events made while the goal waited, not made yet
        (see :meth:`_follow_lazily`); only while the plans are stale."""

    def fork(self) -> Self:
        if self._logged:
            # The copy starts from the plans and done steps as they are.  Plan upkeep,
            # timed as such: the look-ahead forks a waiting goal's plans.
            with self._timed():
                self.catch_up()
        forked = super().fork()
        forked.revival = self.revival.copy()
        forked._logged = []
        return forked

    def adopt(self, other: PlanSet) -> Self:
        replaced = super().adopt(other)
        assert isinstance(other, OnlinePlanSet)
        self.revival = other.revival
        self._logged = list(other._logged)
        return replaced

    def drop(self) -> None:
        super().drop()
        self._stale = False
        self._logged = []
        self.revival.clear()

    # -- a goal waiting on the stack ------------------------------------------

    def _refresh(self, state: State, memo: SearchMemo | None = None) -> None:
        if self._stale:
            with self._timed():
                self._recheck_stale(state, memo)

    def _recheck_stale(self, state: State, memo: SearchMemo | None = None) -> None:
        # §2 step 4, deferred while the goal waited (see ``lazy``): re-check every plan
        # from the belief now, repair the broken ones (§2.4), revive what the changes since
        # the last check bring back (§2.5).
        since = self._stale_since if self._stale_since is not None else state
        self.catch_up()
        self._stale, self._stale_since = False, None
        if self._detour_beaten(state, memo):
            return
        self._revise(since, state, memo=memo)

    def _detour_beaten(self, state: State, memo: SearchMemo | None) -> bool:
        """The re-check (§2.4) and the shorter way at resumption (:meth:`shorten_detours`),
        in the order that spares a walk: the goal's lone plan comes back from its wait
        behind the undo steps of what the emergencies did (§2.1), to be walked and then
        offered a shorter way.  That way, searched first, is taken at once when it is
        cheaper and the estimate proves it optimal: nothing the walk could find (the plan
        valid, or repaired) would beat it.  Otherwise the plan is walked as always, and
        the search, made, is shared through ``memo``."""
        if len(self.plans) != 1:
            return False
        best = self.plans[0]
        first = first_own_step(best)
        if not first:
            return False
        rival = cheaper_rival(self, state, best, first, OnDemand(lambda: self._repairer(memo)))
        if rival is None or not proven_optimal(self, rival, state):
            return False
        self.revival.tick()  # an update, as the re-check would count it (§2.5's window)
        take_rival(self, rival)
        self._checked = state
        self._fresh_due = False  # as good as a plan made afresh: proven
        self.revival.expire()
        return True

    def _follow_lazily(
        self, change: Callable[[Plan], Plan | None], after: State, memo: SearchMemo | None = None
    ) -> None:
        """For a goal waiting on the stack (``lazy``): take the event's rewrite of each kept
        plan (and of each plan kept for revival) — ``change`` gives None for a kept plan
        the event ends (a plan kept for revival is then left as it is; a
        :class:`~htnagent.upkeep.success.MovedOn` leaves both as they are) — and leave the
        re-check until the goal is about to run again.

        The kept plans' rewrites are logged, and made when the goal is about to run again
        (:meth:`catch_up`): an emergency's actions all at once, not one copy of every plan
        per action.  (The look-ahead makes them while the last action before the goal
        resumes runs, §4: not at the resumption.)

        A goal no longer waiting whose plans were left so is re-checked now, from
        ``after`` (an earlier belief may not be one its plans can be mended from: the
        event may be what makes them good again)."""
        if not self._stale:
            self._stale, self._stale_since = True, self._checked
        self._checked = None
        self._logged.append(change)
        if self.revival:
            self.revival.rewrite(change)
        if not self.lazy:
            self._recheck_stale(after, memo)

    def catch_up(self) -> None:
        """Make the rewrites logged while the goal waited (:meth:`_follow_lazily`), in
        order; the actions that succeeded one after another in one pass
        (:func:`~htnagent.upkeep.success.followed`), with the steps of the goal's own
        they were added to its done steps.  The plans are then as rewritten event by
        event, not yet re-checked (that waits for the belief the goal runs from)."""
        if not self._logged:
            return
        logged, self._logged = self._logged, []
        plans, done = self.plans, self.done
        for successes, changes in groupby(logged, key=lambda change: isinstance(change, MovedOn)):
            if successes:
                moves = [change for change in changes if isinstance(change, MovedOn)]
                plans, ran_steps = followed(self.domain, plans, moves)
                for step in ran_steps:
                    done = Done(step, done)
            else:
                for change in changes:
                    plans = [q for p in plans if (q := change(p)) is not None]
        self.plans, self.done = plans, done

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
            extra = new_alternatives(result.plans, self.plans, failed)
            self.plans = sorted([*self.plans, *extra], key=lambda q: q.cost)[:k]
            self._checked = state

    # -- events ---------------------------------------------------------------

    def action_succeeded(
        self, action: Atom, before: State, after: State, memo: SearchMemo | None = None
    ) -> None:
        """The executed action finished with success; the belief went ``before`` → ``after`` (§2.1)."""
        if self.lazy or self._stale:
            with self._timed():
                self._follow_lazily(moved_on(self.domain, action), after, memo)
            return
        if len(self.plans) == 1 and before is self._checked:
            # The common case, what the general case below comes to for it: the one plan,
            # valid from ``before``, ran the action; it moves on and is valid from ``after``
            # -- and plans kept for revival follow, none coming back (after a repair, the
            # plan as it was waits there for 64 updates).
            only = self.plans[0]
            steps = only.steps
            if steps and steps[0].action == action and not self.revival.due(before, after):
                with self._timed():
                    self.done = Done(steps[0], self.done)
                    self.plans = [only.rest()]
                    self._checked = after
                    self.revival.tick()
                    if self.revival:
                        self.revival.rewrite(moved_on(self.domain, action))
                        self.revival.expire()
                return
        with self._timed():
            move = moved_on(self.domain, action)
            self._note_done(action)
            kept = kept_after_success(
                self.domain,
                self.plans,
                move,
                before,
                after,
                trusted=before is self._checked,
                untouched=lambda p: self._untouched(p, before, after),
            )
            # §2.5: plans kept for revival follow the same steps, so that a revived plan
            # is valid from where the robot is by then (not from where it was removed).
            if self.revival:
                self.revival.rewrite(move)
            self._revise(before, after, kept, memo=memo)

    def _note_done(self, action: Atom) -> None:
        """Add the step that did ``action`` to the goal's done steps, if a kept plan made it."""
        step = ran(self.plans, action)
        if step is not None:
            self.done = Done(step, self.done)

    def action_failed(
        self, action: Atom, before: State, after: State, memo: SearchMemo | None = None
    ) -> None:
        """The executed action failed (§2.2): plans starting with it go, the rest are re-checked."""
        if self.lazy or self._stale:
            with self._timed():
                self._follow_lazily(lambda p: None if starts_with(p, action) else p, after, memo)
            return
        with self._timed():
            had = bool(self.plans)
            self.plans = without_failed(self.plans, action)
            if had and not self.plans:
                # §2.2 takes a kept alternative at once: the first plan came alone, so
                # find the alternatives now — those that do not start with the failure.
                self.widen(before, failed=action)
            # An alternative that still means to do the failed action later is no better
            # than planning afresh (§2.4).
            broke = means_it_again(self.plans, action)
            self._revise(before, after, best_broke=broke, memo=memo)

    def action_suspended(
        self, action: Atom, before: State, after: State, memo: SearchMemo | None = None
    ) -> None:
        """The running action was stopped half way (§3, Algorithm 1, steps 2–3).

        ``after`` is the belief with the suspension effect (step 1, done by the caller).
        """
        with self._timed():
            suspended = Suspension(self.domain, action, rollbacks=self.settings.rollbacks)
            if self.lazy or self._stale:
                self._follow_lazily(suspended, after, memo)  # step 3's rewrite; its re-check waits
                return
            kept = suspended.kept(
                self.plans,
                before,
                after,
                trusted=before is self._checked,
                untouched=lambda p: self._untouched(p, before, after),
            )
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
            rewrite = whole(self.domain, action)
            if self.lazy or self._stale:
                self._follow_lazily(rewrite, after, memo)
                return
            resume = resume_action(action)
            kept = [
                Kept(p, self._untouched(p, before, after))
                if resume not in p.actions
                else Kept(rewrite(p), False)
                for p in self.plans
            ]
            self.revival.rewrite(rewrite)
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
                self._follow_lazily(lambda p: p, after, memo)
                return
            kept = [Kept(p, self._untouched(p, before, after)) for p in self.plans]
            self._revise(before, after, kept, memo=memo)

    # -- re-check, repair, quality --------------------------------------------

    def _repairer(self, memo: SearchMemo | None = None, *, local: bool = False) -> Repairer:
        """The searches of one update; with ``local``, the repairs' budgets: the goal's plan
        afresh gets what planning it from scratch took (:func:`~htnagent.upkeep.quality.comparison_budget`);
        below the goal, :data:`~htnagent.upkeep.repair.LOCAL_SHARE` of what that plan afresh
        took (:meth:`Repairer.repair`) -- or, where it found none, of what planning the goal
        from scratch took -- none if that is less than :data:`~htnagent.upkeep.repair.LOCAL_MIN`
        (the rest of :data:`~htnagent.upkeep.repair.LOCAL_BUDGET` once the goal has no plan
        afresh)."""
        if not local:
            return Repairer(self.domain, self.goal, self.settings, self.stats, self._avoided, memo)
        whole = min(self.settings.budget, LOCAL_BUDGET)
        known = self.scratch_expansions
        first = whole if known is None else min(whole, math.ceil(LOCAL_SHARE * known))
        if first < LOCAL_MIN:
            first = 0  # too small a share to pay for a search
        return Repairer(
            self.domain,
            self.goal,
            self.settings,
            self.stats,
            self._avoided,
            memo,
            local_budget=first,
            reserve=whole - first,
            fresh_budget=comparison_budget(self),
        )

    def _revise(
        self,
        before: State,
        after: State,
        kept: list[Kept] | None = None,
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
            kept = [Kept(p, False) for p in self.plans]
        elif not best_broke and not back and all(valid for _, valid in kept):
            # Every plan is known valid and nothing comes back: nothing to re-check.
            if len(kept) == 1:
                self.plans = [kept[0].plan]
            else:
                cheapest = sorted(unique(p for p, _ in kept), key=by_cost)
                self.plans = cheapest[: max(self.settings.alternatives, 1)]
            self._checked = after
            self.revival.expire()
            return
        repairer = OnDemand(lambda: self._repairer(memo, local=True))
        candidates = [*kept, *(Kept(p, False) for p in back)]
        self.plans, broke = recheck_all(self, self.revival, candidates, len(kept), after, repairer)
        if best_broke or broke:
            self._as_good_as_fresh(after, repairer)
        if repairer.made is not None and repairer.made.unsolvable is not None:
            self._unsolvable = repairer.made.unsolvable
        self._checked = after
        self.revival.expire()

    def _best_replaced(self, state: State, memo: SearchMemo | None = None) -> None:
        with self._timed():
            self._as_good_as_fresh(state, lambda: self._repairer(memo))

    def _as_good_as_fresh(self, state: State, repairer: Callable[[], Repairer]) -> bool:
        """§2.4: the best plan took the place of a broken one: it must be no worse than a
        plan made afresh from ``state`` (:func:`~htnagent.upkeep.quality.fresher_kept`).
        Returns whether it is known to be now (False: the search for a fresh plan found none).

        Once known, no comparison is due for a way opened earlier (:meth:`reconsider`).
        """
        known = fresher_kept(self, state, repairer)
        if known:
            self._fresh_due = False
        return known

    def reconsider(self, state: State, memo: SearchMemo | None = None) -> None:
        """§2.4's rule after a change from outside that may have opened a cheaper way (a
        door opened) while the goal waited on the stack, or while its action ran: its best
        plan, still valid, is compared with a plan made afresh (unless the estimate proves
        it optimal) before the goal acts again.  Naive plans afresh at resumption, and
        when its plan breaks; on-line never settles for a longer way than naive."""
        if not self._fresh_due:
            return
        self._fresh_due = False
        self._refresh(state, memo)
        best = self.best
        if best is None:
            return
        with self._timed():
            repairer = OnDemand(lambda: self._repairer(memo))
            if self._as_good_as_fresh(state, repairer):
                return
            # No plan afresh (the goal's methods may not start again from part of it
            # done): the lowest task above the first step is re-decomposed instead (not
            # the goal itself: that is the search that just found nothing).
            first = first_own_step(best)
            if first < len(best.steps):
                rival_from(self, state, best, first, repairer)

    def shorten_detours(self, state: State, memo: SearchMemo | None = None) -> bool:
        """Give a resumed goal the chance of a shorter way than its undo detour.

        docs/design.md §2.1 keeps a plan valid by putting the undo of every action
        the emergency made in front of it, so after an emergency the best kept
        plan may walk back first.  At resumption, if it starts with such inserted
        undo steps, it gets a rival: the lowest compound task above its first own
        step, re-decomposed from the current belief (a repair as in §2.4), plus
        what follows that task.  The cheaper of the two is selected.  Returns
        whether the plan was shortened.

        ``memo``: the searches made from ``state`` in the same update (a resumption's
        re-check may have planned the goal afresh from it already: the rival is that plan).
        """
        self._refresh(state, memo)
        best = self.best
        if best is None:
            return False
        # The detour: the leading steps that plan maintenance put there.
        first = first_own_step(best)
        if not first:
            return False
        with self._timed():
            return rival_from(self, state, best, first, lambda: self._repairer(memo))


__all__ = ["OnlinePlanSet"]
