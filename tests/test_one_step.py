"""One step ahead (docs/design.md §7.5): greedy search by the lifted estimate weighs what
the next decomposition costs in the state the actions before it lead to -- a plane sent to
the right airport, not to the first one declared -- and never over-estimates."""

from __future__ import annotations

import math
import random

import pytest

from htnagent.hddl.check import check_plan
from htnagent.model.preconditions import LazyDecomposer
from htnagent.model.terms import Atom
from htnagent.planning import one_step as one_step_module
from htnagent.planning.hddl_translation import HddlPlanning
from htnagent.planning.ipc_output import ipc_plan
from htnagent.planning.one_step import OneStepAhead
from htnagent.planning.planner import PlannerSettings, PlanStatus, Search, plan
from tests.support import fact, translated

AIRPORTS = 8

# As Logistics' ACHIEVE-AT2: a plane is where it should be, or flies to any airport and
# tries again.  The lifted estimate counts the task 0 wherever the plane is.
PLANES = """
(define (domain planes)
  (:requirements :hierarchy :typing :negative-preconditions :method-preconditions)
  (:types plane airport)
  (:predicates (at ?p - plane ?a - airport))
  (:task be-at :parameters (?p - plane ?a - airport))
  (:method there :parameters (?p - plane ?a - airport) :task (be-at ?p ?a)
    :precondition (at ?p ?a) :ordered-subtasks (and))
  (:method fly-on :parameters (?p - plane ?a ?from ?via - airport) :task (be-at ?p ?a)
    :precondition (and (not (at ?p ?a)) (at ?p ?from))
    :ordered-subtasks (and (fly ?p ?from ?via) (be-at ?p ?a)))
  (:action fly :parameters (?p - plane ?from ?to - airport) :precondition (at ?p ?from)
    :effect (and (not (at ?p ?from)) (at ?p ?to))))
"""


def _planes(tasks: str, start: str = "a1") -> HddlPlanning:
    airports = " ".join(f"a{k}" for k in range(1, AIRPORTS + 1))
    return translated(
        PLANES,
        f"(define (problem p) (:domain planes) (:objects pl - plane {airports} - airport)"
        f" (:htn :ordered-subtasks (and {tasks})) (:init (at pl {start})))",
    )


def _ahead(planning: HddlPlanning) -> OneStepAhead:
    domain, state = planning.domain, planning.state
    assert domain.task_costs is not None
    dyn = state.dynamic_predicates

    def ways(name: str) -> list[tuple[str, LazyDecomposer]]:
        return [(m.name, m.compiled_lazy(dyn)) for m in domain.methods.get(name, ())]

    return OneStepAhead(domain, state.static, dyn, domain.task_costs, ways)


def _greedy(planning: HddlPlanning) -> list[str]:
    settings = PlannerSettings(alternatives=1, budget=5_000, search=Search.GBFS)
    found = plan(planning.domain, planning.state, planning.tasks, settings)
    assert found.status is PlanStatus.SOLVED and found.best is not None
    assert [str(v) for v in check_plan(planning.hddl, planning.problem, ipc_plan(found.best))] == []
    return [str(s.action) for s in found.best.steps if not s.action.name.startswith("__")]


def test_greedy_search_flies_straight_to_the_airport(monkeypatch: pytest.MonkeyPatch) -> None:
    planning = _planes(f"(be-at pl a{AIRPORTS}) (be-at pl a3)")
    assert _greedy(planning) == [f"fly(pl,a1,a{AIRPORTS})", f"fly(pl,a{AIRPORTS},a3)"]
    # Without it, every flight ties and the plane goes the airports' way.
    monkeypatch.setattr(OneStepAhead, "extra", lambda *_: 0.0)
    assert len(_greedy(planning)) > 2


