"""How fast an emergency is served (``python -m bench reaction``): submit → first action at the robot.

The museum scenario (n40 → n1): at t = 2 s, while the robot is on arc59, the
emergency goto(n28) is submitted (``Runtime.submit``, from a clock timer, as a
user's code would).  The reaction time is the wall-clock time from that call to
the moment the simulated robot starts the emergency's first action (its
``robot_moving`` event) — suspending the running move, planning the
emergency, and sending its first action down, at every level.  One level (the
navigator alone, ``goto_node(n28)``) and two (guide over navigator,
``goto(n28)``); both modes, interleaved trial by trial so that the machine's
noise weighs on both alike.  Writes ``bench/results/reaction.json``:
``{levels, mode, median_ms, p99_ms, runs}``.
"""

from __future__ import annotations

import functools
import gc
import json
import statistics
import sys
import time
from pathlib import Path
from typing import Any

import anyio

from bench.machine import machine_line
from htnagent.model.terms import parse
from htnagent.runtime.events import RobotActing, RobotMoving, TraceEvent
from htnagent.scenario import Scenario, parse_scenario
from htnagent.system.runtime import Runtime
from htnagent.system.simulation import run_scenario

ROOT = Path(__file__).resolve().parent.parent
RESULTS = Path(__file__).resolve().parent / "results"
AT = 2.0


def scenario(levels: int) -> Scenario:
    """The museum run with one or two levels of agents, and no emergency of its own."""
    agents: list[dict[str, str]] = [{"name": "navigator", "domain": "museum.nodes", "executor": "robot"}]
    task = "goto_node(n1)"
    if levels == 2:
        agents.insert(0, {"name": "guide", "domain": "museum.areas", "executor": "navigator"})
        task = "goto(n1)"
    data: dict[str, Any] = {
        "name": f"reaction, {levels} level(s)",
        "map": "museum_map.yaml",
        "robot": {"start": "n40", "speed": 1.0},
        "agents": agents,
        "goals": [{"agent": agents[0]["name"], "task": task}],
    }
    return parse_scenario(data, "<reaction>", ROOT / "scenarios")


async def trial(levels: int, mode: str, built: Scenario) -> float:
    """One run: the reaction time in ms."""
    top = built.agent_names[0]
    emergency = parse("goto(n28)" if levels == 2 else "goto_node(n28)")
    mark: dict[str, float] = {}
    stop = anyio.Event()

    def on_start(runtime: Runtime) -> None:
        def submit() -> None:
            mark["submitted"] = time.perf_counter()
            runtime.submit(top, emergency, emergency=True)

        runtime.clock.call_at(AT, submit)

    def observe(event: TraceEvent) -> None:
        started = isinstance(event, RobotMoving | RobotActing)
        if started and "submitted" in mark and "served" not in mark:
            mark["served"] = time.perf_counter()
            stop.set()

    await run_scenario(built, replanning=mode, observers=[observe], on_start=on_start, stop=stop)
    return (mark["served"] - mark["submitted"]) * 1000


def main(runs: int = 300) -> int:
    """``runs`` trials per (levels, mode); print and write the figures."""
    built = {levels: scenario(levels) for levels in (1, 2)}
    samples: dict[tuple[int, str], list[float]] = {(lv, m): [] for lv in (1, 2) for m in ("online", "naive")}
    for key in samples:  # warm up: the domains' landmark tables, the imports
        anyio.run(functools.partial(trial, key[0], key[1], built[key[0]]))
    gc.collect()
    started = time.perf_counter()
    for i in range(runs):
        for (levels, mode), values in samples.items():
            gc.collect()  # so that a collection left over from the last trial does not land in this one
            values.append(anyio.run(functools.partial(trial, levels, mode, built[levels])))
        if (i + 1) % 100 == 0:
            elapsed = time.perf_counter() - started
            print(f"{i + 1}/{runs} trials, {elapsed:.0f} s", file=sys.stderr, flush=True)
    rows = []
    for (levels, mode), values in samples.items():
        ordered = sorted(values)
        rows.append(
            {
                "levels": levels,
                "mode": mode,
                "median_ms": round(statistics.median(ordered), 4),
                "p99_ms": round(ordered[min(len(ordered) - 1, int(0.99 * len(ordered)))], 4),
                "runs": len(ordered),
            }
        )
    RESULTS.mkdir(parents=True, exist_ok=True)
    (RESULTS / "reaction.json").write_text(json.dumps(rows, indent=2) + "\n")
    for row in rows:
        line = f"median {row['median_ms']:.3f} ms  p99 {row['p99_ms']:.3f} ms"
        print(f"{row['levels']} level(s) {row['mode']:<6} {line}")
    print(machine_line(), file=sys.stderr)
    return 0
