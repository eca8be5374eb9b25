"""htnagent: on-line HTN planning agents that handle emergency goals.

The package in layers, lowest first (docs/layout.md): ``model`` (terms, beliefs, domains,
plans), ``planning`` (the planner), ``upkeep`` (plans kept valid as the agent acts),
``runtime`` (messages, clock, trace, executors' interface), ``agent`` (Algorithms 2–5),
``system`` (agents in one task group; running a scenario), ``views`` and ``cli``.

The public names below are imported on first use: ``import htnagent`` itself costs
nothing, so the command line can install its signal handlers before anything
heavy is loaded (see :mod:`htnagent.cli.launch`).
"""

from __future__ import annotations

import importlib
from typing import TYPE_CHECKING, Any

# Every public name and the module it comes from: the one list (``__all__`` is made from it).
_EXPORTS: dict[str, str] = {
    "Agent": "agent",
    "AgentConfig": "agent",
    "GoalStatus": "agent",
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
    "Domain": "model.domain",
    "Effect": "model.operators",
    "Suspension": "model.operators",
    "Plan": "model.plans",
    "Step": "model.plans",
    "State": "model.state",
    "Atom": "model.terms",
    "parse": "model.terms",
    "plan": "planning.planner",
    "PlannerSettings": "planning.planner",
    "PlanResult": "planning.planner",
    "PlanStatus": "planning.planner",
    "PlanSet": "upkeep",
    "Replanning": "upkeep",
    "event_from_dict": "runtime.events",
    "EVENT_KINDS": "runtime.events",
    "Summary": "runtime.events",
    "TraceEvent": "runtime.events",
    "ActionFailed": "runtime.executor",
    "Alarm": "runtime.executor",
    "ActionOutcome": "runtime.executor",
    "Executor": "runtime.executor",
    "ExecutorActor": "runtime.executor",
    "ExecutorContext": "runtime.executor",
    "Phase": "runtime.progress",
    "Progress": "runtime.progress",
    "EventStream": "runtime.trace",
    "load_scenario": "scenario",
    "Scenario": "scenario",
    "GoalOutcome": "system.runtime",
    "Runtime": "system.runtime",
    "build_runtime": "system.simulation",
    "run_scenario": "system.simulation",
    "RunReport": "system.simulation",
}

if TYPE_CHECKING:
    # The same names for the type checker, re-exported (tests/test_public_api.py keeps the two equal).
    from htnagent.agent import (
        Agent as Agent,
    )
    from htnagent.agent import (
        AgentConfig as AgentConfig,
    )
    from htnagent.agent import (
        GoalStatus as GoalStatus,
    )
    from htnagent.errors import (
        DomainError as DomainError,
    )
    from htnagent.errors import (
        HddlError as HddlError,
    )
    from htnagent.errors import (
        HtnAgentError as HtnAgentError,
    )
    from htnagent.errors import (
        PlanningError as PlanningError,
    )
    from htnagent.errors import (
        PlotError as PlotError,
    )
    from htnagent.errors import (
        RemoteError as RemoteError,
    )
    from htnagent.errors import (
        RuntimeClosedError as RuntimeClosedError,
    )
    from htnagent.errors import (
        ScenarioError as ScenarioError,
    )
    from htnagent.errors import (
        SettingsError as SettingsError,
    )
    from htnagent.errors import (
        TextFormError as TextFormError,
    )
    from htnagent.errors import (
        TraceFormatError as TraceFormatError,
    )
    from htnagent.errors import (
        UnknownNameError as UnknownNameError,
    )
    from htnagent.model.domain import (
        Domain as Domain,
    )
    from htnagent.model.operators import (
        Effect as Effect,
    )
    from htnagent.model.operators import (
        Suspension as Suspension,
    )
    from htnagent.model.plans import (
        Plan as Plan,
    )
    from htnagent.model.plans import (
        Step as Step,
    )
    from htnagent.model.state import (
        State as State,
    )
    from htnagent.model.terms import (
        Atom as Atom,
    )
    from htnagent.model.terms import (
        parse as parse,
    )
    from htnagent.planning.planner import (
        PlannerSettings as PlannerSettings,
    )
    from htnagent.planning.planner import (
        PlanResult as PlanResult,
    )
    from htnagent.planning.planner import (
        PlanStatus as PlanStatus,
    )
    from htnagent.planning.planner import (
        plan as plan,
    )
    from htnagent.runtime.events import (
        EVENT_KINDS as EVENT_KINDS,
    )
    from htnagent.runtime.events import (
        Summary as Summary,
    )
    from htnagent.runtime.events import (
        TraceEvent as TraceEvent,
    )
    from htnagent.runtime.events import (
        event_from_dict as event_from_dict,
    )
    from htnagent.runtime.executor import (
        ActionFailed as ActionFailed,
    )
    from htnagent.runtime.executor import (
        ActionOutcome as ActionOutcome,
    )
    from htnagent.runtime.executor import (
        Alarm as Alarm,
    )
    from htnagent.runtime.executor import (
        Executor as Executor,
    )
    from htnagent.runtime.executor import (
        ExecutorActor as ExecutorActor,
    )
    from htnagent.runtime.executor import (
        ExecutorContext as ExecutorContext,
    )
    from htnagent.runtime.progress import (
        Phase as Phase,
    )
    from htnagent.runtime.progress import (
        Progress as Progress,
    )
    from htnagent.runtime.trace import (
        EventStream as EventStream,
    )
    from htnagent.scenario import (
        Scenario as Scenario,
    )
    from htnagent.scenario import (
        load_scenario as load_scenario,
    )
    from htnagent.system.runtime import (
        GoalOutcome as GoalOutcome,
    )
    from htnagent.system.runtime import (
        Runtime as Runtime,
    )
    from htnagent.system.simulation import (
        RunReport as RunReport,
    )
    from htnagent.system.simulation import (
        build_runtime as build_runtime,
    )
    from htnagent.system.simulation import (
        run_scenario as run_scenario,
    )
    from htnagent.upkeep import (
        PlanSet as PlanSet,
    )
    from htnagent.upkeep import (
        Replanning as Replanning,
    )

__all__ = sorted(_EXPORTS)


def __getattr__(name: str) -> Any:
    module = _EXPORTS.get(name)
    if module is None:
        raise AttributeError(f"module 'htnagent' has no attribute {name!r}")
    value = getattr(importlib.import_module(f"htnagent.{module}"), name)
    globals()[name] = value
    return value
