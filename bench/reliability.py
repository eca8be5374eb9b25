"""Storms: random museums, goals, nested emergencies, faults, doors (``python -m bench reliability``).

Each storm run builds a random scenario — a generated map, a guide and a
navigator (or the navigator alone), normal goals, emergencies at random times
(often arriving during other emergencies), doors shut and opened at random,
moves that fail at random, and a per-action timeout — runs it to the end and
checks, on every run, the invariants of
:class:`~htnagent.testing.invariants.RunChecker` (every goal ends exactly once;
beliefs match the robot; no action starts against the world; a reached goal
has the robot there; emergencies are served at once; stacks end empty; no
agent crashes) and that no task is left running.

:func:`storm` runs one seeded storm and returns what it saw; the test suite
runs a bounded number through hypothesis, the benchmark many more.
"""

from __future__ import annotations

import json
import random
import sys
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import anyio

from htnagent.maps import generate_map, map_to_yaml_data
from htnagent.scenario import parse_scenario
from htnagent.simulation import run_scenario
from htnagent.testing.invariants import RunChecker
from htnagent.trace import Event

RESULTS = Path(__file__).resolve().parent / "results"


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


def storm_data(seed: int) -> dict[str, Any]:
    """A random scenario (as parsed YAML) for ``seed``."""
    rng = random.Random(seed)
    world = generate_map(rng.randint(1, 3), rng.randint(1, 3), rng.randint(2, 3), seed)
    nodes = sorted(world.nodes)
    arcs = sorted(world.arcs)
    two_levels = rng.random() < 0.7
    agents = (
        [
            {"name": "guide", "domain": "museum.areas", "executor": "navigator"},
            {"name": "navigator", "domain": "museum.nodes", "executor": "robot"},
        ]
        if two_levels
        else [{"name": "navigator", "domain": "museum.nodes", "executor": "robot"}]
    )
    top = agents[0]["name"]
    task = "goto" if two_levels else "goto_node"
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


async def storm(seed: int) -> StormResult:
    """Run one storm and check the invariants (:class:`~htnagent.testing.invariants.RunChecker`)."""
    data = storm_data(seed)
    scenario = parse_scenario(data, f"<storm {seed}>")
    result = StormResult(seed=seed)
    result.goals = len(data["goals"])
    result.emergencies = sum(1 for g in data["goals"] if g.get("emergency"))
    result.doors = len(data["events"])
    checker = RunChecker()

    def observe(event: Event) -> None:
        if event["event"] == "action_finished" and event.get("reason", "").startswith("the move failed"):
            result.failures_injected += 1

    before = _tasks()
    report = await run_scenario(scenario, observers=[checker, observe], on_start=checker.attach)
    result.violations += checker.finish()
    result.max_depth = checker.max_depth
    assert checker.runtime is not None
    result.lost = sum(1 for o in checker.runtime.outcomes.values() if o.status is None)
    for row in report.summary["goals"]:
        if row["status"] == "success":
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


def main(runs: int = 300) -> int:
    """Run ``runs`` storms; print and write the figures."""
    totals: dict[str, int] = {
        "runs": 0,
        "goals": 0,
        "emergencies": 0,
        "doors": 0,
        "faults_injected": 0,
        "succeeded": 0,
        "failed_with_reason": 0,
        "lost": 0,
        "max_stack_depth": 0,
        "violations": 0,
    }
    started = time.perf_counter()
    bad: list[str] = []
    for seed in range(runs):
        r = anyio.run(storm, seed)
        totals["runs"] += 1
        totals["goals"] += r.goals
        totals["emergencies"] += r.emergencies
        totals["doors"] += r.doors
        totals["faults_injected"] += r.failures_injected
        totals["succeeded"] += r.succeeded
        totals["failed_with_reason"] += r.failed
        totals["lost"] += r.lost
        totals["max_stack_depth"] = max(totals["max_stack_depth"], r.max_depth)
        totals["violations"] += len(r.violations)
        bad += [f"seed {seed}: {v}" for v in r.violations]
        if (seed + 1) % 50 == 0:
            print(
                f"{seed + 1}/{runs} storms, {time.perf_counter() - started:.0f} s",
                file=sys.stderr,
                flush=True,
            )
    RESULTS.mkdir(parents=True, exist_ok=True)
    (RESULTS / "reliability.json").write_text(json.dumps({**totals, "examples": bad[:20]}, indent=2) + "\n")
    for key, value in totals.items():
        print(f"{key:>20}: {value}")
    for line in bad[:20]:
        print("  " + line)
    return 1 if bad else 0
