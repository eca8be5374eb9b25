"""An HDDL problem solved: translated, then planned for one plan by a portfolio of searches.

:func:`solve` is what ``plan --hddl`` and the IPC bench run: the translation
(:mod:`htnagent.planning.hddl_translation`) and the planner's searches
(:mod:`htnagent.planning.planner`, docs/design.md §7) under one time limit and one
budget of expansions.
"""

from __future__ import annotations

import dataclasses
import functools
import gc
import threading
import time
from collections.abc import Callable
from dataclasses import dataclass

from htnagent.hddl import model as m
from htnagent.model.plans import Plan
from htnagent.planning.composition import MAX_GROUND, MAX_GROUND_ALONE, ground, lifted_is_lost
from htnagent.planning.hddl_translation import TOP, HddlPlanning, OutOfTime, translate
from htnagent.planning.one_at_a_time import cheaper_one_at_a_time
from htnagent.planning.planner import (
    PlannerSettings,
    PlanResult,
    PlanStatus,
    Progress,
    Search,
    plan,
    searches_stopped,
)

HDDL_BUDGET = 20_000_000
"""The expansions :func:`solve` allows by default: a limit on memory more than on time."""


DFS_ALONE = 0.25
"""Seconds the portfolio's depth-first search runs alone before greedy best-first search
starts beside it.  Where depth-first wins, it mostly wins at once (Barman's and Depots's
largest problems take it under 0.2 s)."""
DFS_SECONDS = 2.0
"""The seconds of work depth-first search gets at :data:`DFS_EARLY_SHARE` of the time,
beside the greedy searches; past them it keeps a quarter (:func:`dfs_allowance`)."""
DFS_EARLY_SHARE = 3 / 8
"""Depth-first search's share of the time after :data:`DFS_ALONE` until it has had
:data:`DFS_SECONDS`."""
DFS_SHARE = 0.25
"""Depth-first search's share of the time once it has had :data:`DFS_SECONDS`."""
GROUNDED_SHARE = 1 / 4
"""The share of the time after :data:`DFS_ALONE` that the grounded search gets (its
grounding included) while depth-first search has :data:`DFS_EARLY_SHARE`: greedy best-first
search guided by relaxed composition (:mod:`htnagent.planning.composition`), for the
domains where the lifted estimate sees nothing.  Where grounding is past its cap the search
never starts, and its share goes back to the others."""
GROUNDED_LATE_SHARE = 1 / 2
"""The grounded search's share once depth-first search is down to :data:`DFS_SHARE` (past
about 5 s): half, the lifted greedy search keeping a quarter as depth-first search does.
Past those first seconds, on the problems measured (docs/design.md §7.2), every answer where
the grounding was affordable came from the grounded search (AssemblyHierarchical,
Entertainment, Factories-simple, Woodworking): the best-informed search gets the most time.
Where the grounding was not affordable, the grounded search has stopped, and the lifted
greedy search has its time."""


WAKE_SECONDS = 0.1
"""How often the lifted greedy search, waiting while the grounded search has its share,
looks at the clock and for a stop asked for."""


GROUNDED_DFS_SECONDS = 0.5
"""Where the searches decompose some method by its ground methods
(:attr:`~htnagent.planning.composition.Composition.decompositions`), the lifted depth-first
search, binding such a method by types, is lost: once the grounding is ready, depth-first
search's thread goes on in method order by the ground methods (guided only to drop the dead
ends the grounding sees), with its share of the time.  Where that thread has already ended,
the grounded search spends these seconds of its own work depth-first first, before its
greedy best-first search: greedy search can lose itself in a region where the estimate falls
but the goal is out of reach and no dead-end test of the grounding sees it, where depth-first
search in method order, pruned by the grounding, goes another way."""


SolveProgress = Callable[[Search, int, float], None]
"""Told how far :func:`solve` has got: ``(search, expansions, seconds)``."""


