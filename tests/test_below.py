"""What a task list can still make true, in the grounded estimate (docs/design.md §7.2,
step 6): a fact, or a goal fact, that a task needs and that no task before it can add is out
of reach, however cheaply some action below another task would add it."""

from __future__ import annotations

import math

import pytest

from htnagent.hddl import parse_domain, parse_problem
from htnagent.hddl.check import check_plan
from htnagent.planning import below
from htnagent.planning.below import Below, Split, starting_needs
from htnagent.planning.hddl_translation import HddlPlanning, translate
from htnagent.planning.ipc_output import ipc_plan
from htnagent.planning.planner import PlannerSettings, PlanStatus, Search, plan
from tests.support import fact, grounded

SWITCHES = 7
"""Switches set between the two parts' painting: 2**7 ways to set them, each a state."""

DYES = f"""
(define (domain dyes)
  (:requirements :hierarchy :typing :method-preconditions)
  (:types part switch - object)
  (:constants {" ".join(f"s{k}" for k in range(1, SWITCHES + 1))} - switch)
  (:predicates (red ?p - part) (blue ?p - part) (primed ?p - part) (lit ?s - switch)
               (same ?p ?q - part))
  (:task paint :parameters (?p - part))
  (:task finish :parameters (?p - part))
  (:task set :parameters (?s - switch))
  ; Blue takes one action, red two: blue looks cheaper, but the goal wants p1 red and no
  ; task after the painting can dye p1 again.
  (:method m-blue :parameters (?p - part) :task (paint ?p) :ordered-subtasks (and (dye-blue ?p)))
  (:method m-red
    :parameters (?p - part)
    :task (paint ?p)
    :ordered-subtasks (and (prime ?p) (dye-red ?p)))
  ; The part finished is one the static facts name: what the lifted goal check reads,
  ; "finish may dye any part red", keeps the dead end; the grounding knows it is p2 only.
  (:method m-finish
    :parameters (?p ?q - part)
    :task (finish ?p)
    :precondition (same ?p ?q)
    :ordered-subtasks (and (prime ?q) (dye-red ?q)))
  (:method m-on :parameters (?s - switch) :task (set ?s) :subtasks (and (turn-on ?s)))
  (:method m-off :parameters (?s - switch) :task (set ?s) :subtasks (and (turn-off ?s)))
  (:action prime :parameters (?p - part) :effect (primed ?p))
  (:action dye-red :parameters (?p - part) :precondition (primed ?p) :effect (red ?p))
  (:action dye-blue :parameters (?p - part) :effect (blue ?p))
  (:action turn-on :parameters (?s - switch) :effect (lit ?s))
  (:action turn-off :parameters (?s - switch) :effect (not (lit ?s))))
"""


def _dyes() -> HddlPlanning:
    domain = parse_domain(DYES, "dyes.hddl")
    sets = " ".join(f"(set s{k})" for k in range(1, SWITCHES + 1))
    problem = parse_problem(
        "(define (problem p) (:domain dyes) (:objects p1 p2 - part)"
        f" (:htn :ordered-subtasks (and (paint p1) {sets} (finish p2)))"
        " (:init (same p1 p1) (same p2 p2)) (:goal (and (red p1) (red p2))))",
        domain,
        "p.hddl",
    )
    return translate(domain, problem)


def test_a_goal_fact_no_task_left_can_add_is_out_of_reach() -> None:
    planning = _dyes()
    c = grounded(planning)
    goal = next(t for t in planning.tasks if t.name == "__goal")
    start = planning.state.dynamic
    sets = [fact("set", f"s{k}") for k in range(1, SWITCHES + 1)]
    finish = fact("finish", "p2")
    # Painted blue: only p2's finish dyes red below the tasks left.
    assert c.estimate([fact("dye-blue", "p1"), *sets, finish, goal], start) == math.inf
    assert c.estimate([fact("prime", "p1"), fact("dye-red", "p1"), *sets, finish, goal], start) < math.inf
    # The same list with the state's p1 red already: nothing is missing.
    assert c.estimate([fact("dye-blue", "p1"), *sets, finish, goal], start | {fact("red", "p1")}) < math.inf
    # The goal alone, with nothing left to dye: out of reach, where it was 4 actions away.
    assert c.estimate([goal], start) == math.inf
    # Tasks before it that can dye both parts red: within reach again.
    assert c.estimate([fact("paint", "p1"), finish, goal], start) < math.inf
    assert c.estimate([fact("paint", "p1"), goal], start) == math.inf


def test_the_search_drops_the_choice_that_lost_the_goal(monkeypatch: pytest.MonkeyPatch) -> None:
    # Greedy search, guided by relaxed composition: blue looks a cheaper way to paint p1,
    # and below it lie 2**7 ways to set the switches, none with a plan.  Knowing what the
    # tasks left can add, blue is dropped where it is chosen.
    planning = _dyes()
    settings = PlannerSettings(alternatives=1, budget=200, search=Search.GBFS)
    found = plan(planning.domain, planning.state, planning.tasks, settings, guide=grounded(planning).estimate)
    assert found.status is PlanStatus.SOLVED
    assert found.best is not None
    assert [str(v) for v in check_plan(planning.hddl, planning.problem, ipc_plan(found.best))] == []
    # The same search as it was, any action adding any fact, is lost in the dead region.
    monkeypatch.setattr(Below, "lost", lambda *_: False)
    lost = plan(planning.domain, planning.state, planning.tasks, settings, guide=grounded(planning).estimate)
    assert lost.status is PlanStatus.BUDGET_EXHAUSTED


def test_what_a_task_needs_at_its_start_is_what_every_way_needs() -> None:
    # Primitive 10 needs fact 1 (one variant) and facts 1 and 2 (another): only 1.
    # Task 20 -> 10 (and needs 3 itself), or 20 -> 21 20 (recursion), 21 primitive needing 4.
    needs = starting_needs(
        [(10, [1]), (10, [1, 2]), (21, [4])],
        [Split(20, [3], [10]), Split(20, [], [21, 20]), Split(22, [5], [])],
    )
    assert needs[10] == frozenset({1})
    assert needs[20] == frozenset()  # 3 or 4: nothing every way needs
    assert needs[22] == frozenset({5})


def test_a_fact_needed_must_hold_or_come_from_a_task_before() -> None:
    # 0 -> 1 -> 0 (recursion), 1 -> 2; 3 -> 4; primitive 2 adds fact 7, 4 adds 8.
    b = Below({0: [1], 1: [0, 2], 3: [4]}, {2: [7], 4: [8]}, {5: [7]})
    assert b.adds(0) == b.adds(1) == frozenset({7})
    assert b.needs == {5: frozenset({7})}
    assert b.lost(frozenset({7}), [])
    assert not b.lost(frozenset({7}), [0])
    assert b.lost(frozenset({7}), [3])
    assert b.lost(frozenset({7, 8}), [0])
    assert not b.lost(frozenset({7, 8}), [0, 3])


def test_below_forgets_past_its_bound_and_answers_the_same(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setattr(below, "MAX_KEPT", 1)
    b = Below({0: [1, 2], 3: [1]}, {1: [5], 2: [6]}, {})
    assert b.adds(0) == frozenset({5, 6})
    assert b.adds(3) == frozenset({5})
    assert b.adds(0) == frozenset({5, 6})
