"""Agents in other processes over Zenoh (docs/contracts.md "Agents in other processes").

Two real processes on the loopback: a serving process (``python -m htnagent
serve``) runs the navigator and the robot; the parent runs the guide, here
under asyncio and trio or as ``python -m htnagent run``.  A lost peer — killed
or frozen — fails the orders in flight with ``peer lost`` and the run ends with
its summary, never a hang; one restarted, or thawed, serves the next goal.  Skipped
without the ``zenoh`` extra.
"""

from __future__ import annotations

import functools
import json
import signal
import time
from pathlib import Path
from typing import Any

import anyio
import pytest

pytest.importorskip("zenoh", reason="the zenoh extra is not installed")

from htnagent.runtime.events import PeerJoined, Summary
from htnagent.scenario import load_scenario
from htnagent.system.simulation import run_scenario
from tests.remote_support import (
    Lines,
    free_port,
    htnagent,
    inet_sockets,
    remote_scenario,
    serving,
    stop,
)
from tests.support import shipped_run, summary_of

SPEED = 20.0
"""Simulated seconds per real second: the museum run takes about 3 s, and a message's
few milliseconds on the way stay well inside the half move the emergency waits for."""
GUARD = 30.0


def in_one_process(name: str) -> dict[str, Any]:
    _, events = shipped_run(name)
    last = events[-1]
    assert isinstance(last, Summary)
    return last.as_dict()


@pytest.mark.parametrize("backend", ["asyncio", "trio"])
def test_the_museum_with_a_served_navigator_ends_as_in_one_process(tmp_path: Path, backend: str) -> None:
    port = free_port()
    path = remote_scenario(tmp_path, port)
    scenario = load_scenario(path)
    seen: list[str] = []

    async def parent() -> Any:
        with anyio.fail_after(GUARD):
            return await run_scenario(scenario, speed=SPEED, observers=[lambda e: seen.append(e.event)])

    with serving(path, port, SPEED):
        report = anyio.run(parent, backend=backend)
    got, expected = summary_of(report), in_one_process("museum.yaml")
    # The same outcomes (the times of a run at the wall clock's pace may differ a little).
    assert report.summary.outcomes == tuple(
        (g["agent"], g["goal"], g["status"], g.get("reason", "")) for g in expected["goals"]
    )
    assert got["visited"] == expected["visited"]
    assert got["distance"] == pytest.approx(expected["distance"], abs=1e-6)
    assert got["robot"] == expected["robot"]
    # The serving process's agents and robot are in the parent's trace too.
    assert "robot_moving" in seen and seen.count("peer_joined") == 1


def _parent_run(path: Path, speed: float) -> tuple[Any, Lines]:
    proc = htnagent("run", str(path), "--json", "--speed", str(speed))
    assert proc.stdout is not None
    return proc, Lines(proc.stdout)


def _events(lines: list[str]) -> list[dict[str, Any]]:
    return [json.loads(line) for line in lines if line.strip()]


@pytest.mark.parametrize("how", [signal.SIGKILL, signal.SIGSTOP], ids=["killed", "frozen"])
def test_a_lost_serving_process_fails_the_run_with_peer_lost_within_3_s(tmp_path: Path, how: int) -> None:
    port = free_port()
    path = remote_scenario(tmp_path, port)
    with serving(path, port, speed=5) as host:
        parent, out = _parent_run(path, speed=5)
        try:
            out.until('"robot_moving"', timeout=15)
            # Only the configured addresses: the host listens on its endpoint, the parent
            # only connects to it; no UDP (no scouting), no other listener.
            for proto, local, remote, state in inet_sockets(host.pid):
                assert proto == "tcp" and local == f"127.0.0.1:{port}", (proto, local, remote, state)
            for proto, local, remote, state in inet_sockets(parent.pid):
                assert proto == "tcp" and remote == f"127.0.0.1:{port}" and state != "0A", (
                    proto,
                    local,
                    remote,
                )
            lost_at = time.monotonic()
            host.send_signal(how)
            code = parent.wait(timeout=10)
            took = time.monotonic() - lost_at
            events = _events(out.rest(5))
            assert parent.stderr is not None
            err = parent.stderr.read()
        finally:
            stop(parent)
    assert code == 1, err
    assert took < 3.0, f"{took:.2f} s"
    assert events[-1]["event"] == "summary"
    assert any(e["event"] == "peer_lost" and e["agent"] == "navigator" for e in events)
    failed = [e for e in events if e["event"] == "action_finished" and e["result"] == "failure"]
    assert failed and "peer lost" in failed[0]["reason"]
    assert events[-1]["goals"][0]["status"] == "failure"


