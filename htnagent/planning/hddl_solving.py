"""An HDDL problem solved: translated, then planned for one plan by a portfolio of searches.

:func:`solve` is what ``plan --hddl`` and the IPC bench run: the translation
(:mod:`htnagent.planning.hddl_translation`) and the planner's searches
(:mod:`htnagent.planning.planner`, docs/design.md §7) under one time limit and one
budget of expansions.
"""

from __future__ import annotations

import dataclasses
import functools
import time
from collections.abc import Callable
from dataclasses import dataclass

from htnagent.hddl import model as m
from htnagent.model.plans import Plan
from htnagent.planning.hddl_translation import HddlPlanning, OutOfTime, translate
from htnagent.planning.planner import PlannerSettings, PlanResult, PlanStatus, Progress, Search, plan

HDDL_BUDGET = 20_000_000
"""The expansions :func:`solve` allows by default: a limit on memory more than on time."""


DFS_SHARE = 0.2
"""The largest share of the time limit the default portfolio gives depth-first search
before greedy best-first takes over."""
DFS_SECONDS = 2.0
"""The most seconds the portfolio's depth-first search may take.  Where it wins, it wins
at once (Barman's and Depots's largest problems take it under 0.2 s); past that, the
time is better spent on the greedy search."""


SolveProgress = Callable[[Search, int, float], None]
"""Told how far :func:`solve` has got: ``(search, expansions, seconds)``."""


@dataclass(frozen=True, slots=True)
class Solved:
    """What :func:`solve` found: the translated problem, the search that ended it with its
    settings, and the result (expansions and seconds of every search it ran).

    ``planning`` is None when the time ran out during the translation: the result is then
    :attr:`~htnagent.planning.planner.PlanStatus.TIMED_OUT`, after no expansion.
    """

    planning: HddlPlanning | None
    search: Search
    settings: PlannerSettings
    result: PlanResult


def solve(
    domain: m.Domain,
    problem: m.Problem,
    *,
    search: Search | None = None,
    timeout: float | None = None,
    budget: int = HDDL_BUDGET,
    progress: SolveProgress | None = None,
) -> Solved:
    """Translate the problem and plan it: one plan (K = 1) within ``timeout`` seconds and
    ``budget`` expansions, by ``search`` -- or, by default (None), a portfolio: depth-first
    in method order for :data:`DFS_SECONDS` (or a fifth of a shorter time left), then greedy
    best-first for the rest.

    The ``timeout`` bounds the translation and the searches together: the translation reads
    the clock as it goes (every :data:`~htnagent.planning.hddl_translation.CLOCK_EVERY`
    objects, facts or literals), and when the time runs out there, the result is
    :attr:`~htnagent.planning.planner.PlanStatus.TIMED_OUT` as when a search runs out of it.

    Some domains are written for SHOP's order (Barman: depth-first solves at once what
    greedy search loses itself in), others need the estimate (Blocksworld): the portfolio
    is never far from the better of the two.  Depth-first search that ends without a plan
    has explored every node (there are no cycles: each state and task list is expanded
    once), so that answer is final.

    ``progress(search, expansions, seconds)``, if given, hears how far the solve has got:
    the search under way, the expansions of every search so far and the seconds since the
    solve began, at most every :data:`~htnagent.planning.planner.PROGRESS_EVERY` seconds.
    """
    started = time.perf_counter()
    deadline = None if timeout is None else started + timeout
    try:
        planning = translate(domain, problem, deadline=deadline)
    except OutOfTime:
        settings = PlannerSettings(
            alternatives=1, budget=budget, search=search or Search.DFS, time_limit=timeout
        )
        out_of_time = PlanResult(PlanStatus.TIMED_OUT, seconds=time.perf_counter() - started)
        return Solved(None, settings.search, settings, out_of_time)
    run = functools.partial(plan, planning.domain, planning.state, planning.tasks)

    def told(search: Search, before: int) -> Progress | None:
        """The planner's progress for ``search`` as the solve's: its expansions after ``before``."""
        if progress is None:
            return None
        return lambda n, _: progress(search, before + n, time.perf_counter() - started)

    def time_left() -> float | None:
        # The planner takes a positive limit: a search started at the deadline reads the clock
        # after its first few hundred nodes, as any search past its time does.
        return None if deadline is None else max(deadline - time.perf_counter(), 1e-3)

    if search is not None:
        settings = PlannerSettings(alternatives=1, budget=budget, search=search, time_limit=time_left())
        return Solved(planning, search, settings, run(settings, progress=told(search, 0)))
    left = time_left()
    first = PlannerSettings(
        alternatives=1,
        budget=budget,
        search=Search.DFS,
        time_limit=min(left * DFS_SHARE, DFS_SECONDS) if left is not None else DFS_SECONDS,
    )
    tried = run(first, progress=told(Search.DFS, 0))
    if tried.status in (PlanStatus.SOLVED, PlanStatus.UNSOLVABLE) or tried.expansions >= budget:
        return Solved(planning, Search.DFS, first, tried)
    left = time_left()
    then = PlannerSettings(
        alternatives=1, budget=budget - tried.expansions, search=Search.GBFS, time_limit=left
    )
    found = run(then, progress=told(Search.GBFS, tried.expansions))
    total = dataclasses.replace(
        found, expansions=found.expansions + tried.expansions, seconds=found.seconds + tried.seconds
    )
    return Solved(planning, Search.GBFS, dataclasses.replace(then, budget=budget), total)


