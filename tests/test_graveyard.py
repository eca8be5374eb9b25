"""What a long search made is freed in a thread of its own, so that its answer does not wait
for the freeing (docs/design.md §7: the time limit)."""

from __future__ import annotations

import gc
import threading

import pytest

from htnagent.planning import planner
from htnagent.planning.planner import PlannerSettings, Search, plan
from tests.test_reach import _varnish


def test_the_graveyard_frees_in_its_own_thread_and_thaws_the_collector() -> None:
    freed_in: list[str] = []

    class Remain:
        def __del__(self) -> None:
            freed_in.append(threading.current_thread().name)

    yard = planner._Graveyard()
    items = [Remain() for _ in range(2_500)]
    by_key = {i: Remain() for i in range(2_500)}
    yard.bury((items, by_key))
    del items, by_key
    assert yard.empty.wait(10)
    # Every one freed there, a thousand at a time, none by the caller.
    assert len(freed_in) == 5_000
    assert set(freed_in) == {"htnagent-graveyard"}
    # Frozen out of the collector's sight while they waited; in sight again once freed.
    assert gc.get_freeze_count() == 0


def test_a_long_search_hands_what_it_made_to_the_graveyard(monkeypatch: pytest.MonkeyPatch) -> None:
    planning = _varnish()
    settings = PlannerSettings(alternatives=1, budget=5_000, search=Search.GBFS)
    kept = plan(planning.domain, planning.state, planning.tasks, settings)
    buried: list[tuple[object, ...]] = []

    class Spy:
        def bury(self, remains: tuple[object, ...]) -> None:
            buried.append(remains)

    monkeypatch.setattr(planner, "_GRAVEYARD", Spy())
    monkeypatch.setattr(planner, "LET_GO_AFTER", 0.0)  # every search counts as long
    handed = plan(planning.domain, planning.state, planning.tasks, settings)
    # The same answer; the search's open list, expanded keys and caches go to be freed.
    assert handed.status is kept.status and handed.best is not None and kept.best is not None
    assert [s.action for s in handed.best.steps] == [s.action for s in kept.best.steps]
    (remains,) = buried
    assert isinstance(remains[0], list) and len(remains[0]) > 0  # the open list
    assert all(isinstance(made, dict) for made in remains[1:])
    # A short one frees what it made itself.
    monkeypatch.setattr(planner, "LET_GO_AFTER", 60.0)
    plan(planning.domain, planning.state, planning.tasks, settings)
    assert len(buried) == 1