@pytest.mark.parametrize("how", ["restarted", "thawed"])
def test_a_serving_process_back_after_being_lost_serves_the_next_goal(tmp_path: Path, how: str) -> None:
    # restarted: killed, then started afresh; thawed: frozen past its lease, then let go on
    # (it still holds what it was ordered before: the parent tells it that is dropped).
    port = free_port()
    goals = "  - {agent: guide, task: goto(n1)}\n  - {agent: guide, task: goto(n28), when: {time: 60}}\n"
    path = remote_scenario(tmp_path, port, goals=goals)
    with serving(path, port, speed=20) as host:
        parent, out = _parent_run(path, speed=20)
        try:
            out.until('"robot_moving"', timeout=15)
            host.send_signal(signal.SIGKILL if how == "restarted" else signal.SIGSTOP)
            out.until('"peer_lost"', timeout=5)
            # Back only once the first goal has failed (else it may be served after all).
            out.until('"goal_finished","goal":"goto(n1)"', timeout=5)
            if how == "restarted":
                with serving(path, port, speed=20):
                    code = parent.wait(timeout=20)
            else:
                host.send_signal(signal.SIGCONT)
                code = parent.wait(timeout=20)
            events = _events(out.rest(5))
        finally:
            stop(parent)
    assert code == 1
    summary = events[-1]
    assert [g["status"] for g in summary["goals"]] == ["failure", "success"]
    assert "peer lost" in summary["goals"][0]["reason"]
    peers = [e for e in events if e["event"].startswith("peer_")]
    assert [e["event"] for e in peers] == ["peer_joined", "peer_lost", "peer_joined"], peers
    assert summary["robot"] == {"at": "n28"}


def test_no_serving_process_is_one_line_and_exit_2_after_the_wait(tmp_path: Path) -> None:
    path = remote_scenario(tmp_path, free_port(), peer_wait=1)
    start = time.monotonic()
    proc = htnagent("run", str(path))
    _, err = proc.communicate(timeout=20)
    assert proc.returncode == 2
    assert time.monotonic() - start < 10
    lines = err.strip().splitlines()
    assert len(lines) == 1 and "no process serves agent navigator" in lines[0], err
    assert lines[0].startswith("htnagent: error: ")


def test_serving_on_a_port_in_use_is_one_line_and_exit_2(tmp_path: Path) -> None:
    port = free_port()
    path = remote_scenario(tmp_path, port)
    with serving(path, port, speed=1):
        proc = htnagent("serve", str(path), "--agent", "navigator", "--listen", f"tcp/127.0.0.1:{port}")
        _, err = proc.communicate(timeout=20)
    assert proc.returncode == 2
    assert len(err.strip().splitlines()) == 1 and "cannot open a Zenoh session" in err, err


def test_peer_joined_is_traced_once_per_join(tmp_path: Path) -> None:
    # (Checked through the library, as a user embedding the runtime would see it.)
    port = free_port()
    path = remote_scenario(tmp_path, port, goals="  - {agent: guide, task: goto(n39)}\n")
    scenario = load_scenario(path)
    joined: list[PeerJoined] = []

    def watch(event: object) -> None:
        if isinstance(event, PeerJoined):
            joined.append(event)

    with serving(path, port, speed=50):
        report = anyio.run(functools.partial(run_scenario, scenario, speed=50.0, observers=[watch]))
    assert report.succeeded
    assert [(j.agent, j.side, j.endpoint) for j in joined] == [
        ("navigator", "serving", f"tcp/127.0.0.1:{port}")
    ]


def test_a_serving_process_serves_a_second_parent_after_the_first_is_gone(tmp_path: Path) -> None:
    port = free_port()
    path = remote_scenario(tmp_path, port, goals="  - {agent: guide, task: goto(n39)}\n")
    with serving(path, port, speed=20):
        first, out = _parent_run(path, speed=20)
        try:
            out.until('"robot_moving"', timeout=15)
        finally:
            stop(first)  # killed half way: the serving process drops what it was ordered
        second, out = _parent_run(path, speed=20)
        try:
            code = second.wait(timeout=20)
            events = _events(out.rest(5))
        finally:
            stop(second)
    assert code == 0, events[-3:]
    assert events[-1]["goals"][0]["status"] == "success"


