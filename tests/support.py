"""What several test files share: trace events in their JSON form (``run --json``'s objects),
and the shipped scenarios' runs.

Tests compare events as the dicts users script against; the library hands out typed
events (:mod:`htnagent.runtime.events`).
"""

from __future__ import annotations

import functools
import json
from collections.abc import Callable, Iterable, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import anyio
import pytest

from htnagent.hddl import parse_domain, parse_problem
from htnagent.model.domain import Domain, State
from htnagent.model.terms import Atom
from htnagent.planning.composition import Composition, ground
from htnagent.planning.hddl_translation import HddlPlanning, translate
from htnagent.planning.planner import PlannerSettings, plan
from htnagent.runtime.events import TraceEvent
from htnagent.runtime.trace import WALL_CLOCK_FIELDS
from htnagent.scenario import Scenario, load_scenario, parse_scenario
from htnagent.system.simulation import RunReport, run_scenario
from htnagent.upkeep import repair as repair_module

Event = dict[str, Any]
"""A trace event's JSON object."""


def as_dicts(events: Iterable[TraceEvent]) -> list[Event]:
    """The events' JSON objects."""
    return [e.as_dict() for e in events]


def record(into: list[Event]) -> Callable[[TraceEvent], None]:
    """An observer that appends each event's JSON object to ``into``."""
    return lambda event: into.append(event.as_dict())


def events_of(report: RunReport) -> list[Event]:
    """A run's events (kept with ``keep_events=True``) as JSON objects."""
    return as_dicts(report.events)


def summary_of(report: RunReport) -> Event:
    """A run's summary event as its JSON object."""
    return report.summary.as_dict()


def statuses(report: RunReport) -> list[str]:
    """Each goal's status in a run's summary, in the order the goals were given."""
    return [g["status"] for g in summary_of(report)["goals"]]


SCENARIO_DIR = Path(__file__).resolve().parents[1] / "scenarios"

SHIPPED = tuple(sorted(p.name for p in SCENARIO_DIR.glob("*.yaml") if p.name != "museum_map.yaml"))
"""Every scenario shipped in ``scenarios/`` (the map file aside)."""


def inline(data: dict[str, Any], name: str = "inline.yaml") -> Scenario:
    """A scenario written in the test, on the museum map."""
    return parse_scenario({"name": name, "map": "museum_map.yaml", **data}, name, SCENARIO_DIR)


def half_way_emergency(*, then: Sequence[dict[str, Any]] = (), close: Sequence[str] = ()) -> dict[str, Any]:
    """The navigator alone walks n40 → n35 along arc59; half way (the walk's progress) the
    emergency goto_node(n29) arrives.  ``then``: goals given after these two; ``close``: arcs
    shut at t = 1 s, while the robot walks."""
    return {
        "robot": {"start": "n40", "speed": 1.0},
        "agents": [{"name": "navigator", "domain": "museum.nodes", "executor": "robot"}],
        "goals": [
            {"agent": "navigator", "task": "goto_node(n35)"},
            {
                "agent": "navigator",
                "task": "goto_node(n29)",
                "emergency": True,
                "when": {"action": "move(n40,n35,arc59)", "progress": 0.5},
            },
            *then,
        ],
        "events": [{"when": {"time": 1.0}, "close": arc} for arc in close],
    }


@functools.cache
def shipped_run(name: str) -> tuple[Scenario, tuple[TraceEvent, ...]]:
    """A shipped scenario and its run's events (run once per test session; do not change them)."""
    scenario = load_scenario(SCENARIO_DIR / name)
    report = anyio.run(functools.partial(run_scenario, scenario, keep_events=True))
    return scenario, tuple(report.events)


def without_wall_clock(value: Any) -> Any:
    """An event's JSON object (or any part of it) with every wall-clock field left out, at any
    depth (the summary's resumptions too): what must be the same from run to run."""
    if isinstance(value, dict):
        return {k: without_wall_clock(v) for k, v in value.items() if k not in WALL_CLOCK_FIELDS}
    if isinstance(value, list):
        return [without_wall_clock(v) for v in value]
    return value


def write_trace(events: Iterable[TraceEvent], path: Path) -> Path:
    """``events`` as ``run --json`` writes them, into ``path``."""
    path.write_text("".join(json.dumps(e.as_dict(), separators=(",", ":")) + "\n" for e in events))
    return path


def one_error_line(err: str) -> str:
    """The one line a refused command printed on stderr (no traceback)."""
    assert "Traceback" not in err
    lines = err.splitlines()
    assert len(lines) == 1, err
    assert lines[0].startswith("htnagent: error: ")
    return lines[0]


@dataclass(frozen=True, slots=True)
class Search:
    """One search plan repair made: its tasks (as text), settings and expansions."""

    tasks: list[str]
    settings: PlannerSettings
    expansions: int


def record_repair_searches(monkeypatch: pytest.MonkeyPatch) -> list[Search]:
    """Every search :mod:`htnagent.upkeep.repair` makes from now on (repairs, the goal's
    re-plan, the comparison with a fresh plan), in order."""
    searches: list[Search] = []

    def recording(domain: Domain, state: State, tasks: list[object], *args: object, **kw: object) -> object:
        settings = args[0] if args else kw["settings"]
        assert isinstance(settings, PlannerSettings)
        result = plan(domain, state, tasks, *args, **kw)  # type: ignore[arg-type]
        named = [str(t[0] if isinstance(t, tuple) else t) for t in tasks]
        searches.append(Search(named, settings, result.expansions))
        return result

    monkeypatch.setattr(repair_module, "plan", recording)
    return searches


def grounded(planning: HddlPlanning) -> Composition:
    """The grounded estimate of a translated HDDL problem (its grounding must be affordable)."""
    found = ground(planning.domain, planning.state, planning.tasks)
    assert found is not None
    return found


def fact(name: str, *args: str) -> Atom:
    """The ground atom ``name(args...)``."""
    return Atom(name, args)


def translated(domain_text: str, problem_text: str) -> HddlPlanning:
    """An HDDL domain and problem, given as text, read and translated for the planner."""
    domain = parse_domain(domain_text, "domain.hddl")
    return translate(domain, parse_problem(problem_text, domain, "problem.hddl"))
