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
- security (``security`` rows): a ``serve`` process over mutual TLS (test
  certificates from :mod:`htnagent.remote.certs`) with its real parent here,
  and intruders: a client without a certificate, with another root's, plain TCP
  to the TLS port, a peer with a valid certificate that is not the parent
  (orders of its own, replays of the parent's, out-of-order, wrongly typed,
  malformed and oversized payloads), and that peer flooding 100,000 messages;
  per case the orders sent, executed (the served navigator receiving a goal:
  the serving process's trace, relayed to its parent) and refused (by the link,
  below us, or by the gate: ``peer_refused``), and for the flood the serving
  process's resident memory before and after;
- a fleet (``--robots 1,10,100``): this process runs one guide per robot
  (:func:`htnagent.system.fleet.run_fleet`, one Zenoh session for all), and
  ``serve`` processes of up to ``PER_PROCESS`` robots each run their navigators
  and simulated robots (one session each), over mutual TLS; every robot is the
  museum scenario (its goal, its emergency) in a scenario file of its own (its
  endpoint, its namespace): the wall time until every goal ended, the sessions
  open (this process's and the serving processes'), per robot, orders and
  messages a second (paced by the simulated clock at ``SPEED``: not a throughput
  limit), and whether every robot ended with the goals, nodes and distance of
  the run in one process.

