"""htnagent: on-line HTN planning agents that handle emergency goals.

The planner and plan maintenance are pure synchronous code (:mod:`htnagent.planner`,
:mod:`htnagent.planset`); the runtime of agents on anyio sits on top
(:mod:`htnagent.runtime`, :mod:`htnagent.agent`).
"""

from __future__ import annotations

import logging

from htnagent.agent import Agent, AgentConfig, GoalStatus
from htnagent.domain import Domain, Effect, State, Suspension
from htnagent.executor import Executor, ExecutorActor, Outcome
from htnagent.plan import Plan, Step
from htnagent.planner import PlannerSettings, PlanResult, PlanStatus, plan
from htnagent.planset import PlanSet, Replanning
from htnagent.runtime import GoalOutcome, Runtime
from htnagent.terms import Atom, parse

logging.getLogger("htnagent").addHandler(logging.NullHandler())

__all__ = [
    "Agent",
    "AgentConfig",
    "Atom",
    "Domain",
    "Effect",
    "Executor",
    "ExecutorActor",
    "GoalOutcome",
    "GoalStatus",
    "Outcome",
    "Plan",
    "PlanResult",
    "PlanSet",
    "PlanStatus",
    "PlannerSettings",
    "Replanning",
    "Runtime",
    "State",
    "Step",
    "Suspension",
    "parse",
    "plan",
]
