"""What a task list can still reach, in the grounded search (docs/design.md §7.2, step 7):
relaxed composition kept to the actions below the list's own tasks drops a node whose goal
some action below another task adds -- but only from a fact no task left can bring back."""

from __future__ import annotations

import dataclasses
import math
import random
from pathlib import Path

import pytest

from htnagent.hddl import parse_domain, parse_problem, read_domain, read_problem
from htnagent.hddl.check import check_plan
from htnagent.model.terms import Atom
from htnagent.planning import below as below_module
from htnagent.planning import reach as reach_module
from htnagent.planning.below import Gathered
from htnagent.planning.hddl_translation import HddlPlanning, translate
from htnagent.planning.ipc_output import ipc_plan
from htnagent.planning.planner import PlannerSettings, PlanStatus, Search, plan
from htnagent.planning.reach import WithinReach
from tests.support import fact, grounded

HERE = Path(__file__).parent / "hddl"

SWITCHES = 7
"""Switches set between the two parts' processing: 2**7 ways to set them, each a state."""

VARNISH = f"""
(define (domain varnish)
  (:requirements :hierarchy :typing)
  (:types part switch - object)
  (:constants {" ".join(f"s{k}" for k in range(1, SWITCHES + 1))} - switch)
  (:predicates (untreated ?p - part) (glazed ?p - part) (primed ?p - part)
               (varnished ?p - part) (lit ?s - switch))
  (:task process :parameters (?p - part))
  (:task set :parameters (?s - switch))
  ; Glazing takes one action, varnishing two: glazing looks cheaper.
  (:method m-glaze :parameters (?p - part) :task (process ?p) :ordered-subtasks (and (glaze ?p)))
  (:method m-varnish
    :parameters (?p - part)
    :task (process ?p)
    :ordered-subtasks (and (prime ?p) (varnish ?p)))
  ; As Woodworking's method16: processing one part may varnish any part...
  (:method m-any
    :parameters (?p ?q - part)
    :task (process ?p)
    :ordered-subtasks (and (prime ?q) (varnish ?q)))
  ; ... but only a part's own processing strips or sands its glaze off.  (Two ways: a fact
  ; one action alone adds is a landmark the goal's check already watches, design §7.3.)
  (:method m-strip
    :parameters (?p - part)
    :task (process ?p)
    :ordered-subtasks (and (strip ?p) (prime ?p) (varnish ?p)))
  (:method m-sand
    :parameters (?p - part)
    :task (process ?p)
    :ordered-subtasks (and (sand ?p) (prime ?p) (varnish ?p)))
  (:method m-on :parameters (?s - switch) :task (set ?s) :subtasks (and (turn-on ?s)))
  (:method m-off :parameters (?s - switch) :task (set ?s) :subtasks (and (turn-off ?s)))
  (:action glaze :parameters (?p - part) :precondition (untreated ?p)
    :effect (and (glazed ?p) (not (untreated ?p))))
  (:action strip :parameters (?p - part) :precondition (glazed ?p)
    :effect (and (untreated ?p) (not (glazed ?p))))
  (:action sand :parameters (?p - part) :precondition (glazed ?p)
    :effect (and (untreated ?p) (not (glazed ?p))))
  (:action prime :parameters (?p - part) :precondition (untreated ?p) :effect (primed ?p))
  (:action varnish :parameters (?p - part) :precondition (primed ?p) :effect (varnished ?p))
  (:action turn-on :parameters (?s - switch) :effect (lit ?s))
  (:action turn-off :parameters (?s - switch) :effect (not (lit ?s))))
"""


def _varnish() -> HddlPlanning:
    domain = parse_domain(VARNISH, "varnish.hddl")
    sets = " ".join(f"(set s{k})" for k in range(1, SWITCHES + 1))
    problem = parse_problem(
        "(define (problem p) (:domain varnish) (:objects p1 p2 - part)"
        f" (:htn :ordered-subtasks (and (process p1) {sets} (process p2)))"
        " (:init (untreated p1) (untreated p2)) (:goal (and (varnished p1) (varnished p2))))",
        domain,
        "p.hddl",
    )
    return translate(domain, problem)


def test_a_goal_fact_added_below_a_task_left_from_a_fact_none_brings_back_is_out_of_reach() -> None:
    planning = _varnish()
    c = grounded(planning)
    goal = next(t for t in planning.tasks if t.name == "__goal")
    sets = [fact("set", f"s{k}") for k in range(1, SWITCHES + 1)]
    rest = [*sets, fact("process", "p2"), goal]
    glazed = frozenset({fact("glazed", "p1"), fact("untreated", "p2")})
    # p1 glazed: process(p2) may still varnish p1 (m-any), so the estimate and step 6 keep
    # the node; but priming p1 needs it untreated, and only p1's own processing undoes the glaze.
    assert c.estimate(rest, glazed) < math.inf
    assert c.dead_end(rest, glazed)
    # p1 primed instead: varnishing it is within reach below process(p2).
    primed = frozenset({fact("untreated", "p1"), fact("primed", "p1"), fact("untreated", "p2")})
    assert not c.dead_end(rest, primed)
    # With p1's own processing still to come, its glaze can be stripped.
    assert not c.dead_end([fact("process", "p1"), *rest], glazed)
    # The start is within reach; a task the grounding never met might do anything.
    assert not c.dead_end(list(planning.tasks), planning.state.dynamic)
    assert not c.dead_end([fact("process", "p3"), *rest], glazed)


