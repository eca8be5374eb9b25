"""The searches' decompositions by the ground methods the grounder kept (docs/design.md
§7.2): as many ways as the grounding kept, not the product of the parameters' types, and
none lost that a plan could take."""

from __future__ import annotations

import dataclasses
import math
import threading
import time
from collections.abc import Sequence
from typing import Any

import pytest

from htnagent.hddl.check import check_plan
from htnagent.model.domain import Method
from htnagent.model.terms import Atom
from htnagent.planning import composition, hddl_solving
from htnagent.planning.composition import Composition, ground, lifted_is_lost
from htnagent.planning.hddl_solving import Solved, solve_anytime
from htnagent.planning.hddl_translation import HddlPlanning
from htnagent.planning.ipc_output import ipc_plan
from htnagent.planning.planner import (
    PlannerSettings,
    PlanResult,
    PlanStatus,
    Search,
    plan,
    searches_stopped,
    stop_searches,
)
from tests.test_composition import WORKSHOP, _workshop

N = 12
"""Colours, brushes and tools of the workshop: finish-m has N**3 bindings an item by types."""


def _grounded(planning: HddlPlanning, tasks: tuple[Atom, ...] | None = None) -> Composition:
    # A cap of 1,000 (under N**3): the grounder binds finish-m by the join.
    found = ground(planning.domain, planning.state, planning.tasks if tasks is None else tasks, cap=1_000)
    assert found is not None
    return found


def _finish_m(planning: HddlPlanning) -> Method:
    (method,) = planning.domain.methods["finish"]
    return method


def test_a_task_decomposes_in_the_ways_the_grounding_kept_not_by_types() -> None:
    planning = _workshop(N)
    c = _grounded(planning)
    method = _finish_m(planning)
    assert method in c.decompositions  # its parameters are bound by the join
    finish = Atom("finish", ("i1",))
    start = planning.state
    lifted = method.compiled(start.dynamic_predicates)(finish, start)
    assert len(lifted) == N**3
    ground_ways = c.decompositions[method](finish, start)
    # i1 is coated in c1 with b1 alone; any tool sands it (a blunt one once it is smooth).
    assert len(ground_ways) == N
    # Nothing a plan could take is lost: every lifted way the estimate does not drop is a
    # ground way.  (The estimate drops more: sanding with a blunt tool after a coat, which
    # does not make the item smooth -- design §7.2, step 6.)
    for state in (start.dynamic, start.dynamic | {Atom("painted", ("i1",))}):
        kept = {w for w in lifted if c.estimate(w, state) < math.inf}
        assert kept == {w for w in ground_ways if c.estimate(w, state) < math.inf}
        assert kept


def test_a_split_methods_own_subtasks_keep_their_places_among_its_groups() -> None:
    # finish-m with subtasks of its own (rinse, bound by its task) between those of its two
    # groups (sanding: any tool; coating: any colour and brush): each ground way puts each
    # subtask where the method has it -- every one a lifted way, and the same ways the
    # estimate keeps.
    text = WORKSHOP.replace(
        ":ordered-subtasks (and (coat ?i ?c ?b) (sand ?i ?t)))",
        ":ordered-subtasks (and (sand ?i ?t) (rinse ?i) (coat ?i ?c ?b) (rinse ?i)))",
    ).replace("  (:action paint", "  (:action rinse :parameters (?i - item) :effect (and))\n  (:action paint")
    planning = _workshop(N, text)
    c = _grounded(planning)
    method = _finish_m(planning)
    finish = Atom("finish", ("i1",))
    start = planning.state
    lifted = method.compiled(start.dynamic_predicates)(finish, start)
    ground_ways = c.decompositions[method](finish, start)
    assert ground_ways and all(w[1] == w[3] == Atom("rinse", ("i1",)) for w in ground_ways)
    assert set(ground_ways) <= set(lifted)
    assert {w for w in lifted if c.estimate(w, start.dynamic) < math.inf} == {
        w for w in ground_ways if c.estimate(w, start.dynamic) < math.inf
    }


