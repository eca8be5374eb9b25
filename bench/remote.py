"""``python -m bench remote``: agents in two processes over Zenoh, on the loopback.

- round trip: an ``execute`` order and its ``success`` answer, one at a time,
  through :mod:`htnagent.remote`'s link, codec and event-loop bridge (the other
  process answers every order at once): median and p99, ms;
- throughput: orders sent without waiting, answered orders per second;
- noticing a lost peer: from SIGKILL, and from SIGSTOP, to the liveliness
  token's loss seen in the event loop, ms;
- the museum run with the navigator served by another process (``serve``),
  against the same run in one process: the summary's goals, visited nodes
  and distance, and the wall time.

Writes ``bench/results/remote.json`` (one object).
"""

from __future__ import annotations

import functools
import json
import signal
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path
from typing import Any

import anyio

from bench.machine import machine_line
from htnagent.messages import Execute, Success
from htnagent.remote.codec import decode, encode
from htnagent.remote.link import Keys, Link
from htnagent.terms import parse

RESULTS = Path(__file__).resolve().parent / "results"
REPO = Path(__file__).resolve().parents[1]
ROUND_TRIPS = 5000
BURST = 10_000
TRIALS = 5
SPEED = 40.0


def _free_port() -> int:
    import socket

    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return int(s.getsockname()[1])


# -- the other process: answers every order at once ----------------------------------------------


async def _echo(endpoint: str) -> None:
    keys = Keys("bench", "echo")
    async with Link(listen=[endpoint]) as link:
        put = link.publisher(keys.up)

        def answer(payload: bytes) -> None:
            t, order = decode(payload)
            assert isinstance(order, Execute)
            put(encode(t, Success(action=order.action, seq=order.seq)))

        link.on_sample(keys.down, answer)
        link.token(keys.host_alive)
        print("ready", flush=True)
        await anyio.sleep_forever()


def _start_echo(endpoint: str) -> subprocess.Popen[str]:
    proc = subprocess.Popen(
        [sys.executable, "-m", "bench.remote", "echo", endpoint], stdout=subprocess.PIPE, text=True, cwd=REPO
    )
    assert proc.stdout is not None and proc.stdout.readline().strip() == "ready"
    return proc


# -- this process: the parent's side -----------------------------------------------------------


async def _measure_link(endpoint: str, proc: subprocess.Popen[str]) -> dict[str, Any]:
    keys = Keys("bench", "echo")
    action = parse("move(n40,n35,arc59)")
    answers: dict[int, float] = {}
    waiting: dict[int, anyio.Event] = {}
    alive = anyio.Event()
    lost = anyio.Event()
    lost_at: list[float] = []

    def arrived(payload: bytes) -> None:
        _, result = decode(payload)
        assert isinstance(result, Success)
        answers[result.seq] = time.perf_counter()
        event = waiting.pop(result.seq, None)
        if event is not None:
            event.set()

    def liveliness(up: bool) -> None:
        if up:
            alive.set()
        else:
            lost_at.append(time.perf_counter())
            lost.set()

    async with Link(connect=[endpoint]) as link:
        link.on_sample(keys.up, arrived)
        link.on_liveliness(keys.host_alive, liveliness)
        put = link.publisher(keys.down)
        link.token(keys.parent_alive)
        with anyio.fail_after(10):
            await alive.wait()
        trips = []
        for seq in range(1, ROUND_TRIPS + 1):
            done = waiting[seq] = anyio.Event()
            start = time.perf_counter()
            put(encode(0.0, Execute(action=action, seq=seq)))
            await done.wait()
            trips.append((answers[seq] - start) * 1000)
        trips.sort()
        first = ROUND_TRIPS + 1
        last = first + BURST - 1
        all_in = waiting[last] = anyio.Event()
        start = time.perf_counter()
        for seq in range(first, last + 1):
            put(encode(0.0, Execute(action=action, seq=seq)))
        with anyio.fail_after(60):
            await all_in.wait()
        burst_s = time.perf_counter() - start
    return {
        "round_trip_median_ms": round(statistics.median(trips), 4),
        "round_trip_p99_ms": round(trips[int(len(trips) * 0.99)], 4),
        "round_trips": ROUND_TRIPS,
        "orders_per_s": round(BURST / burst_s),
        "burst": BURST,
    }