def test_the_search_drops_the_node_where_the_glaze_made_the_goal_unreachable(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    # Greedy search: glazing p1 looks the cheaper way to process it, and below it lie 2**7
    # ways to set the switches, none with a plan.  Asked once the glaze is done, step 7
    # drops the node there.
    planning = _varnish()
    c = grounded(planning)
    settings = PlannerSettings(alternatives=1, budget=300, search=Search.GBFS, prune=c.dead_end)
    found = plan(planning.domain, planning.state, planning.tasks, settings, guide=c.estimate)
    assert found.status is PlanStatus.SOLVED
    assert found.best is not None
    assert [str(v) for v in check_plan(planning.hddl, planning.problem, ipc_plan(found.best))] == []
    # Without it the same search is lost in the dead region.
    monkeypatch.setattr(WithinReach, "lost", lambda *_: False)
    lost = plan(planning.domain, planning.state, planning.tasks, settings, guide=c.estimate)
    assert lost.status is PlanStatus.BUDGET_EXHAUSTED


def test_the_search_asks_only_of_the_nodes_an_action_led_to() -> None:
    planning = _varnish()
    c = grounded(planning)
    asked: list[tuple[tuple[Atom, ...], frozenset[Atom]]] = []

    def prune(tasks: object, dynamic: frozenset[Atom]) -> bool:
        assert isinstance(tasks, tuple)
        asked.append((tasks, dynamic))
        return c.dead_end(tasks, dynamic)

    settings = PlannerSettings(alternatives=1, budget=300, search=Search.GBFS, prune=prune)
    found = plan(planning.domain, planning.state, planning.tasks, settings, guide=c.estimate)
    assert found.status is PlanStatus.SOLVED and found.best is not None
    # The first node is asked; the node the glaze led to is asked (and dropped); the glaze's
    # own node, a decomposition's child in the start state, expanded first, is not.
    start = planning.state.dynamic
    assert asked[0] == (tuple(planning.tasks), start)
    goal = next(t for t in planning.tasks if t.name == "__goal")
    rest = (*(fact("set", f"s{k}") for k in range(1, SWITCHES + 1)), fact("process", "p2"), goal)
    assert (rest, frozenset({fact("glazed", "p1"), fact("untreated", "p2")})) in asked
    assert ((fact("glaze", "p1"), *rest), start) not in asked
    # Told the first node has no plan, the search expands nothing.
    told = dataclasses.replace(settings, prune=lambda *_: True)
    none = plan(planning.domain, planning.state, planning.tasks, told, guide=c.estimate)
    assert none.status is PlanStatus.UNSOLVABLE and none.expansions == 0


@pytest.mark.parametrize(
    ("domain_file", "problem_file"),
    [("courier-domain.hddl", "courier.hddl"), ("courier-domain.hddl", "courier-oneway.hddl"), ("", "")],
)
def test_a_node_said_out_of_reach_has_no_plan(domain_file: str, problem_file: str) -> None:
    # The oracle: the planner's own exhaustive search from the node, without the test.  Over
    # the nodes a greedy search meets (taken at random), every one said out of reach has none.
    if domain_file:
        domain = read_domain(HERE / domain_file)
        planning = translate(domain, read_problem(HERE / problem_file, domain))
    else:
        planning = _varnish()
    c = grounded(planning)
    met: list[tuple[tuple[Atom, ...], frozenset[Atom]]] = []

    def guide(tasks: object, dynamic: frozenset[Atom]) -> float:
        assert isinstance(tasks, tuple)
        met.append((tasks, dynamic))
        return c.estimate(tasks, dynamic)

    settings = PlannerSettings(alternatives=1, budget=2_000, search=Search.GBFS)
    plan(planning.domain, planning.state, planning.tasks, settings, guide=guide)
    rng = random.Random(7)
    sample = rng.sample(met, min(len(met), 150))
    said_lost = [(tasks, dynamic) for tasks, dynamic in sample if c.dead_end(tasks, dynamic)]
    exhaustive = PlannerSettings(alternatives=1, budget=200_000, search=Search.DFS)
    for tasks, dynamic in said_lost:
        state = planning.state.with_dynamic(dynamic)
        found = plan(planning.domain, state, list(tasks), exhaustive)
        assert found.status is PlanStatus.UNSOLVABLE, (tasks, dynamic)
    if not domain_file:
        assert said_lost  # the varnishing problem has such nodes: the oracle was asked


def test_the_pass_reaches_only_through_what_lies_below_the_tasks() -> None:
    # Facts 0-1, tasks 2-5.  Action k0 (task 4) needs fact 0 and adds fact 1; action k1
    # (task 5) needs fact 1; method k2 makes task 2 from task 4, method k3 task 3 from task 5.
    below = Gathered({2: (4,), 3: (5,)}, lambda t: (t,))
    r = WithinReach(
        needs=[1, 1, 1, 1],
        consumers=[[0], [1], [], [], [2], [3]],
        outputs=[(1, 4), (5,), (2,), (3,)],
        free=[],
        below=below,
        actions=2,
    )
    assert below(2) == frozenset({2, 4})
    assert not r.lost([2], [0])
    assert r.lost([3], [0])  # fact 1 comes only from the action below task 2
    assert not r.lost([2, 3], [0])
    assert not r.lost([3], [1])
    assert r.lost([2], [])
    assert not r.lost([], [])


def test_what_lies_below_is_forgotten_past_its_bound_and_answered_the_same(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    monkeypatch.setattr(below_module, "MAX_KEPT", 1)
    below = Gathered({0: (1, 2), 3: (1,)}, lambda t: (t,))
    assert below(0) == frozenset({0, 1, 2})
    assert below(3) == frozenset({1, 3})
    assert below(0) == frozenset({0, 1, 2})


def _one_pass(
    needs: list[int],
    consumers: list[list[int]],
    outputs: list[tuple[int, ...]],
    below: Gathered,
    tasks: list[int],
    start: list[int],
) -> bool:
    """The oracle: step 7 as the design says it, one pass of the relaxation from the state
    through the actions and methods whose task lies below the list, and a task not reached."""
    allowed = set().union(*(below(t) for t in tasks)) if tasks else set()
    left = needs[:]
    todo = list(start)
    todo += [o for k, n in enumerate(needs) if n == 0 and outputs[k][-1] in allowed for o in outputs[k]]
    reached = set()
    while todo:
        n = todo.pop()
        if n in reached:
            continue
        reached.add(n)
        for k in consumers[n]:
            left[k] -= 1
            if left[k] == 0 and outputs[k][-1] in allowed:
                todo.extend(outputs[k])
    return any(t not in reached for t in tasks)


@pytest.mark.parametrize("seed", range(40))
@pytest.mark.parametrize("forgetful", [False, True])
def test_the_two_halves_answer_as_one_pass_over_what_lies_below(
    seed: int, forgetful: bool, monkeypatch: pytest.MonkeyPatch
) -> None:
    # Random groundings, recursive methods and actions of no precondition among them, asked
    # of random lists from random states, against the one pass (the oracle above); where
    # forgetful, each memory keeps only what it worked out last.
    if forgetful:
        monkeypatch.setattr(reach_module, "MAX_KEPT_BYTES", 1)
    rng = random.Random(seed)
    n_facts, n_tasks = rng.randint(1, 12), rng.randint(1, 10)
    facts = range(n_facts)
    tasks = range(n_facts, n_facts + n_tasks)
    primitive = rng.sample(list(tasks), rng.randint(1, n_tasks))
    compound = [t for t in tasks if t not in primitive]
    inputs: list[list[int]] = []
    outputs: list[tuple[int, ...]] = []
    for t in primitive:
        for _ in range(rng.randint(1, 2)):
            inputs.append(rng.sample(facts, rng.randint(0, min(2, n_facts))))
            outputs.append((*rng.sample(facts, rng.randint(0, min(2, n_facts))), t))
    actions = len(inputs)
    children: dict[int, list[int]] = {}
    for t in compound:
        for _ in range(rng.randint(0, 3)):
            subtasks = [rng.choice(tasks) for _ in range(rng.randint(0, 3))]
            inputs.append([*rng.sample(facts, rng.randint(0, min(2, n_facts))), *subtasks])
            outputs.append((t,))
            children.setdefault(t, []).extend(subtasks)
    needs = [len(i) for i in inputs]
    consumers: list[list[int]] = [[] for _ in range(n_facts + n_tasks)]
    for k, ins in enumerate(inputs):
        for i in ins:
            consumers[i].append(k)
    below = Gathered(children, lambda t: (t,))
    free = [k for k, n in enumerate(needs) if n == 0]
    r = WithinReach(needs, consumers, outputs, free, below, actions=actions)
    said = []
    for _ in range(30):
        start = rng.sample(facts, rng.randint(0, n_facts))
        asked = [rng.choice(tasks) for _ in range(rng.randint(0, 4))]
        expected = _one_pass(needs, consumers, outputs, below, asked, start)
        assert r.lost(asked, start) == expected, (asked, start)
        said.append(expected)
        if forgetful:  # each memory holds only what it worked out last
            assert len(r._usable._values) <= 1 and len(r._reached._values) <= 1
    if seed == 0:
        assert True in said and False in said  # both answers are asked