def test_a_task_the_grounding_never_met_decomposes_by_the_lifted_method() -> None:
    planning = _workshop(N)
    c = _grounded(planning, (Atom("finish", ("i1",)),))  # i2 never met
    method = _finish_m(planning)
    ways = c.decompositions[method](Atom("finish", ("i2",)), planning.state)
    assert len(ways) == N**3


def test_the_search_tries_only_the_ground_ways_and_finds_the_same_plan() -> None:
    planning = _workshop(N)
    c = _grounded(planning)
    estimated = [0]

    def guide(tasks: Sequence[Atom], dynamic: frozenset[Atom]) -> float:
        estimated[0] += 1
        return c.estimate(tasks, dynamic)

    plans = []
    for decompositions in (c.decompositions, None):
        estimated[0] = 0
        settings = PlannerSettings(
            alternatives=1, search=Search.GBFS, guide=guide, decompositions=decompositions
        )
        result = plan(planning.domain, planning.state, planning.tasks, settings)
        assert result.status is PlanStatus.SOLVED and result.best is not None
        assert [str(v) for v in check_plan(planning.hddl, planning.problem, ipc_plan(result.best))] == []
        plans.append(([str(s.action) for s in result.best.steps], estimated[0]))
    (by_ground, tried_ground), (by_types, tried_types) = plans
    assert by_ground == by_types
    # Each finish task: N ways estimated, not N**3.
    assert tried_ground < 10 * N < 2 * N**3 <= tried_types


def test_depth_first_search_decomposes_by_them_too() -> None:
    planning = _workshop(N)
    c = _grounded(planning)
    settings = PlannerSettings(
        alternatives=1, search=Search.DFS, guide=c.estimate, decompositions=c.decompositions
    )
    result = plan(planning.domain, planning.state, planning.tasks, settings)
    assert result.status is PlanStatus.SOLVED and result.best is not None
    assert [str(v) for v in check_plan(planning.hddl, planning.problem, ipc_plan(result.best))] == []


