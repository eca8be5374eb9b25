"""Properties of the museum domains' plans on random maps, checked against networkx.

Every plan must replay from its start state; the navigator's best route must be as
short as networkx's shortest path (arc length as weight); alternatives must replay,
reach the goal and come cheapest first.  Runs derandomized, so failures reproduce.
"""

from __future__ import annotations

import random
from dataclasses import dataclass
from typing import Any

import networkx as nx
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from htnagent.domains.maps import WorldMap, generate_map
from htnagent.domains.museum import areas_domain, nodes_domain
from htnagent.model.plans import replay
from htnagent.model.terms import Atom
from htnagent.planning.planner import PlannerSettings, PlanStatus, plan
from htnagent.scenario import parse_map

FAST = settings(
    max_examples=300,
    derandomize=True,
    deadline=None,
    suppress_health_check=[HealthCheck.too_slow],
)


@dataclass(frozen=True)
class Trip:
    """A map and a journey on it."""

    world: WorldMap
    start: str
    goal: str


def _graph(world: WorldMap) -> nx.Graph:
    g = nx.Graph()
    g.add_nodes_from(world.nodes)
    for arc in world.arcs.values():
        if g.has_edge(arc.a, arc.b) and g[arc.a][arc.b]["weight"] <= arc.length:
            continue
        g.add_edge(arc.a, arc.b, weight=arc.length)
    return g


@st.composite
def generated_trips(draw: st.DrawFn) -> Trip:
    """A museum from ``generate_map`` (each area a jittered grid), and two of its nodes."""
    world = generate_map(
        draw(st.integers(1, 3)),
        draw(st.integers(1, 3)),
        draw(st.integers(2, 4)),
        draw(st.integers(0, 10_000)),
    )
    return _trip(draw, world)


@st.composite
def random_trips(draw: st.DrawFn) -> Trip:
    """Any small connected map: random places, areas and arcs; some arcs with a length of their own.

    Hypothesis draws the sizes and a seed; the map itself comes from that seed, which
    explores far more shapes per example than drawing every coordinate would.
    """
    n = draw(st.integers(2, 14))
    n_areas = draw(st.integers(1, 3))
    extra = draw(st.integers(0, 2 * n))
    rng = random.Random(draw(st.integers(0, 2**32 - 1)))
    nodes: dict[str, Any] = {
        f"p{i}": {"area": f"zone{rng.randint(1, n_areas)}", "x": rng.randint(0, 30), "y": rng.randint(0, 30)}
        for i in range(n)
    }
    pairs = {(rng.randrange(i), i) for i in range(1, n)}  # a spanning tree keeps it connected
    for _ in range(extra):
        a, b = rng.sample(range(n), 2)
        pairs.add((min(a, b), max(a, b)))
    arcs: dict[str, Any] = {}
    for k, (a, b) in enumerate(sorted(pairs)):
        ends = [f"p{a}", f"p{b}"]
        # A third of the arcs say their own length, shorter or longer than the straight line.
        arcs[f"r{k}"] = ends if rng.random() < 2 / 3 else {"ends": ends, "length": rng.uniform(0.5, 60.0)}
    data = {"areas": {f"zone{i}": None for i in range(1, n_areas + 1)}, "nodes": nodes, "arcs": arcs}
    return _trip(draw, parse_map(data, "<random map>"))


def _trip(draw: st.DrawFn, world: WorldMap) -> Trip:
    # Mostly two different nodes: a trip to where the robot already is proves little.
    names = sorted(world.nodes)
    start = draw(st.sampled_from(names))
    others = [n for n in names if n != start]
    goal = draw(st.sampled_from(others)) if others and draw(st.integers(0, 9)) > 0 else start
    return Trip(world, start, goal)


TRIPS = st.one_of(generated_trips(), random_trips())


def _check_navigation(trip: Trip, k: int) -> None:
    domain = nodes_domain(trip.world)
    start = domain.initial_state(trip.start)
    result = plan(domain, start, [Atom("goto_node", (trip.goal,))], PlannerSettings(alternatives=k))
    assert result.status is PlanStatus.SOLVED
    shortest = nx.shortest_path_length(_graph(trip.world), trip.start, trip.goal, weight="weight")
    assert result.plans[0].cost == pytest.approx(shortest, abs=1e-6)
    costs = [p.cost for p in result.plans]
    assert costs == sorted(costs)
    assert len({p.actions for p in result.plans}) == len(result.plans)
    for p in result.plans:
        end = replay(domain, start, p.actions)
        assert end is not None, f"{p} does not replay"
        assert end.dynamic == {Atom("at", (trip.goal,))}
        assert p.cost == pytest.approx(sum(domain.actions.cost(a) for a in p.actions))


@FAST
@given(TRIPS)
def test_navigator_best_route_is_a_shortest_path(trip: Trip) -> None:
    _check_navigation(trip, k=1)


@FAST
@given(TRIPS)
def test_navigator_alternatives_replay_reach_the_goal_and_come_cheapest_first(trip: Trip) -> None:
    _check_navigation(trip, k=3)


@FAST
@given(TRIPS)
def test_guide_plan_replays_in_the_areas_domain(trip: Trip) -> None:
    domain = areas_domain(trip.world)
    start = domain.initial_state(trip.start)
    result = plan(domain, start, [Atom("goto", (trip.goal,))], PlannerSettings(alternatives=2))
    assert result.status is PlanStatus.SOLVED
    goal_area = trip.world.nodes[trip.goal].area
    for p in result.plans:
        assert p.actions[-1] == Atom("goto_node", (trip.goal,))
        end = replay(domain, start, p.actions)
        assert end is not None, f"{p} does not replay"
        assert end.dynamic == {Atom("at", (goal_area,))}


@FAST
@given(generated_trips())
def test_navigator_can_carry_out_the_guides_plan(trip: Trip) -> None:
    # Stratified planning (docs/design.md §5): each parent action is a task the child can plan.
    guide, navigator = areas_domain(trip.world), nodes_domain(trip.world)
    parent = plan(guide, guide.initial_state(trip.start), [Atom("goto", (trip.goal,))]).best
    assert parent is not None
    here = navigator.initial_state(trip.start)
    for action in parent.actions:
        child = plan(navigator, here, [action], PlannerSettings(alternatives=1)).best
        assert child is not None, f"navigator cannot do {action}"
        after = replay(navigator, here, child.actions)
        assert after is not None
        here = after
        if action.name == "move_area":
            (position,) = here.dynamic
            assert trip.world.nodes[str(position.args[0])].area == action.args[1]
    assert here.dynamic == {Atom("at", (trip.goal,))}
