"""The planner's search step against networkx's A* on the same graph (``python -m bench step``).

On generated museums of about 1,000, 5,000 and 10,000 nodes, the navigator
plans ``goto_node`` between far-apart nodes (K = 1, its own estimate), and
networkx's ``astar_path`` finds the shortest path between the same nodes with
the straight line as its heuristic.  A search step is one node taken off the
open list and expanded: for networkx a graph node (all its edges relaxed), for
the planner a search node (a compound task decomposed, or an action applied —
a graph node costs it two steps: ``goto_node`` into a move, then the move).
Medians over repeated runs of each search; writes ``bench/results/step.json``:
``{nodes, pair, planner_steps, planner_us_per_step, nx_steps, nx_us_per_step, ratio}``.
"""

from __future__ import annotations

import functools
import json
import math
import statistics
import sys
import time
from pathlib import Path
from typing import Any

import networkx as nx

from bench.astar_estimate import PAIRS, node_near
from bench.machine import machine_line
from htnagent.domains import nodes_domain
from htnagent.domains.maps import WorldMap, generate_map
from htnagent.model.terms import Atom
from htnagent.planning.planner import PlannerSettings, plan

RESULTS = Path(__file__).resolve().parent / "results"
MAPS = [(4, 4, 8, 1), (9, 9, 8, 1), (12, 12, 9, 1)]
"""``(cols, rows, side, seed)``: 1,024, 5,184 and 11,664 nodes."""


def _straight_line(world: WorldMap, x: float, y: float, u: str, v: str) -> float:
    node = world.nodes[u]
    return math.hypot(node.x - x, node.y - y)


def _weight(popped: set[str], u: str, v: str, d: dict[str, float]) -> float:
    popped.add(u)  # networkx relaxes the edges of each node it expands: count those nodes
    return d["weight"]


def main(runs: int = 5) -> int:
    """Time both searches on each map and pair; print and write the figures."""
    rows: list[dict[str, Any]] = []
    for cols, rows_, side, seed in MAPS:
        world = generate_map(cols, rows_, side, seed)
        domain = nodes_domain(world)
        graph = nx.Graph()
        for arc in world.arcs.values():
            graph.add_edge(arc.a, arc.b, weight=arc.length)
        for name, a, b in PAIRS[:4]:
            start, goal = node_near(world, *a), node_near(world, *b)
            state = domain.initial_state(start)
            task = [Atom("goto_node", (goal,))]
            plan(domain, state, task, PlannerSettings(alternatives=1))  # warm up (landmarks)
            ours: list[float] = []
            expansions = 0
            for _ in range(runs):
                t = time.perf_counter()
                result = plan(domain, state, task, PlannerSettings(alternatives=1))
                ours.append(time.perf_counter() - t)
                expansions = result.expansions
            target = world.nodes[goal]
            heuristic = functools.partial(_straight_line, world, target.x, target.y)
            theirs: list[float] = []
            popped: set[str] = set()
            for _ in range(runs):
                popped.clear()
                t = time.perf_counter()
                weight = functools.partial(_weight, popped)
                nx.astar_path(graph, start, goal, heuristic=heuristic, weight=weight)
                theirs.append(time.perf_counter() - t)
            nx_steps = len(popped) + 1
            ours_us = statistics.median(ours) / expansions * 1e6
            theirs_us = statistics.median(theirs) / nx_steps * 1e6
            row = {
                "nodes": len(world.nodes),
                "pair": name,
                "planner_steps": expansions,
                "planner_us_per_step": round(ours_us, 2),
                "nx_steps": nx_steps,
                "nx_us_per_step": round(theirs_us, 2),
                "ratio": round(ours_us / theirs_us, 2),
            }
            rows.append(row)
            print(
                f"{row['nodes']:>6} nodes {name:<14} planner {expansions:>5} steps {ours_us:6.1f} µs a step; "
                f"networkx {nx_steps:>5} steps {theirs_us:5.1f} µs a step; {row['ratio']}×",
                file=sys.stderr,
                flush=True,
            )
    RESULTS.mkdir(parents=True, exist_ok=True)
    (RESULTS / "step.json").write_text(json.dumps(rows, indent=2) + "\n")
    ratio = statistics.median(r["ratio"] for r in rows)
    print(f"median: a planner step costs {ratio:.1f}× a networkx step ({machine_line()})", file=sys.stderr)
    return 0
