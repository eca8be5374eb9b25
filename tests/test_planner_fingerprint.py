"""The planner finds what it found before it was made faster: same plans, costs, records, expansions.

``planner_fingerprint.json`` was written by the planner before its search was compiled
for speed, so that the compiled search is held to the same answers: for many searches on
the museum map and generated maps — K = 1 to 3, shut doors, two goals in a row, a small
budget, a suspended move (resume, rollback, rollbacks off, an action to avoid),
``move_area``, the guide's ``goto`` and the talking guide's ``present`` — the status,
the number of expansions, the plan costs, and a digest of every plan: its actions, step
costs, decomposition records (task and method, up to the goal) and which steps and
records the plans share.  A change that alters any of these fails here; one that means
to (a new tie-break, a better estimate) writes the file again with
``python -m tests.test_planner_fingerprint`` and says why.
"""

from __future__ import annotations

import hashlib
import json
import random
from pathlib import Path
from typing import Any

from htnagent.domains.guide_talk import talk_domain
from htnagent.domains.maps import WorldMap, generate_map
from htnagent.domains.museum import areas_domain, nodes_domain
from htnagent.model.domain import Domain
from htnagent.model.plans import Decomposition
from htnagent.model.state import State
from htnagent.model.terms import Atom
from htnagent.planning.planner import PlannerSettings, PlanResult, plan
from htnagent.scenario.map_file import load_map

ROOT = Path(__file__).resolve().parent.parent
FINGERPRINT = Path(__file__).resolve().parent / "planner_fingerprint.json"


def _fingerprint(result: PlanResult) -> dict[str, Any]:
    ids: dict[int, int] = {}  # shared steps and records, by first appearance

    def same(o: object) -> int:
        return ids.setdefault(id(o), len(ids))

    shown: list[object] = []
    for p in result.plans:
        for s in p.steps:
            chain: list[list[object]] = []
            record: Decomposition | None = s.record
            while record is not None:
                chain.append([str(record.task), record.method, same(record)])
                record = record.parent
            shown.append([str(s.action), s.cost, same(s), chain])
    digest = hashlib.sha256(json.dumps(shown).encode()).hexdigest()[:16]
    return {
        "status": result.status.value,
        "expansions": result.expansions,
        "costs": [round(p.cost, 9) for p in result.plans],
        "plans": digest,
    }


def _run(
    domain: Domain,
    state: State,
    tasks: list[Atom],
    *,
    recover: bool = True,
    avoid: frozenset[Atom] = frozenset(),
    **settings: Any,
) -> dict[str, Any]:
    return _fingerprint(plan(domain, state, tasks, PlannerSettings(**settings), recover=recover, avoid=avoid))


def _cases_on(name: str, world: WorldMap, pairs: int) -> dict[str, dict[str, Any]]:
    out: dict[str, dict[str, Any]] = {}
    rng = random.Random(name)
    nd, ad = nodes_domain(world), areas_domain(world)
    names, arcs = sorted(world.nodes), sorted(world.arcs)
    for i in range(pairs):
        a, b, c = rng.choice(names), rng.choice(names), rng.choice(names)
        here = f"{name}/{i}/{a}-{b}"
        st = nd.initial_state(a)
        goto = [Atom("goto_node", (b,))]
        for k in (1, 2, 3):
            out[f"{here}/k{k}"] = _run(nd, st, goto, alternatives=k)
        shut = st.updated(add=[Atom("closed", (x,)) for x in rng.sample(arcs, max(1, len(arcs) // 10))])
        out[f"{here}/shut"] = _run(nd, shut, goto, alternatives=2, budget=20_000)
        out[f"{here}/two goals"] = _run(nd, st, [*goto, Atom("goto_node", (c,))], alternatives=2)
        out[f"{here}/budget"] = _run(nd, st, goto, alternatives=2, budget=30)
        arc = next(x for x in (world.arcs[n] for n in arcs) if a in (x.a, x.b))
        move = Atom("move", (a, arc.b if arc.a == a else arc.a, arc.name))
        half = nd.suspend(st, move)
        for k in (1, 3):
            out[f"{here}/suspended/k{k}"] = _run(nd, half, goto, alternatives=k)
            out[f"{here}/suspended/k{k}/no rollbacks"] = _run(nd, half, goto, alternatives=k, rollbacks=False)
        out[f"{here}/suspended/avoid"] = _run(
            nd, half, goto, alternatives=2, avoid=frozenset({Atom("rollback", (move,))})
        )
        out[f"{here}/suspended/no recovery"] = _run(nd, half, goto, alternatives=2, recover=False)
        out[f"{here}/avoid"] = _run(nd, st, goto, alternatives=2, avoid=frozenset({move}))
        doors = [(x, y) for x, y, _ in world.doors if x == world.nodes[a].area]
        if doors:
            x, y = doors[rng.randrange(len(doors))]
            for k in (1, 2):
                out[f"{here}/move_area/k{k}"] = _run(nd, st, [Atom("move_area", (x, y))], alternatives=k)
        for k in (1, 2):
            out[f"{here}/guide/k{k}"] = _run(ad, ad.initial_state(a), [Atom("goto", (b,))], alternatives=k)
    return out


def cases() -> dict[str, dict[str, Any]]:
    """Every search's fingerprint, by a name that says what it was."""
    museum = load_map("museum_map.yaml", "museum", ROOT / "scenarios", None)
    out = _cases_on("museum", museum, 8)
    for cols, rows, side, seed in [(1, 1, 3, 0), (2, 2, 4, 1), (3, 2, 5, 7), (3, 3, 6, 3)]:
        out |= _cases_on(f"map{cols}x{rows}x{side}/{seed}", generate_map(cols, rows, side, seed), 4)
    talk = talk_domain(museum)
    names = sorted(museum.nodes)
    for i, exhibit in enumerate(["statue", "fresco", "mosaic", "vase"]):
        st = talk.initial_state(names[i * 7 % len(names)])
        for k in (1, 2):
            out[f"talk/{exhibit}/k{k}"] = _run(
                talk, st, [Atom("present", (exhibit,)), Atom("goto_node", ("n1",))], alternatives=k
            )
        half = talk.suspend(st, Atom("explain", (exhibit,)))
        out[f"talk/{exhibit}/suspended"] = _run(talk, half, [Atom("present", (exhibit,))], alternatives=2)
    return out


def test_the_planner_finds_what_it_found_before() -> None:
    expected = json.loads(FINGERPRINT.read_text())
    found = cases()
    assert found.keys() == expected.keys()
    changed = {name: (expected[name], found[name]) for name in found if found[name] != expected[name]}
    assert not changed, f"{len(changed)} searches changed, e.g. {next(iter(changed.items()))}"


if __name__ == "__main__":
    FINGERPRINT.write_text(json.dumps(cases(), indent=1, sort_keys=True) + "\n")
