"""An agent that plans with the grounded estimate (scenario ``planner: {search: grounded}``,
docs/design.md §7.2): what ``plan --hddl`` may answer with, an agent of an HDDL domain
plans with too, in every search it makes."""

from __future__ import annotations

import functools
from pathlib import Path
from typing import Any

import anyio

from htnagent.planning.planner import PlanStatus, Search, plan
from htnagent.reading import read_yaml
from htnagent.scenario import Scenario, parse_scenario
from htnagent.system.runtime import Runtime
from htnagent.system.simulation import run_scenario
from tests.support import summary_of
from tests.test_composition import DOMAIN as CABLES
from tests.test_composition import _problem as cables_problem

# t ends only where q holds, and nothing makes q: the lifted searches decompose t into t
# and one more action for ever (the task list grows until the budget runs out), while the
# grounded estimate of t is infinite from the start.
FOREVER = (
    "(define (domain forever) (:requirements :hierarchy) (:predicates (p) (q))"
    " (:task t :parameters ()) (:method m :parameters () :task (t) :ordered-subtasks (and (t) (a)))"
    " (:method end :parameters () :task (t) :precondition (q) :ordered-subtasks ())"
    " (:action a :parameters () :effect (p)))"
)
FOREVER_PROBLEM = "(define (problem p) (:domain forever) (:htn :ordered-subtasks (t)) (:init))"


def _scenario(tmp_path: Path, domain: str, problem: str, search: str) -> Scenario:
    (tmp_path / "domain.hddl").write_text(domain)
    (tmp_path / "p.hddl").write_text(problem)
    data: dict[str, Any] = {
        "name": "grounded",
        "robot": {},
        "planner": {"search": search, "budget": 3_000},
        "agents": [
            {
                "name": "agent",
                "domain": {"hddl": "domain.hddl", "problem": "p.hddl"},
                "executor": "robot",
            }
        ],
        "goals": [{"agent": "agent", "tasks": "problem"}],
    }
    return parse_scenario(data, str(tmp_path / "s.yaml"), tmp_path)


def test_an_hddl_agent_gets_the_grounded_guide_and_its_searches_use_it(tmp_path: Path) -> None:
    s = _scenario(tmp_path, FOREVER, FOREVER_PROBLEM, "grounded")
    settings = s.settings_for("agent")
    assert settings.search is Search.GBFS and settings.guide is not None
    assert s.settings_for("agent") is settings  # grounded once
    assert s.settings.guide is None  # the scenario-wide settings name no problem
    domain, state, goal = s.domain_for("agent"), s.initial_state("agent"), s.goal_task(0)
    guided = plan(domain, state, [goal], settings)
    assert guided.status is PlanStatus.UNSOLVABLE and guided.expansions <= 2
    lifted = plan(domain, state, [goal], s.settings)
    assert lifted.status is PlanStatus.BUDGET_EXHAUSTED


def _run(s: Scenario) -> tuple[dict[str, Any], Runtime]:
    runtimes: list[Runtime] = []
    report = anyio.run(functools.partial(run_scenario, s, on_start=runtimes.append))
    return summary_of(report), runtimes[0]


def test_the_running_agent_plans_with_the_guide(tmp_path: Path) -> None:
    summary, runtime = _run(_scenario(tmp_path, FOREVER, FOREVER_PROBLEM, "grounded"))
    assert runtime.agents["agent"].settings.guide is not None
    [goal] = summary["goals"]
    assert goal["status"] == "failure" and "unsolvable" in goal["reason"]
    # Without it the same agent searches until its budget is spent.
    summary, runtime = _run(_scenario(tmp_path, FOREVER, FOREVER_PROBLEM, "gbfs"))
    assert runtime.agents["agent"].settings.guide is None
    assert "unsolvable" not in summary["goals"][0]["reason"]


def test_a_grounded_agent_carries_out_its_network(tmp_path: Path) -> None:
    # Ports joined by wires, each link checked (tests/test_composition.py's domain).
    summary, runtime = _run(_scenario(tmp_path, CABLES, cables_problem("join p1 p3"), "grounded"))
    assert runtime.agents["agent"].settings.guide is not None
    assert [g["status"] for g in summary["goals"]] == ["success"]


def test_a_scenario_without_an_hddl_agent_plans_greedily_without_a_guide() -> None:
    folder = Path(__file__).resolve().parents[1] / "scenarios"
    data = read_yaml(folder / "museum.yaml", "scenario")
    data["planner"] = {"search": "grounded"}
    s = parse_scenario(data, str(folder / "museum.yaml"), folder)
    for spec in s.agents:
        settings = s.settings_for(spec.name)
        assert settings.search is Search.GBFS and settings.guide is None
