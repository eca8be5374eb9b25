"""Measuring one run: resume time at the parent and the child, and whole-run planning.

Resume time is measured the same way in both modes, on the wall clock, from
outside the agents (trace observers run inside ``emit``, at the very moment of
the event):

- it starts when the emergency goal ends at the top agent (its ``goal_finished``);
- **parent**: until the top agent's first order to its child after that (the
  resumed goal's first action, sent down);
- **child**: from there until the first order the bottom agent sends to the
  robot — the resumed goal's first move;
- **total**: parent plus child.  With one agent, the parent's time runs to the
  first order to the robot and the child's is 0.

Everything done between those instants counts: re-using or re-making plans, the
clear of a suspended action that will not be resumed, message passing.  Work
done earlier (while the emergency's last action ran) does not.  Simulated time
does not move meanwhile: nothing else runs.  ``planning_ms`` is the agents' own
count of wall-clock time spent planning and keeping plans, over the whole run.
"""

from __future__ import annotations

import time
from collections.abc import Callable, Iterable
from dataclasses import dataclass, field

from htnagent.runtime.events import GoalFinished, GoalResumed, MessageSent, TraceEvent
from htnagent.runtime.trace import Observer
from htnagent.scenario import Scenario
from htnagent.system.runtime import Runtime
from htnagent.system.simulation import run_scenario

_ORDERS = ("execute", "resume")


@dataclass
class RunFigures:
    """What one run of a scenario measured."""

    parent_ms: float | None = None
    child_ms: float | None = None
    distance: float = 0.0
    planning_ms: float = 0.0
    succeeded: bool = False
    resumes: list[float] = field(default_factory=list)
    """The top agent's own ``replan_ms`` of every resumption (for nested emergencies)."""

    @property
    def total_ms(self) -> float | None:
        """Parent plus child resume time."""
        if self.parent_ms is None:
            return None
        return self.parent_ms + (self.child_ms or 0.0)


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
    top, bottom = names[0], names[-1]
    emergency = next(str(g.task) for g in scenario.goals if g.emergency)
    marks: dict[str, float] = {}

    def observe(event: TraceEvent) -> None:
        now = time.perf_counter()
        agent = event.agent
        if isinstance(event, GoalResumed) and agent == top:
            figures.resumes.append(event.replan_ms)
        if figures.total_ms is not None and "child" in marks:
            return
        if "ended" not in marks:
            if isinstance(event, GoalFinished) and agent == top and event.goal == emergency:
                marks["ended"] = now
            return
        if not isinstance(event, MessageSent) or event.kind not in _ORDERS:
            return
        if agent == top and "parent" not in marks:
            marks["parent"] = now
            figures.parent_ms = (now - marks["ended"]) * 1000
        if agent == bottom and event.to == "robot" and "child" not in marks:
            marks["child"] = now
            if top == bottom:
                figures.parent_ms, figures.child_ms = (now - marks["ended"]) * 1000, 0.0
            else:
                figures.child_ms = (now - marks.get("parent", marks["ended"])) * 1000

    report = await run_scenario(
        scenario, replanning=mode, observers=[observe, *observers], on_start=on_start, look_ahead=look_ahead
    )
    figures.distance = report.summary.distance
    figures.planning_ms = sum(report.summary.planning_ms.values())
    figures.succeeded = report.succeeded
    return figures
