"""The goal's fact landmarks in greedy search's estimate (docs/design.md §7.4), on a small
domain written here after Monroe-Partially-Observable's shape: the goal is a fact only the
last of a chain of observed actions adds, each needing the fact the one before it added."""

from __future__ import annotations

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from htnagent.hddl import parse_domain, parse_problem
from htnagent.hddl.check import check_plan
from htnagent.model.terms import Atom
from htnagent.planning import landmarks, planner
from htnagent.planning.hddl_translation import HddlPlanning, translate
from htnagent.planning.ipc_output import ipc_plan
from htnagent.planning.landmarks import GoalLandmarks, necessary_preconditions
from htnagent.planning.planner import PlannerSettings, PlanStatus, Search, plan

# Every agent runs one errand: from home to the shop, four wanders, back home.  Only the
# watched agent's two trips between home and the shop can be the observed actions, and
# only they make l2 and then l3, the goal.  Each errand's chore has a way that costs
# nothing (so the lifted estimate of every errand is the same) and is never open.
_DOMAIN = """
(define (domain watched)
  (:requirements :typing :hierarchy :equality)
  (:types agent place)
  (:constants {agents} - agent {places} home shop - place)
  (:predicates (at ?a - agent ?p - place) (excused ?a - agent) (road ?x ?y - place)
               (l1) (l2) (l3))
  (:task top)
  (:task errand :parameters (?a - agent))
  (:task chore :parameters (?a - agent))
  (:task wander :parameters (?a - agent))
  (:task cmove :parameters (?a - agent ?from ?to - place))
  (:method top-errand :parameters (?a - agent) :task (top)
    :ordered-subtasks (errand ?a))
  (:method errand-m :parameters (?a - agent) :task (errand ?a)
    :ordered-subtasks (and (cmove ?a home shop) (chore ?a) (cmove ?a shop home)))
  (:method chore-excused :parameters (?a - agent) :task (chore ?a)
    :precondition (excused ?a) :ordered-subtasks ())
  (:method chore-work :parameters (?a - agent) :task (chore ?a)
    :ordered-subtasks (and (wander ?a) (wander ?a) (wander ?a) (wander ?a)))
  (:method wander-on :parameters (?a - agent ?from ?to - place) :task (wander ?a)
    :precondition (and (at ?a ?from) (road ?from ?to))
    :ordered-subtasks (cmove ?a ?from ?to))
  (:method plain :parameters (?a - agent ?from ?to - place) :task (cmove ?a ?from ?to)
    :ordered-subtasks (move ?a ?from ?to))
  (:method seen-1 :parameters (?a - agent ?from ?to - place) :task (cmove ?a ?from ?to)
    :precondition (and (= ?a watched) (= ?from home) (= ?to shop)) :ordered-subtasks (obs1))
  (:method seen-2 :parameters (?a - agent ?from ?to - place) :task (cmove ?a ?from ?to)
    :precondition (and (= ?a watched) (= ?from shop) (= ?to home)) :ordered-subtasks (obs2))
  (:action move :parameters (?a - agent ?from ?to - place)
    :precondition (and (at ?a ?from) (road ?from ?to))
    :effect (and (at ?a ?to) (not (at ?a ?from))))
  (:action obs1 :parameters ()
    :precondition (and (at watched home) (l1))
    :effect (and (at watched shop) (not (at watched home)) (l2) (not (l1))))
  (:action obs2 :parameters ()
    :precondition (and (at watched shop) (l2))
    :effect (and (at watched home) (not (at watched shop)) (l3) (not (l2))))
)
"""


def _needs(planning: HddlPlanning) -> dict[Atom, frozenset[Atom]]:
    domain = planning.domain
    return necessary_preconditions(domain, domain.goal_facts, planning.state.dynamic_predicates)


def _planning(agents: list[str], places: list[str]) -> HddlPlanning:
    everywhere = [*places, "home", "shop"]
    roads = " ".join(f"(road {x} {y})" for x in everywhere for y in everywhere if x != y)
    start = " ".join(f"(at {a} home)" for a in agents)
    domain = parse_domain(_DOMAIN.format(agents=" ".join(agents), places=" ".join(places)), "watched.hddl")
    problem = f"""(define (problem p) (:domain watched)
      (:htn :ordered-subtasks (top))
      (:init {start} {roads} (l1))
      (:goal (l3)))"""
    return translate(domain, parse_problem(problem, domain, "p.hddl"))


def _at(place: str) -> Atom:
    return Atom("at", ("watched", place))


