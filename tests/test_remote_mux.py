"""A session's robots' payloads put together (one put per peer session and round), split
back on the other side, each through the gate of its own link.

:class:`htnagent.remote.link.Mux` changes how many Zenoh puts carry the payloads, never
who may speak: a part is one robot's numbered payload, admitted or refused by its
link's gate exactly as a put on its key would be; a put that does not parse is dropped
whole.  Skipped without the ``zenoh`` extra.
"""

from __future__ import annotations

import functools
import struct
import threading
from collections.abc import Callable, Iterator
from pathlib import Path

import anyio
import pytest

pytest.importorskip("zenoh", reason="the zenoh extra is not installed")

import zenoh

from htnagent.limits import MAX_PAYLOAD_BYTES
from htnagent.model.terms import parse
from htnagent.remote.codec import Received, encode
from htnagent.remote.gate import Gate
from htnagent.remote.link import MUX_PARTS, Link, Mux, zenoh_config
from htnagent.runtime.events import PeerJoined, Summary, TraceEvent
from htnagent.runtime.messages import Execute, Success
from htnagent.runtime.trace import Observer
from htnagent.scenario import load_scenario
from htnagent.system.fleet import FleetReport, run_fleet
from htnagent.system.serving import serve
from tests.remote_support import free_port, remote_scenario
from tests.support import shipped_run

ACTION = parse("move(n1,n2)")
BIG = MAX_PAYLOAD_BYTES + 128 * 1024


@pytest.fixture
def mux() -> Iterator[Mux]:
    """A mux on a session of its own that listens and connects nowhere."""
    session = zenoh.open(zenoh_config())
    try:
        yield Mux(session)
    finally:
        session.close()  # type: ignore[no-untyped-call]


def test_a_put_splits_back_into_its_parts_in_order() -> None:
    parts = [(b"htnagent/a/navigator/up", b"one"), (b"htnagent/b/navigator/up", b""), (b"k", b"three" * 100)]
    got = Mux.split(Mux.pack(parts))
    assert got is not None
    assert [(key, bytes(payload)) for key, payload in got] == parts


@pytest.mark.parametrize(
    "data",
    [
        b"",
        b"htn1",  # no part at all
        b"htn2" + struct.pack("<HI", 1, 1) + b"kv",  # another wire form
        b"htn1" + struct.pack("<H", 1),  # a part's lengths cut short
        b"htn1" + struct.pack("<HI", 1, 10) + b"k" + b"short",  # a payload cut short
        b"htn1" + struct.pack("<HI", 1, 1) + b"kv" + b"x",  # trailing bytes
        b"htn1" + (struct.pack("<HI", 1, 0) + b"k") * (MUX_PARTS + 1),  # too many parts
        b"htn1"
        + struct.pack("<HI", 1, MAX_PAYLOAD_BYTES + 128 * 1024)
        + b"k"
        + b"x" * (MAX_PAYLOAD_BYTES + 128 * 1024),
    ],
    ids=[
        "empty",
        "no parts",
        "wrong magic",
        "header cut",
        "payload cut",
        "trailing",
        "too many",
        "oversized",
    ],
)
def test_a_put_that_does_not_parse_is_dropped_whole(mux: Mux, data: bytes) -> None:
    assert Mux.split(data) is None
    heard: list[bytes] = []
    mux.route("k", lambda payload: heard.append(bytes(payload)))
    mux.deliver(data)
    assert heard == [] and mux.refused == 1


def test_each_part_goes_through_the_gate_of_its_key_and_no_other(mux: Mux) -> None:
    # Expect: robot a's gate admits its parent's order and refuses a forged one; robot b
    # hears nothing of a's; a part for a key nobody here listens on is dropped.
    gates = {name: Gate(lambda item: isinstance(item, Execute), "orders go down") for name in "ab"}
    heard: dict[str, list[Received]] = {"a": [], "b": []}
    for name, gate in gates.items():
        gate.bind("parent")

        def admitted(payload: memoryview, gate: Gate = gate, name: str = name) -> None:
            got = gate.admit(payload)
            if got is not None:
                heard[name].append(got)

        mux.route(f"htnagent/{name}/navigator/down", admitted)
    order = encode(0.0, Execute(action=ACTION, seq=1), "parent", 1)
    forged = encode(0.0, Execute(action=ACTION, seq=2), "intruder", 2)
    wrong = encode(0.0, Success(action=ACTION, seq=1), "parent", 3)  # a result never goes down
    mux.deliver(
        Mux.pack(
            [
                (b"htnagent/a/navigator/down", order),
                (b"htnagent/a/navigator/down", forged),
                (b"htnagent/a/navigator/down", wrong),
                (b"htnagent/c/navigator/down", order),
            ]
        )
    )
    assert [got.n for got in heard["a"]] == [1] and heard["b"] == []
    assert gates["a"].refused == 2 and gates["b"].refused == 0
    assert mux.refused == 1  # the part for robot c, whom nobody here serves


