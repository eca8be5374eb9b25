"""The embedding API and the ``run`` command, seen from outside.

- :class:`~htnagent.system.runtime.Runtime` works under asyncio and trio alike, and
  :meth:`~htnagent.system.runtime.Runtime.events` streams the trace;
- a scenario run is deterministic: the same events every run, whether simulated
  time runs as fast as it can or is paced against the wall clock;
- ``python -m htnagent run`` keeps the output promises of docs/contracts.md.
"""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path
from typing import Any

import anyio
import pytest

from htnagent.agent import GoalStatus
from htnagent.errors import HtnAgentError, SettingsError, UnknownNameError
from htnagent.model.terms import atom
from htnagent.runtime.trace import WALL_CLOCK_FIELDS, EventStream
from htnagent.scenario import load_scenario
from htnagent.system.runtime import GoalOutcome, Runtime
from htnagent.system.simulation import run_scenario
from tests.support import Event, events_of
from tests.test_agent_runtime import COURIER, GUARD, courier, robot

REPO = Path(__file__).resolve().parents[1]
MUSEUM = REPO / "scenarios" / "museum.yaml"
WALL_CLOCK = WALL_CLOCK_FIELDS | {"wall_ms"}


# -- the embedding API --------------------------------------------------------------------------


async def achieve_with_a_stream() -> tuple[GoalOutcome, list[str]]:
    """``achieve`` goto(d) while another task reads ``events()`` to its end."""
    seen: list[str] = []

    async def read(stream: EventStream) -> None:
        async with stream:
            async for event in stream:
                seen.append(f"{event.agent} {event.event}")

    with anyio.fail_after(GUARD):
        # Leaving the runtime ends the stream, so the reader finishes by itself.
        async with anyio.create_task_group() as tg, Runtime([courier()], robot()) as rt:
            tg.start_soon(read, rt.events())
            outcome = await rt.achieve(COURIER, atom("goto(d)"))
    return outcome, seen


@pytest.mark.parametrize("backend", ["asyncio", "trio"])
def test_achieve_and_the_event_stream_work_under_asyncio_and_trio(backend: str) -> None:
    outcome, seen = anyio.run(achieve_with_a_stream, backend=backend)
    assert outcome.status is GoalStatus.SUCCESS
    assert (outcome.agent, str(outcome.goal), outcome.emergency, outcome.reason) == (
        COURIER,
        "goto(d)",
        False,
        "",
    )
    # Expect: the whole story, streamed in order, and nothing after it.
    assert [s for s in seen if not s.endswith("message")] == [
        "courier goal_received",
        "courier plan_selected",
        "courier action_started",
        "robot robot_moving",
        "courier action_finished",
        "courier action_started",
        "robot robot_moving",
        "courier action_finished",
        "courier goal_finished",
    ]


async def test_a_closed_event_stream_stops_being_fed() -> None:
    async with Runtime([courier()], robot()) as rt:
        stream = rt.events()
        await stream.aclose()
        await rt.achieve(COURIER, atom("scan(a)"))
        assert rt.trace.observers == []


async def test_submit_names_the_agents_when_the_agent_is_unknown() -> None:
    async with Runtime([courier()], robot()) as rt:
        with pytest.raises(KeyError, match="no agent named 'boss'; agents: courier"):
            rt.submit("boss", atom("goto(d)"))


def test_a_runtime_needs_an_agent() -> None:
    with pytest.raises(ValueError, match="at least one agent"):
        Runtime([], robot())


@pytest.mark.parametrize(
    ("setting", "value"),
    [
        ("action_timeout", 0),
        ("action_timeout", -1.0),
        ("action_timeout", float("nan")),
        ("action_timeout", float("inf")),
        ("max_failures", 0),
        ("max_depth", 0),
        ("maintained_depth", -1),
        ("max_failures", 2.5),
    ],
)
def test_an_agent_setting_out_of_range_is_refused_when_given(setting: str, value: float) -> None:
    # An action timeout of 0 or NaN was taken, and every action then failed at once.
    with pytest.raises(SettingsError, match=f"agent courier: {setting} must be"):
        courier("a", **{setting: value})


# -- determinism ------------------------------------------------------------------------------------


def without_wall_clock(value: Any) -> Any:
    """The value with every wall-clock measurement left out, at any depth."""
    if isinstance(value, dict):
        return {k: without_wall_clock(v) for k, v in value.items() if k not in WALL_CLOCK}
    if isinstance(value, list):
        return [without_wall_clock(v) for v in value]
    return value


