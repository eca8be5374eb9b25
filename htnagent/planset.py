"""TEMPORARY SHIM: removed at merge.  Plan upkeep lives in :mod:`htnagent.upkeep`.

Kept only so that ``htnagent/agent.py`` (being rewritten elsewhere) still imports
and builds its plan sets as ``PlanSet(domain, goal, mode, settings, stats)``;
everything else imports :mod:`htnagent.upkeep`.
"""

# TEMPORARY SHIM: removed at merge.

from __future__ import annotations

from typing import TYPE_CHECKING

from htnagent.domain import Domain
from htnagent.planner import PlannerSettings
from htnagent.terms import Atom
from htnagent.upkeep import (
    NaivePlanSet,
    OnlinePlanSet,
    PlanningStats,
    Repairer,
    Replanning,
    Revival,
    SearchMemo,
    new_plan_set,
)
from htnagent.upkeep import PlanSet as _PlanSet

if TYPE_CHECKING:

    class PlanSet(_PlanSet):
        """The old constructor's signature, for the type checker (TEMPORARY SHIM)."""

        def __init__(
            self,
            domain: Domain,
            goal: Atom,
            mode: Replanning | None = None,
            settings: PlannerSettings | None = None,
            stats: PlanningStats | None = None,
        ) -> None: ...

else:
    # TEMPORARY SHIM: a function standing for the old class's constructor.
    def PlanSet(
        domain: Domain,
        goal: Atom,
        mode: Replanning | None = None,
        settings: PlannerSettings | None = None,
        stats: PlanningStats | None = None,
    ) -> _PlanSet:
        return new_plan_set(domain, goal, mode or Replanning.ONLINE, settings, stats)


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
