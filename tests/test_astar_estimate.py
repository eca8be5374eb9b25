"""The navigator's estimate makes the planner an A* search that opens far less of a big map.

``bench/astar_estimate.py`` measures the same on more pairs and maps, with times.
Across the whole map (corner to corner) the estimate saves less, because routes
through the doors run 1.3-1.6 times the straight line; between inner points it must
save more than half the expansions.  No timing is asserted.
"""

from __future__ import annotations

import dataclasses
import math

import pytest

from htnagent.domains.maps import WorldMap, generate_map
from htnagent.domains.museum import nodes_domain
from htnagent.model.domain import Domain
from htnagent.model.terms import Atom
from htnagent.planning.planner import PlannerSettings, PlanResult, plan


@pytest.fixture(scope="module")
def big_map() -> WorldMap:
    world = generate_map(4, 4, 8, seed=1)
    assert len(world.nodes) == 1024
    return world


def _node_near(world: WorldMap, fx: float, fy: float) -> str:
    xs = [n.x for n in world.nodes.values()]
    ys = [n.y for n in world.nodes.values()]
    x = min(xs) + fx * (max(xs) - min(xs))
    y = min(ys) + fy * (max(ys) - min(ys))
    return min(world.nodes.values(), key=lambda n: (math.hypot(n.x - x, n.y - y), n.name)).name


def _both_ways(
    world: WorldMap, a: tuple[float, float], b: tuple[float, float]
) -> tuple[PlanResult, PlanResult]:
    informed = nodes_domain(world)
    blind: Domain = dataclasses.replace(informed, estimates={})  # a copy gets caches of its own
    start, goal = _node_near(world, *a), _node_near(world, *b)
    assert world.distance(start, goal) > 80.0  # far apart: the map is about 135 m across
    task = [Atom("goto_node", (goal,))]
    settings = PlannerSettings(alternatives=1)
    with_h = plan(informed, informed.initial_state(start), task, settings)
    without = plan(blind, blind.initial_state(start), task, settings)
    assert with_h.best is not None and without.best is not None
    assert with_h.best.cost == pytest.approx(without.best.cost, abs=1e-9)
    return with_h, without


@pytest.mark.parametrize(
    ("a", "b"),
    [((0.25, 0.25), (0.75, 0.75)), ((0.75, 0.25), (0.25, 0.75)), ((0.0, 0.5), (1.0, 0.5))],
    ids=["inner-diagonal", "inner-anti-diagonal", "west-east"],
)
def test_estimate_halves_the_expansions_for_the_same_cost(
    big_map: WorldMap, a: tuple[float, float], b: tuple[float, float]
) -> None:
    with_h, without = _both_ways(big_map, a, b)
    assert with_h.expansions < without.expansions / 2


@pytest.mark.parametrize(
    ("a", "b"), [((0.0, 0.0), (1.0, 1.0)), ((1.0, 0.0), (0.0, 1.0))], ids=["NW-SE", "NE-SW"]
)
def test_estimate_never_costs_expansions_across_the_whole_map(
    big_map: WorldMap, a: tuple[float, float], b: tuple[float, float]
) -> None:
    with_h, without = _both_ways(big_map, a, b)
    assert with_h.expansions < without.expansions