def test_each_fact_needs_what_every_action_adding_it_needs() -> None:
    planning = _planning(["b0", "watched"], ["q0"])
    found = _needs(planning)
    # l3 only from obs2, which needs l2 and the watched agent at the shop; l2 only from obs1.
    assert found[Atom("l3")] == {Atom("l2"), Atom("at", ("watched", "shop"))}
    assert found[Atom("l2")] == {Atom("l1"), Atom("at", ("watched", "home"))}
    # at(watched,shop) comes from obs1 or from any move: what they share is no one fact
    # (a move's origin is its own variable), and road() never changes.
    assert found[Atom("at", ("watched", "shop"))] == frozenset()
    assert Atom("l1") in found and found[Atom("l1")] == frozenset()


def test_the_count_is_the_false_goal_facts_and_the_false_landmarks_behind_them() -> None:
    planning = _planning(["watched"], ["q0"])
    marks = GoalLandmarks(planning.domain.goal_facts, _needs(planning))
    assert marks.beyond_goals
    # At the start: l3, l2 and the shop to reach (l1 and home hold).
    assert marks.count(frozenset({Atom("l1"), _at("home")})) == 3
    # Away from home before the first observation: home is needed again.
    assert marks.count(frozenset({Atom("l1"), _at("q0")})) == 4
    # After obs1: l3 alone (l2 and the shop hold, what is behind l2 no longer counts).
    assert marks.count(frozenset({Atom("l2"), _at("shop")})) == 1
    assert marks.count(frozenset({Atom("l3"), _at("home")})) == 0


def test_without_landmarks_behind_the_goal_the_count_is_the_false_goal_facts() -> None:
    marks = GoalLandmarks((Atom("g"), Atom("h"), Atom("g")), {Atom("g"): frozenset()})
    assert not marks.beyond_goals
    assert marks.count(frozenset({Atom("h")})) == 1


@pytest.mark.parametrize("watched_at", [0, 2, 4])
def test_greedy_search_follows_the_landmarks_to_the_observed_agent(
    watched_at: int, monkeypatch: pytest.MonkeyPatch
) -> None:
    """Every errand costs the same to the lifted estimate; the landmarks tell the watched
    agent's apart as soon as its first trip is the observed one, wherever the agent comes
    in the order of the bindings.  Without them (monkeypatched away) greedy search goes
    through the other agents' wanders first: hundreds of expansions more.  (The dead-end
    test of design §7.3 would drop the other agents' errands at once, since only the
    watched agent's may add l3: it is off here, so that the estimate alone is measured.)"""
    monkeypatch.setattr(planner, "checks_goal", lambda domain, tasks: False)
    agents = ["b0", "b1", "b2", "b3"]
    agents.insert(watched_at, "watched")
    planning = _planning(agents, ["q0", "q1", "q2", "q3"])
    settings = PlannerSettings(alternatives=1, search=Search.GBFS, budget=100_000)

    def greedy() -> int:
        landmarks._MADE.clear()
        result = plan(planning.domain, planning.state, planning.tasks, settings)
        assert result.status is PlanStatus.SOLVED and result.best is not None
        assert [str(v) for v in check_plan(planning.hddl, planning.problem, ipc_plan(result.best))] == []
        return result.expansions

    guided = greedy()
    monkeypatch.setattr(GoalLandmarks, "beyond_goals", property(lambda self: False))
    unguided = greedy()
    assert guided <= 100
    if watched_at == 0:  # the last binding tried: unguided, every other agent's errand first
        assert unguided > 5 * guided


@st.composite
def _graphs_and_states(
    draw: st.DrawFn,
) -> tuple[GoalLandmarks, frozenset[Atom], frozenset[Atom], frozenset[Atom]]:
    """Random landmarks (cycles allowed) over a few facts, a state whose needed facts are
    known, an unrelated one, and a state a few facts away from the first."""
    facts = [Atom(f"f{i}") for i in range(draw(st.integers(2, 9)))]
    goals = draw(st.lists(st.sampled_from(facts), min_size=1, max_size=4))
    needs = {
        f: frozenset(draw(st.lists(st.sampled_from(facts), max_size=3)))
        for f in draw(st.lists(st.sampled_from(facts), max_size=len(facts)))
    }
    states = st.frozensets(st.sampled_from(facts))
    before, other = draw(states), draw(states)
    flipped = draw(st.frozensets(st.sampled_from(facts), max_size=3))
    return GoalLandmarks(goals, needs), before, other, before ^ flipped


@given(_graphs_and_states())
@settings(max_examples=300, deadline=None)
def test_the_needed_facts_after_an_action_are_those_a_fresh_walk_finds(
    case: tuple[GoalLandmarks, frozenset[Atom], frozenset[Atom], frozenset[Atom]],
) -> None:
    # The search works out the state after an action from the state before it (only what
    # the changed facts are behind, or behind them, again); the oracle walks from scratch.
    marks, before, other, after = case
    fresh = GoalLandmarks(marks.goals, marks.needs)
    marks.needed(before)  # known: worked out from it
    assert marks.needed_after(before, after) == fresh.needed(after)
    assert marks.needed_after(other, before) == fresh.needed(before)  # (other unknown: a walk)
