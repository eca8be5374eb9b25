"""Micro-benchmark: what one plan-set update costs, against plan length and alternatives.

Run from the repository root: ``python -m bench.planset_updates``.  On generated
museums of growing size the navigator plans ``goto_node`` across the map with K
alternatives, then the benchmark times, per update: following the plan (action
succeeded), an action no plan starts with (an emergency's move, undo put in
front), a suspension (Algorithm 1) and a belief change (a shut arc off the
route).  Writes ``bench/results/planset_updates.json``.
"""

from __future__ import annotations

import json
import statistics
import time
from pathlib import Path

from htnagent.domains import nodes_domain
from htnagent.domains.maps import WorldMap, generate_map
from htnagent.model.domain import Domain, State
from htnagent.model.terms import Atom
from htnagent.planning.planner import PlannerSettings
from htnagent.upkeep import new_plan_set

RESULTS = Path(__file__).resolve().parent / "results"


def _far_pair(world: WorldMap) -> tuple[str, str]:
    nodes = list(world.nodes.values())
    first = min(nodes, key=lambda n: n.x + n.y)
    last = max(nodes, key=lambda n: n.x + n.y)
    return first.name, last.name


def _median_ms(samples: list[float]) -> float:
    return round(statistics.median(samples) * 1000, 4) if samples else 0.0


def measure(world: WorldMap, k: int, repeats: int = 5) -> dict[str, float]:
    """Median milliseconds per kind of update for one map and K."""
    domain: Domain = nodes_domain(world)
    start, target = _far_pair(world)
    goal = Atom("goto_node", (target,))
    follow: list[float] = []
    foreign: list[float] = []
    suspend: list[float] = []
    changed: list[float] = []
    length = 0
    for _ in range(repeats):
        belief: State = domain.initial_state(start)
        ps = new_plan_set(domain, goal, settings=PlannerSettings(alternatives=k))
        ps.make(belief)
        best = ps.best
        assert best is not None
        length = len(best)
        # Follow the first three steps.
        for _ in range(min(3, len(best) - 1)):
            assert ps.best is not None
            action = ps.best.steps[0].action
            after = domain.apply(belief, action)
            assert after is not None
            t = time.perf_counter()
            ps.action_succeeded(action, belief, after)
            follow.append(time.perf_counter() - t)
            belief = after
        # A move that no plan starts with: the undo goes in front of every plan.
        assert ps.best is not None
        planned = ps.best.steps[0].action
        here = str(planned.args[0])
        others = [
            Atom("move", f.args)
            for f in belief.static.candidates("arc", 0, here)
            if Atom("move", f.args) != planned
        ]
        if others:
            after = domain.apply(belief, others[0])
            assert after is not None
            t = time.perf_counter()
            ps.action_succeeded(others[0], belief, after)
            foreign.append(time.perf_counter() - t)
            belief = after
        # Suspend the next planned action (Algorithm 1).
        assert ps.best is not None
        running = ps.best.steps[0].action
        after = domain.suspend(belief, running)
        t = time.perf_counter()
        ps.action_suspended(running, belief, after)
        suspend.append(time.perf_counter() - t)
        belief = after
        # A door shuts somewhere off the route.
        used = {str(s.action.args[-1]) for p in ps.plans for s in p.steps if s.action.name == "move"}
        spare = next(a for a in sorted(world.arcs) if a not in used)
        after = belief.updated(add=[Atom("closed", (spare,))])
        t = time.perf_counter()
        ps.belief_changed(belief, after)
        changed.append(time.perf_counter() - t)
    return {
        "nodes": len(world.nodes),
        "plan_length": length,
        "alternatives": k,
        "success_ms": _median_ms(follow),
        "foreign_action_ms": _median_ms(foreign),
        "suspend_ms": _median_ms(suspend),
        "belief_change_ms": _median_ms(changed),
    }


def main() -> None:
    rows = []
    sizes = [(2, 2, 3), (2, 4, 4), (4, 4, 5), (6, 6, 6), (8, 8, 8)]
    print(
        f"{'nodes':>6} {'len':>4} {'K':>2} {'success':>9} {'foreign':>9} {'suspend':>9} {'belief':>9}  (ms)"
    )
    for cols, rows_, side in sizes:
        world = generate_map(cols, rows_, side, seed=7)
        for k in (1, 2, 4, 8):
            row = measure(world, k)
            rows.append(row)
            print(
                f"{row['nodes']:>6} {row['plan_length']:>4} {k:>2} {row['success_ms']:>9.3f} "
                f"{row['foreign_action_ms']:>9.3f} {row['suspend_ms']:>9.3f} {row['belief_change_ms']:>9.3f}",
                flush=True,
            )
    RESULTS.mkdir(parents=True, exist_ok=True)
    (RESULTS / "planset_updates.json").write_text(json.dumps(rows, indent=2) + "\n")
    print(f"wrote {RESULTS / 'planset_updates.json'}")


if __name__ == "__main__":
    main()
