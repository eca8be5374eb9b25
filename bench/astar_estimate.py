"""Benchmark: what the navigator's A* estimate saves, on generated museums of 1,024 and 2,500 nodes.

Run from the repository root: ``python -m bench.astar_estimate``.  For several
far-apart pairs of nodes the navigator plans ``goto_node`` twice: with the
domain's estimates (the larger of the straight line and a landmark bound, A*) and with a copy of the domain
whose ``estimates`` are emptied (``h = 0``, uniform-cost search).  It prints
expansions and milliseconds both ways, with their ratio, for K = 1 (the first,
optimal plan) and K = 4 (alternatives, as an agent searches after a failure), and writes
``bench/results/astar_estimate.json``.

How much A* saves depends on the pair.  Across the whole map (corner to corner,
side to side) the search without estimate stops only when the map is nearly
exhausted, while routes through the doors are 1.3-1.6 times the straight line,
so A* still has to open most of the map.  Between two inner points the estimate
prunes far more.  Both kinds of pair are measured.
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import math
import platform
import statistics
import time
from pathlib import Path
from typing import Any

from htnagent.domains import nodes_domain
from htnagent.domains.maps import WorldMap, generate_map
from htnagent.model.domain import Domain
from htnagent.model.terms import Atom
from htnagent.planning.planner import PlannerSettings, PlanResult, plan

RESULTS = Path(__file__).resolve().parent / "results"

MAPS = [(4, 4, 8, 1), (5, 5, 10, 1)]
"""Generated maps as ``(cols, rows, side, seed)``: 1,024 and 2,500 nodes."""

PAIRS: list[tuple[str, tuple[float, float], tuple[float, float]]] = [
    ("corner NW-SE", (0.0, 0.0), (1.0, 1.0)),
    ("corner NE-SW", (1.0, 0.0), (0.0, 1.0)),
    ("side W-E", (0.0, 0.5), (1.0, 0.5)),
    ("side N-S", (0.5, 0.0), (0.5, 1.0)),
    ("inner diagonal", (0.25, 0.25), (0.75, 0.75)),
    ("inner anti-diagonal", (0.75, 0.25), (0.25, 0.75)),
]
"""Pairs of places as fractions of the map's extent; each becomes the nearest node."""


def node_near(world: WorldMap, fx: float, fy: float) -> str:
    """The node nearest the point at fractions ``fx``, ``fy`` of the map's extent."""
    xs = [n.x for n in world.nodes.values()]
    ys = [n.y for n in world.nodes.values()]
    x = min(xs) + fx * (max(xs) - min(xs))
    y = min(ys) + fy * (max(ys) - min(ys))
    return min(world.nodes.values(), key=lambda n: (math.hypot(n.x - x, n.y - y), n.name)).name


def without_estimates(domain: Domain) -> Domain:
    """A copy of the domain that gives the planner no estimate (``h = 0``)."""
    # The copy gets caches of its own (Domain.actions is made anew).
    return dataclasses.replace(domain, name=f"{domain.name} (no estimate)", estimates={})


def _run(domain: Domain, start: str, goal: str, k: int, repeat: int) -> tuple[PlanResult, float]:
    state = domain.initial_state(start)
    task = [Atom("goto_node", (goal,))]
    samples: list[float] = []
    result: PlanResult | None = None
    for _ in range(repeat):
        t = time.perf_counter()
        result = plan(domain, state, task, PlannerSettings(alternatives=k))
        samples.append(time.perf_counter() - t)
    assert result is not None and result.best is not None
    return result, statistics.median(samples) * 1000


