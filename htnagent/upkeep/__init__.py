"""Plan upkeep: a goal's alternative plans kept valid while the agent acts (docs/design.md §2–§3).

One rule a module, each citing the step it implements:

- :mod:`~htnagent.upkeep.base` — :class:`PlanSet`, what both modes share:
  planning afresh when nothing is left (§2.7), achieved only now (§2.8);
- :mod:`~htnagent.upkeep.online` — :class:`OnlinePlanSet` (Dynagent style),
  built from :mod:`~htnagent.upkeep.success` (§2.1),
  :mod:`~htnagent.upkeep.failure` (§2.2), :mod:`~htnagent.upkeep.suspension`
  (§3, Algorithm 1), :mod:`~htnagent.upkeep.recheck` and
  :mod:`~htnagent.upkeep.repair` (§2.4), :mod:`~htnagent.upkeep.quality` (no
  worse than planning afresh, §2.4), :mod:`~htnagent.upkeep.revival` (§2.5);
  the tidy-up (§2.6) is :func:`htnagent.model.plans.tidy`;
- :mod:`~htnagent.upkeep.naive` — :class:`NaivePlanSet`, kept for comparison;
- :mod:`~htnagent.upkeep.kinds` — the class of each :class:`Replanning` mode
  (:data:`PLAN_SET_KINDS`) and :func:`new_plan_set`.

Pure and synchronous: the agent runtime calls it; no event loop inside.
"""

from htnagent.upkeep.base import PlanSet
from htnagent.upkeep.kinds import PLAN_SET_KINDS, new_plan_set
from htnagent.upkeep.modes import Replanning
from htnagent.upkeep.naive import NaivePlanSet
from htnagent.upkeep.online import OnlinePlanSet
from htnagent.upkeep.repair import LOCAL_BUDGET, Repairer, SearchMemo, done_subtasks, one_plan
from htnagent.upkeep.revival import Revival
from htnagent.upkeep.stats import PlanningStats

__all__ = [
    "LOCAL_BUDGET",
    "PLAN_SET_KINDS",
    "NaivePlanSet",
    "OnlinePlanSet",
    "PlanSet",
    "PlanningStats",
    "Repairer",
    "Replanning",
    "Revival",
    "SearchMemo",
    "done_subtasks",
    "new_plan_set",
    "one_plan",
]