Better = Callable[[Plan], None]
"""Told each plan :func:`solve_anytime` finds, each cheaper than the one before."""


def solve_anytime(
    domain: m.Domain,
    problem: m.Problem,
    better: Better,
    *,
    search: Search | None = None,
    timeout: float | None = None,
    budget: int = HDDL_BUDGET,
    progress: SolveProgress | None = None,
) -> Solved:
    """:func:`solve`, then cheaper plans until the time runs out: each plan found, the
    first and every cheaper one after it, is told to ``better`` at once.

    The first plan comes as :func:`solve` finds it, as soon.  Then branch and bound
    (:func:`~htnagent.planning.planner.plan`'s ``improving``): a search that follows only
    nodes whose actions so far plus the least cost of their tasks stay under the cheapest
    plan's cost, which falls with every plan it finds -- greedy best-first (or the
    ``search`` given, depth-first for ``dfs``), so that a cheaper plan comes soon.  The
    search ends when the time or the budget runs out, or when no node under the bound is
    left: the last plan is then the cheapest there is (``result.exhausted``).  With
    ``search`` A*, the first plan is already the cheapest: nothing follows it.
    """
    started = time.perf_counter()
    first = solve(domain, problem, search=search, timeout=timeout, budget=budget, progress=progress)
    best = first.result.best
    if best is None or first.planning is None:
        return first
    better(best)
    if first.search is Search.ASTAR:
        return dataclasses.replace(first, result=dataclasses.replace(first.result, exhausted=True))
    spent = first.result.expansions
    left = None if timeout is None else timeout - (time.perf_counter() - started)
    if best.cost <= 0 or spent >= budget or (left is not None and left <= 0):
        return first
    order = Search.DFS if search is Search.DFS else Search.GBFS
    settings = PlannerSettings(
        alternatives=1, budget=budget - spent, search=order, time_limit=left, cost_bound=best.cost
    )
    told = None if progress is None else _after(progress, order, spent, started)
    planning = first.planning
    found = plan(planning.domain, planning.state, planning.tasks, settings, progress=told, improving=better)
    plans = found.plans or (best,)
    total = PlanResult(
        PlanStatus.SOLVED,
        plans,
        spent + found.expansions,
        first.result.seconds + found.seconds,
        found.exhausted,
    )
    return Solved(planning, order if found.plans else first.search, settings, total)


def _after(progress: SolveProgress, search: Search, before: int, started: float) -> Progress:
    return lambda n, _: progress(search, before + n, time.perf_counter() - started)


__all__ = [
    "DFS_SECONDS",
    "DFS_SHARE",
    "HDDL_BUDGET",
    "Better",
    "SolveProgress",
    "Solved",
    "solve",
    "solve_anytime",
]
