"""Differential testing: random scenarios run on-line and naive, and compared.

On-line replanning keeps and modifies plans; naive replanning plans afresh
whenever a plan is needed.  On-line must be at least as right as naive
everywhere (docs/design.md §2.4, §2.8, §4).  :func:`scenario_data` makes a
random scenario from a seed — a generated museum, one agent or a guide over a
navigator, normal goals, emergencies at random times and on the progress of a
move (often nested), doors shut and opened — and :func:`compare` runs it in
both modes and checks:

- every run keeps the invariants of :class:`~htnagent.testing.invariants.RunChecker`
  (a ``goto`` success has the robot at that node; an emergency is served in
  the same instant; beliefs match the robot; every goal ends once; ...);
- both modes end every goal the same way;
- on-line travels no farther than naive: within :data:`NO_DOORS_SLACK` when no
  door moves, within :data:`DOORS_SLACK` per run with doors (and, summed over
  many runs, :data:`DOORS_TOTAL_SLACK` — checked by the caller).
"""

from __future__ import annotations

import random
from dataclasses import dataclass, field
from typing import Any

from htnagent.domains.maps import generate_map, map_to_yaml_data
from htnagent.runtime.events import RobotMoving, TraceEvent
from htnagent.scenario import parse_scenario
from htnagent.system.runtime import Runtime
from htnagent.system.simulation import run_scenario
from htnagent.testing.invariants import RunChecker
from htnagent.testing.storms import agent_chain

NO_DOORS_SLACK = 0.02
"""Without door events, on-line may travel at most 2% farther than naive."""
DOORS_SLACK = 0.10
"""With door events, at most 10% farther in one run (timing decides which door is met shut)."""
DOORS_TOTAL_SLACK = 0.01
"""With door events, at most 1% farther summed over many runs."""


@dataclass
class ModeRun:
    """One scenario run in one mode."""

    mode: str
    statuses: list[str]
    distance: float
    violations: list[str]
    max_depth: int


@dataclass
class Comparison:
    """One scenario in both modes, and what broke."""

    seed: int
    goals: int
    emergencies: int
    door_events: int
    online: ModeRun
    naive: ModeRun
    violations: list[str] = field(default_factory=list)

    @property
    def doors(self) -> bool:
        """Whether the scenario shuts or opens doors."""
        return self.door_events > 0


Route = list[tuple[str, float, float]]
"""The robot's moves for the first goal alone: (action, start time, duration)."""


def scenario_data(seed: int, route: Route | None = None) -> dict[str, Any]:
    """A random scenario (as parsed YAML) for ``seed``.

    ``route`` lists the moves the robot makes for the first goal when nothing
    interrupts it.  One emergency may then be triggered part way along one of
    them — one that is reached before anything else happens, so that both
    modes see the same history until then and the trigger fires in both.
    """
    rng = random.Random(seed)
    world = generate_map(rng.randint(1, 3), rng.randint(1, 3), rng.randint(2, 3), seed)
    nodes = sorted(world.nodes)
    arcs = sorted(world.arcs)
    two_levels = rng.random() < 0.6
    agents, top, task = agent_chain(two_levels)
    start = rng.choice(nodes)
    goals: list[dict[str, Any]] = [
        {"agent": top, "task": f"{task}({rng.choice(nodes)})"} for _ in range(rng.randint(1, 2))
    ]
    for _ in range(rng.randint(1, 4)):
        # Emergencies bunch up, so that they often arrive during one another.
        when = round(rng.choice([rng.uniform(0.0, 30.0), rng.uniform(0, 8)]), 2)
        goals.append(
            {"agent": top, "task": f"{task}({rng.choice(nodes)})", "emergency": True, "when": {"time": when}}
        )
    events: list[dict[str, Any]] = []
    if rng.random() < 0.5:
        for _ in range(rng.randint(1, 3)):
            arc = rng.choice(arcs)
            shut = round(rng.uniform(0.0, 40.0), 2)
            events.append({"when": {"time": shut}, "close": arc})
            if rng.random() < 0.7:
                events.append({"when": {"time": round(shut + rng.uniform(1.0, 20.0), 2)}, "open": arc})
    progress = round(rng.uniform(0.1, 0.9), 2)
    wanted = rng.random() < 0.5
    if route and wanted:
        first = min(float(x["when"]["time"]) for x in [*goals, *events] if "when" in x)
        early = [move for move, begun, took in route if begun + progress * took < first - 1e-3]
        if early:
            goals[-1]["when"] = {"action": rng.choice(early), "progress": progress}
    return {
        "name": f"differential {seed}",
        "map": map_to_yaml_data(world),
        "robot": {"start": start, "speed": 1.0},
        "agents": agents,
        "goals": goals,
        "events": events,
    }


async def _route(seed: int) -> Route:
    """The moves the robot makes for the first goal alone (where a trigger may be placed)."""
    data = scenario_data(seed)
    data["goals"] = data["goals"][:1]
    data["events"] = []
    moves: Route = []

    def observe(event: TraceEvent) -> None:
        if isinstance(event, RobotMoving) and not event.resumed:
            moves.append((event.action, event.t, event.duration))

    scenario = parse_scenario(data, f"<differential {seed}>")
    await run_scenario(scenario, replanning="naive", observers=[observe])
    return moves


async def run_mode(data: dict[str, Any], mode: str) -> ModeRun:
    """Run the scenario in one mode with the invariants watched."""
    scenario = parse_scenario(data, f"<{data['name']}>")
    checker = RunChecker()

    def start(runtime: Runtime) -> None:
        checker.attach(runtime)

    report = await run_scenario(scenario, replanning=mode, observers=[checker], on_start=start)
    violations = [f"{mode}: {v}" for v in checker.finish()]
    statuses: list[str] = [g.status for g in report.summary.goals]
    return ModeRun(mode, statuses, report.summary.distance, violations, checker.max_depth)


async def compare(seed: int) -> Comparison:
    """Run scenario ``seed`` in both modes and check them against each other."""
    data = scenario_data(seed, await _route(seed))
    online = await run_mode(data, "online")
    naive = await run_mode(data, "naive")
    goals = data["goals"]
    result = Comparison(
        seed,
        goals=len(goals),
        emergencies=sum(1 for g in goals if g.get("emergency")),
        door_events=len(data["events"]),
        online=online,
        naive=naive,
    )
    result.violations += online.violations + naive.violations
    for i, (a, b) in enumerate(zip(online.statuses, naive.statuses, strict=True)):
        if a != b:
            result.violations.append(f"goal {i} ({goals[i]['task']}): on-line {a}, naive {b}")
    slack = DOORS_SLACK if result.doors else NO_DOORS_SLACK
    if online.distance > naive.distance * (1 + slack) + 1e-6:
        result.violations.append(
            f"on-line travelled {online.distance:.2f} m, naive {naive.distance:.2f} m "
            f"(+{online.distance / max(naive.distance, 1e-9) - 1:.1%}, allowed {slack:.0%})"
        )
    return result
