"""What a task may add, and when (docs/design.md §7.3): conditions on the task's arguments
from its methods' equalities and static facts, and the landmarks behind the goal watched
as the goal is, on a small domain written here after Monroe-Partially-Observable's shape.

Someone fetches each crate: a person who can lift it walks to it.  Only the watched
person's walk from home to the yard can be the observed action, and only it makes l2, the
goal.  Which crate, and which lifter, the methods choose themselves."""

from __future__ import annotations

from collections.abc import Mapping

import pytest

from htnagent.hddl import parse_domain, parse_problem
from htnagent.hddl.check import check_plan
from htnagent.model.terms import Atom
from htnagent.planning import planner
from htnagent.planning.goal_support import GoalSupport, adders
from htnagent.planning.hddl_translation import HddlPlanning, translate
from htnagent.planning.ipc_output import ipc_plan
from htnagent.planning.landmarks import GoalLandmarks
from htnagent.planning.planner import PlannerSettings, PlanStatus, Search, plan
from tests.test_landmarks import _DOMAIN as _WATCHED_DOMAIN
from tests.test_landmarks import _planning as _watched

_DOMAIN = """
(define (domain fetching)
  (:requirements :typing :hierarchy :equality)
  (:types person crate place)
  (:constants watched - person home yard - place)
  (:predicates (at ?x - object ?p - place) (can_lift ?p - person ?c - crate)
               (road ?x ?y - place) (l1) (l2))
  (:task top)
  (:task fetch :parameters (?c - crate))
  (:task walk :parameters (?p - person ?to - place))
  (:task cwalk :parameters (?p - person ?from ?to - place))
  (:method top-m :parameters (?c - crate) :task (top) :ordered-subtasks (fetch ?c))
  (:method fetch-m :parameters (?c - crate ?p - person ?to - place) :task (fetch ?c)
    :precondition (and (can_lift ?p ?c) (at ?c ?to))
    :ordered-subtasks (walk ?p ?to))
  (:method walk-m :parameters (?p - person ?from ?to - place) :task (walk ?p ?to)
    :precondition (at ?p ?from)
    :ordered-subtasks (cwalk ?p ?from ?to))
  (:method plain :parameters (?p - person ?from ?to - place) :task (cwalk ?p ?from ?to)
    :ordered-subtasks (go ?p ?from ?to))
  (:method seen :parameters (?p - person ?from ?to - place) :task (cwalk ?p ?from ?to)
    :precondition (and (= ?p watched) (= ?from home) (= ?to yard))
    :ordered-subtasks (obs))
  (:action go :parameters (?p - person ?from ?to - place)
    :precondition (and (at ?p ?from) (road ?from ?to))
    :effect (and (at ?p ?to) (not (at ?p ?from))))
  (:action obs :parameters ()
    :precondition (and (at watched home) (l1))
    :effect (and (at watched yard) (not (at watched home)) (l2) (not (l1))))
)
"""


def _planning(people: int, crates: int, lifts: str = "all") -> HddlPlanning:
    """``people`` others besides the watched one, ``crates`` crates, one in the yard and the
    others elsewhere; everyone lifts every crate (``lifts="all"``), or the watched person
    lifts none (``"none"``) or the one crate named."""
    others = [f"q{i}" for i in range(people)]
    boxes = [f"c{i}" for i in range(crates)]
    places = [f"s{i}" for i in range(crates)]
    everywhere = ["home", "yard", *places]
    roads = " ".join(f"(road {x} {y})" for x in everywhere for y in everywhere if x != y)
    can = " ".join(f"(can_lift {p} {c})" for p in others for c in boxes)
    can += " ".join(f" (can_lift watched {c})" for c in boxes if lifts in ("all", c))
    at = " ".join(f"(at {c} {'yard' if i == crates - 1 else places[i]})" for i, c in enumerate(boxes))
    named = " ".join(others) + " - person" if others else ""
    domain = parse_domain(_DOMAIN, "fetching.hddl")
    problem = f"""(define (problem p) (:domain fetching)
      (:objects {named} {" ".join(boxes)} - crate {" ".join(places)} - place)
      (:htn :ordered-subtasks (top))
      (:init {" ".join(f"(at {p} home)" for p in [*others, "watched"])} {at} {roads} {can} (l1))
      (:goal (l2)))"""
    return translate(domain, parse_problem(problem, domain, "p.hddl"))


def _conditions(found: Mapping[str, frozenset[tuple[str, object, object]]], name: str) -> set[object]:
    return {cond for pred, _, cond in found[name] if pred == "l2"}