def test_cheaper_plans_after_a_grounded_first_plan_go_on_as_the_search_that_found_it(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    # The portfolio's answer as its grounded depth-first search gives it (a lifted search
    # answers this small problem first, so that answer is made here).
    planning = _workshop(N)
    c = _grounded(planning)
    settings = PlannerSettings(
        alternatives=1, search=Search.DFS, guide=c.estimate, decompositions=c.decompositions
    )
    settings = dataclasses.replace(settings, prune=c.dead_end)
    first = plan(planning.domain, planning.state, planning.tasks, settings)
    assert first.best is not None
    monkeypatch.setattr(hddl_solving, "solve", lambda *_, **__: Solved(planning, Search.DFS, settings, first))
    used: list[PlannerSettings] = []
    real = plan

    def spy(*args: Any, **kwargs: Any) -> PlanResult:
        used.append(args[3])
        return real(*args, **kwargs)

    monkeypatch.setattr(hddl_solving, "plan", spy)
    solve_anytime(planning.hddl, planning.problem, lambda _: None, timeout=5)
    (improving,) = used
    assert improving.search is Search.DFS
    assert improving.decompositions is c.decompositions and improving.guide is not None
    assert improving.prune is settings.prune  # and the test of what the list can still reach (step 7)
    assert improving.cost_bound == first.best.cost


def test_depth_first_search_goes_on_by_the_ground_methods_once_grounded(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    # The portfolio (design §7): where the grounder decomposes methods by their ground
    # methods, the lifted depth-first search is lost; once the grounding is ready, depth-first
    # search's thread goes on by the ground methods.  Here every other search is made lost
    # (each waits at its checkpoint until told to stop): the answer can only come from
    # depth-first search by the ground methods, in depth-first search's thread.
    planning = _workshop(13)  # 13**3 bindings of finish-m an item by types: decomposed
    calls: list[tuple[str, Search, bool]] = []
    real = plan

    def lost_but_grounded_dfs(*args: Any, **kwargs: Any) -> PlanResult:
        settings: PlannerSettings = args[3]
        grounded = settings.decompositions is not None
        calls.append((threading.current_thread().name, settings.search, grounded))
        if settings.search is Search.DFS and grounded:
            return real(*args, **kwargs)
        checkpoint = kwargs.get("checkpoint")
        ends = time.monotonic() + 20
        while time.monotonic() < ends and not (checkpoint is not None and checkpoint()):
            time.sleep(0.005)
        return PlanResult(PlanStatus.INTERRUPTED)

    monkeypatch.setattr(hddl_solving, "plan", lost_but_grounded_dfs)
    solved = hddl_solving.solve(planning.hddl, planning.problem, timeout=30)
    assert solved.result.status is PlanStatus.SOLVED and solved.result.best is not None
    assert solved.search is Search.DFS and solved.settings.decompositions is not None
    assert solved.settings.prune is not None  # the grounded searches drop what step 7 finds dead
    assert ("htnagent-dfs", Search.DFS, False) in calls  # the lifted one first
    assert ("htnagent-dfs", Search.DFS, True) in calls  # then by the ground methods
    # The grounded search's own thread goes straight to its greedy search.
    assert [c for c in calls if c[0] == "htnagent-grounded"] == [("htnagent-grounded", Search.GBFS, True)]
    best = solved.result.best
    assert [str(v) for v in check_plan(planning.hddl, planning.problem, ipc_plan(best))] == []


def test_the_lifted_searches_are_lost_where_types_make_thousands_of_ways_of_one_task() -> None:
    # finish-m binds colour, brush and tool by their types: n**3 ways of each finish task.
    assert lifted_is_lost(_workshop(13).domain, _workshop(13).state)  # 2,197: past 2,000
    assert not lifted_is_lost(_workshop(12).domain, _workshop(12).state)  # 1,728


def _portfolio_with(
    monkeypatch: pytest.MonkeyPatch,
    planning: HddlPlanning,
    real_ones: set[tuple[str, Search, bool]],
    slow_grounded: float = 0.0,
) -> tuple[Solved, dict[str, int]]:
    """The portfolio where only the searches ``real_ones`` (thread, search, by the grounding)
    plan; every other one is lost: it asks its checkpoint every 5 ms until told to stop.
    Also how many times each thread's lost search was let go on by its checkpoint.  The
    grounded greedy search, where real, first spends ``slow_grounded`` seconds so."""
    real = plan
    went_on: dict[str, int] = {}

    def searches(*args: Any, **kwargs: Any) -> PlanResult:
        settings: PlannerSettings = args[3]
        thread = threading.current_thread().name
        which = (thread, settings.search, settings.decompositions is not None)
        checkpoint = kwargs.get("checkpoint")
        lost = which not in real_ones
        ends = time.monotonic() + (20 if lost else slow_grounded if settings.guide is not None else 0)
        while time.monotonic() < ends:
            if searches_stopped() or (checkpoint is not None and checkpoint()):
                return PlanResult(PlanStatus.INTERRUPTED)
            went_on[thread] = went_on.get(thread, 0) + 1
            time.sleep(0.005)
        return PlanResult(PlanStatus.INTERRUPTED) if lost else real(*args, **kwargs)

    monkeypatch.setattr(hddl_solving, "plan", searches)
    return hddl_solving.solve(planning.hddl, planning.problem, timeout=30), went_on


@pytest.mark.parametrize("n", [13, 12])
def test_where_the_lifted_searches_are_lost_the_lifted_greedy_search_waits_for_the_grounded_one(
    n: int, monkeypatch: pytest.MonkeyPatch
) -> None:
    # Only the grounded greedy search answers, after half a second of work.  Where the
    # lifted searches are lost (13), the lifted greedy search, in the main thread, waits at
    # its checkpoint meanwhile (its time is the grounded search's); elsewhere (12) it goes on.
    grounded_only = {("htnagent-grounded", Search.GBFS, True)}
    solved, went_on = _portfolio_with(monkeypatch, _workshop(n), grounded_only, slow_grounded=0.5)
    assert solved.result.status is PlanStatus.SOLVED and solved.settings.guide is not None
    if n == 13:
        assert went_on.get("MainThread", 0) <= 2  # let go on only before the grounding began
    else:
        assert went_on["MainThread"] > 40


def test_where_the_grounding_fails_the_lifted_greedy_search_goes_on(monkeypatch: pytest.MonkeyPatch) -> None:
    # The lifted searches lost, but the grounding past its cap: the lifted greedy search,
    # waiting, goes on, and answers (the others are lost) -- at once, not once the others'
    # time is up.
    monkeypatch.setattr(hddl_solving, "MAX_GROUND_ALONE", 50)
    solved, went_on = _portfolio_with(monkeypatch, _workshop(13), {("MainThread", Search.GBFS, False)})
    assert solved.result.status is PlanStatus.SOLVED
    assert solved.search is Search.GBFS and solved.settings.guide is None  # the lifted one
    assert "htnagent-grounded" not in went_on  # no grounded search: the grounding failed
    assert solved.result.seconds < 10


def test_where_the_grounding_gives_no_ground_methods_the_lifted_greedy_search_goes_on(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    # Said lost, but the grounding decomposes nothing by its ground methods (12: finish-m's
    # 1,728 ways are bound by types): the lifted greedy search goes on once it is grounded,
    # and answers while the grounded search, lost here, still runs (not once its time is up).
    monkeypatch.setattr(hddl_solving, "lifted_is_lost", lambda *_: True)
    solved, _ = _portfolio_with(monkeypatch, _workshop(12), {("MainThread", Search.GBFS, False)})
    assert solved.result.status is PlanStatus.SOLVED and solved.settings.guide is None
    assert solved.result.seconds < 10


def test_a_stop_asked_for_ends_the_portfolio_while_the_lifted_greedy_search_waits(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    # The lifted searches lost, every search lost, and a grounding that takes its time (it
    # reads its checkpoint every 5 ms): a stop asked for half a second in ends it all.
    def slow_ground(*args: Any, checkpoint: Any = None, **kwargs: Any) -> None:
        ends = time.monotonic() + 20
        while time.monotonic() < ends and not checkpoint():
            time.sleep(0.005)

    monkeypatch.setattr(hddl_solving, "ground", slow_ground)
    stopping = threading.Timer(0.5, stop_searches)
    stopping.start()
    try:
        solved, _ = _portfolio_with(monkeypatch, _workshop(13), set())
    finally:
        stopping.cancel()
        stop_searches(False)
    assert solved.result.status is PlanStatus.INTERRUPTED
    assert solved.result.seconds < 5


@pytest.mark.parametrize("n", [13, 12])
def test_where_the_lifted_searches_are_lost_the_grounding_keeps_on_past_its_seconds(
    n: int, monkeypatch: pytest.MonkeyPatch
) -> None:
    # GROUNDING_SECONDS at 0: elsewhere (12) the grounding gives up at once and the lifted
    # greedy search answers; where the lifted searches are lost (13) it goes on, and the
    # grounded greedy search answers.
    monkeypatch.setattr(hddl_solving, "GROUNDING_SECONDS", 0.0)
    real_ones = {("MainThread", Search.GBFS, False), ("htnagent-grounded", Search.GBFS, True)}
    solved, _ = _portfolio_with(monkeypatch, _workshop(n), real_ones)
    assert solved.result.status is PlanStatus.SOLVED
    assert (solved.settings.guide is not None) == (n == 13)


def test_a_checkpoint_saying_stop_stops_the_grounding_in_its_last_steps_too(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    # Past the fixed point, pruning and compiling come in large steps (a second or more on
    # the largest groundings): the checkpoint is asked between them.  Here it says stop once
    # the least costs are worked out.
    least_costs = composition._least_costs
    pruning: list[bool] = []

    def noted(*args: Any) -> Any:
        pruning.append(True)
        return least_costs(*args)

    monkeypatch.setattr(composition, "_least_costs", noted)
    planning = _workshop(N)
    assert ground(planning.domain, planning.state, planning.tasks, checkpoint=lambda: bool(pruning)) is None
    pruning.clear()
    assert ground(planning.domain, planning.state, planning.tasks, checkpoint=lambda: False) is not None
