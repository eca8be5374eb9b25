"""``python -m bench remote``: agents in two processes over Zenoh, on the loopback.

- round trip: an ``execute`` order and its ``success`` answer, one at a time,
  through :mod:`htnagent.remote`'s link, codec and event-loop bridge (the other
  process answers every order at once): median and p99, ms;
- throughput: orders sent without waiting, answered orders per second;
- noticing a lost peer: from SIGKILL, and from SIGSTOP, to the liveliness
  token's loss seen in the event loop, ms;
- the museum run with the navigator served by another process (``serve``),
  against the same run in one process: the summary's goals, visited nodes
  and distance, and the wall time;
- a fleet (``--robots 1,4,8``): this process runs one guide per robot
  (:func:`htnagent.system.fleet.run_fleet`), N ``serve`` processes each run one
  navigator and its simulated robot, every robot the museum scenario (its goal,
  its emergency) in a scenario file of its own (its endpoint, its namespace):
  the wall time until every goal ended, per robot, orders and messages a second
  (paced by the simulated clock at ``SPEED``: not a throughput limit), and
  whether every robot ended with the goals, nodes and distance of the run in one
  process.

Writes ``bench/results/remote.json`` (one object; the fleet's rows under ``fleet``).
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
from htnagent.model.terms import parse
from htnagent.remote.codec import Received, encode, receive
from htnagent.remote.link import Keys, Link
from htnagent.runtime.messages import Execute, Success

RESULTS = Path(__file__).resolve().parent / "results"
REPO = Path(__file__).resolve().parents[1]
ROUND_TRIPS = 5000
BURST = 10_000
TRIALS = 5
SPEED = 40.0
ROBOTS = (1, 4, 8)
"""Serving processes in the fleet measurement (each a Python process with a Zenoh session:
on the two cores measured, more would measure the scheduler)."""
ORDERS = frozenset({"execute", "suspend", "resume", "clear"})


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
        me = link.session_id
        sent = 0

        def answer(got: Received) -> None:
            nonlocal sent
            order = got.item
            assert isinstance(order, Execute)
            sent += 1
            put(encode(got.t, Success(action=order.action, seq=order.seq), me, sent))

        link.on_sample(keys.down, answer, receive)
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

    def arrived(got: Received) -> None:
        result = got.item
        assert isinstance(result, Success)
        answers[result.seq] = time.perf_counter()
        event = waiting.pop(result.seq, None)
        if event is not None:
            event.set()

    def liveliness(up: bool, session: str) -> None:
        if up:
            alive.set()
        else:
            lost_at.append(time.perf_counter())
            lost.set()

    async with Link(connect=[endpoint]) as link:
        link.on_sample(keys.up, arrived, receive)
        link.on_liveliness(keys.host_alive, liveliness)
        put = link.publisher(keys.down)
        me = link.session_id
        link.token(keys.parent_alive)
        with anyio.fail_after(10):
            await alive.wait()
        trips = []
        for seq in range(1, ROUND_TRIPS + 1):
            done = waiting[seq] = anyio.Event()
            start = time.perf_counter()
            put(encode(0.0, Execute(action=action, seq=seq), me, seq))
            await done.wait()
            trips.append((answers[seq] - start) * 1000)
        trips.sort()
        first = ROUND_TRIPS + 1
        last = first + BURST - 1
        all_in = waiting[last] = anyio.Event()
        start = time.perf_counter()
        for seq in range(first, last + 1):
            put(encode(0.0, Execute(action=action, seq=seq), me, seq))
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

    def liveliness(up: bool, session: str) -> None:
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
    from htnagent.system.simulation import run_scenario

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
    same = (local.outcomes, local.visited, local.robot) == (remote.outcomes, remote.visited, remote.robot)
    same = same and abs(local.distance - remote.distance) < 1e-6
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


def _robot_scenario(folder: Path, index: int, port: int) -> Path:
    """Robot ``index`` of a fleet: the museum scenario, its navigator served at the port,
    under a namespace of its own (its keys are its own, whatever the endpoints)."""
    scenarios = REPO / "scenarios"
    text = (scenarios / "museum.yaml").read_text()
    text = text.replace("name: museum guide", f"name: robot {index}, museum guide")
    text = text.replace("map: museum_map.yaml", f"map: {scenarios / 'museum_map.yaml'}")
    text = text.replace("executor: robot}", f'executor: robot, remote: "tcp/127.0.0.1:{port}"}}')
    text += f"namespace: bench/fleet/robot{index}\npeer_wait: 30\n"
    path = folder / f"robot{index}.yaml"
    path.write_text(text)
    return path


def _serve(path: Path, port: int) -> subprocess.Popen[str]:
    return subprocess.Popen(
        [
            *(sys.executable, "-m", "htnagent", "serve", str(path), "--agent", "navigator"),
            *("--listen", f"tcp/127.0.0.1:{port}", "--speed", str(SPEED)),
        ],
        stdout=subprocess.PIPE,
        text=True,
        cwd=REPO,
    )


def _fleet(robots: int) -> dict[str, Any]:
    """One guide per robot here, ``robots`` serving processes: the fleet's figures."""
    from htnagent.runtime.events import MessageSent, PeerJoined, TraceEvent
    from htnagent.runtime.trace import Observer
    from htnagent.scenario import load_scenario
    from htnagent.system.fleet import run_fleet
    from htnagent.system.simulation import run_scenario

    alone = anyio.run(run_scenario, load_scenario(REPO / "scenarios" / "museum.yaml")).summary
    counts = {"orders": 0, "messages": 0}
    joined: list[float] = []

    def count(event: TraceEvent) -> None:
        # The parent's trace holds the serving processes' events too: both levels' messages.
        if isinstance(event, PeerJoined):
            joined.append(time.perf_counter())
        elif isinstance(event, MessageSent):
            counts["messages"] += 1
            counts["orders"] += event.kind in ORDERS

    def observers(index: int) -> list[Observer]:
        return [count]

    with tempfile.TemporaryDirectory() as tmp:
        ports = [_free_port() for _ in range(robots)]
        paths = [_robot_scenario(Path(tmp), i, port) for i, port in enumerate(ports)]
        # All started at once, then waited for: their start-ups overlap.
        hosts = [_serve(path, port) for path, port in zip(paths, ports, strict=True)]
        try:
            for host in hosts:
                assert host.stdout is not None and host.stdout.readline().startswith("serving")
            scenarios = [load_scenario(path) for path in paths]
            start = time.perf_counter()
            report = anyio.run(functools.partial(run_fleet, scenarios, speed=SPEED, observers=observers))
            wall = time.perf_counter() - start
        finally:
            for host in hosts:
                host.kill()
                host.wait()
    summaries = [run.summary for run in report.runs]
    same = [
        (s.outcomes, s.visited, s.robot) == (alone.outcomes, alone.visited, alone.robot)
        and abs(s.distance - alone.distance) < 1e-6
        for s in summaries
    ]
    simulated = max(s.t for s in summaries)
    return {
        "robots": robots,
        "speed": SPEED,
        "wall_s": round(wall, 3),
        "setup_s": round(max(joined) - start, 3),
        "paced_s": round(simulated / SPEED, 3),
        "per_robot_ms": round(wall / robots * 1000, 1),
        "orders_per_s": round(counts["orders"] / wall, 1),
        "messages_per_s": round(counts["messages"] / wall, 1),
        "all_succeeded": report.succeeded,
        "same_as_one_process": all(same),
        "distance_m": sorted({s.distance for s in summaries}),
        "failed": [
            {"robot": i, "goal": g.goal, "reason": g.reason}
            for i, s in enumerate(summaries)
            for g in s.goals
            if g.status != "success"
        ],
    }


def main(robots: tuple[int, ...] = ROBOTS) -> int:
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
    fleet = []
    for n in robots:
        row = _fleet(n)
        print(f"fleet: {row}", file=sys.stderr)
        fleet.append(row)
    out = {
        "machine": machine_line(),
        **link,
        "notice_killed_ms": {"median": round(statistics.median(killed), 1), "max": round(max(killed), 1)},
        "notice_frozen_ms": {"median": round(statistics.median(frozen), 1), "max": round(max(frozen), 1)},
        "trials": TRIALS,
        "museum": museum,
        "fleet": fleet,
    }
    RESULTS.mkdir(exist_ok=True)
    (RESULTS / "remote.json").write_text(json.dumps(out, indent=2) + "\n")
    print(json.dumps(out, indent=2))
    ok = museum["same_goals_visited_distance"] and all(
        r["all_succeeded"] and r["same_as_one_process"] for r in fleet
    )
    return 0 if ok else 1


if __name__ == "__main__":
    if sys.argv[1:2] == ["echo"]:
        anyio.run(_echo, sys.argv[2])
    else:
        raise SystemExit(main())