async def _notice(endpoint: str, how: signal.Signals) -> float:
    """Milliseconds from sending ``how`` to the echo process to its token's loss seen here."""
    keys = Keys("bench", "echo")
    proc = _start_echo(endpoint)
    alive, lost = anyio.Event(), anyio.Event()
    lost_at: list[float] = []

    def liveliness(up: bool) -> None:
        if up:
            alive.set()
        else:
            lost_at.append(time.perf_counter())
            lost.set()

    try:
        async with Link(connect=[endpoint]) as link:
            link.on_liveliness(keys.host_alive, liveliness)
            with anyio.fail_after(10):
                await alive.wait()
            await anyio.sleep(0.2)
            start = time.perf_counter()
            proc.send_signal(how)
            with anyio.fail_after(10):
                await lost.wait()
            return (lost_at[0] - start) * 1000
    finally:
        proc.kill()
        proc.wait()


def _museum() -> dict[str, Any]:
    from htnagent.scenario import load_scenario
    from htnagent.simulation import run_scenario

    scenarios = REPO / "scenarios"
    one = load_scenario(scenarios / "museum.yaml")
    start = time.perf_counter()
    local = anyio.run(run_scenario, one).summary
    local_s = time.perf_counter() - start
    start = time.perf_counter()
    paced = anyio.run(functools.partial(run_scenario, one, speed=SPEED)).summary
    paced_s = time.perf_counter() - start
    port = _free_port()
    with tempfile.TemporaryDirectory() as tmp:
        text = (scenarios / "museum.yaml").read_text()
        text = text.replace("map: museum_map.yaml", f"map: {scenarios / 'museum_map.yaml'}")
        text = text.replace("executor: robot}", f'executor: robot, remote: "tcp/127.0.0.1:{port}"}}')
        path = Path(tmp) / "museum_remote.yaml"
        path.write_text(text)
        host = subprocess.Popen(
            [
                *(sys.executable, "-m", "htnagent", "serve", str(path), "--agent", "navigator"),
                *("--listen", f"tcp/127.0.0.1:{port}", "--speed", str(SPEED)),
            ],
            stdout=subprocess.PIPE,
            text=True,
            cwd=REPO,
        )
        try:
            assert host.stdout is not None and host.stdout.readline().startswith("serving")
            two = load_scenario(path)
            start = time.perf_counter()
            remote = anyio.run(functools.partial(run_scenario, two, speed=SPEED)).summary
            remote_s = time.perf_counter() - start
        finally:
            host.kill()
            host.wait()
    same = (local.goals, local.visited, local.robot) == (remote.goals, remote.visited, remote.robot) and abs(
        local.distance - remote.distance
    ) < 1e-6
    return {
        "speed": SPEED,
        "same_goals_visited_distance": same,
        "distance_one_process": local.distance,
        "distance_two_processes": remote.distance,
        "wall_s_one_process_virtual": round(local_s, 3),
        "wall_s_one_process_paced": round(paced_s, 3),
        "wall_s_two_processes_paced": round(remote_s, 3),
        "simulated_s": remote.t,
        "paced_same": paced.distance == local.distance,
    }


def main() -> int:
    endpoint = f"tcp/127.0.0.1:{_free_port()}"
    proc = _start_echo(endpoint)
    try:
        link = anyio.run(_measure_link, endpoint, proc)
    finally:
        proc.kill()
        proc.wait()
    print(f"link: {link}", file=sys.stderr)
    killed = [anyio.run(_notice, f"tcp/127.0.0.1:{_free_port()}", signal.SIGKILL) for _ in range(TRIALS)]
    frozen = [anyio.run(_notice, f"tcp/127.0.0.1:{_free_port()}", signal.SIGSTOP) for _ in range(TRIALS)]
    print(f"killed: {killed}\nfrozen: {frozen}", file=sys.stderr)
    museum = _museum()
    print(f"museum: {museum}", file=sys.stderr)
    out = {
        "machine": machine_line(),
        **link,
        "notice_killed_ms": {"median": round(statistics.median(killed), 1), "max": round(max(killed), 1)},
        "notice_frozen_ms": {"median": round(statistics.median(frozen), 1), "max": round(max(frozen), 1)},
        "trials": TRIALS,
        "museum": museum,
    }
    RESULTS.mkdir(exist_ok=True)
    (RESULTS / "remote.json").write_text(json.dumps(out, indent=2) + "\n")
    print(json.dumps(out, indent=2))
    return 0


if __name__ == "__main__":
    if sys.argv[1:2] == ["echo"]:
        anyio.run(_echo, sys.argv[2])
    else:
        raise SystemExit(main())
