"""htnagent: on-line HTN planning agents that handle emergency goals.

The planner and plan maintenance are pure synchronous code (:mod:`htnagent.planner`,
:mod:`htnagent.planset`); the runtime of agents on anyio sits on top
(:mod:`htnagent.runtime`, :mod:`htnagent.agent`).

The names below are imported on first use: ``import htnagent`` itself costs
nothing, so the command line can install its signal handlers before anything
heavy is loaded (see :mod:`htnagent.launch`).
"""

from __future__ import annotations

import importlib
import logging
import sys
import types
from typing import TYPE_CHECKING, Any

logging.getLogger("htnagent").addHandler(logging.NullHandler())


class _Package(types.ModuleType):
    """This package: ``htnagent.plan`` is the planning function, loaded on first use.

    ``htnagent.plan`` is also a module (plans as values), and importing a submodule binds
    its name in the package: that binding is ignored, the function stays.
    """

    @property
    def plan(self) -> Any:
        chosen = self.__dict__.get("_plan")
        if chosen is not None:
            return chosen
        from htnagent.planner import plan

        return plan

    @plan.setter
    def plan(self, value: Any) -> None:
        if not isinstance(value, types.ModuleType):  # a submodule's binding is not taken
            self.__dict__["_plan"] = value

    @plan.deleter
    def plan(self) -> None:
        self.__dict__.pop("_plan", None)


sys.modules[__name__].__class__ = _Package

_WHERE = {
    "Agent": "agent",
    "AgentConfig": "agent",
    "GoalStatus": "agent",
    "Domain": "domain",
    "Effect": "domain",
    "State": "state",
    "Suspension": "domain",
    "DomainError": "errors",
    "HddlError": "errors",
    "HtnAgentError": "errors",
    "PlanningError": "errors",
    "PlotError": "errors",
    "RemoteError": "errors",
    "RuntimeClosedError": "errors",
    "ScenarioError": "errors",
    "SettingsError": "errors",
    "TextFormError": "errors",
    "TraceFormatError": "errors",
    "UnknownNameError": "errors",
    "EVENT_KINDS": "events",
    "event_from_dict": "events",
    "Summary": "events",
    "TraceEvent": "events",
    "Executor": "executor",
    "ExecutorActor": "executor",
    "ActionOutcome": "executor",
    "ActionFailed": "executor",
    "ExecutorContext": "executor",
    "Plan": "plan",
    "Step": "plan",
    "PlannerSettings": "planner",
    "PlanResult": "planner",
    "PlanStatus": "planner",
    "PlanSet": "planset",
    "Replanning": "planset",
    "GoalOutcome": "runtime",
    "Runtime": "runtime",
    "Scenario": "scenario",
    "load_scenario": "scenario",
    "RunReport": "simulation",
    "run_scenario": "simulation",
    "Atom": "terms",
    "parse": "terms",
    "EventStream": "trace",
}

__all__ = [
    "EVENT_KINDS",
    "ActionFailed",
    "ActionOutcome",
    "Agent",
    "AgentConfig",
    "Atom",
    "Domain",
    "DomainError",
    "Effect",
    "EventStream",
    "Executor",
    "ExecutorActor",
    "ExecutorContext",
    "GoalOutcome",
    "GoalStatus",
    "HddlError",
    "HtnAgentError",
    "Plan",
    "PlanResult",
    "PlanSet",
    "PlanStatus",
    "PlannerSettings",
    "PlanningError",
    "PlotError",
    "RemoteError",
    "Replanning",
    "RunReport",
    "Runtime",
    "RuntimeClosedError",
    "Scenario",
    "ScenarioError",
    "SettingsError",
    "State",
    "Step",
    "Summary",
    "Suspension",
    "TextFormError",
    "TraceEvent",
    "TraceFormatError",
    "UnknownNameError",
    "event_from_dict",
    "load_scenario",
    "parse",
    "plan",
    "run_scenario",
]


def __getattr__(name: str) -> Any:
    module = _WHERE.get(name)
    if module is None:
        raise AttributeError(f"module 'htnagent' has no attribute {name!r}")
    value = getattr(importlib.import_module(f"htnagent.{module}"), name)
    globals()[name] = value
    return value


def __dir__() -> list[str]:
    return sorted([*globals(), *_WHERE])


if TYPE_CHECKING:
    from htnagent.agent import Agent, AgentConfig, GoalStatus
    from htnagent.domain import Domain, Effect, Suspension
    from htnagent.errors import (
        DomainError,
        HddlError,
        HtnAgentError,
        PlanningError,
        PlotError,
        RuntimeClosedError,
        ScenarioError,
        SettingsError,
        TextFormError,
        TraceFormatError,
        UnknownNameError,
    )
    from htnagent.events import EVENT_KINDS, Summary, TraceEvent, event_from_dict
    from htnagent.executor import ActionFailed, ActionOutcome, Executor, ExecutorActor, ExecutorContext
    from htnagent.plan import Plan, Step
    from htnagent.planner import PlannerSettings, PlanResult, PlanStatus, plan
    from htnagent.planset import PlanSet, Replanning
    from htnagent.runtime import GoalOutcome, Runtime
    from htnagent.scenario import Scenario, load_scenario
    from htnagent.simulation import RunReport, run_scenario
    from htnagent.state import State
    from htnagent.terms import Atom, parse
    from htnagent.trace import EventStream