@dataclass(frozen=True, slots=True)
class Solved:
    """What :func:`solve` found: the translated problem, the search that ended it with its
    settings, and the result (expansions and seconds of every search it ran).  The grounded
    search's settings carry its guide (:attr:`PlannerSettings.guide`).

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
    in method order alone for :data:`DFS_ALONE` seconds, then greedy best-first beside it,
    and a grounded greedy search (:data:`GROUNDED_SHARE`, later :data:`GROUNDED_LATE_SHARE`),
    taking turns (threads, one at a time: the process uses one core) until one of them has
    the answer.  Depth-first
    search is never abandoned -- a search that is getting there gets there (one that needs
    8 s alone answers within 30 s) -- but once it has had :data:`DFS_SECONDS` of work it
    keeps only a quarter of the time (:func:`dfs_allowance`): the greedy searches are the
    ones that scale.  Where the grounding decomposes methods by their ground methods,
    depth-first search goes on by them once it is ready (:data:`GROUNDED_DFS_SECONDS`).
    Where the lifted searches are lost
    (:func:`~htnagent.planning.composition.lifted_is_lost`: some method's types make
    thousands of ways of one task), the lifted greedy search waits from the start of the
    grounding, whose search then has all the time but depth-first search's; it goes on
    only where the grounding fails (or leaves no method to decompose by ground methods).

    The ``timeout`` bounds the translation and the searches together: the translation reads
    the clock as it goes (every :data:`~htnagent.planning.hddl_translation.CLOCK_EVERY`
    objects, facts or literals), and when the time runs out there, the result is
    :attr:`~htnagent.planning.planner.PlanStatus.TIMED_OUT` as when a search runs out of it.

    Some domains are written for SHOP's order (Barman: depth-first solves at once what
    greedy search loses itself in), others need the estimate (Blocksworld): the portfolio
    is never far from the better of the two.  Either search that ends without a plan
    has explored every node (there are no cycles: each state and task list is expanded
    once), so that answer is final.  Each search may take the whole ``budget``.

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
    return _portfolio(planning, budget, time_left, progress, started)


ANYTIME_PARTS_SHARE = 1 / 4
"""The most of the time left after the first plan that :func:`solve_anytime` gives to
planning each task of the network alone in turn (:mod:`htnagent.planning.one_at_a_time`),
before A*.  Mostly it takes a fraction of a second."""


ANYTIME_ASTAR_SHARE = 1 / 4
"""The share of the time and budget left after the first plan that :func:`solve_anytime`
gives A* under that plan's cost, before greedy branch and bound."""


GROUNDING_SECONDS = 2.0
"""The most seconds of work the grounded search spends grounding: past them it gives up
(and its share of the time goes back to the others), whatever is left under the cap --
but where the lifted searches are lost
(:func:`~htnagent.planning.composition.lifted_is_lost`): there the grounding goes on until
the time limit, under :data:`~htnagent.planning.composition.MAX_GROUND_ALONE`."""


def _early_end() -> float:
    """The second of the portfolio at which depth-first search has had :data:`DFS_SECONDS`
    of work (about 4.9): its share falls from :data:`DFS_EARLY_SHARE` to :data:`DFS_SHARE`."""
    return DFS_ALONE + (DFS_SECONDS - DFS_ALONE) / DFS_EARLY_SHARE


def grounded_allowance(elapsed: float) -> float:
    """The seconds of work the grounded search (its grounding included) may have had
    ``elapsed`` seconds into the portfolio: :data:`GROUNDED_SHARE` of the time after
    :data:`DFS_ALONE`, then :data:`GROUNDED_LATE_SHARE` once depth-first search's share
    has fallen."""
    early_end = _early_end()
    if elapsed <= early_end:
        return max(elapsed - DFS_ALONE, 0.0) * GROUNDED_SHARE
    return (early_end - DFS_ALONE) * GROUNDED_SHARE + (elapsed - early_end) * GROUNDED_LATE_SHARE


def dfs_allowance(elapsed: float) -> float:
    """The seconds of work depth-first search may have had ``elapsed`` seconds into the
    portfolio: all of them while it runs alone (:data:`DFS_ALONE`), then
    :data:`DFS_EARLY_SHARE` until it has had :data:`DFS_SECONDS`, then :data:`DFS_SHARE`
    of the time after.  With the grounded search's share beside it, the lifted greedy
    search keeps the rest: 3/8 of the time at first, a quarter later -- all of it but
    depth-first search's where the grounded search does not run."""
    if elapsed <= DFS_ALONE:
        return elapsed
    early_end = _early_end()
    if elapsed <= early_end:
        return DFS_ALONE + (elapsed - DFS_ALONE) * DFS_EARLY_SHARE
    return DFS_SECONDS + (elapsed - early_end) * DFS_SHARE


