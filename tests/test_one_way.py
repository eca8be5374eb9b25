"""One-way facts in the grounded estimate (docs/design.md §7.2, step 5): a task list that
uses up a fact nothing renews before a later task needs it is a dead end, which the delete
relaxation alone cannot see."""

from __future__ import annotations

import math

import pytest

from htnagent.hddl import parse_domain, parse_problem
from htnagent.hddl.check import check_plan
from htnagent.planning import composition
from htnagent.planning.hddl_translation import HddlPlanning, translate
from htnagent.planning.ipc_output import ipc_plan
from htnagent.planning.one_way import OneWay
from htnagent.planning.planner import PlannerSettings, PlanStatus, Search, plan
from tests.support import fact, grounded

SWITCHES = 7
"""Switches set between the two houses' building: 2**7 ways to set them, each a state."""

PLOTS = f"""
(define (domain plots)
  (:requirements :negative-preconditions :hierarchy :typing :method-preconditions)
  (:types house plot switch - object)
  (:constants {" ".join(f"s{k}" for k in range(1, SWITCHES + 1))} - switch)
  (:predicates (free ?p - plot) (on ?h - house ?p - plot) (lit ?s - switch) (started ?h - house)
               (cleared ?p - plot) (dug ?p - plot))
  (:task settle :parameters (?a ?b - house))
  (:task prepare :parameters (?p - plot))
  (:task set :parameters (?s - switch))
  ; The plots are chosen long before the houses are built, and nothing frees a plot again:
  ; both houses on one plot is a dead end the delete relaxation sees only once the first
  ; is built.
  (:method m-settle
    :parameters (?a ?b - house ?p ?q - plot)
    :task (settle ?a ?b)
    :precondition (and (free ?p) (free ?q))
    :ordered-subtasks (and (prepare ?p) (prepare ?q)
                           {" ".join(f"(set s{k})" for k in range(1, SWITCHES + 1))}
                           (build ?a ?p) (build ?b ?q)))
  ; Only p1 is cleared: under delete relaxation, both houses there is the cheapest choice.
  (:method m-ready :parameters (?p - plot) :task (prepare ?p) :precondition (cleared ?p) :subtasks ())
  (:method m-clear
    :parameters (?p - plot)
    :task (prepare ?p)
    :precondition (not (cleared ?p))
    :ordered-subtasks (and (dig ?p) (level ?p)))
  (:method m-on :parameters (?s - switch) :task (set ?s) :subtasks (and (turn-on ?s)))
  (:method m-off :parameters (?s - switch) :task (set ?s) :subtasks (and (turn-off ?s)))
  (:action build
    :parameters (?h - house ?p - plot)
    :precondition (and (free ?p) (not (started ?h)))
    :effect (and (not (free ?p)) (on ?h ?p) (started ?h)))
  (:action dig :parameters (?p - plot) :effect (dug ?p))
  (:action level :parameters (?p - plot) :precondition (dug ?p) :effect (cleared ?p))
  (:action turn-on :parameters (?s - switch) :effect (lit ?s))
  (:action turn-off :parameters (?s - switch) :effect (not (lit ?s))))
"""


def _plots(plots: int = 3) -> HddlPlanning:
    domain = parse_domain(PLOTS, "plots.hddl")
    names = " ".join(f"p{k}" for k in range(1, plots + 1))
    free = " ".join(f"(free p{k})" for k in range(1, plots + 1))
    problem = parse_problem(
        f"(define (problem p) (:domain plots) (:objects h1 h2 - house {names} - plot)"
        f" (:htn :ordered-subtasks (and (settle h1 h2))) (:init {free} (cleared p1)))",
        domain,
        "p.hddl",
    )
    return translate(domain, problem)


def test_a_fact_used_up_before_a_later_task_needs_it_is_a_dead_end() -> None:
    planning = _plots()
    c = grounded(planning)
    start = planning.state.dynamic
    sets = [fact("set", f"s{k}") for k in range(1, SWITCHES + 1)]
    apart = [*sets, fact("build", "h1", "p1"), fact("build", "h2", "p2")]
    clash = [*sets, fact("build", "h1", "p1"), fact("build", "h2", "p1")]
    assert c.estimate(apart, start) < math.inf
    # Without the build before it, the second house could still go on p1.
    assert c.estimate(clash[:-2] + clash[-1:], start) < math.inf
    assert c.estimate(clash, start) == math.inf
    # Nor where the state has no free p1 to begin with.
    assert c.estimate(clash[-1:], start - {fact("free", "p1")}) == math.inf


def test_a_negated_fact_nothing_undoes_is_one_way_too() -> None:
    # started(h1) is added by build and deleted by nothing: a second build of h1 needs its
    # negation, which the first one ends.
    planning = _plots()
    c = grounded(planning)
    twice = [fact("build", "h1", "p1"), fact("build", "h1", "p2")]
    assert c.estimate(twice, planning.state.dynamic) == math.inf
    assert c.estimate(twice[1:], planning.state.dynamic) < math.inf


def test_what_every_decomposition_needs_a_compound_task_needs() -> None:
    planning = _plots()
    c = grounded(planning)
    settle = fact("settle", "h1", "h2")
    start = planning.state.dynamic
    assert c.estimate([settle], start) < math.inf
    # Every way to settle builds h1, which needs h1 not started: a build of h1 before it
    # ends that.
    assert c.estimate([fact("build", "h1", "p3"), settle], start) == math.inf
    # No one plot is needed by every way (each picks its own): without p3, the others.
    assert c.estimate([settle], start - {fact("free", "p3")}) < math.inf


def test_the_search_escapes_the_plateau_the_clash_makes(monkeypatch: pytest.MonkeyPatch) -> None:
    # Greedy search, guided by relaxed composition: both houses on the cleared plot looks
    # cheapest, and below that choice lie 2**7 ways to set the switches, none with a plan.
    # With one-way facts the clash is dropped where it is made.
    planning = _plots()
    settings = PlannerSettings(alternatives=1, budget=400, search=Search.GBFS)
    guide = grounded(planning).estimate
    found = plan(planning.domain, planning.state, planning.tasks, settings, guide=guide)
    assert found.status is PlanStatus.SOLVED
    assert found.best is not None
    assert [str(v) for v in check_plan(planning.hddl, planning.problem, ipc_plan(found.best))] == []
    # The same search without them is lost in the dead region.
    monkeypatch.setattr(composition, "OneWay", _NoOneWay)
    guide = grounded(planning).estimate
    lost = plan(planning.domain, planning.state, planning.tasks, settings, guide=guide)
    assert lost.status is PlanStatus.BUDGET_EXHAUSTED


class _NoOneWay:
    """The grounded estimate as it was: nothing is one-way."""

    @staticmethod
    def of(*_: object) -> OneWay:
        return OneWay({}, {})
