"""Planner edge cases: admissibility with several compound tasks, duplicates, foreign heads."""

from __future__ import annotations

import gc
import math

import pytest

from htnagent.errors import SettingsError
from htnagent.model.domain import Domain, State
from htnagent.model.terms import Atom, parse
from htnagent.planning import planner
from htnagent.planning.planner import PlannerSettings, PlanStatus, plan

POINTS = {"p": (0.0, 0.0), "a": (10.0, 0.0), "b": (11.0, 0.0)}


def _line() -> Domain:
    """Three places on a line, p - a - b, b close to a; or a lift from p to b and back."""
    d = Domain("line")
    d.operator(
        "walk(?f,?t)",
        pre=["at(?f)", "place(?t)"],
        add=["at(?t)"],
        delete=["at(?f)"],
        cost=lambda act: math.dist(POINTS[str(act.args[0])], POINTS[str(act.args[1])]),
    )
    d.method("visit(?n)", "here", when=["at(?n)"], do=[])
    d.method("visit(?n)", "walk", when=["not at(?n)", "at(?x)"], do=["walk(?x,?n)"])
    d.operator("lift", pre=["at(p)"], add=["at(b)", "seen(a)"], delete=["at(p)"], cost=15.0)
    d.method("both(?x,?y)", "walking", do=["visit(?x)", "visit(?y)"])
    d.method("both(?x,?y)", "by_lift", do=["lift"])

    def straight_line(task: Atom, state: State) -> float:
        here = next(str(f.args[0]) for f in state.dynamic if f.name == "at")
        return math.dist(POINTS[here], POINTS[str(task.args[0])])

    d.estimate("visit", straight_line)
    d.facts = tuple(parse(f"place({n})") for n in POINTS)
    return d


def test_several_compound_tasks_still_give_the_cheapest_plan() -> None:
    d = _line()
    state = d.initial_state().updated(add=[parse("at(p)")])
    result = plan(d, state, [parse("both(a,b)")], PlannerSettings(alternatives=1))
    # Expect: walking p -> a -> b costs 10 + 1 = 11, the lift 15.  Summing the estimates
    # of visit(a) and visit(b) both from p (10 + 11 = 21) would have put the lift first.
    assert result.best is not None
    assert result.best.text() == ["walk(p,a)", "walk(a,b)"] and result.best.cost == 11.0


def test_a_repeated_plan_does_not_take_an_alternatives_place() -> None:
    d = Domain("dup")
    d.operator("a", add=["done"])
    d.operator("b", add=["done"], cost=2.0)
    d.method("goal", "first", do=["a"])
    d.method("goal", "wrapped", do=["inner"])
    d.method("inner", "just_a", do=["a"])  # the same plan, a second way
    d.method("goal", "other", do=["b"])
    result = plan(d, d.initial_state(), [parse("goal")], PlannerSettings(alternatives=2))
    assert [p.text() for p in result.plans] == [["a"], ["b"]]


def test_a_task_no_operator_head_matches_is_a_dead_end_not_an_error() -> None:
    d = Domain("doors")
    d.operator("open(door1)", add=["open(door1)"])
    d.method("enter", "by_door2", do=["open(door2)"])
    result = plan(d, d.initial_state(), [parse("enter")])
    assert result.status is PlanStatus.UNSOLVABLE


def test_the_search_pauses_the_cyclic_collector_and_restores_it() -> None:
    seen: list[bool] = []
    d = Domain("gc")
    d.operator("step(?x,?y)", pre=["at(?x)", "link(?x,?y)"], add=["at(?y)"], delete=["at(?x)"])
    d.method("reach(?n)", "here", when=["at(?n)"], do=[])
    d.method(
        "reach(?n)", "walk", when=["not at(?n)", "at(?x)", "link(?x,?y)"], do=["step(?x,?y)", "reach(?n)"]
    )

    def estimate(task: Atom, state: State) -> float:
        seen.append(gc.isenabled())
        return 0.0

    d.estimate("reach", estimate)
    state = State.from_facts([parse("at(a)"), parse("link(a,b)")], d.dynamic_predicates)
    assert gc.isenabled()
    assert plan(d, state, [parse("reach(b)")]).best is not None
    assert seen and not any(seen)  # paused while searching
    assert gc.isenabled()  # and back on after
    gc.disable()
    try:
        plan(d, state, [parse("reach(b)")])
        assert not gc.isenabled()  # a caller's own choice is left as it was
    finally:
        gc.enable()


def test_a_method_that_grows_its_own_task_list_ends_as_out_of_budget(monkeypatch: pytest.MonkeyPatch) -> None:
    # t -> t t puts one more task in the list at each expansion, and each node copies its
    # list: with the default budget the search took memory without end (18 GB in two
    # minutes).  Lists beyond a bound are not followed: out of budget, not unsolvable.
    monkeypatch.setattr(planner, "_MAX_TASK_LIST", 200)  # 10,000 by default: the same, slower
    d = Domain("grow")
    d.operator("flip(?x)", add=["on(?x)"], cost=0.0)
    d.method("t(?x)", "again", when=[], do=["t(?x)", "t(?x)"])
    result = plan(d, d.initial_state(), [parse("t(a)")], PlannerSettings(alternatives=1))
    assert result.status is PlanStatus.BUDGET_EXHAUSTED
    assert result.expansions <= 200


def test_a_bound_on_the_task_list_may_be_given_with_the_settings() -> None:
    # Plan repair bounds a local search's growth to a little more than it was given (the
    # goal's re-plan comes next): the same out-of-budget end, much sooner.
    d = Domain("grow")
    d.operator("flip(?x)", add=["on(?x)"], cost=0.0)
    d.method("t(?x)", "again", when=[], do=["t(?x)", "t(?x)"])
    result = plan(d, d.initial_state(), [parse("t(a)")], PlannerSettings(alternatives=1, max_tasks=20))
    assert result.status is PlanStatus.BUDGET_EXHAUSTED
    assert result.expansions <= 20
    with pytest.raises(SettingsError, match="max_tasks must be at least 1, not 0"):
        PlannerSettings(max_tasks=0)


def test_a_network_given_as_one_task_may_be_as_long_as_it_decomposes_into(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    # HDDL's initial network is one task decomposing into the whole network: a list longer
    # than the bound on growth is what was given, not growth, and is planned.
    monkeypatch.setattr(planner, "_MAX_TASK_LIST", 200)
    d = Domain("many")
    d.operator("tick(?x)", cost=1.0)
    d.method("all(?x)", "each", when=[], do=["tick(?x)"] * 300)
    result = plan(d, d.initial_state(), [parse("all(a)")], PlannerSettings(alternatives=1))
    assert result.status is PlanStatus.SOLVED and len(result.plans[0].steps) == 300
