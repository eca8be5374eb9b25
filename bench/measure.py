"""Measuring one run: resume replanning time at the parent and the child, and totals.

The resume replanning time is wall-clock time measured inside the agents when
the suspended goals are resumed:

- **parent**: the ``replan_ms`` of the top agent's ``goal_resumed`` event for the
  first goal (reusing or remaking its plans, the clear of a suspended action
  that will not be resumed with the repairs it causes, and the detour check);
- **child**: the ``replan_ms`` of the next agent's ``goal_resumed`` event for the
  goal it stacked when the emergency came — whenever the parent resumes it,
  which can be during the emergency if the emergency plan starts by finishing
  the suspended move — or, when the parent clears that goal instead, the
  planning the child does for the parent's next order.

Planning happens synchronously inside an agent's task and simulated time does
not move meanwhile, so reading the agents' planning counters at those trace
events measures exactly that work.
"""

from __future__ import annotations

from dataclasses import dataclass, field

from htnagent.runtime import Runtime
from htnagent.scenario import Scenario
from htnagent.simulation import run_scenario
from htnagent.trace import Event


@dataclass
class RunFigures:
    """What one run of a scenario measured."""

    parent_ms: float | None = None
    child_ms: float | None = None
    distance: float = 0.0
    planning_ms: float = 0.0
    resumes: list[float] = field(default_factory=list)
    succeeded: bool = False

    @property
    def total_ms(self) -> float | None:
        """Parent plus child resume time."""
        if self.parent_ms is None:
            return None
        return self.parent_ms + (self.child_ms or 0.0)


async def measure_run(scenario: Scenario, mode: str) -> RunFigures:
    """Run the scenario once in ``mode`` and return its figures."""
    figures = RunFigures()
    top = scenario.agent_names[0]
    child = scenario.agent_names[1] if len(scenario.agent_names) > 1 else None
    first_goal = str(scenario.goals[0].task)
    holder: dict[str, Runtime] = {}
    watching: dict[str, float] = {}
    stacked_goal: dict[str, str] = {}

    def start(runtime: Runtime) -> None:
        holder["rt"] = runtime

    def observe(event: Event) -> None:
        runtime = holder["rt"]
        kind, agent = event["event"], event["agent"]
        if kind == "goal_resumed" and agent == top:
            figures.resumes.append(float(event["replan_ms"]))
            if event["goal"] == first_goal and figures.parent_ms is None:
                figures.parent_ms = float(event["replan_ms"])
        elif child is None or agent != child or figures.child_ms is not None:
            return
        elif kind == "goal_suspended" and "stacked" not in watching:
            watching["stacked"] = 1.0
            stacked_goal["goal"] = event["goal"]
        elif kind == "goal_resumed" and event["goal"] == stacked_goal.get("goal"):
            figures.child_ms = float(event["replan_ms"])
        elif kind == "goal_cleared" and event["goal"] == stacked_goal.get("goal"):
            watching["since"] = runtime.agents[child].stats.seconds
        elif kind == "action_started" and "since" in watching:
            figures.child_ms = (runtime.agents[child].stats.seconds - watching.pop("since")) * 1000

    report = await run_scenario(scenario, replanning=mode, observers=[observe], on_start=start)
    figures.distance = float(report.summary["distance"])
    figures.planning_ms = float(sum(report.summary["planning_ms"].values()))
    figures.succeeded = report.succeeded
    if child is not None and figures.parent_ms is not None and figures.child_ms is None:
        figures.child_ms = 0.0  # the child had nothing left to plan
    return figures
