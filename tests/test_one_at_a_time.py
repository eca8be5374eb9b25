"""A plan made cheaper one task of its network at a time (docs/design.md §7.6), and the
planner's tasks that follow a list without being planned (``plan``'s ``then``)."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import pytest

from htnagent.hddl import read_domain, read_problem
from htnagent.hddl.check import check_plan
from htnagent.model.plans import Plan
from htnagent.model.terms import Atom
from htnagent.planning import hddl_solving
from htnagent.planning.hddl_solving import solve, solve_anytime
from htnagent.planning.hddl_translation import TOP, HddlPlanning, translate
from htnagent.planning.ipc_output import actions_of, ipc_plan
from htnagent.planning.one_at_a_time import Cheaper, Outcome, cheaper_one_at_a_time, parts_of
from htnagent.planning.planner import PlannerSettings, Search, plan, stop_searches
from tests.test_anytime import LIFT, lift

# Chores, done in turn.  Each task has a long way and a short one; the long one comes
# first, so depth-first search in method order, the portfolio's first plan, takes it.
#  - keep: the short way (rush) loses the flag, which nothing brings back;
#  - meal: the short way (hasty) leaves the kitchen dirty, and a dessert cooked in a
#    dirty kitchen takes three scrubs first.
CHORES = """
(define (domain chores)
  (:requirements :typing :hierarchy :negative-preconditions :method-preconditions)
  (:types thing)
  (:constants a b - thing)
  (:predicates (flag) (dirty) (done ?t - thing))
  (:task keep :parameters (?t - thing))
  (:task tidy :parameters (?t - thing))
  (:task meal :parameters (?t - thing))
  (:task dessert :parameters (?t - thing))
  (:task day :parameters ())
  (:method day-of-chores :parameters () :task (day)
    :ordered-subtasks (and (tidy a) (keep a) (tidy b)))
  (:task rest :parameters ())
  (:method rest-at-once :parameters () :task (rest) :ordered-subtasks ())
  (:task nap :parameters (?t - thing))
  (:method nap-long :parameters (?t - thing) :task (nap ?t)
    :ordered-subtasks (and (wipe ?t) (wipe ?t)))
  (:method nap-skipped :parameters (?t - thing) :task (nap ?t) :ordered-subtasks ())
  (:task treat :parameters (?t - thing))
  (:method treat-in-a-clean-kitchen :parameters (?t - thing) :task (treat ?t)
    :precondition (not (dirty))
    :ordered-subtasks (and (serve ?t)))
  (:method keep-carefully :parameters (?t - thing) :task (keep ?t)
    :ordered-subtasks (and (careful ?t) (careful ?t)))
  (:method keep-rushing :parameters (?t - thing) :task (keep ?t)
    :ordered-subtasks (and (rush ?t)))
  (:method tidy-long :parameters (?t - thing) :task (tidy ?t)
    :ordered-subtasks (and (wipe ?t) (wipe ?t) (wipe ?t)))
  (:method tidy-short :parameters (?t - thing) :task (tidy ?t)
    :ordered-subtasks (and (wipe ?t)))
  (:method meal-careful :parameters (?t - thing) :task (meal ?t)
    :ordered-subtasks (and (prepare ?t) (serve ?t)))
  (:method meal-hasty :parameters (?t - thing) :task (meal ?t)
    :ordered-subtasks (and (serve-hasty ?t)))
  (:method dessert-clean :parameters (?t - thing) :task (dessert ?t)
    :precondition (not (dirty))
    :ordered-subtasks (and (serve ?t)))
  (:method dessert-dirty :parameters (?t - thing) :task (dessert ?t)
    :precondition (dirty)
    :ordered-subtasks (and (scrub) (scrub) (scrub) (serve ?t)))
  (:action careful :parameters (?t - thing) :effect (done ?t))
  (:action rush :parameters (?t - thing) :effect (and (done ?t) (not (flag))))
  (:action wipe :parameters (?t - thing) :effect (done ?t))
  (:action prepare :parameters (?t - thing) :effect ())
  (:action serve :parameters (?t - thing) :effect (done ?t))
  (:action serve-hasty :parameters (?t - thing) :effect (and (done ?t) (dirty)))
  (:action scrub :parameters () :effect (not (dirty)))
)
"""


def chores(tmp_path: Path, tasks: str, goal: str = "") -> tuple[HddlPlanning, Plan]:
    """The chores problem of ``tasks`` (and ``goal``), translated, and its portfolio's first plan."""
    (tmp_path / "domain.hddl").write_text(CHORES)
    goal_part = f"  (:goal {goal})\n" if goal else ""
    (tmp_path / "problem.hddl").write_text(
        "(define (problem p) (:domain chores)\n"
        f"  (:htn :ordered-subtasks (and {tasks}))\n"
        f"{goal_part}  (:init (flag)))\n"
    )
    domain = read_domain(tmp_path / "domain.hddl")
    problem = read_problem(tmp_path / "problem.hddl", domain)
    first = solve(domain, problem).result.best
    assert first is not None
    return translate(domain, problem), first