def _all_but_dfs(elapsed: float) -> float:
    """The grounded search's allowance where the lifted greedy search waits for it: all the
    time but depth-first search's."""
    return elapsed - dfs_allowance(elapsed)


_FINAL = (PlanStatus.SOLVED, PlanStatus.UNSOLVABLE)


class _Paced:
    """A search in a thread of its own that keeps to an allowance of the portfolio's time:
    at each of its checkpoints it waits while its thread's work is ahead of
    ``allowance(seconds since the portfolio began)``, and stops once told to."""

    def __init__(
        self, name: str, allowance: Callable[[float], float], begun: float, news: threading.Event
    ) -> None:
        self.allowance = allowance
        self.news = news  # set when it ends (shared by the helpers)
        self.begun = begun
        self.out: list[PlanResult] = []
        self.ended = threading.Event()
        self.stop = threading.Event()
        self.others_on = threading.Event()  # set while the main thread's search runs too
        self.name = name
        self.cpu_start = 0.0

    def pace(self) -> bool:
        """The thread's checkpoint: True tells its search to stop."""
        while self.others_on.is_set() and not self.stop.is_set():
            used = time.thread_time() - self.cpu_start
            if used <= self.allowance(time.perf_counter() - self.begun):
                break
            time.sleep(0.005)  # the other threads run meanwhile
        return self.stop.is_set()

    def start(self, work: Callable[[_Paced], PlanResult | None]) -> None:
        def body() -> None:
            self.cpu_start = time.thread_time()
            try:
                result = work(self)
                if result is not None:
                    self.out.append(result)
            finally:
                self.ended.set()
                self.news.set()

        threading.Thread(target=body, name=self.name, daemon=True).start()

    def answered(self) -> bool:
        return self.ended.is_set() and bool(self.out) and self.out[0].status in _FINAL