async def museum_events(speed: float | None = None) -> list[Event]:
    with anyio.fail_after(GUARD):
        report = await run_scenario(load_scenario(MUSEUM), speed=speed, keep_events=True)
    assert report.succeeded
    events: list[Event] = without_wall_clock(events_of(report))
    return events


async def test_museum_run_gives_the_same_events_every_time() -> None:
    first, second = await museum_events(), await museum_events()
    assert first == second
    # The run is the published one: suspended on arc59, resumed after the emergency.
    assert {"goal_suspended", "goal_resumed"} <= {e["event"] for e in first}
    assert first[-1]["event"] == "summary"


async def test_museum_run_paced_against_the_wall_clock_gives_the_same_events() -> None:
    # About 65 simulated seconds at 200 per real second: a third of a second.
    assert await museum_events(speed=200.0) == await museum_events()


# -- the command line ------------------------------------------------------------------------------


def htnagent(*args: str) -> subprocess.CompletedProcess[str]:
    return subprocess.run(
        [sys.executable, "-m", "htnagent", *args],
        cwd=REPO,
        capture_output=True,
        text=True,
        timeout=30,
        check=False,
    )


def test_run_json_prints_one_event_a_line_and_ends_with_the_summary() -> None:
    done = htnagent("run", "scenarios/museum.yaml", "--json")
    assert done.returncode == 0, done.stderr
    events = [json.loads(line) for line in done.stdout.splitlines()]
    assert all({"t", "agent", "event"} <= e.keys() for e in events)
    summary = events[-1]
    assert summary["event"] == "summary"
    assert [e for e in events if e["event"] == "summary"] == [summary]
    assert {"goals", "robot", "visited", "distance", "planning_ms"} <= summary.keys()
    # Expect: both goals, in the file's order, succeeded; the robot ended at n1.
    assert [(g["agent"], g["goal"], g["status"]) for g in summary["goals"]] == [
        ("guide", "goto(n1)", "success"),
        ("guide", "goto(n28)", "success"),
    ]
    assert summary["robot"] == {"at": "n1"}
    assert summary["visited"][0] == "n40" and "n28" in summary["visited"] and summary["visited"][-1] == "n1"
    assert summary["distance"] > 0
    assert set(summary["planning_ms"]) == {"guide", "navigator"}
    # The fields docs/contracts.md lists for the events the run must show.
    resumed = [e for e in events if e["event"] == "goal_resumed"]
    assert resumed and all({"goal", "replanning", "replan_ms"} <= e.keys() for e in resumed)
    assert all(e["replanning"] == "online" for e in resumed)


def test_run_prints_a_readable_trace_with_the_suspension_and_the_resumption() -> None:
    done = htnagent("run", "scenarios/museum.yaml")
    assert done.returncode == 0, done.stderr
    assert "suspended" in done.stdout and "resumed" in done.stdout
    assert "Traceback" not in done.stderr


async def test_what_the_runtime_refuses_is_an_htnagent_error() -> None:
    # Expect: misuse of the embedding API raises our own errors (also the builtin ones
    # callers may catch), never a bare KeyError or ValueError.
    with pytest.raises(SettingsError) as setting:
        Runtime([], robot())
    async with Runtime([courier()], robot()) as rt:
        with pytest.raises(UnknownNameError) as name:
            rt.submit("boss", atom("goto(d)"))
        with pytest.raises(UnknownNameError) as ticket:
            await rt.outcome(99)
    for error in (setting.value, name.value, ticket.value):
        assert isinstance(error, HtnAgentError)
    assert isinstance(setting.value, ValueError) and isinstance(name.value, KeyError)
    assert str(name.value) == "no agent named 'boss'; agents: courier"


@pytest.mark.parametrize("hook", ["subscribe", "on_progress", "on_goal_end"])
async def test_a_callback_that_raises_is_dropped_and_the_runtime_goes_on(hook: str) -> None:
    # A goal-end callback that raised tore the whole runtime down, where a trace observer
    # or a progress listener that raises is dropped and the agents go on.
    calls: list[object] = []

    def broken(value: object) -> None:
        calls.append(value)
        raise ZeroDivisionError("the user's callback")

    with anyio.fail_after(GUARD):
        async with Runtime([courier()], robot()) as rt:
            getattr(rt, hook)(broken)
            first = await rt.achieve(COURIER, atom("goto(d)"))
            second = await rt.achieve(COURIER, atom("goto(a)"))
    assert first.status is second.status is GoalStatus.SUCCESS
    # Dropped after it raised (a progress listener is each actor's: the courier's and the robot's).
    assert len(calls) == (2 if hook == "on_progress" else 1)
