"""The plan-set class of each replanning mode, and the factory that picks it.

The on-line and naive modes are two classes behind one interface
(:class:`~htnagent.upkeep.base.PlanSet`); a caller that holds a
:class:`~htnagent.upkeep.modes.Replanning` value looks its class up here once.
"""

from __future__ import annotations

from htnagent.model.domain import Domain
from htnagent.model.terms import Atom
from htnagent.planning.planner import PlannerSettings
from htnagent.upkeep.base import PlanSet
from htnagent.upkeep.modes import Replanning
from htnagent.upkeep.naive import NaivePlanSet
from htnagent.upkeep.online import OnlinePlanSet
from htnagent.upkeep.stats import PlanningStats

PLAN_SET_KINDS: dict[Replanning, type[PlanSet]] = {
    Replanning.ONLINE: OnlinePlanSet,
    Replanning.NAIVE: NaivePlanSet,
}
"""The plan-set class of each replanning mode."""


def new_plan_set(
    domain: Domain,
    goal: Atom,
    mode: Replanning = Replanning.ONLINE,
    settings: PlannerSettings | None = None,
    stats: PlanningStats | None = None,
) -> PlanSet:
    """The plans of ``goal``, kept as ``mode`` says (none yet: see :meth:`~PlanSet.ensure`)."""
    return PLAN_SET_KINDS[mode](domain, goal, settings, stats)


__all__ = ["PLAN_SET_KINDS", "new_plan_set"]
