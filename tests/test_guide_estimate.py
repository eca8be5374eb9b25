"""The guide's A* estimate for ``goto(N)``: the exact route over the doors plus the walk in.

Checked against an oracle of its own (networkx's Dijkstra on the door graph, doors
shut or not): the estimate never exceeds the cheapest plan (admissible, so A*
keeps its plans optimal), equals it while every door is open, and so leaves the
search next to nothing beyond the route itself.
"""

from __future__ import annotations

import math
import random

import networkx as nx
import pytest

from htnagent.domains.maps import WorldMap, generate_map
from htnagent.domains.museum import areas_domain, areas_facts
from htnagent.model.state import State
from htnagent.model.terms import Atom
from htnagent.planning.planner import PlannerSettings, heuristic, plan


def _door_graph(world: WorldMap, shut: set[str]) -> nx.Graph:
    centre = world.centroids
    graph = nx.Graph()
    for a, b, arc in world.doors:
        if arc.name not in shut:
            (xa, ya), (xb, yb) = centre[a], centre[b]
            graph.add_edge(a, b, weight=math.hypot(xa - xb, ya - yb))
    return graph


def _oracle(world: WorldMap, start: str, goal: str, shut: set[str]) -> float | None:
    """The cheapest plan for goto(goal) from node ``start``: the door route, then the walk in."""
    here, there = world.nodes[start].area, world.nodes[goal].area
    try:
        route = nx.dijkstra_path_length(_door_graph(world, shut), here, there) if here != there else 0.0
    except (nx.NetworkXNoPath, nx.NodeNotFound):
        return None
    node = world.nodes[goal]
    x, y = world.centroids[node.area]
    return route + math.hypot(node.x - x, node.y - y)


@pytest.mark.parametrize("seed", range(6))
def test_the_estimate_is_admissible_and_exact_while_doors_are_open(seed: int) -> None:
    rng = random.Random(seed)
    world = generate_map(rng.randint(2, 7), rng.randint(2, 7), 3, seed)
    d = areas_domain(world)
    names = sorted(world.nodes)
    doors = sorted({arc.name for _, _, arc in world.doors})
    for _ in range(8):
        start, goal = rng.choice(names), rng.choice(names)
        shut = set(rng.sample(doors, rng.randint(0, len(doors) // 3))) if rng.random() < 0.5 else set()
        facts = [*areas_facts(world, start), *(Atom("closed", (arc,)) for arc in shut)]
        state = State.from_facts(facts, d.dynamic_predicates)
        task = Atom("goto", (goal,))
        estimate = heuristic(d, [task], state)
        best = _oracle(world, start, goal, shut)
        result = plan(d, state, [task], PlannerSettings(alternatives=1))
        if best is None:
            assert result.best is None
            continue
        assert result.best is not None
        assert result.best.cost == pytest.approx(best)  # A* stays optimal
        assert estimate <= best + 1e-9
        if not shut:
            assert estimate == pytest.approx(best)


def test_the_search_opens_little_more_than_the_route_on_a_large_map() -> None:
    world = generate_map(20, 14, 3, seed=1)
    d = areas_domain(world)
    names = list(world.nodes)
    state = State.from_facts(areas_facts(world, names[0]), d.dynamic_predicates)
    result = plan(d, state, [Atom("goto", (names[-1],))], PlannerSettings(alternatives=1))
    assert result.best is not None
    # Corner to corner over 280 areas: a few steps an area on the route (the goto, the
    # moves through its doors), not the thousands an estimate of the route alone opens
    # between routes that differ by less than the walk in.
    assert result.expansions <= 6 * len(result.best.steps)
