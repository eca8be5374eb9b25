"""The look-ahead changes no outcome (docs/design.md §4): with ``AgentConfig.look_ahead`` on
and off, in both modes, the six published cases, the nested emergencies and the shut door
end the same — the same goals' outcomes, nodes visited and distance, and the same trace
but for the ``prepare`` hints and the measured times.

And the switch is real: off, nothing is worked out ahead and no hint is sent.
"""

from __future__ import annotations

from typing import Any

import pytest

from htnagent.agent.look_ahead import LookAhead, NoLookAhead
from htnagent.runtime.events import TraceEvent
from htnagent.scenario import load_scenario
from htnagent.system.runtime import Runtime
from htnagent.system.simulation import RunReport, run_scenario
from tests.support import SCENARIO_DIR, without_wall_clock

PUBLISHED = sorted(p.name for p in SCENARIO_DIR.glob("paper_*.yaml"))
CASES = [*PUBLISHED, "nested_emergencies.yaml", "door_shut.yaml"]


async def _run(file: str, mode: str, look_ahead: bool) -> tuple[RunReport, list[Runtime]]:
    runtimes: list[Runtime] = []
    report = await run_scenario(
        load_scenario(SCENARIO_DIR / file),
        replanning=mode,
        look_ahead=look_ahead,
        keep_events=True,
        on_start=runtimes.append,
    )
    return report, runtimes


def _story(events: list[TraceEvent]) -> list[dict[str, Any]]:
    """The trace without the hints and the wall-clock measurements."""
    story = []
    for event in events:
        data = event.as_dict()
        if data.get("kind") == "prepare":
            continue
        story.append(without_wall_clock(data))
    return story


def test_the_cases_are_the_published_six_and_two_more() -> None:
    assert len(CASES) == 8


@pytest.mark.parametrize("mode", ["online", "naive"])
@pytest.mark.parametrize("file", CASES)
async def test_the_look_ahead_changes_no_outcome(file: str, mode: str) -> None:
    on, _ = await _run(file, mode, look_ahead=True)
    off, _ = await _run(file, mode, look_ahead=False)
    assert on.succeeded
    assert off.summary.outcomes == on.summary.outcomes
    assert off.summary.visited == on.summary.visited
    assert off.summary.distance == on.summary.distance
    assert _story(off.events) == _story(on.events)


@pytest.mark.parametrize("file", ["paper_n40_n1_n28.yaml", "nested_emergencies.yaml"])
async def test_look_ahead_off_works_nothing_out_ahead(file: str, monkeypatch: pytest.MonkeyPatch) -> None:
    foreseen: list[bool] = []
    foresee = LookAhead.foresee

    def recording(self: LookAhead, action: Any) -> bool:
        made = foresee(self, action)
        foreseen.append(made or self.prediction is not None)
        return made

    monkeypatch.setattr(LookAhead, "foresee", recording)

    def hints(report: RunReport) -> int:
        return sum(1 for e in report.events if e.as_dict().get("kind") == "prepare")

    # On, the resumption is worked out ahead and the child is told the next order.
    on, runtimes = await _run(file, "online", look_ahead=True)
    assert all(isinstance(a.look_ahead, LookAhead) for a in runtimes[0].agents.values())
    assert any(foreseen) and hints(on) > 0
    # Off, none of it.
    foreseen.clear()
    off, runtimes = await _run(file, "online", look_ahead=False)
    assert off.succeeded
    assert not any(type(a.look_ahead) is not NoLookAhead for a in runtimes[0].agents.values())
    assert foreseen == [] and hints(off) == 0
