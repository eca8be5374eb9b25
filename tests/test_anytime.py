"""Cheaper plans after the first: the planner's branch and bound (``improving``), and
``plan --hddl --anytime`` (docs/contracts.md "Command line")."""

from __future__ import annotations

import heapq
import itertools
import json
import random
import signal
import subprocess
import sys
import time
from pathlib import Path
from typing import Any

import pytest

from htnagent.cli.commands import main
from htnagent.errors import SettingsError
from htnagent.hddl import read_domain, read_problem
from htnagent.hddl.check import check_plan
from htnagent.hddl.plan_file import parse_plan
from htnagent.model.plans import Plan
from htnagent.planning import hddl_solving
from htnagent.planning.hddl_solving import solve, solve_anytime
from htnagent.planning.hddl_translation import translate
from htnagent.planning.one_at_a_time import Cheaper, Outcome
from htnagent.planning.planner import PlannerSettings, PlanStatus, Search, plan

HERE = Path(__file__).resolve().parent / "hddl"
ROOT = Path(__file__).resolve().parent.parent
DOMAIN = HERE / "courier-domain.hddl"
SHARED_ROVER = ROOT.parent / "shared" / "data" / "ipc" / "Rover-GTOHP"
LIFT = HERE / "lift-domain.hddl"


def ring(tmp_path: Path, rooms: int = 8) -> Path:
    """The courier on a ring of rooms: the parcel in r1, wanted in the last room -- one
    step back from r0, but the first door the search tries leads the long way round."""
    names = [f"r{i}" for i in range(rooms)]
    pairs = zip(names, names[1:] + names[:1], strict=True)
    doors = " ".join(f"(door {a} {b}) (door {b} {a})" for a, b in pairs)
    path = tmp_path / "ring.hddl"
    path.write_text(
        f"(define (problem ring) (:domain courier)\n"
        f"  (:objects bot - robot p1 - parcel {' '.join(names)} - room)\n"
        f"  (:htn :parameters () :ordered-subtasks (and (t1 (deliver p1 {names[-1]}))))\n"
        f"  (:init (at bot hall) (door hall r0) (door r0 hall) (in p1 r1) {doors}))\n"
    )
    return path


def test_branch_and_bound_tells_each_cheaper_plan_and_ends_with_the_cheapest(tmp_path: Path) -> None:
    domain = read_domain(DOMAIN)
    problem = read_problem(ring(tmp_path), domain)
    planning = translate(domain, problem)
    optimal = plan(planning.domain, planning.state, planning.tasks, PlannerSettings(alternatives=1))
    assert optimal.best is not None
    first = solve(domain, problem).result.best
    assert first is not None and first.cost > optimal.best.cost  # the search's first plan is not the cheapest
    told: list[Plan] = []
    settings = PlannerSettings(alternatives=1, search=Search.GBFS, cost_bound=first.cost)
    found = plan(planning.domain, planning.state, planning.tasks, settings, improving=told.append)
    costs = [p.cost for p in told]
    assert costs and all(a > b for a, b in itertools.pairwise(costs))
    assert costs[0] < first.cost
    assert costs[-1] == optimal.best.cost
    assert found.status is PlanStatus.SOLVED and found.exhausted
    assert found.best is told[-1]
    # Under a bound no plan meets, the search says so: nothing under it.
    none = plan(
        planning.domain,
        planning.state,
        planning.tasks,
        PlannerSettings(alternatives=1, search=Search.DFS, cost_bound=optimal.best.cost),
        improving=told.append,
    )
    assert (none.status, none.plans, none.exhausted) == (PlanStatus.UNSOLVABLE, (), True)


def test_solve_anytime_finds_first_as_solve_does_then_the_cheapest(tmp_path: Path) -> None:
    domain = read_domain(DOMAIN)
    problem = read_problem(ring(tmp_path), domain)
    told: list[Plan] = []
    solved = solve_anytime(domain, problem, told.append, timeout=30)
    first = solve(domain, problem).result.best
    assert first is not None and told[0].cost == first.cost
    assert solved.result.best is told[-1] and solved.result.exhausted
    assert told[-1].cost == 6
    # A* finds the cheapest first: nothing follows it.
    told.clear()
    solve_anytime(domain, problem, told.append, search=Search.ASTAR, timeout=30)
    assert [p.cost for p in told] == [6]