def _one(*objects: str) -> frozenset[str]:
    return frozenset(objects)


def test_a_methods_equalities_become_the_condition_on_its_task_and_pass_up() -> None:
    planning = _planning(2, 2)
    found = adders(planning.domain, planning.state.static)
    assert _conditions(found, "obs") == {()}
    assert _conditions(found, "cwalk") == {((0, _one("watched")), (1, _one("home")), (2, _one("yard")))}
    # walk(?p,?to) binds ?from itself: the condition keeps what its own arguments carry.
    assert _conditions(found, "walk") == {((0, _one("watched")), (1, _one("yard")))}
    # fetch(?c) binds the lifter itself: the crates the watched person can lift.
    assert _conditions(found, "fetch") == {((0, _one("c0", "c1")),)}
    assert _conditions(found, "go") == set()


def test_a_static_fact_a_fixed_variable_needs_must_exist() -> None:
    # The watched person lifts nothing: no fetch can send them to the yard, so nothing above
    # a walk may add the goal -- and with no static facts given, anything may.
    planning = _planning(2, 2, lifts="none")
    found = adders(planning.domain, planning.state.static)
    assert _conditions(found, "walk") == {((0, _one("watched")), (1, _one("yard")))}
    assert _conditions(found, "fetch") == set()
    assert _conditions(adders(planning.domain), "fetch") == {()}
    # The watched person lifts c1 alone: only a fetch of c1 may send them to the yard.
    planning = _planning(2, 2, lifts="c1")
    assert _conditions(adders(planning.domain, planning.state.static), "fetch") == {((0, _one("c1")),)}
    support = GoalSupport.of(planning.domain, planning.state.static)
    assert Atom("l2") in support.may_add(Atom("fetch", ("c1",)))
    assert Atom("l2") not in support.may_add(Atom("fetch", ("c0",)))


def test_may_add_reads_the_condition_on_the_ground_task() -> None:
    planning = _planning(2, 2)
    support = GoalSupport.of(planning.domain, planning.state.static)
    l2 = Atom("l2")
    assert support.may_add(Atom("walk", ("watched", "yard"))) == {l2}
    assert support.may_add(Atom("walk", ("q0", "yard"))) == frozenset()
    assert support.may_add(Atom("walk", ("watched", "s0"))) == frozenset()
    assert support.may_add(Atom("walk", ("?p", "yard"))) == {l2}  # a variable: anyone
    assert support.may_add(Atom("cwalk", ("watched", "s0", "yard"))) == frozenset()


def test_no_plan_without_a_search_when_no_task_may_add_the_goal() -> None:
    planning = _planning(2, 2, lifts="none")
    for search in (Search.DFS, Search.GBFS, Search.ASTAR):
        settings = PlannerSettings(alternatives=1, budget=1_000, search=search)
        result = plan(planning.domain, planning.state, planning.tasks, settings)
        assert result.status is PlanStatus.UNSOLVABLE
        assert result.expansions == 0


@pytest.mark.parametrize("search", [Search.DFS, Search.GBFS])
def test_the_search_drops_every_lifter_but_the_watched_one_where_it_is_chosen(
    search: Search, monkeypatch: pytest.MonkeyPatch
) -> None:
    """Every other lifter's walk is dropped as soon as it is chosen: it cannot add l2 and
    nothing after it can.  Without the test (monkeypatched away) the search walks the
    others to every crate first, and finds out at the goal's check."""
    planning = _planning(6, 4)
    settings = PlannerSettings(alternatives=1, budget=200_000, search=search)

    def searched() -> int:
        result = plan(planning.domain, planning.state, planning.tasks, settings)
        assert result.status is PlanStatus.SOLVED and result.best is not None
        assert [str(v) for v in check_plan(planning.hddl, planning.problem, ipc_plan(result.best))] == []
        assert [s.action.name for s in result.best.steps if not s.action.name.startswith("__")] == ["obs"]
        return result.expansions

    held = searched()
    monkeypatch.setattr(planner, "checks_goal", lambda domain, tasks: False)
    blind = searched()
    assert held <= 12
    assert blind > 3 * held