def valid(tmp_path: Path, found: Plan) -> bool:
    domain = read_domain(tmp_path / "domain.hddl")
    return not check_plan(domain, read_problem(tmp_path / "problem.hddl", domain), ipc_plan(found))


def turns(planning: HddlPlanning, first: Plan, seconds: float = 10) -> Cheaper:
    return cheaper_one_at_a_time(
        planning.domain, planning.state, first, TOP, time_limit=seconds, budget=100_000
    )


def cheaper(planning: HddlPlanning, first: Plan) -> Plan | None:
    found = turns(planning, first)
    assert (found.outcome is Outcome.CHEAPER) == (found.plan is not None)
    return found.plan


def test_a_plan_is_cut_at_its_networks_tasks(tmp_path: Path) -> None:
    _, first = chores(tmp_path, "(keep a) (tidy b) (meal a)", goal="(flag)")
    parts = parts_of(first, TOP)
    assert [str(p.task) for p in parts] == ["keep(a)", "tidy(b)", "meal(a)", "__goal"]
    assert tuple(s for p in parts for s in p.steps) == first.steps
    assert [p.cost for p in parts] == [2, 3, 2, 0]


def test_a_network_of_one_task_is_cut_as_that_tasks_method(tmp_path: Path) -> None:
    # One task costs anything: its subtasks are the parts (the goal's check is one more).
    planning, first = chores(tmp_path, "(day)", goal="(flag)")
    parts = parts_of(first, TOP)
    assert [str(p.task) for p in parts] == ["tidy(a)", "keep(a)", "tidy(b)", "__goal"]
    found = cheaper(planning, first)
    assert found is not None and found.cost == 1 + 2 + 1
    assert valid(tmp_path, found)


@pytest.mark.parametrize("seed", range(6))
def test_each_rider_planned_alone_gives_the_cheapest_lift_plan(tmp_path: Path, seed: int) -> None:
    # The cheapest plan worked out apart from the planner (test_anytime.lift): riders are
    # served in turn, so the cheapest for each in turn is the cheapest for all.
    domain = read_domain(LIFT)
    path, cheapest = lift(tmp_path, seed, floors=12, riders=6)
    problem = read_problem(path, domain)
    planning = translate(domain, problem)
    first = solve(domain, problem).result.best
    assert first is not None and first.cost > cheapest
    found = cheaper(planning, first)
    assert found is not None and found.cost == cheapest
    assert not check_plan(domain, problem, ipc_plan(found))


def test_each_task_gets_its_cheapest_way_where_the_others_are_unchanged(tmp_path: Path) -> None:
    planning, first = chores(tmp_path, "(tidy a) (tidy b) (keep a)")
    assert first.cost == 3 + 3 + 2
    found = cheaper(planning, first)
    assert found is not None and found.cost == 1 + 1 + 1  # keep's rush too: there is no goal
    assert valid(tmp_path, found)


def test_a_tasks_cheapest_way_does_not_lose_the_goal_for_the_tasks_after_it(tmp_path: Path) -> None:
    # Rushing loses the flag, which no later task brings back: the goal's check, seeing the
    # tasks after, keeps the careful way, and tidying still gets its short way.
    planning, first = chores(tmp_path, "(keep a) (tidy b)", goal="(flag)")
    assert first.cost == 2 + 3
    found = cheaper(planning, first)
    assert found is not None and found.cost == 2 + 1
    assert [str(a) for a in actions_of(found)] == ["careful(a)", "careful(a)", "wipe(b)"]
    assert valid(tmp_path, found)


def test_a_dearer_result_is_not_taken(tmp_path: Path) -> None:
    # The hasty meal is the cheapest alone, but leaves the kitchen dirty: the dessert then
    # takes three scrubs.  2 + 1 before, 1 + 4 one at a time.
    planning, first = chores(tmp_path, "(meal a) (dessert b)")
    assert first.cost == 3
    assert cheaper(planning, first) is None
    told: list[Plan] = []
    (tmp_path / "domain.hddl").write_text(CHORES)
    domain = read_domain(tmp_path / "domain.hddl")
    solved = solve_anytime(domain, read_problem(tmp_path / "problem.hddl", domain), told.append, timeout=10)
    assert [p.cost for p in told] == [3] and solved.result.exhausted


def test_tasks_that_follow_are_not_planned_but_count_for_the_goal(tmp_path: Path) -> None:
    planning, _ = chores(tmp_path, "(keep a) (tidy b)", goal="(flag)")
    domain, state = planning.domain, planning.state
    astar = PlannerSettings(alternatives=1, search=Search.ASTAR)
    keep, tidy, goal = Atom("keep", ("a",)), Atom("tidy", ("b",)), Atom("__goal")
    # Alone, keeping rushes; with the tidying and the goal after it, it keeps the flag.
    alone = plan(domain, state, [keep], astar).best
    assert alone is not None and [str(s.action) for s in alone.steps] == ["rush(a)"]
    followed = plan(domain, state, [keep], astar, then=[tidy, goal]).best
    assert followed is not None and [str(s.action) for s in followed.steps] == ["careful(a)", "careful(a)"]
    # A bound is on the plan's cost with the least cost of the tasks after it (1 + 0).
    under = PlannerSettings(alternatives=1, search=Search.ASTAR, cost_bound=2 + 1)
    assert plan(domain, state, [keep], under, then=[tidy, goal]).best is None


