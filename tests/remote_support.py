"""What the tests of agents in other processes share: free ports, scenarios with a remote
agent, serving processes, their sockets."""

from __future__ import annotations

import os
import queue
import re
import signal
import socket
import subprocess
import sys
import threading
import time
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import IO

REPO = Path(__file__).resolve().parents[1]
SCENARIOS = REPO / "scenarios"


def free_port() -> int:
    """A TCP port of the loopback nobody listens on (now)."""
    with socket.socket(socket.AF_INET, socket.SOCK_STREAM) as s:
        s.bind(("127.0.0.1", 0))
        return int(s.getsockname()[1])


def remote_scenario(
    tmp: Path,
    port: int,
    *,
    base: str = "museum.yaml",
    goals: str | None = None,
    peer_wait: float = 5,
    robot: str | None = None,
) -> Path:
    """A copy of a shipped scenario whose navigator is served at ``tcp/127.0.0.1:PORT``.

    ``robot``: one robot of a fleet, with a file and a namespace of its own."""
    text = (SCENARIOS / base).read_text()
    text = text.replace("map: museum_map.yaml", f"map: {SCENARIOS / 'museum_map.yaml'}")
    text, n = re.subn(
        r"executor: robot\}", f'executor: robot, remote: "tcp/127.0.0.1:{port}"}}', text, count=1
    )
    assert n == 1, "the scenario's last agent is not written {name: ..., executor: robot}"
    if goals is not None:
        text = text[: text.index("\ngoals:")] + "\ngoals:\n" + goals
    namespace = f"test/{tmp.name}" if robot is None else f"test/{tmp.name}/{robot}"
    text += f"\npeer_wait: {peer_wait}\nnamespace: {namespace}\n"
    path = tmp / (f"remote_{base}" if robot is None else f"remote_{robot}_{base}")
    path.write_text(text)
    return path


class Lines:
    """A process's output lines, read on a thread, waited for with a time limit."""

    def __init__(self, stream: IO[str]) -> None:
        self.lines: list[str] = []
        self._queue: queue.Queue[str | None] = queue.Queue()
        self._thread = threading.Thread(target=self._read, args=(stream,), daemon=True)
        self._thread.start()

    def _read(self, stream: IO[str]) -> None:
        for line in stream:
            self._queue.put(line)
        self._queue.put(None)

    def until(self, pattern: str, timeout: float) -> str:
        """The first new line holding ``pattern``; AssertionError after ``timeout`` seconds."""
        deadline = time.monotonic() + timeout
        while True:
            left = deadline - time.monotonic()
            try:
                line = self._queue.get(timeout=max(left, 0.001))
            except queue.Empty:
                raise AssertionError(
                    f"no line with {pattern!r} within {timeout} s: {self.lines[-5:]}"
                ) from None
            if line is None:
                raise AssertionError(f"the output ended without {pattern!r}: {self.lines[-5:]}")
            self.lines.append(line)
            if pattern in line:
                return line

    def rest(self, timeout: float) -> list[str]:
        """Every line up to the end of the output."""
        self._thread.join(timeout)
        while True:
            try:
                line = self._queue.get_nowait()
            except queue.Empty:
                return self.lines
            if line is not None:
                self.lines.append(line)


def htnagent(*args: str) -> subprocess.Popen[str]:
    """``python -m htnagent ARGS`` in a process of its own, stdout and stderr piped."""
    return subprocess.Popen(
        [sys.executable, "-m", "htnagent", *args],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        cwd=REPO,
    )


@contextmanager
def serving(scenario: Path, port: int, speed: float) -> Iterator[subprocess.Popen[str]]:
    """A process serving the navigator of ``scenario`` at the port, ready; killed at the end."""
    with serving_all([(scenario, port)], speed) as procs:
        yield procs[0]


@contextmanager
def serving_all(robots: list[tuple[Path, int]], speed: float) -> Iterator[list[subprocess.Popen[str]]]:
    """A process per ``(scenario, port)`` serving its navigator, all ready; killed at the end.

    They are all started before any is waited for: their start-ups overlap."""
    procs: list[subprocess.Popen[str]] = []
    try:
        for scenario, port in robots:
            procs.append(
                htnagent(
                    *("serve", str(scenario), "--agent", "navigator"),
                    *("--listen", f"tcp/127.0.0.1:{port}", "--speed", str(speed)),
                )
            )
        for proc in procs:
            assert proc.stdout is not None
            Lines(proc.stdout).until("serving navigator", timeout=15)
        yield procs
    finally:
        for proc in procs:
            stop(proc)


def stop(proc: subprocess.Popen[str]) -> None:
    """Kill the process (even a stopped one) and reap it."""
    if proc.poll() is None:
        proc.send_signal(signal.SIGKILL)
    proc.wait(10)
    for stream in (proc.stdout, proc.stderr):
        if stream is not None:
            stream.close()


def inet_sockets(pid: int) -> list[tuple[str, str, str, str]]:
    """The process's TCP and UDP sockets: (protocol, local address, remote address, state)."""
    inodes = set()
    for fd in Path(f"/proc/{pid}/fd").iterdir():
        try:
            target = os.readlink(fd)
        except OSError:
            continue
        if target.startswith("socket:["):
            inodes.add(target[8:-1])
    found = []
    for proto in ("tcp", "tcp6", "udp", "udp6"):
        rows = Path(f"/proc/{pid}/net/{proto}").read_text().splitlines()[1:]
        for row in rows:
            cols = row.split()
            if cols[9] in inodes:
                found.append((proto, _address(cols[1]), _address(cols[2]), cols[3]))
    return found


def _address(hex_address: str) -> str:
    host, port = hex_address.split(":")
    raw = bytes.fromhex(host)
    if len(raw) == 4:
        text = socket.inet_ntop(socket.AF_INET, raw[::-1])
    else:  # IPv6: four 32-bit words, each little-endian
        words = b"".join(raw[i : i + 4][::-1] for i in range(0, 16, 4))
        text = socket.inet_ntop(socket.AF_INET6, words)
    return f"{text}:{int(port, 16)}"
