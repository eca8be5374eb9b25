"""An initial task network with open parameters (``(:htn :parameters (...))``): each is bound
where its tasks start, by a part of the network of its own (``__partK``), not all at once at
the root -- and the parts are left out of the IPC plan."""

from __future__ import annotations

import pytest

from htnagent.hddl import parse_domain, parse_problem
from htnagent.hddl.check import check_plan
from htnagent.planning.hddl_solving import solve
from htnagent.planning.hddl_translation import PART, TOP, translate
from htnagent.planning.ipc_output import ipc_plan
from htnagent.planning.planner import PlannerSettings, PlanStatus, Search, plan

# Items dyed a colour that must be ready; only c8 is at first.  dye also makes its colour
# ready, so whether one is ready may change along the network: the root cannot check it
# before its tasks start, and binds each colour by its type alone.
DOMAIN = """
(define (domain dyes)
  (:requirements :typing :hierarchy)
  (:types item colour)
  (:predicates (ready ?c - colour) (dyed ?i - item ?c - colour))
  (:task paint :parameters (?i - item ?c - colour))
  (:method paint-m :parameters (?i - item ?c - colour) :task (paint ?i ?c)
    :ordered-subtasks (dye ?i ?c))
  (:action dye :parameters (?i - item ?c - colour)
    :precondition (ready ?c)
    :effect (and (dyed ?i ?c) (ready ?c)))
)
"""


def _problem(items: int, constraint: str = "") -> str:
    params = " ".join(f"?x{i}" for i in range(items))
    tasks = " ".join(f"(paint i{i} ?x{i})" for i in range(items))
    return f"""
(define (problem many) (:domain dyes)
  (:objects {" ".join(f"i{i}" for i in range(items))} - item c1 c2 c3 c4 c5 c6 c7 c8 - colour)
  (:htn :parameters ({params} - colour) :ordered-subtasks (and {tasks}) {constraint})
  (:init (ready c8))
)
"""


def test_each_open_parameter_is_bound_where_its_task_starts() -> None:
    # At the root, 8^6 bindings to try one after the other, each failing at its first dye
    # unless it is c8 throughout; bound part by part, at most 8 tries a task.
    domain = parse_domain(DOMAIN, "dyes.hddl")
    problem = parse_problem(_problem(6), domain, "p.hddl")
    planning = translate(domain, problem)
    [root] = planning.domain.methods[TOP]
    assert [t.name for t in root.subtasks] == [f"{PART}{k}" for k in range(1, 7)]
    settings = PlannerSettings(alternatives=1, budget=2_000, search=Search.DFS)
    result = plan(planning.domain, planning.state, planning.tasks, settings)
    assert result.status is PlanStatus.SOLVED and result.best is not None
    actions = [str(s.action) for s in result.best.steps if not s.action.name.startswith("__")]
    assert actions == [f"dye(i{i},c8)" for i in range(6)]
    shown = ipc_plan(result.best)
    assert [str(v) for v in check_plan(domain, problem, shown)] == []
    assert all(not d.task.name.startswith("__") for d in shown.decompositions)
    assert len(shown.root) == 6  # the network's own tasks, not its parts


@pytest.mark.parametrize("search", [None, Search.GBFS, Search.ASTAR])
def test_every_search_solves_the_network_in_parts(search: Search | None) -> None:
    domain = parse_domain(DOMAIN, "dyes.hddl")
    problem = parse_problem(_problem(4), domain, "p.hddl")
    solved = solve(domain, problem, search=search, timeout=20)
    assert solved.result.best is not None
    assert [str(v) for v in check_plan(domain, problem, ipc_plan(solved.result.best))] == []


def test_a_parameter_the_constraints_name_stays_at_the_root() -> None:
    domain = parse_domain(DOMAIN, "dyes.hddl")
    problem = parse_problem(_problem(3, ":constraints (and (= ?x1 c8))"), domain, "p.hddl")
    planning = translate(domain, problem)
    [root] = planning.domain.methods[TOP]
    # ?x0 and ?x2 have parts of their own; ?x1 is bound at the root and passed to none.
    assert [t.name for t in root.subtasks] == [f"{PART}1", "paint", f"{PART}2"]
    settings = PlannerSettings(alternatives=1, budget=2_000, search=Search.DFS)
    result = plan(planning.domain, planning.state, planning.tasks, settings)
    assert result.best is not None
    assert [str(v) for v in check_plan(domain, problem, ipc_plan(result.best))] == []
