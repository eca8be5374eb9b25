"""TEMPORARY SHIM: removed at merge.  Plan repair lives in :mod:`htnagent.upkeep.repair`."""

# TEMPORARY SHIM: removed at merge.

from htnagent.upkeep.repair import LOCAL_BUDGET, Repairer, SearchMemo, done_subtasks, one_plan

__all__ = ["LOCAL_BUDGET", "Repairer", "SearchMemo", "done_subtasks", "one_plan"]