def lift(tmp_path: Path, seed: int, floors: int = 10, riders: int = 5) -> tuple[Path, float]:
    """A lift problem drawn from ``seed``, and the cost of its cheapest plan worked out
    apart from the planner: each rider's board and depart, one move to the rider's floor
    where the lift is not there already, and one to the rider's destination."""
    rng = random.Random(seed)
    names = [f"f{i}" for i in range(floors)]
    above = " ".join(f"(above {a} {b})" for i, a in enumerate(names) for b in names[i + 1 :])
    trips = [rng.sample(names, 2) for _ in range(riders)]
    facts = " ".join(f"(origin r{i} {a}) (destin r{i} {b})" for i, (a, b) in enumerate(trips))
    riders_named = " ".join(f"r{i}" for i in range(riders))
    tasks = " ".join(f"(serve r{i})" for i in range(riders))
    path = tmp_path / f"lift-{seed}.hddl"
    path.write_text(
        f"(define (problem lift-{seed}) (:domain lift)\n"
        f"  (:objects {' '.join(names)} - floor {riders_named} - rider)\n"
        f"  (:htn :ordered-subtasks (and {tasks}))\n"
        f"  (:init (lift-at f0) {above} {facts}))\n"
    )
    at, cost = "f0", 0.0
    for origin, destination in trips:
        cost += (origin != at) + 3.0  # board, the move to the destination, depart
        at = destination
    return path, cost


@pytest.mark.parametrize("seed", range(4))
def test_anytime_runs_a_star_under_the_first_plans_cost_first(tmp_path: Path, seed: int) -> None:
    # The first plan, depth-first in method order, stops at every floor on the way; greedy
    # branch and bound would shed one move at a time.  Each rider planned alone in turn
    # (design §7.6) gives the cheapest plan at once, and A* under its cost says it is the
    # cheapest.
    domain = read_domain(LIFT)
    path, cheapest = lift(tmp_path, seed)
    problem = read_problem(path, domain)
    told: list[Plan] = []
    solved = solve_anytime(domain, problem, told.append, timeout=30)
    first = solve(domain, problem).result.best
    assert first is not None and first.cost > cheapest
    assert [p.cost for p in told] == [first.cost, cheapest]
    assert solved.search is Search.ASTAR and solved.result.exhausted
    assert solved.result.best is told[-1]


