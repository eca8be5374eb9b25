"""The goal-support dead-end test (docs/design.md §7.3): which goal facts each task may add,
worked out lifted on small domains written here, and the searches it cuts short."""

from __future__ import annotations

import pytest

from htnagent.hddl import parse_domain, parse_problem
from htnagent.hddl.check import check_plan
from htnagent.model.networks import network_task
from htnagent.model.plans import Plan
from htnagent.model.terms import Atom
from htnagent.planning.goal_support import GoalSupport, adders
from htnagent.planning.hddl_solving import solve
from htnagent.planning.hddl_translation import HddlPlanning, translate
from htnagent.planning.ipc_output import ipc_plan
from htnagent.planning.planner import PlannerSettings, PlanStatus, Search, plan

# Blocks put on one another by tasks that may first put the lower block on the table (the
# first method, tried first by depth-first search) or leave it where it is (the second):
# the first undoes a goal fact an earlier task made, and nothing later makes it again.
DOMAIN = """
(define (domain piles)
  (:requirements :typing :hierarchy :negative-preconditions)
  (:types block)
  (:predicates (on ?x ?y - block) (ontable ?x - block) (clear ?x - block))
  (:task put :parameters (?x ?y - block))
  (:task base :parameters (?x - block))
  (:task fix :parameters (?x - block))
  (:method put-m :parameters (?x ?y - block) :task (put ?x ?y)
    :ordered-subtasks (and (base ?y) (stack ?x ?y)))
  (:method base-down :parameters (?x ?z - block) :task (base ?x)
    :precondition (on ?x ?z)
    :ordered-subtasks (unstack ?x ?z))
  (:method base-stay :parameters (?x - block) :task (base ?x)
    :ordered-subtasks ())
  (:method fix-any :parameters (?x ?y - block) :task (fix ?x)
    :ordered-subtasks (stack ?y ?x))
  (:action stack :parameters (?x ?y - block)
    :precondition (and (clear ?x) (clear ?y) (ontable ?x))
    :effect (and (on ?x ?y) (not (clear ?y)) (not (ontable ?x))))
  (:action unstack :parameters (?x ?y - block)
    :precondition (and (on ?x ?y) (clear ?x))
    :effect (and (not (on ?x ?y)) (clear ?y) (ontable ?x)))
)
"""


def _problem(n: int, goal: bool = True) -> str:
    blocks = [f"b{i}" for i in range(n)]
    tasks = " ".join(f"(put {blocks[i + 1]} {blocks[i]})" for i in range(n - 1))
    on = " ".join(f"(on {blocks[i + 1]} {blocks[i]})" for i in range(n - 1))
    return f"""
(define (problem tower) (:domain piles)
  (:objects {" ".join(blocks)} - block)
  (:htn :ordered-subtasks (and {tasks}))
  (:init {" ".join(f"(ontable {b}) (clear {b})" for b in blocks)})
  {f"(:goal (and {on}))" if goal else ""}
)
"""


def _planning(n: int, goal: bool = True) -> HddlPlanning:
    domain = parse_domain(DOMAIN, "piles.hddl")
    return translate(domain, parse_problem(_problem(n, goal), domain, "p.hddl"))


def test_what_each_task_may_add_passes_its_arguments_down() -> None:
    found = adders(_planning(3).domain)
    p = "p"
    assert found["stack"] >= {("on", ((p, 0), (p, 1)), ())}
    # put(?x,?y) adds on(?x,?y) through stack(?x,?y): its own arguments, nothing else, and
    # whatever they are (no method's equality fixes them).
    assert ("on", ((p, 0), (p, 1)), ()) in found["put"]
    assert not any(pred == "on" and spec != ((p, 0), (p, 1)) for pred, spec, _ in found["put"])
    # fix(?x) stacks a block its method binds itself: on(anything, ?x).
    assert ("on", (None, (p, 0)), ()) in found["fix"]
    assert not any(pred == "on" for pred, _, _ in found["base"])  # only unstack: no on()


def test_may_add_reads_the_ground_task_and_treats_a_variable_as_anything() -> None:
    planning = _planning(3)
    support = GoalSupport.of(planning.domain)
    on10, on21 = Atom("on", ("b1", "b0")), Atom("on", ("b2", "b1"))
    assert support.goals == {on10, on21}

    def goal_facts(task: Atom) -> frozenset[Atom]:  # (it also watches the landmarks behind)
        return support.may_add(task) & support.goals

    assert goal_facts(Atom("put", ("b1", "b0"))) == {on10}
    assert goal_facts(Atom("put", ("b0", "b1"))) == frozenset()
    assert goal_facts(Atom("fix", ("b1",))) == {on21}
    assert goal_facts(Atom("stack", ("?x", "b1"))) == {on21}
    assert goal_facts(Atom("base", ("b1",))) == frozenset()
    # unstack deletes on(), a goal fact; stack deletes clear() and ontable(), marks behind
    # the goal (only unstack adds them, and every stack needs them).
    assert support.marks == {Atom(p, (b,)) for p in ("clear", "ontable") for b in ("b1", "b2")} | {
        Atom("clear", ("b0",))
    }
    assert support.deleters == {"unstack", "stack"}
    # lost: a missing goal fact that no task left may add.
    assert support.lost([on21], [Atom("base", ("b1",)), Atom("put", ("b2", "b1"))]) is False
    assert support.lost([on21], [Atom("base", ("b1",)), Atom("put", ("b2", "b0"))]) is True
    assert support.lost([], []) is False


