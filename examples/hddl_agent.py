"""An agent on an HDDL domain, run from Python, with an emergency.

``examples/hddl/porter.yaml`` puts a porter robot's agent on the HDDL files next to it:
the agent plans on ``porter_domain.hddl`` (translated into htnagent's planning model),
its belief starts as ``porter_problem.hddl``'s ``:init``, and a simulated robot carries
out the domain's actions on its own copy of the facts.  The scenario gives a goal
(bring the medicine to ward-b) and an emergency half way along a walk (bring the
defibrillator to ward-a); the walk is suspended, and resumed afterwards.

This program first asks the planner what the agent would do, then runs the scenario
(in simulated time), printing the agent's goals and actions as they happen.

Run it from the repository root::

    python examples/hddl_agent.py
"""

from __future__ import annotations

import sys
from pathlib import Path

import anyio

from htnagent import TraceEvent, load_scenario, parse, plan, run_scenario

SCENARIO = Path(__file__).resolve().parent / "hddl" / "porter.yaml"


def show(event: TraceEvent) -> None:
    """Print the agent's goals and actions (a trace observer: it only watches)."""
    e = event.as_dict()
    said = f"t={e['t']:5.1f}s  {e['agent']}:"
    if e["event"] == "goal_received":
        print(said, "EMERGENCY" if e["emergency"] else "goal", e["goal"])
    elif e["event"] in ("goal_suspended", "goal_resumed"):
        print(said, e["goal"], e["event"].removeprefix("goal_"))
    elif e["event"] == "goal_finished":
        print(said, e["goal"], "ended:", e["status"])
    elif e["event"] == "action_started" and not str(e["action"]).startswith("__"):
        # (``__done`` and its kin are the translation's markers for a method's end.)
        print(said, "  ", e["action"])


def main() -> int:
    scenario = load_scenario(SCENARIO)

    # What the agent would plan from its start belief, without running anything.
    domain = scenario.domain_for("porter")
    result = plan(domain, scenario.initial_state("porter"), [parse("bring(medicine,ward-b)")])
    assert result.best is not None, result.status
    steps = [str(a) for a in result.best.actions if not a.name.startswith("__")]
    print("plan for bring(medicine,ward-b):", ", ".join(steps))

    # The scenario's goals, at their triggers, on the simulated robot.
    report = anyio.run(lambda: run_scenario(scenario, observers=[show]))
    for goal in report.summary.goals:
        print(f"{goal.goal}: {goal.status}")
    return 0 if report.succeeded else 1


if __name__ == "__main__":
    sys.exit(main())