def test_every_item_crosses_the_wire_unchanged() -> None:
    from htnagent.model.terms import parse
    from htnagent.remote.codec import CodecError, Item, RobotStatus, WorldChange, decode, encode
    from htnagent.runtime.events import GoalReceived
    from htnagent.runtime.messages import (
        BeliefUpdate,
        Clear,
        Execute,
        Failure,
        ParentLost,
        Prepare,
        Refused,
        Resume,
        Success,
        Suspend,
        Suspended,
    )
    from htnagent.runtime.progress import Phase, Progress

    a = parse("move(n40,n35,arc59)")
    items: list[Item] = [
        Execute(action=a, seq=1),
        Suspend(action=a, seq=1),
        Resume(action=a, seq=2),
        Clear(action=a),
        Prepare(action=a),
        ParentLost(),
        BeliefUpdate(add=(parse("closed(arc51)"),), delete=(parse("closed(arc3)"),)),
        Success(action=a, seq=1),
        Failure(action=a, seq=1, reason="no", permanent=True),
        Suspended(action=a, seq=1),
        Refused(action=a, seq=1),
        Progress("robot", a, Phase.STARTED, 4.2, 0.5),
        GoalReceived(agent="navigator", t=1.5, goal="goto_node(n1)", emergency=False),
        RobotStatus(robot={"at": "n1"}, visited=("n40", "n1"), distance=3.5),
        WorldChange(arc="arc51", close=True),
    ]
    for item in items:
        assert decode(encode(2.5, item)) == (2.5, item)
    for bad in [
        b"",
        b"[]",
        b'{"t": 1, "type": "message", "body": {"kind": "submit"}}',
        b"\xff",
        b'{"t": true}',
    ]:
        with pytest.raises(CodecError):
            decode(bad)


def test_the_wire_is_plain_json_and_what_json_cannot_say_is_refused_anywhere() -> None:
    from htnagent.model.terms import parse
    from htnagent.remote.codec import CodecError, Item, RobotStatus, encode_batch, receive
    from htnagent.runtime.events import MessageSent
    from htnagent.runtime.messages import Success

    a = parse("move(n40,n35,arc59)")
    items: list[tuple[float, Item]] = [
        (1.5, Success(action=a, seq=3)),
        (1.5, MessageSent(agent="navigator", t=1.5, to="robot", kind="execute", action=str(a))),
        (2.0, RobotStatus(robot={"at": "n35"}, visited=("n40", "n35"), distance=4.123105625617661)),
    ]
    payload = encode_batch(items, "a1b2", 7)
    # Any JSON reader reads it, and what the standard library writes is read back the same:
    # a peer of another version or language speaks the same wire.
    written = json.loads(payload)
    assert written["from"] == "a1b2" and written["n"] == 7 and len(written["items"]) == 3
    again = receive(json.dumps(written).encode())
    assert (again.items, again.sender, again.n) == (tuple(items), "a1b2", 7)
    # NaN and Infinity are not JSON: refused wherever they are, not only in a time.
    body = '{"robot": {"at": "n1"}, "visited": ["n1"], "distance": %s}'
    for number in ("NaN", "Infinity", "-Infinity"):
        bad = '{"t": 1.0, "type": "status", "body": ' + body % number + ', "from": "a1b2", "n": 1}'
        with pytest.raises(CodecError):
            receive(bad.encode())
    # A lone surrogate is not text.
    with pytest.raises(CodecError):
        receive(b'{"t": 1.0, "type": "world", "body": {"arc": "\\ud800", "close": true}, "from": "x"}')


def test_an_order_before_the_parents_token_is_held_and_handled_when_the_token_comes(tmp_path: Path) -> None:
    # Zenoh hands the parent's token and its first order to the event loop from different
    # threads: the order may come first (seen under load).  It is held (not refused, not
    # lost), handled once the token binds that parent, and the join is traced once.
    from htnagent.model.terms import parse
    from htnagent.remote.codec import encode
    from htnagent.remote.link import Keys
    from htnagent.runtime.events import PeerJoined, TraceEvent
    from htnagent.runtime.messages import Prepare
    from htnagent.system.serving import Host
    from htnagent.system.simulation import build_runtime

    scenario = load_scenario(remote_scenario(tmp_path, free_port()))

    async def main() -> tuple[bool, bool, list[str], int]:
        runtime, world = build_runtime(scenario, speed=1.0, first="navigator")
        keys = Keys(scenario.key_space, "navigator")
        host = Host(runtime, world, "navigator", "guide", keys, "tcp/127.0.0.1:7447")
        joined: list[str] = []

        def watch(event: TraceEvent) -> None:
            if isinstance(event, PeerJoined):
                joined.append(event.side)

        runtime.subscribe(watch)
        early = host.gate.admit(encode(0.0, Prepare(action=parse("move_area(area8,area7)")), "p1", 1))
        before = host.parent_up
        host._liveliness(True, "p1")  # the token, late
        host._liveliness(True, "p1")  # and seen again: still one join
        return early is None and not before, host.parent_up, joined, host.gate.admitted

    held, up, joined, admitted = anyio.run(main)
    assert held and up and joined == ["parent"] and admitted == 1