def test_a_stop_asked_for_ends_the_turns_with_no_plan(tmp_path: Path) -> None:
    # The command line's Ctrl-C or SIGTERM (stop_searches): the plans told so far stand.
    planning, first = chores(tmp_path, "(tidy a) (tidy b) (keep a)")
    stop_searches()
    try:
        assert cheaper(planning, first) is None
    finally:
        stop_searches(False)
    assert cheaper(planning, first) is not None


def test_only_the_default_anytime_search_plans_one_task_at_a_time(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    # `--search gbfs --anytime` is greedy branch and bound alone (docs/contracts.md).
    domain = read_domain(LIFT)
    path, _ = lift(tmp_path, 0)
    problem = read_problem(path, domain)
    called: list[int] = []
    real = cheaper_one_at_a_time

    def counted(*args: Any, **kwargs: Any) -> Cheaper:
        called.append(1)
        return real(*args, **kwargs)

    monkeypatch.setattr(hddl_solving, "cheaper_one_at_a_time", counted)
    solve_anytime(domain, problem, lambda _: None, search=Search.GBFS, timeout=10)
    assert called == []
    solve_anytime(domain, problem, lambda _: None, timeout=10)
    assert called == [1]


def test_a_task_going_down_a_level_leaves_its_siblings_as_they_are(tmp_path: Path) -> None:
    # The day is the one task that costs anything: it is cut as its method; the rest, done
    # by no action, stays a part of its own (not the whole network again).
    planning, first = chores(tmp_path, "(day) (rest)")
    assert [str(p.task) for p in parts_of(first, TOP)] == ["tidy(a)", "keep(a)", "tidy(b)", "rest"]
    found = cheaper(planning, first)
    assert found is not None and found.cost == 1 + 1 + 1
    assert valid(tmp_path, found)


def test_a_plan_of_no_cost_ends_the_anytime_search(tmp_path: Path) -> None:
    # Both naps skipped: nothing is cheaper than nothing, and nothing is searched under it.
    planning, first = chores(tmp_path, "(nap a) (nap b)")
    assert first.cost == 4
    found = cheaper(planning, first)
    assert found is not None and found.cost == 0 and valid(tmp_path, found)
    domain = read_domain(tmp_path / "domain.hddl")
    told: list[Plan] = []
    solved = solve_anytime(domain, read_problem(tmp_path / "problem.hddl", domain), told.append, timeout=10)
    assert [p.cost for p in told] == [4, 0] and solved.result.exhausted


def test_a_part_with_no_plan_after_the_others_changed_the_world_gives_none(tmp_path: Path) -> None:
    # The hasty meal is the cheapest alone, and leaves the kitchen dirty: the treat, served
    # only in a clean kitchen, then has no plan (A* sees every node).  No goal is checked at
    # the end, so nothing told the meal's search that the treat comes after it.
    planning, first = chores(tmp_path, "(meal a) (treat b)")
    assert first.cost == 3
    found = turns(planning, first)
    assert (found.outcome, found.plan) == (Outcome.NO_PLAN, None)


def test_out_of_time_every_part_keeps_its_plan(tmp_path: Path) -> None:
    planning, first = chores(tmp_path, "(tidy a) (tidy b) (keep a)")
    found = turns(planning, first, seconds=0)
    assert (found.outcome, found.plan, found.expansions) == (Outcome.NOT_CHEAPER, None, 0)


def clock(monkeypatch: pytest.MonkeyPatch, readings: list[float]) -> None:
    """The step's clock (not the searches'): these readings in turn, then the last again."""
    left = iter(readings)
    last = [readings[-1]]

    def read() -> float:
        last[0] = next(left, last[0])
        return last[0]

    monkeypatch.setattr("htnagent.planning.one_at_a_time.perf_counter", read)


@pytest.mark.parametrize(("late", "outcome"), [(15.0, Outcome.CHEAPER), (25.0, Outcome.OUT_OF_TIME)])
def test_past_its_time_with_the_world_changed_greedy_search_finishes_within_as_long_again(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, late: float, outcome: Outcome
) -> None:
    # 10 s for the step: the first tidying is planned at 1 s (its short way: the world has
    # changed), and then the clock reads ``late``.  Within the 10 s more, greedy search
    # plans the rest; past them, the step ends with no plan.
    planning, first = chores(tmp_path, "(tidy a) (tidy b) (keep a)")
    clock(monkeypatch, [0.0, 1.0, 1.0, late])
    found = turns(planning, first, seconds=10)
    assert found.outcome is outcome
    if outcome is Outcome.CHEAPER:
        assert found.plan is not None and found.plan.cost == 1 + 1 + 1 and valid(tmp_path, found.plan)