Writes ``bench/results/remote.json`` (one object; the fleet's rows under ``fleet``,
the intruders' under ``security``), after each part (a stopped run keeps what it
measured).
"""

from __future__ import annotations

import functools
import json
import os
import re
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
ROBOTS = (1, 10, 100)
"""Robots in the fleet measurement."""
PER_PROCESS = 10
"""Robots one ``serve`` process runs (100 robots: 10 processes, each one Zenoh session)."""
FLOOD = 100_000
"""Messages of the flood from a peer on the link that is not the parent."""
INTRUDER_ORDERS = 50
"""Orders each intruder sends."""
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
            for t, order in got.items:
                assert isinstance(order, Execute)
                sent += 1
                put(encode(t, Success(action=order.action, seq=order.seq), me, sent))

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
        for _, result in got.items:
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


def _robot_scenario(folder: Path, index: int, port: int, certs: Path | None = None) -> Path:
    """Robot ``index`` of a fleet: the museum scenario, its navigator served at the port
    (over mutual TLS with ``certs``), under a namespace of its own (its keys are its own,
    whatever the endpoints)."""
    scenarios = REPO / "scenarios"
    text = (scenarios / "museum.yaml").read_text()
    text = text.replace("name: museum guide", f"name: robot {index}, museum guide")
    text = text.replace("map: museum_map.yaml", f"map: {scenarios / 'museum_map.yaml'}")
    if certs is None:
        remote = f'"tcp/127.0.0.1:{port}"'
    else:
        remote = (
            f'{{endpoint: "tls/127.0.0.1:{port}", root_ca: {certs}/root.pem, '
            f"certificate: {certs}/parent.pem, key: {certs}/parent.key}}"
        )
    text = text.replace("executor: robot}", f"executor: robot, remote: {remote}}}")
    text += f"namespace: bench/fleet/robot{index}\npeer_wait: 30\n"
    path = folder / f"robot{index}.yaml"
    path.write_text(text)
    return path


def _serve(
    paths: list[Path], port: int, certs: Path | None = None, allow: tuple[str, ...] = ()
) -> subprocess.Popen[str]:
    """A ``serve`` process for the robots of ``paths`` at the port (mutual TLS with ``certs``;
    with ``allow``, Zenoh's access control lets only those certificate names through)."""
    if certs is None:
        secured: tuple[str, ...] = ("--listen", f"tcp/127.0.0.1:{port}")
    else:
        secured = (
            *("--listen", f"tls/127.0.0.1:{port}", "--root-ca", str(certs / "root.pem")),
            *("--certificate", str(certs / "serve.pem"), "--key", str(certs / "serve.key")),
            *(a for name in allow for a in ("--allow", name)),
        )
    return subprocess.Popen(
        [
            *(sys.executable, "-m", "htnagent", "serve", *map(str, paths), "--agent", "navigator"),
            *secured,
            *("--speed", str(SPEED)),
        ],
        stdout=subprocess.PIPE,
        text=True,
        cwd=REPO,
    )


def _sessions_of(ready_line: str) -> int:
    """The Zenoh sessions a ``serve`` process said it has open (its ready line)."""
    found = re.search(r"(\d+) Zenoh sessions?\)", ready_line)
    assert found is not None, ready_line
    return int(found.group(1))


def _fleet(robots: int, certs: Path) -> dict[str, Any]:
    """One guide per robot here, ``serve`` processes of up to ``PER_PROCESS`` robots: the figures."""
    from htnagent.remote.link import sessions_open
    from htnagent.runtime.events import MessageSent, PeerJoined, TraceEvent
    from htnagent.runtime.trace import Observer
    from htnagent.scenario import load_scenario
    from htnagent.system.fleet import run_fleet
    from htnagent.system.simulation import run_scenario

    alone = anyio.run(run_scenario, load_scenario(REPO / "scenarios" / "museum.yaml")).summary
    counts = {"orders": 0, "messages": 0}
    joined: list[float] = []
    sessions_here: list[int] = []

    def count(event: TraceEvent) -> None:
        # The parent's trace holds the serving processes' events too: both levels' messages.
        if isinstance(event, PeerJoined):
            joined.append(time.perf_counter())
            sessions_here.append(sessions_open())
        elif isinstance(event, MessageSent):
            counts["messages"] += 1
            counts["orders"] += event.kind in ORDERS

    def observers(index: int) -> list[Observer]:
        return [count]

    processes = max(1, -(-robots // PER_PROCESS))
    with tempfile.TemporaryDirectory() as tmp:
        ports = [_free_port() for _ in range(processes)]
        paths = [_robot_scenario(Path(tmp), i, ports[i // PER_PROCESS], certs) for i in range(robots)]
        groups = [paths[k * PER_PROCESS : (k + 1) * PER_PROCESS] for k in range(processes)]
        # All started at once, then waited for: their start-ups overlap.
        hosts = [_serve(group, port, certs) for group, port in zip(groups, ports, strict=True)]
        try:
            served_sessions = 0
            for host in hosts:
                assert host.stdout is not None
                line = host.stdout.readline()
                assert line.startswith("serving"), line
                served_sessions += _sessions_of(line)
            scenarios = [load_scenario(path) for path in paths]
            served_cpu = sum(_cpu_s(host.pid) for host in hosts)
            load = os.getloadavg()[0]  # others' work on a shared machine slows the CPU seconds too
            start, cpu = time.perf_counter(), time.process_time()
            # The serving side's events this counts (messages) besides the summary's own: the
            # robots' actions and motions are not sent to the parent (run_fleet's ``relayed``).
            relayed = {"message"}
            run = functools.partial(run_fleet, scenarios, speed=SPEED, observers=observers, relayed=relayed)
            report = anyio.run(run)
            wall, cpu = time.perf_counter() - start, time.process_time() - cpu
            served_cpu = sum(_cpu_s(host.pid) for host in hosts) - served_cpu
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
        "processes": processes,
        "sessions": max(sessions_here, default=0) + served_sessions,
        "sessions_parent": max(sessions_here, default=0),
        "success": report.succeeded and all(same),
        "wall_s": round(wall, 3),
        "speed": SPEED,
        "tls": "mutual",
        "relayed": sorted(relayed),
        "setup_s": round(max(joined) - start, 3),
        # CPU seconds during the run: this process (its guides, the relayed traces, Zenoh's
        # threads) and the serving processes together; on 2 cores, wall >= their sum / 2.
        "cpu_s_parent": round(cpu, 3),
        "cpu_s_serving": round(served_cpu, 3),
        "cpu_ms_per_robot": round((cpu + served_cpu) / robots * 1000, 1),
        "load": round(load, 2),
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


# -- intruders against a serving process over mutual TLS ------------------------------------------


def _cpu_s(pid: int) -> float:
    """CPU seconds (user and system) process ``pid`` has used so far."""
    fields = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()
    return (int(fields[11]) + int(fields[12])) / os.sysconf("SC_CLK_TCK")


def _rss_mb(pid: int) -> float:
    for line in Path(f"/proc/{pid}/status").read_text().splitlines():
        if line.startswith("VmRSS:"):
            return round(int(line.split()[1]) / 1024, 1)
    raise AssertionError(f"no VmRSS for process {pid}")


class _Watch:
    """The real parent here: bound to the serving process, it hears the serving process's
    trace (relayed up): goals the navigator received, payloads refused."""

    def __init__(self) -> None:
        self.executed = 0
        self.refused = 0
        self.events = 0

    def up(self, got: Any) -> None:
        from htnagent.runtime.events import GoalReceived, PeerRefused

        for _, item in got.items:
            self.events += 1
            if isinstance(item, GoalReceived) and item.agent == "navigator":
                self.executed += 1
            elif isinstance(item, PeerRefused):
                self.refused += item.count


async def _security(
    certs: Path, other: Path, done: list[dict[str, Any]], save: Any, allow: tuple[str, ...] = ()
) -> None:
    """The intruder cases against one ``serve`` process; with ``allow`` (Zenoh's access
    control for the parent's certificate name), only the forger holding a certificate of
    the fleet's root."""
    import zenoh

    from htnagent.remote.codec import encode as encode_item
    from htnagent.remote.link import Security, zenoh_config
    from htnagent.runtime.messages import Prepare

    action = parse("move_area(area8,area7)")
    port = _free_port()
    endpoint = f"tls/127.0.0.1:{port}"
    root = str(certs / "root.pem")
    with tempfile.TemporaryDirectory() as tmp:
        path = _robot_scenario(Path(tmp), 0, port, certs)
        host = _serve([path], port, certs, allow)
        try:
            assert host.stdout is not None and host.stdout.readline().startswith("serving")
            keys = Keys("bench/fleet/robot0", "navigator")
            parent = Security(
                root_ca=root,
                certificate=str(certs / "parent.pem"),
                key=str(certs / "parent.key"),
                mutual=True,
            )
            watch = _Watch()
            async with Link(connect=[endpoint], security=parent) as link:
                alive = anyio.Event()
                link.on_sample(keys.up, watch.up, receive)
                link.on_liveliness(keys.host_alive, lambda up, _: alive.set() if up else None)
                link.token(keys.parent_alive)
                with anyio.fail_after(10):
                    await alive.wait()
                parent_id = link.session_id
                # The parent's own payloads first (harmless: a plan prepared, nothing executed),
                # numbered 1..100: a replay of its numbers is then refused.
                put = link.publisher(keys.down)
                for n in range(1, 101):
                    put(encode(0.0, Prepare(action=action), parent_id, n))

                async def case(name: str, security: Security | None, via: str, payloads: Any) -> None:
                    before = (watch.executed, watch.refused)
                    rss_before = _rss_mb(host.pid)
                    config = zenoh_config(connect=[via], security=security)
                    session = await anyio.to_thread.run_sync(zenoh.open, config)
                    try:
                        await anyio.sleep(0.6)  # connected, if it can be
                        # Reached: it sees the serving process's token (TLS refused it: no
                        # peer at all; access control: connected, and nothing comes through).
                        replies = await anyio.to_thread.run_sync(
                            lambda: list(session.liveliness().get(f"{keys.host_alive}/*", timeout=0.3))
                        )
                        reached = any(r.ok is not None for r in replies)
                        me = str(session.info.zid())
                        sent = 0
                        started = time.perf_counter()
                        for payload in payloads(me):
                            # Blocking, as our own links put: every message arrives (the
                            # default, drop, would let Zenoh shed some of the flood itself).
                            session.put(keys.down, payload, congestion_control=zenoh.CongestionControl.BLOCK)
                            sent += 1
                        put_s = time.perf_counter() - started
                        # Refusals are reported once a second: wait until all are in (or 60 s).
                        deadline = time.monotonic() + 60
                        while reached and watch.refused - before[1] < sent and time.monotonic() < deadline:  # noqa: ASYNC110 (counted on Zenoh's thread)
                            await anyio.sleep(0.25)
                        await anyio.sleep(1.2)
                    finally:
                        await anyio.to_thread.run_sync(session.close)
                    executed = watch.executed - before[0]
                    refused = sent if not reached else watch.refused - before[1]
                    row: dict[str, Any] = {
                        "case": name,
                        "orders_sent": sent,
                        "orders_executed": executed,
                        "refused": refused,
                        "refused_by": "link" if not reached else "gate",
                        "reached_the_serving_process": reached,
                    }
                    if sent >= FLOOD:
                        row |= {
                            "rss_before_mb": rss_before,
                            "rss_after_mb": _rss_mb(host.pid),
                            "growth_mb": round(_rss_mb(host.pid) - rss_before, 1),
                            "put_s": round(put_s, 3),
                        }
                    print(f"security: {row}", file=sys.stderr)
                    done.append(row)
                    save()

                def orders(count: int, forged: str | None = None, first: int = 1) -> Any:
                    def make(me: str) -> Any:
                        sender = forged or me
                        return (
                            encode_item(0.0, Execute(action=action, seq=first + k), sender, first + k)
                            for k in range(count)
                        )

                    return make

                on_link = Security(
                    root_ca=root,
                    certificate=str(certs / "intruder.pem"),
                    key=str(certs / "intruder.key"),
                    mutual=True,
                )
                theirs = Security(
                    root_ca=root,
                    certificate=str(other / "parent.pem"),
                    key=str(other / "parent.key"),
                    mutual=True,
                )
                tcp = f"tcp/127.0.0.1:{port}"
                if allow:
                    await case(
                        f"forging the parent's id with a certificate of the root, --allow {allow[0]}",
                        on_link,
                        endpoint,
                        orders(INTRUDER_ORDERS, forged=parent_id, first=1000),
                    )
                    return
                await case(
                    "no certificate", Security(root_ca=root, mutual=True), endpoint, orders(INTRUDER_ORDERS)
                )
                await case("another root's certificate", theirs, endpoint, orders(INTRUDER_ORDERS))
                await case("plain tcp to the tls port", None, tcp, orders(INTRUDER_ORDERS))
                await case("a peer on the link, not the parent", on_link, endpoint, orders(INTRUDER_ORDERS))
                await case(
                    "replayed: the parent's session id, old numbers",
                    on_link,
                    endpoint,
                    orders(INTRUDER_ORDERS, forged=parent_id, first=1),
                )
                await case(
                    "wrongly typed: results sent down",
                    on_link,
                    endpoint,
                    lambda me: (encode_item(0.0, Success(action=action, seq=k), me, k) for k in range(1, 51)),
                )
                await case(
                    "malformed and oversized",
                    on_link,
                    endpoint,
                    lambda me: [b"{not json", b"[]", b"\xff" * 10, b"x" * (1024 * 1024 + 1)] * 10,
                )
                await case(
                    f"a flood of {FLOOD:,} messages",
                    on_link,
                    endpoint,
                    lambda me: (
                        encode_item(0.0, Execute(action=action, seq=k), me, k) for k in range(1, FLOOD + 1)
                    ),
                )
        finally:
            host.kill()
            host.wait()


def main(robots: tuple[int, ...] = ROBOTS) -> int:
    from htnagent.remote.certs import make_certificates

    out: dict[str, Any] = {"machine": machine_line()}

    def save() -> None:
        RESULTS.mkdir(exist_ok=True)
        (RESULTS / "remote.json").write_text(json.dumps(out, indent=2) + "\n")

    endpoint = f"tcp/127.0.0.1:{_free_port()}"
    proc = _start_echo(endpoint)
    try:
        link = anyio.run(_measure_link, endpoint, proc)
    finally:
        proc.kill()
        proc.wait()
    print(f"link: {link}", file=sys.stderr)
    out |= link
    killed = [anyio.run(_notice, f"tcp/127.0.0.1:{_free_port()}", signal.SIGKILL) for _ in range(TRIALS)]
    frozen = [anyio.run(_notice, f"tcp/127.0.0.1:{_free_port()}", signal.SIGSTOP) for _ in range(TRIALS)]
    print(f"killed: {killed}\nfrozen: {frozen}", file=sys.stderr)
    out["notice_killed_ms"] = {"median": round(statistics.median(killed), 1), "max": round(max(killed), 1)}
    out["notice_frozen_ms"] = {"median": round(statistics.median(frozen), 1), "max": round(max(frozen), 1)}
    out["trials"] = TRIALS
    museum = _museum()
    print(f"museum: {museum}", file=sys.stderr)
    out["museum"] = museum
    save()
    with tempfile.TemporaryDirectory() as tmp:
        certs, other = Path(tmp) / "ours", Path(tmp) / "theirs"
        make_certificates(certs, peers=("serve", "parent", "intruder"))
        make_certificates(other)
        security: list[dict[str, Any]] = []
        out["security"] = security
        anyio.run(_security, certs, other, security, save)
        anyio.run(functools.partial(_security, certs, other, security, save, allow=("parent",)))
        fleet: list[dict[str, Any]] = []
        out["fleet"] = fleet
        for n in robots:
            row = _fleet(n, certs)
            print(f"fleet: {row}", file=sys.stderr)
            fleet.append(row)
            save()
    by_robots = {r["robots"]: r["wall_s"] for r in fleet}
    if 10 in by_robots and 100 in by_robots:
        out["fleet_100_over_10"] = round(by_robots[100] / by_robots[10], 3)
    save()
    print(json.dumps(out, indent=2))
    ok = museum["same_goals_visited_distance"] and all(r["success"] for r in fleet)
    ok = ok and all(r["orders_executed"] == 0 for r in security)
    ok = ok and all(r.get("growth_mb", 0) <= 50 for r in security)
    return 0 if ok else 1


if __name__ == "__main__":
    if sys.argv[1:2] == ["echo"]:
        anyio.run(_echo, sys.argv[2])
    else:
        raise SystemExit(main())
