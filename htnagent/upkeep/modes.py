"""How an agent keeps its plans: the two replanning modes (docs/design.md §2).

A setting users choose (scenario files, the command line, ``AgentConfig``).  Each
mode is a plan-set class of its own (:data:`~htnagent.upkeep.kinds.PLAN_SET_KINDS`);
nothing in plan upkeep asks which mode it is in.
"""

from __future__ import annotations

from enum import Enum


class Replanning(Enum):
    """How an agent keeps its plans."""

    ONLINE = "online"
    """Keep every alternative plan and modify it incrementally (Dynagent style)."""
    NAIVE = "naive"
    """Drop kept plans and plan from scratch whenever a plan is needed again."""


__all__ = ["Replanning"]
