"""Naive plan keeping, kept for comparison (docs/design.md §2, last paragraph).

The rule: "The naive mode [...] drops every kept plan and plans from scratch
whenever a plan is needed again."
"""

from __future__ import annotations

from htnagent.model.state import State
from htnagent.model.terms import Atom
from htnagent.planning.planner import PlannerSettings
from htnagent.upkeep.base import PlanSet
from htnagent.upkeep.repair import SearchMemo, one_plan
from htnagent.upkeep.suspension import whole


class NaivePlanSet(PlanSet):
    """Naive plan keeping: only the plan being executed, planned afresh when needed again.

    The plan follows the actions it makes; any other event — a failure, a
    suspension, a belief change that breaks it — drops it, and the next
    :meth:`~PlanSet.ensure` plans from scratch (one plan, no alternatives).
    """

    def widen(self, state: State, *, failed: Atom | None = None) -> None:
        """Nothing is kept in naive mode, so nothing is added."""

    def _search_settings(self) -> PlannerSettings:
        return one_plan(self.settings)

    def _best_replaced(self, state: State, memo: SearchMemo | None = None) -> None:
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
            rewrite = whole(self.domain, action)
            self.plans = [p for p in map(rewrite, self.plans[:1]) if self._valid(p, after)]
            self._checked = after

    def belief_changed(self, before: State, after: State, memo: SearchMemo | None = None) -> None:
        """The plan stays if still valid."""
        with self._timed():
            if self.plans and not self._valid(self.plans[0], after):
                self.plans = []
            self._checked = after


__all__ = ["NaivePlanSet"]