def test_anytime_goes_on_by_branch_and_bound_when_a_stars_share_runs_out(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    # A* gets a share of the time and budget left; out of it, greedy branch and bound
    # goes on under the cheapest cost so far.
    monkeypatch.setattr(hddl_solving, "ANYTIME_ASTAR_SHARE", 1e-9)
    monkeypatch.setattr(
        hddl_solving, "cheaper_one_at_a_time", lambda *_, **__: Cheaper(Outcome.ONE_PART, None, 0)
    )
    domain = read_domain(LIFT)
    path, cheapest = lift(tmp_path, 0)
    told: list[Plan] = []
    solved = solve_anytime(domain, read_problem(path, domain), told.append, timeout=30)
    costs = [p.cost for p in told]
    # (One step ahead, design §7.5, takes it to the cheapest at once: no stops on the way.)
    assert len(costs) >= 2 and all(a > b for a, b in itertools.pairwise(costs))
    assert costs[-1] == cheapest
    assert solved.search is Search.GBFS and solved.result.exhausted


def test_a_star_under_a_bound_stops_at_its_first_plan(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    # A*'s f is the cost so far plus the least cost of the tasks, the bound's own test: the
    # first plan it finds is the cheapest, and no node left on the open list is looked at.
    domain = read_domain(LIFT)
    path, cheapest = lift(tmp_path, 1)
    planning = translate(domain, read_problem(path, domain))
    pops = 0
    real_pop = heapq.heappop

    def counting_pop(heap: list[Any]) -> Any:
        nonlocal pops
        pops += 1
        return real_pop(heap)

    monkeypatch.setattr(heapq, "heappop", counting_pop)
    told: list[tuple[float, int]] = []
    settings = PlannerSettings(alternatives=1, search=Search.ASTAR, cost_bound=cheapest + 10)
    found = plan(
        planning.domain,
        planning.state,
        planning.tasks,
        settings,
        improving=lambda p: told.append((p.cost, pops)),
    )
    assert [cost for cost, _ in told] == [cheapest]
    assert found.exhausted and found.best is not None and found.best.cost == cheapest
    assert pops - told[0][1] <= 2  # the next entry (a lazy one may make one node first): the end


def test_settings_refuse_a_bound_of_nothing_and_improving_alternatives() -> None:
    with pytest.raises(SettingsError, match="cost_bound must be positive"):
        PlannerSettings(cost_bound=0)
    domain = read_domain(DOMAIN)
    planning = translate(domain, read_problem(HERE / "courier.hddl", domain))
    with pytest.raises(SettingsError, match="one plan"):
        plan(
            planning.domain, planning.state, planning.tasks, PlannerSettings(alternatives=2), improving=print
        )


def test_plan_anytime_prints_each_cheaper_plan_in_the_ipc_format(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    problem_file = ring(tmp_path)
    code = main(["plan", "--hddl", str(DOMAIN), str(problem_file), "--format", "ipc", "--anytime"])
    assert code == 0
    out = capsys.readouterr().out
    blocks = [b + "<==\n" for b in out.split("<==\n") if b.strip()]
    assert len(blocks) >= 2
    domain = read_domain(DOMAIN)
    problem = read_problem(problem_file, domain)
    lengths = []
    for block in blocks:
        ipc = parse_plan(block)
        assert [str(v) for v in check_plan(domain, problem, ipc)] == []
        lengths.append(len(ipc.steps))
    assert all(a > b for a, b in itertools.pairwise(lengths))
    assert lengths[-1] == 6


def test_plan_anytime_json_gives_the_last_and_whether_it_is_the_cheapest(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    code = main(["plan", "--hddl", str(DOMAIN), str(ring(tmp_path)), "--format", "json", "--anytime"])
    assert code == 0
    lines = capsys.readouterr().out.splitlines()
    assert len(lines) == 1
    line = json.loads(lines[0])
    assert (len(line["plan"]), line["cheapest"]) == (6, True)


def test_anytime_is_for_hddl(capsys: pytest.CaptureFixture[str]) -> None:
    code = main(["plan", "museum", "--agent", "guide", "--task", "goto(n28)", "--anytime"])
    assert code == 2
    assert (
        capsys.readouterr().err.strip()
        == "htnagent: error: --anytime is for plan --hddl (see htnagent plan --help)"
    )


@pytest.mark.skipif(not (SHARED_ROVER / "p10.hddl").is_file(), reason="the shared IPC suite is not here")
@pytest.mark.parametrize("sig", [signal.SIGINT, signal.SIGTERM])
def test_a_signal_once_a_plan_is_printed_ends_at_once_with_that_plan(sig: signal.Signals) -> None:
    proc = subprocess.Popen(
        [
            *(sys.executable, "-m", "htnagent", "plan", "--hddl"),
            *(str(SHARED_ROVER / "domain.hddl"), str(SHARED_ROVER / "p10.hddl")),
            *("--format", "ipc", "--anytime", "--timeout", "60"),
        ],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        cwd=ROOT,
    )
    assert proc.stdout is not None
    out = []
    for line in proc.stdout:
        out.append(line)
        if line.strip() == "<==":
            break
    proc.send_signal(sig)
    started = time.monotonic()
    rest, err = proc.communicate(timeout=20)
    assert time.monotonic() - started < 5
    assert proc.returncode == 0, err
    text = "".join(out) + rest
    assert text.rstrip().endswith("<==")
    assert text.count("==>") == text.count("<==") >= 1
    assert "Traceback" not in err


def test_depth_first_search_keeps_a_share_of_the_time_however_long_it_takes() -> None:
    from htnagent.planning import hddl_solving as hs

    assert hs.dfs_allowance(0.1) == pytest.approx(0.1)  # alone
    assert hs.dfs_allowance(hs.DFS_ALONE + 1.0) == pytest.approx(hs.DFS_ALONE + hs.DFS_EARLY_SHARE)
    end_of_early = hs.DFS_ALONE + (hs.DFS_SECONDS - hs.DFS_ALONE) / hs.DFS_EARLY_SHARE
    assert hs.dfs_allowance(end_of_early) == pytest.approx(hs.DFS_SECONDS)
    # Never abandoned: a search that needs 8 s of work alone has them within 30 s.
    assert hs.dfs_allowance(30.0) >= 8.0
    # The grounded search's share beside it leaves the lifted greedy search a quarter or more.
    for t in (0.5, 1.0, 3.0, 10.0, 30.0):
        rest = t - hs.dfs_allowance(t) - hs.grounded_allowance(t)
        assert rest >= (t - hs.DFS_ALONE) / 4


def test_the_grounded_search_has_half_the_time_once_depth_first_search_is_down_to_its_quarter() -> None:
    from htnagent.planning import hddl_solving as hs

    assert hs.grounded_allowance(hs.DFS_ALONE) == 0.0
    assert hs.grounded_allowance(2.0) == pytest.approx((2.0 - hs.DFS_ALONE) * hs.GROUNDED_SHARE)
    # Past about 5 s, half of every second: within 30 s, over 13 s of its own work (Factories'
    # 6th problem takes about 9).
    assert hs.grounded_allowance(30.0) - hs.grounded_allowance(10.0) == pytest.approx(10.0)
    assert hs.grounded_allowance(30.0) > 13.0
    for t in (6.0, 10.0, 30.0):
        assert hs.grounded_allowance(t) + hs.dfs_allowance(t) <= t


def test_the_portfolio_answers_from_either_search_when_both_run(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    from htnagent.planning import hddl_solving as hs

    monkeypatch.setattr(hs, "DFS_ALONE", 0.0)  # greedy search beside it at once
    domain = read_domain(DOMAIN)
    problem = read_problem(ring(tmp_path, rooms=30), domain)
    solved = hs.solve(domain, problem, timeout=30)
    assert solved.result.status is PlanStatus.SOLVED
    assert solved.search in (Search.DFS, Search.GBFS)
    best = solved.result.best
    assert best is not None
    from htnagent.planning.ipc_output import ipc_plan

    assert [str(v) for v in check_plan(domain, problem, ipc_plan(best))] == []
