"""A parent asks the serving process for only the trace events its observers look at.

``run_scenario(relayed=...)`` (and ``run_fleet``'s) names the serving side's events to
relay; the summary's own (the goal times') always are.  The serving process is told
with a ``relay`` item as the parent joins, and sends a new parent everything until it
says otherwise.  Skipped without the ``zenoh`` extra.
"""

from __future__ import annotations

import functools
from pathlib import Path
from typing import Any

import anyio
import pytest

pytest.importorskip("zenoh", reason="the zenoh extra is not installed")

from htnagent.remote.codec import CodecError, Relay, decode, encode, receive
from htnagent.runtime.events import ActionStarted, Summary, TraceEvent
from htnagent.scenario import load_scenario
from htnagent.system.goal_times import GoalClock
from htnagent.system.serving import Host, serve
from htnagent.system.simulation import RunReport, build_runtime, remote_keys, run_scenario
from tests.remote_support import free_port, remote_scenario
from tests.support import shipped_run


def test_a_relay_reads_back_as_written() -> None:
    relay = Relay(events=frozenset({"message", "goal_finished"}))
    assert decode(encode(1.5, relay, "me", 1)) == (1.5, relay)


@pytest.mark.parametrize(
    "events",
    ["message", [1], ["x" * 65], ["e"] * 257, None],
    ids=["not a list", "not a name", "too long a name", "too many names", "null"],
)
def test_a_malformed_relay_is_refused(events: Any) -> None:
    payload = b'{"t": 0, "type": "relay", "body": {"events": %s}, "from": "p", "n": 1}' % (
        pytest.importorskip("orjson").dumps(events)
    )
    with pytest.raises(CodecError):
        receive(payload)


def test_the_goal_clock_names_every_event_it_reads() -> None:
    clock = GoalClock(("guide",), [])
    assert {kind.event for kind in clock._handlers} == GoalClock.EVENTS


def _navigator_events(events: list[TraceEvent]) -> set[str]:
    return {e.event for e in events if e.agent in ("navigator", "robot")}


@pytest.mark.parametrize("backend", ["asyncio", "trio"])
def test_a_parent_is_relayed_only_what_it_asks_and_ends_as_in_one_process(
    tmp_path: Path, backend: str
) -> None:
    # Expect: asking for no event of its own, the parent is sent only the goal times'
    # (goal_received, message, ...), no robot_moving nor action_started; the summary,
    # goal times included, is as in one process.
    port = free_port()
    endpoint = f"tcp/127.0.0.1:{port}"
    scenario = load_scenario(remote_scenario(tmp_path, port))
    events: list[TraceEvent] = []

    async def main() -> RunReport:
        async with anyio.create_task_group() as tg:
            ready = anyio.Event()
            served = functools.partial(serve, scenario, "navigator", endpoint, speed=200, ready=ready.set)
            tg.start_soon(served)
            with anyio.fail_after(20):
                await ready.wait()
                report = await run_scenario(scenario, speed=200, observers=[events.append], relayed=())
            tg.cancel_scope.cancel()
        return report

    report = anyio.run(main, backend=backend)
    _, alone = shipped_run("museum.yaml")
    expected = alone[-1]
    assert isinstance(expected, Summary) and report.succeeded
    got = report.summary
    assert (got.outcomes, got.visited, got.robot) == (expected.outcomes, expected.visited, expected.robot)
    assert got.distance == pytest.approx(expected.distance, abs=1e-6)
    # The serving side's (peer_joined is the parent's own, about its side of the link).
    served_events = {e.event for e in events if e.agent in ("navigator", "robot")} - {"peer_joined"}
    assert {"goal_received", "message", "goal_finished"} <= served_events <= GoalClock.EVENTS
    assert report.goal_times is not None and len(report.goal_times.resumptions()) == 1


def test_a_new_parent_is_relayed_everything_until_it_asks(tmp_path: Path) -> None:
    # The serving side of one robot, driven by hand: parent p1 asks for goal_finished only;
    # it goes, p2 binds, and p2 is sent the robot's actions again.
    scenario = load_scenario(remote_scenario(tmp_path, free_port()))
    runtime, world = build_runtime(scenario, speed=1.0, first="navigator")
    host = Host(runtime, world, "navigator", "guide", remote_keys(scenario, "navigator"), "tcp/127.0.0.1:1")
    sent: list[object] = []
    host._out = type("Out", (), {"send": staticmethod(lambda timed: sent.append(timed[1]))})()
    started = ActionStarted(agent="navigator", action="move(n40,n35,arc59)")
    host._liveliness(True, "p1")
    host._handle(Relay(events=frozenset({"goal_finished"})))
    host._event(started)
    assert started not in sent
    host._liveliness(False, "p1")
    host._liveliness(True, "p2")
    host._event(started)
    assert started in sent
