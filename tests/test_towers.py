"""Towers (IPC 2020): the shared suite's pfile_19 and pfile_20 are answered "unsolvable".

Their :init lacks three ``smallerThan`` facts (``r3 r18``, ``r12 r18``, ``r15 r18``), and
the domain's methods move the rings in the one recursive order, which needs them: no plan
exists.  HyperTensioN says so too (it fails after exploring everything); PANDA and Lilotane
run out of time.  The answer is final only because no task list was cut at the planner's
bound on growing lists -- Towers' recursion is tail recursion, its lists stay short.
This checks the same on three rings, the fact the third move needs taken away.
"""

from __future__ import annotations

from pathlib import Path

import pytest

from htnagent.hddl import parse_problem, read_domain
from htnagent.planning.hddl_solving import solve
from htnagent.planning.ipc_output import actions_of
from htnagent.planning.planner import PlanStatus, Search

DOMAIN = Path(__file__).resolve().parents[2] / "shared" / "data" / "ipc" / "Towers" / "domain.hddl"


def _problem(smaller: list[tuple[str, str]]) -> str:
    facts = " ".join(f"(smallerThan {a} {b})" for a, b in smaller)
    return (
        "(define (problem three) (:domain towers) (:objects t1 t2 t3 - TOWER r1 r2 r3 - RING)"
        " (:htn :ordered-tasks (and (task0 (shiftTower t1 t2 t3))))"
        f" (:init {facts} (on r1 r2) (on r2 r3) (on r3 t1) (towerTop r1 t1) (towerTop t2 t2)"
        " (towerTop t3 t3))"
        " (:goal (and (on r1 r2) (on r2 r3) (on r3 t3))))"
    )


ALL = [(r, o) for i, r in enumerate(("r1", "r2", "r3")) for o in ("r2", "r3", "t1", "t2", "t3")[i:]]


@pytest.mark.skipif(not DOMAIN.is_file(), reason="the shared IPC suite is not here")
@pytest.mark.parametrize("search", [None, Search.DFS, Search.GBFS])
def test_towers_without_a_fact_its_moves_need_is_unsolvable_and_said_so(search: Search | None) -> None:
    domain = read_domain(DOMAIN)
    whole = solve(domain, parse_problem(_problem(ALL), domain, "three.hddl"), search=search, timeout=30)
    assert whole.result.best is not None
    assert len(actions_of(whole.result.best)) == 7
    lacking = [pair for pair in ALL if pair != ("r2", "r3")]  # r2 onto r3 is the sixth move
    solved = solve(domain, parse_problem(_problem(lacking), domain, "three.hddl"), search=search, timeout=30)
    assert solved.result.status is PlanStatus.UNSOLVABLE
