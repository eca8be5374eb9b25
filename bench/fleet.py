"""Many robots in one process (``python -m bench fleet``): does the cost per robot stay flat?

Each robot is the museum scenario of ``scenarios/museum.yaml`` — a guide over a
navigator over a simulated robot, n40 → n1 with an emergency to n28 half way
along arc59 (here at t = 2.06 s, when the robot is there) — in its own
:class:`~htnagent.system.runtime.Runtime`.  All the runtimes share one
:class:`~htnagent.runtime.clock.Clock` (one time keeper, no polling per robot) and one
event loop; the domains (built once from the map) are shared too.  For 10, 100
and 1,000 robots it measures the wall time until every goal has ended, the
cost per robot, the messages per second and the memory per agent (resident set
growth), and writes ``bench/results/fleet.json``:
``{robots, wall_s, per_robot_ms, messages_per_s, rss_mb}`` (plus ``setup_s``, the
part of ``wall_s`` spent building and starting the runtimes).  As a long-running
server would, it freezes the garbage collector's view of what was built before
the goals are given (``gc.freeze``).
"""

from __future__ import annotations

import gc
import json
import resource
import sys
import time
from pathlib import Path
from typing import Any

import anyio
from anyio.abc import TaskStatus

from bench.machine import machine_line
from htnagent.agent import AgentConfig, GoalStatus
from htnagent.executors.robot import Robot, RobotWorld
from htnagent.model.terms import parse
from htnagent.runtime.clock import Clock
from htnagent.runtime.events import MessageSent, TraceEvent
from htnagent.runtime.trace import Trace
from htnagent.scenario import load_scenario
from htnagent.system.runtime import Runtime

ROOT = Path(__file__).resolve().parent.parent
RESULTS = Path(__file__).resolve().parent / "results"
SIZES = (10, 100, 1000)
EMERGENCY_AT = 2.0616  # half way along arc59 (4.123 m at 1 m/s)


def _rss_mb() -> float:
    """The resident set size of this process now, in MB (the peak where /proc is missing)."""
    try:
        with open("/proc/self/statm") as f:
            return int(f.read().split()[1]) * resource.getpagesize() / 2**20
    except OSError:
        return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024


async def fleet(robots: int, freeze: bool = True) -> dict[str, Any]:
    """Run ``robots`` museum robots together; their figures.  ``freeze``: freeze the
    garbage collector's view of everything built before the goals are given."""
    scenario = load_scenario(ROOT / "scenarios" / "museum.yaml")
    configs = [(a.name, scenario.domain_for(a.name), scenario.initial_state(a.name)) for a in scenario.agents]
    clock = Clock()
    messages = [0]

    def count(event: TraceEvent) -> None:
        if isinstance(event, MessageSent):
            messages[0] += 1

    def robot_factory(c: Clock, trace: Trace) -> Robot:
        world = RobotWorld(scenario.world, at=scenario.robot.start)
        return Robot(world, scenario.robot.metres_per_second)

    gc.collect()
    rss_before = _rss_mb()
    started = time.perf_counter()
    statuses: list[GoalStatus | None] = []
    finished = anyio.Event()

    async def hold(runtime: Runtime, *, task_status: TaskStatus[None] = anyio.TASK_STATUS_IGNORED) -> None:
        # Each robot's runtime in a task of its own, side by side (not nested: a cancel
        # scope nested a thousand deep would make every step cost as much as the depth).
        async with runtime:
            task_status.started()
            await finished.wait()

    async with anyio.create_task_group() as tg:
        tg.start_soon(clock.keep_time)
        runtimes = []
        for _ in range(robots):
            runtime = Runtime(
                [AgentConfig(name, domain, belief) for name, domain, belief in configs],
                robot_factory,
                clock=clock,
            )
            runtime.subscribe(count)
            await tg.start(hold, runtime)
            runtimes.append(runtime)
        if freeze:
            # What a long-running server does once started (Python's gc docs): the
            # long-lived objects (runtimes, domains, beliefs) leave the collector's view,
            # so that collections do not cost more as the fleet grows.
            gc.collect()
            gc.freeze()
        setup = time.perf_counter() - started
        tickets = []
        for runtime in runtimes:
            tickets.append((runtime, runtime.submit("guide", parse("goto(n1)"))))

            def urgent(rt: Runtime = runtime) -> None:
                tickets.append((rt, rt.submit("guide", parse("goto(n28)"), emergency=True)))

            clock.call_at(EMERGENCY_AT, urgent)
        done = anyio.Event()
        clock.call_at(EMERGENCY_AT, done.set)
        await done.wait()
        for runtime, ticket in list(tickets):
            statuses.append((await runtime.outcome(ticket)).status)
        wall = time.perf_counter() - started
        rss = _rss_mb() - rss_before
        finished.set()
        tg.cancel_scope.cancel()
    gc.unfreeze()
    ok = all(s is GoalStatus.SUCCESS for s in statuses) and len(statuses) == 2 * robots
    return {
        "robots": robots,
        "wall_s": round(wall, 3),
        "setup_s": round(setup, 3),
        "per_robot_ms": round(wall / robots * 1000, 3),
        "messages_per_s": round(messages[0] / wall),
        "rss_mb": round(rss / (2 * robots), 4),
        "all_succeeded": ok,
    }


def main(sizes: tuple[int, ...] = SIZES) -> int:
    """Run the fleet study; print and write the figures."""
    rows = []
    anyio.run(fleet, sizes[0])  # warm up (imports, caches): the first size is not charged for them
    for robots in sizes:
        print(f"{robots} robots ...", end=" ", file=sys.stderr, flush=True)
        row = anyio.run(fleet, robots)
        rows.append(row)
        print(
            f"{row['wall_s']} s, {row['per_robot_ms']} ms a robot, {row['messages_per_s']} messages/s, "
            f"{row['rss_mb']} MB an agent{'' if row['all_succeeded'] else ', SOME GOALS FAILED'}",
            file=sys.stderr,
            flush=True,
        )
    RESULTS.mkdir(parents=True, exist_ok=True)
    (RESULTS / "fleet.json").write_text(json.dumps(rows, indent=2) + "\n")
    growth = rows[-1]["per_robot_ms"] / rows[0]["per_robot_ms"]
    print(
        f"cost per robot at {rows[-1]['robots']} robots: {growth:.2f}× that at {rows[0]['robots']} "
        f"({machine_line()})",
        file=sys.stderr,
    )
    return 0 if all(r["all_succeeded"] for r in rows) else 1
