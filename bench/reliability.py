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

:func:`~htnagent.testing.storms.storm` runs one seeded storm and returns what it saw;
the test suite runs a bounded number through hypothesis, the benchmark many more.
"""

from __future__ import annotations

import json
import random
import sys
import time
from pathlib import Path
from typing import Any

import anyio

from htnagent.scenario import parse_scenario
from htnagent.system.simulation import build_runtime, run_scenario
from htnagent.testing.invariants import RunChecker
from htnagent.testing.storms import HANG, crash_run, nested_storm_data, storm, storm_data

RESULTS = Path(__file__).resolve().parent / "results"
SCENARIOS = Path(__file__).resolve().parent.parent / "scenarios"


async def close_run(seed: int) -> tuple[int, int, int]:
    """Goals given, then the runtime left at a random moment: (goals, lost, woken waiters)."""
    rng = random.Random(seed)
    data = storm_data(seed)
    scenario = parse_scenario(data, f"<close {seed}>")
    runtime, _ = build_runtime(scenario)
    top = scenario.agent_names[0]
    tickets: list[int] = []
    woken = [0]

    async def wait(ticket: int) -> None:
        await runtime.outcome(ticket)
        woken[0] += 1

    with anyio.fail_after(HANG):
        async with anyio.create_task_group() as waiters, runtime:
            for i, goal in enumerate(scenario.goals):
                ticket = runtime.submit(top, scenario.goal_task(i), emergency=goal.emergency)
                tickets.append(ticket)
                waiters.start_soon(wait, ticket)
            leave = anyio.Event()
            runtime.clock.call_at(rng.uniform(0.0, 30.0), leave.set)
            await leave.wait()
    lost = sum(1 for t in tickets if not runtime.outcomes[t].done)
    return len(tickets), lost, woken[0]


async def nested_run(count: int, mode: str) -> dict[str, Any]:
    """``count`` emergencies nesting: depth reached, goals lost, seconds taken."""
    scenario = parse_scenario(nested_storm_data(count), "<nested>", SCENARIOS)
    checker = RunChecker()
    started = time.perf_counter()
    with anyio.fail_after(HANG * 10):
        report = await run_scenario(scenario, replanning=mode, observers=[checker], on_start=checker.attach)
    checker.finish()
    assert checker.runtime is not None
    statuses = [g.status for g in report.summary.goals]
    return {
        "emergencies": count,
        "mode": mode,
        "max_depth": checker.max_depth,
        "goals": len(statuses),
        "succeeded": statuses.count("success"),
        "lost": sum(1 for o in checker.runtime.outcomes.values() if o.status is None),
        "violations": len(checker.violations),
        "seconds": round(time.perf_counter() - started, 1),
    }


def main(runs: int = 300) -> int:
    """Run ``runs`` storms, crashes and closes, and the 1,000-deep storm; print and write the figures."""
    totals = _storms(runs)
    bad = totals.pop("examples")
    started = time.perf_counter()
    crashes = {"runs": 0, "crashed": 0, "goals": 0, "lost": 0, "hangs": 0, "violations": 0}
    closes = {"runs": 0, "goals": 0, "lost": 0, "waiters_woken": 0, "hangs": 0}
    for seed in range(runs):
        crashes["runs"] += 1
        closes["runs"] += 1
        try:
            goals, lost, crashed, violations = anyio.run(crash_run, seed)
            crashes["crashed"] += crashed
            crashes["goals"] += goals
            crashes["lost"] += lost
            crashes["violations"] += len(violations)
            bad += [f"crash {seed}: {v}" for v in violations]
        except TimeoutError:
            crashes["hangs"] += 1
            bad.append(f"crash {seed}: hung")
        try:
            goals, lost, woken = anyio.run(close_run, seed)
            closes["goals"] += goals
            closes["lost"] += lost
            closes["waiters_woken"] += woken
        except TimeoutError:
            closes["hangs"] += 1
            bad.append(f"close {seed}: hung")
        if (seed + 1) % 100 == 0:
            elapsed = time.perf_counter() - started
            print(f"{seed + 1}/{runs} crash and close runs, {elapsed:.0f} s", file=sys.stderr, flush=True)
    if crashes["lost"] or closes["lost"] or closes["waiters_woken"] != closes["goals"]:
        bad.append("goals lost in crash or close runs")
    nested = []
    for mode in ("online", "naive"):
        print(f"1,000 nested emergencies, {mode} ...", file=sys.stderr, flush=True)
        row = anyio.run(nested_run, 1000, mode)
        nested.append(row)
        if row["lost"] or row["violations"] or row["succeeded"] != row["goals"]:
            bad.append(f"nested storm ({mode}): {row}")
    RESULTS.mkdir(parents=True, exist_ok=True)
    result = {"storms": totals, "crashes": crashes, "closes": closes, "nested": nested, "examples": bad[:20]}
    (RESULTS / "reliability.json").write_text(json.dumps(result, indent=2) + "\n")
    for name, figures in (("storms", totals), ("crashes", crashes), ("closes", closes)):
        print(f"{name}: " + ", ".join(f"{k} {v}" for k, v in figures.items()))
    for row in nested:
        print("nested: " + ", ".join(f"{k} {v}" for k, v in row.items()))
    for line in bad[:20]:
        print("  " + line)
    return 1 if bad else 0


def _storms(runs: int) -> dict[str, Any]:
    totals: dict[str, Any] = {
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
        if (seed + 1) % 100 == 0:
            elapsed = time.perf_counter() - started
            print(f"{seed + 1}/{runs} storms, {elapsed:.0f} s", file=sys.stderr, flush=True)
    totals["examples"] = bad
    return totals