def test_a_put_of_parts_handed_to_a_keys_subscriber_goes_to_the_gates_as_parts() -> None:
    # Zenoh 1.10 now and then hands the first put of a serving process thawed after a freeze
    # -- a Mux put, made on LINKS/<parent's session> -- to the subscriber of a robot's key.
    # Expect: its parts reach their links' gates, admitted as if the put had come the right
    # way; nothing refused (it was traced as a malformed payload, peer_refused).
    endpoint = f"tcp/127.0.0.1:{free_port()}"
    keys = ["htnagent/t/a/navigator/up", "htnagent/t/b/navigator/up"]
    gates = {key: Gate(lambda item: isinstance(item, Success), "results go up") for key in keys}
    heard: dict[str, list[int]] = {key: [] for key in keys}
    blob = Mux.pack([(key.encode(), encode(0.0, Success(action=ACTION, seq=1), "host", 1)) for key in keys])

    async def main() -> None:
        async with Link(listen=[endpoint]) as link:
            both = anyio.Event()
            for key, gate in gates.items():
                gate.bind("host")

                def handler(got: Received, key: str = key) -> None:
                    heard[key].append(got.n)
                    if all(heard.values()):
                        both.set()

                link.on_sample(key, handler, gate.admit)
            link.token("htnagent/t/alive/host")  # last, as a serving process does
            peer = await anyio.to_thread.run_sync(zenoh.open, zenoh_config(connect=[endpoint]))
            try:
                # The token seen: the subscribers declared before it are known to the peer.
                seen = threading.Event()
                watch = peer.liveliness().declare_subscriber(
                    "htnagent/t/alive/host/*", lambda sample: seen.set(), history=True
                )
                assert await anyio.to_thread.run_sync(seen.wait, 10)
                watch.undeclare()  # type: ignore[no-untyped-call]
                peer.put(keys[0], blob)  # the put of parts, on robot a's key
                with anyio.fail_after(10):
                    await both.wait()
            finally:
                await anyio.to_thread.run_sync(peer.close)

    anyio.run(main)
    assert heard == {keys[0]: [1], keys[1]: [1]}
    assert [gate.refused for gate in gates.values()] == [0, 0]


def test_a_round_of_one_robot_after_another_goes_as_one_put_per_peer(mux: Mux) -> None:
    puts: list[bytes] = []
    mux._publishers["peer"] = type("P", (), {"put": staticmethod(puts.append)})()
    flushes: list[object] = []
    for name in "abc":
        mux.send("peer", f"htnagent/{name}/navigator/up".encode(), name.encode(), flushes.append)
    assert puts == [] and len(flushes) == 1  # gathered until the round ends
    mux.flush()
    assert len(puts) == 1
    got = Mux.split(puts[0])
    assert got is not None and [bytes(p) for _, p in got] == [b"a", b"b", b"c"]


@pytest.mark.parametrize("backend", ["asyncio", "trio"])
def test_a_fleets_robots_served_by_one_process_share_its_puts(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, backend: str
) -> None:
    # Two robots, one serving process (in this test's event loop), one parent fleet: the
    # payloads of a round go together, and each robot ends as the museum does alone.
    port = free_port()
    endpoint = f"tcp/127.0.0.1:{port}"
    scenarios = [load_scenario(remote_scenario(tmp_path, port, robot=f"robot{i}")) for i in range(2)]
    parts: list[int] = []
    pack = Mux.pack

    def counted(put: list[tuple[bytes, bytes]]) -> bytes:
        parts.append(len(put))
        return pack(put)

    monkeypatch.setattr(Mux, "pack", staticmethod(counted))
    declared: list[str] = []
    publisher = Link.publisher

    def declaring(link: Link, key: str) -> Callable[[bytes], None]:
        declared.append(key)
        return publisher(link, key)

    monkeypatch.setattr(Link, "publisher", declaring)
    joined: list[TraceEvent] = []

    def observers(index: int) -> list[Observer]:
        return [lambda e: joined.append(e) if isinstance(e, PeerJoined) else None]

    async def main() -> FleetReport:
        async with anyio.create_task_group() as tg:
            ready = anyio.Event()
            tg.start_soon(
                functools.partial(serve, scenarios, "navigator", endpoint, speed=200, ready=ready.set)
            )
            with anyio.fail_after(10):
                await ready.wait()
                report = await run_fleet(scenarios, speed=200, observers=observers)
            tg.cancel_scope.cancel()
        return report

    report = anyio.run(main, backend=backend)
    assert report.succeeded
    _, events = shipped_run("museum.yaml")
    expected = events[-1]
    assert isinstance(expected, Summary)
    for run in report.runs:
        assert run.summary.outcomes == expected.outcomes
        assert run.summary.visited == expected.visited
    assert len(joined) == 2
    assert max(parts) == 2 and sum(parts) > len(parts)  # both robots' payloads in some puts
    # Everything went through the mux, to the peer bound: no robot's key needed a publisher
    # of its own (each one a declaration sent to every peer session).
    assert declared == []
