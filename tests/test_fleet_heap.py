"""A run's long-lived objects stay out of the garbage collector's passes while it runs.

:func:`htnagent.system.heap.long_lived` freezes the heap (``gc.freeze``) and collects the
young generation less often around a scenario's run, a fleet's and a serving process's
service, and puts both back after, however the run ends; a heap the caller froze is left
to the caller.  In one process, with no network: the museum, once and twice.
"""

from __future__ import annotations

import functools
import gc
from collections.abc import Callable, Iterator

import anyio
import pytest

from htnagent.runtime.events import TraceEvent
from htnagent.runtime.trace import Observer
from htnagent.scenario import load_scenario
from htnagent.system.fleet import run_fleet
from htnagent.system.heap import YOUNG, long_lived
from htnagent.system.simulation import run_scenario
from tests.support import SCENARIO_DIR


@pytest.fixture(autouse=True)
def thawed() -> Iterator[None]:
    """Every test starts and ends with nothing frozen (a failing one must not leak a freeze)."""
    gc.unfreeze()
    yield
    gc.unfreeze()


def test_long_lived_freezes_and_thaws_even_on_error() -> None:
    before = gc.get_threshold()
    with pytest.raises(RuntimeError), long_lived():
        assert gc.get_freeze_count() > 0
        assert gc.get_threshold() == (YOUNG, *before[1:])
        raise RuntimeError("a run that fails")
    assert gc.get_freeze_count() == 0
    assert gc.get_threshold() == before


def test_long_lived_leaves_the_callers_freeze_alone() -> None:
    gc.freeze()
    frozen = gc.get_freeze_count()
    before = gc.get_threshold()
    with long_lived():
        assert gc.get_threshold() == before
    assert gc.get_freeze_count() == frozen  # not thawed: the caller froze it


CHECKED = frozenset({"run_started", "goal_finished", "summary"})
"""The events at which the tests ask whether the heap is frozen: a run's start, each goal's
end and its summary.  Not every event: ``gc.get_freeze_count`` walks every frozen object,
and in the suite's process (every test module loaded) that is some 20 ms a call."""


def _freeze_counts(counts: list[tuple[int, str, int]]) -> Callable[[int], list[Observer]]:
    """Observers appending ``(robot, event, freeze count)`` at the :data:`CHECKED` events."""

    def observers(index: int) -> list[Observer]:
        def seen(event: TraceEvent) -> None:
            if event.event in CHECKED:
                counts.append((index, event.event, gc.get_freeze_count()))

        return [seen]

    return observers


def test_a_fleet_runs_frozen_and_ends_thawed() -> None:
    # Two robots whose runs end at different times (the paper's n1-n40-n4 before the
    # museum): the first one's end must not thaw the heap under the other, still running.
    names = ("paper_n1_n40_n4.yaml", "museum.yaml")
    scenarios = [load_scenario(SCENARIO_DIR / name) for name in names]
    counts: list[tuple[int, str, int]] = []
    report = anyio.run(functools.partial(run_fleet, scenarios, observers=_freeze_counts(counts)))
    assert report.succeeded
    # Every robot's start, goals' ends and summary were seen, each with the heap frozen.
    assert {(robot, event) for robot, event, _ in counts} == {(r, e) for r in (0, 1) for e in CHECKED}
    assert min(count for _, _, count in counts) > 0  # the scenarios built before the run were frozen
    assert gc.get_freeze_count() == 0


def test_a_scenario_runs_frozen_and_ends_thawed() -> None:
    # An agent's plan upkeep makes many objects that live a while (kept plans, forks): a
    # full collection then walked the whole heap inside it (7 ms of an IPC agent's run).
    counts: list[tuple[int, str, int]] = []
    report = anyio.run(
        functools.partial(
            run_scenario, load_scenario(SCENARIO_DIR / "museum.yaml"), observers=_freeze_counts(counts)(0)
        )
    )
    assert report.succeeded
    assert {event for _, event, _ in counts} == CHECKED
    assert min(count for _, _, count in counts) > 0
    assert gc.get_freeze_count() == 0


def test_nested_runs_ask_the_collector_once(monkeypatch: pytest.MonkeyPatch) -> None:
    # ``gc.get_freeze_count`` walks every frozen object: a fleet's parent asked it once
    # per robot with the whole fleet frozen.  Only the outermost asks.
    asked: list[int] = []
    count = gc.get_freeze_count

    def counted() -> int:
        asked.append(1)
        return count()

    monkeypatch.setattr(gc, "get_freeze_count", counted)
    with long_lived():
        for _ in range(5):
            with long_lived():
                pass
        assert gc.get_threshold()[0] == YOUNG  # still the outer one's, not put back by an inner
    assert len(asked) == 1
    assert count() == 0