def _valid(planning: HddlPlanning, found: Plan) -> None:
    assert [str(v) for v in check_plan(planning.hddl, planning.problem, ipc_plan(found))] == []


def test_depth_first_search_drops_the_node_that_undoes_a_goal_fact_at_once() -> None:
    # Without the test, depth-first search tries base-down before base-stay for every put,
    # and learns it was wrong only at the goal: 2^(n-2) complete decompositions.  With it,
    # each wrong unstack is dropped where it happens: the expansions grow linearly.
    planning = _planning(14)
    settings = PlannerSettings(alternatives=1, budget=5_000, search=Search.DFS)
    result = plan(planning.domain, planning.state, planning.tasks, settings)
    assert result.status is PlanStatus.SOLVED
    assert result.expansions < 200
    assert result.best is not None
    assert [s.action.name for s in result.best.steps if s.action.name != "__done"] == ["stack"] * 13
    _valid(planning, result.best)
    # The same search that sees the goal only at the end runs out of its budget.
    blind = _planning(14)
    blind.domain.goal_facts = ()
    late = plan(blind.domain, blind.state, blind.tasks, settings)
    assert late.status is PlanStatus.BUDGET_EXHAUSTED


def test_a_goal_no_task_may_add_is_unsolvable_without_a_search() -> None:
    domain = parse_domain(DOMAIN, "piles.hddl")
    text = _problem(3).replace("(:goal (and", "(:goal (and (on b0 b2)")
    planning = translate(domain, parse_problem(text, domain, "p.hddl"))
    for search in (Search.DFS, Search.GBFS, Search.ASTAR):
        settings = PlannerSettings(alternatives=1, budget=1_000, search=search)
        result = plan(planning.domain, planning.state, planning.tasks, settings)
        assert result.status is PlanStatus.UNSOLVABLE
        assert result.expansions == 0


@pytest.mark.parametrize("search", [None, Search.GBFS, Search.ASTAR])
def test_every_search_finds_the_same_valid_plan_with_the_test(search: Search | None) -> None:
    planning = _planning(6)
    solved = solve(planning.hddl, planning.problem, search=search, timeout=10)
    assert solved.result.status is PlanStatus.SOLVED
    assert solved.result.best is not None
    _valid(planning, solved.result.best)


def test_without_a_goal_nothing_is_dropped() -> None:
    # No goal: base-down is as good as base-stay, and depth-first takes it.
    planning = _planning(4, goal=False)
    assert planning.domain.goal_facts == ()
    settings = PlannerSettings(alternatives=1, budget=1_000, search=Search.DFS)
    result = plan(planning.domain, planning.state, planning.tasks, settings)
    assert result.best is not None
    assert any(s.action.name == "unstack" for s in result.best.steps)


def test_a_network_goal_ending_with_the_goal_check_is_searched_with_the_test() -> None:
    # An agent's goal ``tasks: problem`` is the one task tasks(t1,...,tn,__goal) (design §4):
    # it is held to the goal as the problem's own list is, with the same search and
    # expansions, not only once the network has been decomposed.
    planning = _planning(14)
    settings = PlannerSettings(alternatives=1, budget=5_000, search=Search.DFS)
    listed = plan(planning.domain, planning.state, planning.tasks, settings)
    # Another network first, so that the domain's methods for ``tasks`` change after the
    # test was made: what a network may add is read from its own tasks.
    network_task(planning.domain, planning.tasks[:1])
    whole = network_task(planning.domain, planning.tasks)
    result = plan(planning.domain, planning.state, [whole], settings)
    assert result.status is PlanStatus.SOLVED
    assert result.expansions <= listed.expansions + 1  # the network's own decomposition
    assert result.best is not None and listed.best is not None
    assert [s.action for s in result.best.steps] == [s.action for s in listed.best.steps]
    support = GoalSupport.of(planning.domain)
    assert support.may_add(whole) >= support.goals


def test_a_list_without_the_goal_check_is_not_held_to_the_goal() -> None:
    # An agent plans one task of the domain alone (an emergency): the problem's goal need
    # not hold after it, so a goal fact it cannot add is no dead end.
    planning = _planning(3)
    settings = PlannerSettings(alternatives=1, budget=1_000, search=Search.DFS)
    result = plan(planning.domain, planning.state, [Atom("put", ("b1", "b0"))], settings)
    assert result.status is PlanStatus.SOLVED


def test_the_test_is_made_once_a_domain_and_anew_for_a_domain_built_on() -> None:
    # Plan repair searches again and again with the goal's check at the end of its list:
    # working the test out is a fixed point over the whole domain each time (1.6 ms for
    # Barman), so it is made once for a domain.
    planning = _planning(3)
    domain = planning.domain
    first = GoalSupport.of(domain)
    assert GoalSupport.of(domain) is first
    assert GoalSupport.of(_planning(3).domain) is not first  # another domain, even if equal
    domain.operator("paint(?x)", add=["clear(?x)"])
    grown = GoalSupport.of(domain)
    assert grown is not first and "paint" in adders(domain)