def _portfolio(
    planning: HddlPlanning,
    budget: int,
    time_left: Callable[[], float | None],
    progress: SolveProgress | None,
    started: float,
) -> Solved:
    """Depth-first in a thread of its own, and after :data:`DFS_ALONE` greedy best-first
    beside it and the grounded search in a third (see :func:`solve`); the first final
    answer ends them all."""
    run = functools.partial(plan, planning.domain, planning.state, planning.tasks)
    dfs_settings = PlannerSettings(alternatives=1, budget=budget, search=Search.DFS, time_limit=time_left())
    begun = time.perf_counter()
    news = threading.Event()
    dfs = _Paced("htnagent-dfs", dfs_allowance, begun, news)
    grounded = _Paced("htnagent-grounded", grounded_allowance, begun, news)
    helpers = (dfs, grounded)

    # Progress as one count: depth-first search's own while it runs alone, then, said by the
    # greedy search, the searches' expansions together.
    dfs_seen = [0]
    grounded_seen = [0]
    said = [0]
    saying = threading.Lock()

    def say(search: Search, n: int) -> None:
        if progress is not None:
            with saying:
                said[0] = max(said[0], n)  # never less than said before, whichever thread says it
                progress(search, said[0], time.perf_counter() - started)

    def dfs_told(n: int, _: float) -> None:
        dfs_seen[0] = n
        if not dfs.others_on.is_set():
            say(Search.DFS, n)

    greedy_seen = [0]

    def grounded_told(n: int, _: float) -> None:
        grounded_seen[0] = n
        if lifted_waits.is_set():  # the greedy search, waiting, says nothing meanwhile
            say(Search.GBFS, dfs_seen[0] + n + greedy_seen[0])

    def greedy_told(n: int, _: float) -> None:
        greedy_seen[0] = n
        say(Search.GBFS, dfs_seen[0] + grounded_seen[0] + n)

    # Where the lifted searches bind some method's parameters by the thousand (they are
    # lost: `lifted_is_lost`), the lifted greedy search waits and the grounded search --
    # its grounding first -- has its share too; the lifted greedy search goes on only where
    # the grounding fails (or leaves no method to decompose by its ground methods).
    lifted_waits = threading.Event()
    alone = lifted_is_lost(planning.domain, planning.state)

    def greedy_checkpoint() -> bool:
        if lifted_waits.is_set():
            # Woken by a helper's end; and a few times a second to see the clock and a stop
            # asked for (the greedy search, back, then ends on them itself).
            while lifted_waits.is_set() and not grounded.ended.is_set() and not answered():
                left = time_left()
                if searches_stopped() or (left is not None and left <= 1e-3):
                    break
                if dfs.ended.is_set():
                    grounded.others_on.clear()  # alone now: no one else would use the time
                news.wait(WAKE_SECONDS)
                news.clear()
            for h in helpers:
                if not h.ended.is_set():
                    h.others_on.set()  # the greedy search runs again beside them
        return answered()

    def answered() -> bool:
        return dfs.answered() or grounded.answered()

    # Where the grounder decomposes methods by their ground methods, the lifted depth-first
    # search, binding them by type, is lost: once the grounding is ready, depth-first search
    # goes on by the ground methods instead, pruned by the grounding, with its own share.
    by_ground: list[PlannerSettings] = []  # said by the grounded search, once grounded
    switch = threading.Event()
    dfs_used = [dfs_settings]

    def depth_first(paced: _Paced) -> PlanResult:
        lifted = run(dfs_settings, checkpoint=lambda: paced.pace() or switch.is_set(), progress=dfs_told)
        left = budget - lifted.expansions
        if not switch.is_set() or paced.stop.is_set() or lifted.status in _FINAL or left <= 0:
            return lifted
        settings = dataclasses.replace(by_ground[0], budget=left, time_limit=time_left())
        dfs_used[0] = settings

        def told(n: int, seconds: float) -> None:
            dfs_told(lifted.expansions + n, seconds)

        found = run(settings, checkpoint=paced.pace, progress=told)
        return dataclasses.replace(found, expansions=lifted.expansions + found.expansions)

    guided_settings: list[PlannerSettings] = []

    def guided(paced: _Paced) -> PlanResult | None:
        # The grounding counts against the search's share: it is paced like the search.
        left = time_left()
        deadline = None if left is None else time.perf_counter() + left

        def checkpoint() -> bool:
            if not alone and time.thread_time() - paced.cpu_start > GROUNDING_SECONDS:
                return True
            if searches_stopped() or paced.pace():
                return True
            return deadline is not None and time.perf_counter() > deadline

        cap = MAX_GROUND_ALONE if alone else MAX_GROUND
        composition = ground(planning.domain, planning.state, planning.tasks, cap=cap, checkpoint=checkpoint)
        if alone and (composition is None or not composition.decompositions):
            paced.allowance = grounded_allowance  # the lifted greedy search goes on, with its share
            lifted_waits.clear()
            news.set()
        if composition is None or paced.stop.is_set():
            return None

        # The settings carry the guide: what answered is then told by its settings.  Both
        # searches decompose by the ground methods where the grounder bound them by the join.
        def grounded(order: Search, spent: int) -> PlannerSettings:
            return PlannerSettings(
                alternatives=1,
                budget=budget - spent,
                search=order,
                time_limit=time_left(),
                guide=composition.estimate,
                decompositions=composition.decompositions,
                prune=composition.dead_end,
            )

        # Where the searches decompose methods by their ground methods, depth-first search in
        # method order by them, dropping the dead ends the grounding sees (design §7.2),
        # takes over depth-first search's thread and its share; only where that thread has
        # ended does this one spend a moment of its work on it first.  Elsewhere the lifted
        # depth-first search already goes the same way.
        first = PlanResult(PlanStatus.INTERRUPTED)
        if composition.decompositions and not dfs.ended.is_set():
            by_ground.append(grounded(Search.DFS, 0))
            switch.set()  # depth-first search's thread takes it from here
        elif composition.decompositions:
            settings = grounded(Search.DFS, 0)
            begun_dfs = time.thread_time()

            def brief() -> bool:
                return paced.pace() or time.thread_time() - begun_dfs > GROUNDED_DFS_SECONDS

            first = run(settings, checkpoint=brief, progress=grounded_told)
            if first.status in _FINAL or paced.stop.is_set() or first.expansions >= budget:
                guided_settings.append(settings)
                return first
        settings = grounded(Search.GBFS, first.expansions)
        guided_settings.append(settings)

        def told(n: int, seconds: float) -> None:
            grounded_told(first.expansions + n, seconds)

        found = run(settings, checkpoint=paced.pace, progress=told)
        return dataclasses.replace(found, expansions=first.expansions + found.expansions)

    # One collector pause for all the searches (each pauses it itself only when it runs).
    collecting = gc.isenabled()
    gc.disable()
    try:
        dfs.start(depth_first)
        dfs.ended.wait(DFS_ALONE)
        if dfs.ended.is_set() and (dfs.out[0].status in _FINAL or dfs.out[0].expansions >= budget):
            return Solved(planning, Search.DFS, dfs_settings, dfs.out[0])
        greedy = PlannerSettings(alternatives=1, budget=budget, search=Search.GBFS, time_limit=time_left())
        for helper in helpers:
            helper.others_on.set()
        if alone:
            grounded.allowance = _all_but_dfs
            lifted_waits.set()
        grounded.start(guided)
        found = run(greedy, progress=greedy_told, checkpoint=greedy_checkpoint)
        # Out of time (or stopped), the others are too: a grounding under way has no clock.
        settled = found.status in (*_FINAL, PlanStatus.TIMED_OUT, PlanStatus.INTERRUPTED) or answered()
        for helper in helpers:
            helper.others_on.clear()
            if settled:
                helper.stop.set()
        for helper in helpers:
            helper.ended.wait()
    finally:
        for helper in helpers:
            helper.stop.set()
            helper.others_on.clear()
        if collecting:
            gc.enable()
    grounded_settings = guided_settings[0] if guided_settings else greedy
    others = [
        (Search.DFS, dfs_used[0], dfs.out),
        (grounded_settings.search, grounded_settings, grounded.out),
    ]
    both = found.expansions + sum(out[0].expansions for _, _, out in others if out)
    seconds = time.perf_counter() - started
    if found.status not in _FINAL:
        for search, settings, out in others:
            if out and out[0].status in _FINAL:
                return Solved(planning, search, settings, dataclasses.replace(out[0], expansions=both))
    # The greedy search's answer, or no one's: then why the greedy search stopped.
    answer = dataclasses.replace(found, expansions=both, seconds=seconds)
    return Solved(planning, Search.GBFS, greedy, answer)


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

    The first plan comes as :func:`solve` finds it, as soon.  By default (no ``search``
    given), each task of the network is then planned alone, the cheapest, in turn
    (:func:`~htnagent.planning.one_at_a_time.cheaper_one_at_a_time`, for at most
    :data:`ANYTIME_PARTS_SHARE` of the time left).  Then branch and bound
    (:func:`~htnagent.planning.planner.plan`'s ``improving``): a search that follows only
    nodes whose actions so far plus the least cost of their tasks stay under the cheapest
    plan's cost, which falls with every plan it finds.  After the portfolio's first plan,
    A* first, for :data:`ANYTIME_ASTAR_SHARE` of the time and budget left: the first plan
    it finds is the cheapest.  Then greedy best-first (or the ``search`` given,
    depth-first for ``dfs``), so that a cheaper plan comes soon.  Where the grounded
    search found the first plan decomposing by ground methods, the search goes on in its
    own order, with its estimate and ground methods, and no A* before it.  The search
    ends when the time or the budget runs out, or when no node under the bound is left:
    the last plan is then the cheapest there is (``result.exhausted``).  With ``search``
    A*, the first plan is already the cheapest: nothing follows it.
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
    # A first plan from the grounded search where it decomposes by ground methods: the
    # lifted search, binding those methods by type, is lost there, so the search for
    # cheaper plans goes on as the one that found it -- its order, estimate and ground
    # methods (Woodworking's 10th problem: 27 actions, then 15 by depth-first; none
    # cheaper by greedy search).
    grounded = first.settings if first.settings.decompositions else None
    if grounded is not None and search is None:
        order = grounded.search
    planning = first.planning
    run = functools.partial(plan, planning.domain, planning.state, planning.tasks)
    found_by: Search = first.search
    used = first.settings
    if search is None:
        # Design §7.6: each task of the network planned alone, the cheapest, in turn
        # (Logistics' 18-1: 4,277 actions, then 242 within 0.2 s, the cheapest there is).
        share = None if left is None else left * ANYTIME_PARTS_SHARE
        told = None if progress is None else _after(progress, Search.ASTAR, spent, started)
        cheaper = cheaper_one_at_a_time(
            planning.domain,
            planning.state,
            best,
            TOP,
            time_limit=share,
            budget=budget - spent,
            grounded=grounded,
            progress=told,
        )
        spent += cheaper.expansions
        if cheaper.plan is not None:
            best, found_by = cheaper.plan, Search.ASTAR  # (A*, a task at a time)
            better(best)
        left = None if timeout is None else timeout - (time.perf_counter() - started)
        if best.cost <= 0 or spent >= budget or (left is not None and left <= 0):
            seconds = time.perf_counter() - started
            total = PlanResult(PlanStatus.SOLVED, (best,), spent, seconds, best.cost <= 0)
            return Solved(planning, found_by, used, total)
    if search is None and grounded is None:
        # A* first, under the first plan's cost, for a share of the time and budget left:
        # where the space under that cost is small enough it ends with the cheapest plan,
        # and the search ends there (Elevator's s15-2: 615 actions, then 165 within 0.5 s;
        # greedy branch and bound alone sheds one action at a time, 352 after 30 s).
        astar = PlannerSettings(
            alternatives=1,
            budget=max(int((budget - spent) * ANYTIME_ASTAR_SHARE), 1),
            search=Search.ASTAR,
            time_limit=None if left is None else max(left * ANYTIME_ASTAR_SHARE, 1e-3),
            cost_bound=best.cost,
        )
        told = None if progress is None else _after(progress, Search.ASTAR, spent, started)
        cheapest = run(astar, progress=told, improving=better)
        spent += cheapest.expansions
        if cheapest.best is not None:
            best, found_by, used = cheapest.best, Search.ASTAR, astar
        left = None if timeout is None else timeout - (time.perf_counter() - started)
        if cheapest.exhausted or spent >= budget or (left is not None and left <= 0):
            seconds = time.perf_counter() - started
            total = PlanResult(PlanStatus.SOLVED, (best,), spent, seconds, cheapest.exhausted)
            return Solved(planning, found_by, used, total)
    settings = PlannerSettings(
        alternatives=1,
        budget=budget - spent,
        search=order,
        time_limit=left,
        cost_bound=best.cost,
        guide=None if grounded is None else grounded.guide,
        decompositions=None if grounded is None else grounded.decompositions,
        prune=None if grounded is None else grounded.prune,
    )
    told = None if progress is None else _after(progress, order, spent, started)
    found = run(settings, progress=told, improving=better)
    if found.best is not None:
        best, found_by, used = found.best, order, settings
    seconds = time.perf_counter() - started
    total = PlanResult(PlanStatus.SOLVED, (best,), spent + found.expansions, seconds, found.exhausted)
    return Solved(planning, found_by, used, total)


def _after(progress: SolveProgress, search: Search, before: int, started: float) -> Progress:
    return lambda n, _: progress(search, before + n, time.perf_counter() - started)


__all__ = [
    "ANYTIME_ASTAR_SHARE",
    "ANYTIME_PARTS_SHARE",
    "DFS_EARLY_SHARE",
    "DFS_SECONDS",
    "DFS_SHARE",
    "GROUNDED_DFS_SECONDS",
    "GROUNDED_LATE_SHARE",
    "GROUNDED_SHARE",
    "GROUNDING_SECONDS",
    "HDDL_BUDGET",
    "Better",
    "SolveProgress",
    "Solved",
    "solve",
    "solve_anytime",
]
