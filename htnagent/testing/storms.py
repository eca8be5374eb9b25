"""Random and extreme scenarios for reliability runs (``python -m bench reliability``, tests).

- :func:`storm_data` — a random museum, one or two agents, normal goals,
  emergencies at random times (often during other emergencies), doors shut and
  opened, moves that fail at random, a per-action timeout;
- :func:`nested_storm_data` — emergencies one a second to a robot too slow to
  finish anything, so that they nest as deep as there are emergencies.

Both return the scenario as parsed YAML (for :func:`~htnagent.scenario.parse_scenario`).
:func:`storm` runs one and checks every invariant of
:class:`~htnagent.testing.invariants.RunChecker`; :func:`crash_run` runs one in which an
agent's domain raises part way (a bug), and checks everything else still holds.
"""

from __future__ import annotations

import random
from dataclasses import dataclass, field
from typing import Any

import anyio

from htnagent.domains.maps import generate_map, map_to_yaml_data
from htnagent.model.domain import Estimate, State
from htnagent.model.terms import Atom
from htnagent.runtime.events import ActionFinished, TraceEvent
from htnagent.scenario import parse_scenario
from htnagent.system.simulation import run_scenario
from htnagent.testing.invariants import RunChecker

HANG = 60.0
"""Real seconds after which a run counts as hung."""


def agent_chain(two_levels: bool) -> tuple[list[dict[str, str]], str, str]:
    """The museum agents (guide over navigator, or the navigator alone), the agent that
    takes the goals, and the name of its task to go somewhere."""
    navigator = {"name": "navigator", "domain": "museum.nodes", "executor": "robot"}
    if not two_levels:
        return [navigator], "navigator", "goto_node"
    guide = {"name": "guide", "domain": "museum.areas", "executor": "navigator"}
    return [guide, navigator], "guide", "goto"


def storm_data(seed: int) -> dict[str, Any]:
    """A random scenario (as parsed YAML) for ``seed``."""
    rng = random.Random(seed)
    world = generate_map(rng.randint(1, 3), rng.randint(1, 3), rng.randint(2, 3), seed)
    nodes = sorted(world.nodes)
    arcs = sorted(world.arcs)
    two_levels = rng.random() < 0.7
    agents, top, task = agent_chain(two_levels)
    goals: list[dict[str, Any]] = [
        {"agent": top, "task": f"{task}({rng.choice(nodes)})"} for _ in range(rng.randint(1, 3))
    ]
    for _ in range(rng.randint(0, 4)):
        goals.append(
            {
                "agent": top,
                "task": f"{task}({rng.choice(nodes)})",
                "emergency": True,
                "when": {"time": round(rng.uniform(0.0, 40.0), 2)},
            }
        )
    events: list[dict[str, Any]] = []
    for _ in range(rng.randint(0, 4)):
        arc = rng.choice(arcs)
        shut = round(rng.uniform(0.0, 60.0), 2)
        events.append({"when": {"time": shut}, "close": arc})
        if rng.random() < 0.7:
            events.append({"when": {"time": round(shut + rng.uniform(1.0, 30.0), 2)}, "open": arc})
    return {
        "name": f"storm {seed}",
        "map": map_to_yaml_data(world),
        "robot": {
            "start": rng.choice(nodes),
            "speed": 1.0,
            "failure_rate": rng.choice([0.0, 0.0, 0.05, 0.15]),
            "seed": seed,
        },
        "agents": agents,
        "action_timeout": 200.0,
        "goals": goals,
        "events": events,
    }


def nested_storm_data(count: int) -> dict[str, Any]:
    """A navigator on the museum map given ``count`` emergencies, one a second, nesting."""
    nodes = ["n38", "n35", "n31", "n29"]  # never where the robot stands
    goals: list[dict[str, Any]] = [{"agent": "navigator", "task": "goto_node(n1)"}]
    goals += [
        {
            "agent": "navigator",
            "task": f"goto_node({nodes[i % 4]})",
            "emergency": True,
            "when": {"time": 1.0 + i},
        }
        for i in range(count)
    ]
    return {
        "name": f"{count} nested emergencies",
        "map": "museum_map.yaml",
        "robot": {"start": "n40", "speed": 0.001},  # so slow that every emergency nests
        "agents": [{"name": "navigator", "domain": "museum.nodes", "executor": "robot"}],
        "goals": goals,
    }


@dataclass
class StormResult:
    """What one storm run submitted, injected and saw, and which invariants broke."""

    seed: int
    goals: int = 0
    emergencies: int = 0
    doors: int = 0
    failures_injected: int = 0
    succeeded: int = 0
    failed: int = 0
    lost: int = 0
    max_depth: int = 0
    violations: list[str] = field(default_factory=list)


async def storm(seed: int) -> StormResult:
    """Run one storm and check the invariants (:class:`~htnagent.testing.invariants.RunChecker`)."""
    data = storm_data(seed)
    scenario = parse_scenario(data, f"<storm {seed}>")
    result = StormResult(seed=seed)
    result.goals = len(data["goals"])
    result.emergencies = sum(1 for g in data["goals"] if g.get("emergency"))
    result.doors = len(data["events"])
    checker = RunChecker()

    def observe(event: TraceEvent) -> None:
        if isinstance(event, ActionFinished) and event.reason.startswith("the move failed"):
            result.failures_injected += 1

    before = _tasks()
    report = await run_scenario(scenario, observers=[checker, observe], on_start=checker.attach)
    result.violations += checker.finish()
    result.max_depth = checker.max_depth
    assert checker.runtime is not None
    result.lost = sum(1 for o in checker.runtime.outcomes.values() if o.status is None)
    for row in report.summary.goals:
        if row.status == "success":
            result.succeeded += 1
        else:
            result.failed += 1
    left = _tasks() - before
    if left:
        result.violations.append(f"{len(left)} task(s) left running")
    return result


def _tasks() -> set[Any]:
    return {t for t in anyio.get_running_tasks() if t.name is not None} - {
        t for t in anyio.get_running_tasks() if t.id == anyio.get_current_task().id
    }


async def crash_run(seed: int) -> tuple[int, int, bool, list[str]]:
    """A storm in which one agent's domain raises part way (a bug).

    Returns the goals given, the goals lost, whether an agent crashed, and the violations.
    """
    rng = random.Random(seed)
    data = storm_data(seed)
    data["robot"]["failure_rate"] = 0.0
    scenario = parse_scenario(data, f"<crash {seed}>")
    victim = rng.choice(scenario.agent_names)
    domain = scenario.domain_for(victim)
    calls = [0]
    fuse = rng.randint(1, 30)
    for name, estimate in list(domain.estimates.items()):

        def exploding(task: Atom, state: State, estimate: Estimate = estimate) -> float:
            calls[0] += 1
            if calls[0] == fuse:
                raise RuntimeError(f"injected bug after {fuse} estimates")
            return estimate(task, state)

        domain.estimates[name] = exploding
    checker = RunChecker()
    with anyio.fail_after(HANG):
        await run_scenario(scenario, observers=[checker], on_start=checker.attach)
    checker.finish()
    assert checker.runtime is not None
    lost = sum(1 for o in checker.runtime.outcomes.values() if o.status is None)
    # A crash is the fault injected here, not a violation; everything else still must hold.
    crashed = [v for v in checker.violations if "crashed" in v]
    violations = [v for v in checker.violations if "crashed" not in v]
    return len(data["goals"]), lost, bool(crashed), violations