def measure(world: WorldMap, k: int, repeat: int) -> list[dict[str, Any]]:
    """One row per pair: expansions and median milliseconds with and without the estimate."""
    informed = nodes_domain(world)
    blind = without_estimates(informed)
    rows = []
    for label, a, b in PAIRS:
        start, goal = node_near(world, *a), node_near(world, *b)
        with_h, ms_with = _run(informed, start, goal, k, repeat)
        no_h, ms_without = _run(blind, start, goal, k, repeat)
        assert with_h.best is not None and no_h.best is not None
        if not math.isclose(with_h.best.cost, no_h.best.cost, rel_tol=1e-9, abs_tol=1e-9):
            raise AssertionError(f"{start}->{goal}: costs differ, {with_h.best.cost} vs {no_h.best.cost}")
        rows.append(
            {
                "pair": label,
                "start": start,
                "goal": goal,
                "straight_line": round(world.distance(start, goal), 3),
                "cost": round(with_h.best.cost, 3),
                "plan_length": len(with_h.best),
                "alternatives": k,
                "with_estimate": {"expansions": with_h.expansions, "ms": round(ms_with, 2)},
                "without_estimate": {"expansions": no_h.expansions, "ms": round(ms_without, 2)},
                "expansion_ratio": round(with_h.expansions / no_h.expansions, 3),
                "time_ratio": round(ms_with / ms_without, 3),
            }
        )
    return rows


def _print_table(nodes: int, arcs: int, k: int, rows: list[dict[str, Any]]) -> None:
    print(f"\n{nodes} nodes, {arcs} arcs, K = {k}")
    print(
        f"{'pair':<20} {'start':>6} {'goal':>6} {'cost':>8} "
        f"{'exp A*':>8} {'exp h=0':>8} {'ratio':>6} {'ms A*':>8} {'ms h=0':>8} {'ratio':>6}"
    )
    for r in rows:
        w, wo = r["with_estimate"], r["without_estimate"]
        print(
            f"{r['pair']:<20} {r['start']:>6} {r['goal']:>6} {r['cost']:>8.2f} "
            f"{w['expansions']:>8} {wo['expansions']:>8} {r['expansion_ratio']:>6.2f} "
            f"{w['ms']:>8.1f} {wo['ms']:>8.1f} {r['time_ratio']:>6.2f}",
            flush=True,
        )
    exp_w = sum(r["with_estimate"]["expansions"] for r in rows)
    exp_wo = sum(r["without_estimate"]["expansions"] for r in rows)
    ms_w = sum(r["with_estimate"]["ms"] for r in rows)
    ms_wo = sum(r["without_estimate"]["ms"] for r in rows)
    print(
        f"{'all pairs':<20} {'':>6} {'':>6} {'':>8} {exp_w:>8} {exp_wo:>8} {exp_w / exp_wo:>6.2f} "
        f"{ms_w:>8.1f} {ms_wo:>8.1f} {ms_w / ms_wo:>6.2f}"
    )


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0] if __doc__ else None)
    parser.add_argument("--repeat", type=int, default=3, help="runs per measurement; the median is kept")
    parser.add_argument("--out", type=Path, default=RESULTS / "astar_estimate.json")
    args = parser.parse_args(argv)
    report: dict[str, Any] = {
        "benchmark": "astar_estimate",
        "python": platform.python_version(),
        "repeat": args.repeat,
        "maps": [],
    }
    for cols, rows_, side, seed in MAPS:
        world = generate_map(cols, rows_, side, seed)
        entry: dict[str, Any] = {
            "generate_map": {"cols": cols, "rows": rows_, "side": side, "seed": seed},
            "nodes": len(world.nodes),
            "arcs": len(world.arcs),
            "runs": {},
        }
        for k in (1, 4):
            rows = measure(world, k, args.repeat)
            _print_table(len(world.nodes), len(world.arcs), k, rows)
            entry["runs"][f"K={k}"] = rows
        report["maps"].append(entry)
    args.out.parent.mkdir(parents=True, exist_ok=True)
    args.out.write_text(json.dumps(report, indent=2) + "\n")
    print(f"\nwrote {args.out}")


if __name__ == "__main__":
    main()