def test_a_mark_no_task_left_may_add_is_a_dead_end() -> None:
    # The watched agent's two trips are the observed actions: l2 (only obs1 adds it) is a
    # mark behind the goal l3.  A list with the trip back alone may add l3, yet not l2, which
    # the trip back needs first: a dead end, where the goal facts alone would not see one.
    planning = _watched(["b0", "watched"], ["q0"])
    support = GoalSupport.of(planning.domain, planning.state.static, planning.state.dynamic_predicates)
    l2, l3 = Atom("l2"), Atom("l3")
    assert support.marks == {l2}  # at(watched,shop) is behind l3 too, but every move adds it
    start = planning.state.dynamic
    assert support.needed(start) == {l2, l3}
    back = [Atom("cmove", ("watched", "shop", "home")), Atom("__goal", ())]
    there = [Atom("cmove", ("watched", "home", "shop")), *back]
    assert support.lost_at_start(start, back)
    assert not support.lost_at_start(start, there)
    # After obs1, l2 holds and l3 alone is needed: the trip back is enough.
    after = (start - {Atom("l1"), Atom("at", ("watched", "home"))}) | {l2, Atom("at", ("watched", "shop"))}
    assert support.needed(after) == {l3}
    assert not support.lost_after_action(Atom("obs1", ()), start, after, back)
    # The goal facts alone do not see it.
    goal_alone = GoalSupport(planning.domain, GoalLandmarks(planning.domain.goal_facts, {}))
    assert not goal_alone.lost_at_start(start, back)


def test_the_search_brings_the_next_mark_forward() -> None:
    """Greedy search adds, for the next mark, what the tasks before the first that may add it
    cost (design §7.3): the errand whose trip is the observed one comes first, whichever
    agent the bindings try first."""
    planning = _watched(["b0", "b1", "b2", "b3", "watched"], ["q0", "q1", "q2", "q3"])
    support = GoalSupport.of(planning.domain, planning.state.static, planning.state.dynamic_predicates)
    start = planning.state.dynamic

    def cost(name: str) -> float:
        return 1.0

    trip = Atom("cmove", ("watched", "home", "shop"))
    other = Atom("errand", ("b0",))
    assert support.before_next_marks([trip, Atom("__goal", ())], start, cost) == 0.0
    assert support.before_next_marks([other, other, trip], start, cost) == 2.0
    assert support.before_next_marks([Atom("errand", ("watched",))], start, cost) == 0.0
    # Away from home, at(watched,home) is needed behind l2 too: not a mark (every move adds
    # it), so l2 is still the next mark.
    away = (start - {Atom("at", ("watched", "home"))}) | {Atom("at", ("watched", "q0"))}
    assert Atom("at", ("watched", "home")) in support.landmarks.needed(away)
    assert support.before_next_marks([other, other, trip], away, cost) == 2.0


# Two ways to do the day, in the watched domain of tests/test_landmarks.py: the helper's
# errand first and the observed trips after, or the trips first.  Nothing tells the two
# ways apart but where the trips come.
_DAY = _WATCHED_DOMAIN.format(agents="watched helper", places="").replace(
    "  (:action move",
    """  (:task day)
  (:method early :parameters () :task (day)
    :ordered-subtasks (and (cmove watched home shop) (cmove watched shop home)
                           (move helper home shop) (move helper shop home)))
  (:method late :parameters () :task (day)
    :ordered-subtasks (and (move helper home shop) (move helper shop home)
                           (cmove watched home shop) (cmove watched shop home)))
  (:action move""",
)


def test_greedy_search_takes_the_way_that_brings_the_observed_trips_first(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    """Greedy search adds what the tasks before the next mark's first possible adder cost
    (design §7.4): the way with the trips first is ahead, and its plan comes first.  Without
    it (monkeypatched to nothing) the two ways look the same, and the last one written (ties
    go to the newest node), the errand first, is taken."""
    domain = parse_domain(_DAY, "day.hddl")
    problem = """(define (problem p) (:domain watched)
      (:htn :ordered-subtasks (day))
      (:init (at watched home) (at helper home) (road home shop) (road shop home) (l1))
      (:goal (l3)))"""
    planning = translate(domain, parse_problem(problem, domain, "p.hddl"))
    settings = PlannerSettings(alternatives=1, budget=100_000, search=Search.GBFS)
    assert GoalSupport.of(planning.domain, planning.state.static).marks == {Atom("l2")}

    def first_action() -> str:
        result = plan(planning.domain, planning.state, planning.tasks, settings)
        assert result.status is PlanStatus.SOLVED and result.best is not None
        assert [str(v) for v in check_plan(planning.hddl, planning.problem, ipc_plan(result.best))] == []
        return next(s.action.name for s in result.best.steps if not s.action.name.startswith("__"))

    assert first_action() == "obs1"
    monkeypatch.setattr(GoalSupport, "before_next_marks", lambda self, tasks, dynamic, cost: 0.0)
    assert first_action() == "move"
