"""Measuring one run: resume time at the parent and the child, and whole-run planning.

The figures come from :class:`htnagent.system.goal_times.GoalClock`, the observer whose
figures the run's summary gives too (``resumes: [{t, replan_ms, window_ms}]``), so the
benchmarks and ``htnagent run`` always agree.  At the top agent's first resumption:

- the window starts when the goal run before it (the emergency) ends at the top agent
  (its ``goal_finished``);
- **parent**: until the top agent's first order to its child after that (the resumed
  goal's first action, sent down);
- **child**: from there until the first order the bottom agent sends to the robot — the
  resumed goal's first move;
- **total**: parent plus child, the summary's ``window_ms``.  With one agent, the parent's
  time runs to the first order to the robot and the child's is 0.

Everything done between those instants counts: re-using or re-making plans, the clear of
a suspended action that will not be resumed, message passing.  Work done earlier (while
the emergency's last action ran) does not.  Simulated time does not move meanwhile:
nothing else runs.  Beside the window, the agents' own replanning at that resumption (the
paper's measure, the summary's ``replan_ms``): the top agent's ``goal_resumed`` replan_ms
(**parent**) and the child's planning of its first order after it (**child**).
``planning_ms`` is the agents' own count of wall-clock time spent planning and keeping
plans, over the whole run; ``planning_cpu_ms`` the CPU time of the same work, which other
processes on a shared machine do not add to.
"""

from __future__ import annotations

from collections.abc import Callable, Iterable, Mapping
from dataclasses import dataclass, field

from htnagent.runtime.events import GoalResumed, TraceEvent
from htnagent.runtime.trace import Observer
from htnagent.scenario import Scenario
from htnagent.system.runtime import Runtime
from htnagent.system.simulation import run_scenario


@dataclass
class RunFigures:
    """What one run of a scenario measured."""

    parent_ms: float | None = None
    child_ms: float | None = None
    parent_replan_ms: float | None = None
    """The top agent's own replanning at the resumption (its ``goal_resumed`` replan_ms)."""
    child_replan_ms: float | None = None
    """The agents' below it: each one's planning of its first order after the resumption."""
    distance: float = 0.0
    planning_ms: float = 0.0
    planning_cpu_ms: float = 0.0
    succeeded: bool = False
    resumes: list[float] = field(default_factory=list)
    """The top agent's own ``replan_ms`` of every resumption (for nested emergencies)."""

    @property
    def total_ms(self) -> float | None:
        """Parent plus child resume time (the window)."""
        if self.parent_ms is None:
            return None
        return self.parent_ms + (self.child_ms or 0.0)

    @property
    def replan_ms(self) -> float | None:
        """Parent plus child replanning at the resumption (the summary's ``replan_ms``)."""
        if self.parent_replan_ms is None:
            return None
        return self.parent_replan_ms + (self.child_replan_ms or 0.0)


async def measure_run(
    scenario: Scenario,
    mode: str,
    *,
    observers: Iterable[Observer] = (),
    on_start: Callable[[Runtime], None] | None = None,
    look_ahead: bool = True,
) -> RunFigures:
    """Run the scenario once in ``mode`` and return its figures (``look_ahead``: the
    agents' :attr:`~htnagent.agent.AgentConfig.look_ahead`, on by default).

    ``observers`` and ``on_start`` are handed to :func:`~htnagent.system.simulation.run_scenario`
    (the IPC interruption benchmark counts actions and compares beliefs with the world).
    """
    figures = RunFigures()
    names = scenario.agent_names
    top = names[0]

    def observe(event: TraceEvent) -> None:
        if isinstance(event, GoalResumed) and event.agent == top:
            figures.resumes.append(event.replan_ms)

    runtimes: list[Runtime] = []

    def started(runtime: Runtime) -> None:
        runtimes.append(runtime)
        if on_start is not None:
            on_start(runtime)

    report = await run_scenario(
        scenario, replanning=mode, observers=[observe, *observers], on_start=started, look_ahead=look_ahead
    )
    first = next(iter(report.resumptions(top)), None)
    if first is not None:
        # The replanning is the agents' work at the resumption whether or not it found a plan
        # (naive mode may find none for a network it must plan again whole); the window
        # needs an order after it.
        figures.parent_replan_ms = first.replan_ms.get(top, 0.0)
        figures.child_replan_ms = first.total_ms - figures.parent_replan_ms
    if first is not None and first.order_ms is not None:
        window = first.window_ms if first.window_ms is not None else first.order_ms
        figures.parent_ms = window if len(names) == 1 else first.order_ms
        figures.child_ms = 0.0 if len(names) == 1 else window - first.order_ms
    figures.distance = report.summary.distance
    figures.planning_ms = sum(report.summary.planning_ms.values())
    figures.planning_cpu_ms = 1000 * sum(a.stats.cpu_seconds for r in runtimes for a in r.agents.values())
    figures.succeeded = report.succeeded
    return figures


async def interleaved_runs(
    scenario: Scenario, runs: int, variants: Mapping[str, tuple[str, bool]]
) -> dict[str, list[RunFigures]]:
    """``runs`` measured runs of each variant (its mode, and its look-ahead) after one warm-up
    run of each, the variants in turn: whatever else the machine does weighs on all alike."""
    out: dict[str, list[RunFigures]] = {variant: [] for variant in variants}
    for mode, look_ahead in variants.values():
        await measure_run(scenario, mode, look_ahead=look_ahead)
    for _ in range(runs):
        for variant, figures in out.items():
            mode, look_ahead = variants[variant]
            figures.append(await measure_run(scenario, mode, look_ahead=look_ahead))
    return out