def test_what_the_next_decomposition_adds() -> None:
    planning = _planes("(be-at pl a2)")
    ahead = _ahead(planning)
    at1 = frozenset({fact("at", "pl", "a1")})
    be_at_2 = fact("be-at", "pl", "a2")
    # Already there: the cheapest method applies.  Elsewhere: one more flight.
    assert ahead.extra([be_at_2], frozenset({fact("at", "pl", "a2")})) == 0.0
    assert ahead.extra([be_at_2], at1) == 1.0
    # The actions before it are done first, in order.
    assert ahead.extra([fact("fly", "pl", "a1", "a2"), be_at_2], at1) == 0.0
    assert ahead.extra([fact("fly", "pl", "a1", "a5"), be_at_2], at1) == 1.0
    # An action that cannot be done: no plan.
    assert ahead.extra([fact("fly", "pl", "a4", "a2"), be_at_2], at1) == math.inf
    # Nothing compound left: nothing to add.
    assert ahead.extra([fact("fly", "pl", "a1", "a2")], at1) == 0.0


def test_nothing_is_added_past_the_most_actions(monkeypatch: pytest.MonkeyPatch) -> None:
    planning = _planes("(be-at pl a2)")
    ahead = _ahead(planning)
    at1 = frozenset({fact("at", "pl", "a1")})
    tasks = [fact("fly", "pl", "a1", "a1"), fact("fly", "pl", "a1", "a1"), fact("be-at", "pl", "a2")]
    assert ahead.extra(tasks, at1) == 1.0
    monkeypatch.setattr(one_step_module, "MOST_ACTIONS", 1)
    assert _ahead(planning).extra(tasks, at1) == 0.0


def _random_list(rng: random.Random) -> list[Atom]:
    tasks: list[Atom] = []
    for _ in range(rng.randint(1, 4)):
        if rng.random() < 0.2:
            a, b = rng.sample(range(1, AIRPORTS + 1), 2)
            tasks.append(fact("fly", "pl", f"a{a}", f"a{b}"))
        else:
            tasks.append(fact("be-at", "pl", f"a{rng.randint(1, AIRPORTS)}"))
    return tasks


def test_never_more_than_the_cheapest_plan_of_the_list() -> None:
    # The oracle: A* by the lifted estimate (which never over-estimates), on the same list
    # from the same state, for lists and states the test did not pick.
    rng = random.Random(46)
    for _ in range(150):
        tasks = _random_list(rng)
        start = f"a{rng.randint(1, AIRPORTS)}"
        planning = _planes(" ".join(f"({t.name} {' '.join(map(str, t.args))})" for t in tasks), start)
        root = planning.tasks
        assert planning.domain.task_costs is not None
        least = sum(planning.domain.task_costs.get(t.name, 0.0) for t in tasks)
        added = _ahead(planning).extra(tasks, planning.state.dynamic)
        settings = PlannerSettings(alternatives=1, budget=50_000, search=Search.ASTAR)
        best = plan(planning.domain, planning.state, root, settings)
        if best.status is PlanStatus.UNSOLVABLE:
            continue  # (inf or not, nothing to over-estimate)
        assert best.best is not None, (tasks, start)
        assert least + added <= best.best.cost, (tasks, start)
        if added == math.inf:
            pytest.fail(f"said no plan where A* found one: {tasks} from {start}")


def test_not_where_the_problem_has_a_goal(monkeypatch: pytest.MonkeyPatch) -> None:
    # With a goal, greedy search's estimate counts what it still needs (design §7.4).
    asked: list[object] = []

    def extra(_self: OneStepAhead, tasks: object, _dynamic: object) -> float:
        asked.append(tasks)
        return 0.0

    monkeypatch.setattr(OneStepAhead, "extra", extra)
    _greedy(_planes("(be-at pl a3)"))
    assert asked
    asked.clear()
    _greedy(
        translated(
            PLANES,
            "(define (problem p) (:domain planes) (:objects pl - plane a1 a2 a3 - airport)"
            " (:htn :ordered-subtasks (and (be-at pl a3))) (:init (at pl a1)) (:goal (at pl a3)))",
        )
    )
    assert not asked
