"""A fleet: one parent process with a guide per robot, a serving process per navigator and robot.

Each robot is the museum scenario in a file of its own (its endpoint, its
namespace); :func:`htnagent.system.fleet.run_fleet` runs the guides side by side in the
test's event loop while real ``python -m htnagent serve`` processes on the
loopback run the navigators and robots.  Every robot ends as the museum does in
one process; killing one serving process fails only that robot's goal, with
``peer lost``, and the fleet still ends soon after — never a hang.  Skipped
without the ``zenoh`` extra.
"""

from __future__ import annotations

import functools
import signal
import time
from pathlib import Path

import anyio
import pytest

pytest.importorskip("zenoh", reason="the zenoh extra is not installed")

from htnagent.runtime.events import GoalResumed, PeerJoined, PeerLost, Summary, TraceEvent
from htnagent.runtime.trace import Observer
from htnagent.scenario import load_scenario
from htnagent.system.fleet import FleetReport, run_fleet
from tests.remote_support import free_port, remote_scenario, serving_all
from tests.support import shipped_run

SPEED = 20.0
"""As in tests/test_remote.py: the museum takes about 3.2 s, and a message's few
milliseconds stay well inside the half move the emergency waits for."""
GUARD = 20.0
"""Wall-clock seconds a fleet's run may take here before the test fails (never hangs)."""

pytestmark = pytest.mark.timeout(60)


def fleet_files(tmp: Path, robots: int) -> list[tuple[Path, int]]:
    """Robot i: the museum, its navigator served at a free port, in namespace ``…/robot{i}``."""
    files = []
    for i in range(robots):
        port = free_port()
        files.append((remote_scenario(tmp, port, robot=f"robot{i}"), port))
    return files


def alone() -> Summary:
    """The museum run in one process, virtual time: what every robot must match."""
    _, events = shipped_run("museum.yaml")
    last = events[-1]
    assert isinstance(last, Summary)
    return last


def assert_as_alone(summary: Summary, expected: Summary) -> None:
    assert summary.outcomes == expected.outcomes
    assert summary.visited == expected.visited
    assert summary.distance == pytest.approx(expected.distance, abs=1e-6)
    assert summary.robot == expected.robot


@pytest.mark.parametrize("backend", ["asyncio", "trio"])
def test_every_robot_of_a_fleet_ends_as_the_museum_in_one_process(tmp_path: Path, backend: str) -> None:
    from htnagent.remote.link import sessions_open

    files = fleet_files(tmp_path, 2)
    scenarios = [load_scenario(path) for path, _ in files]
    sessions: list[int] = []  # this process's Zenoh sessions, whenever a robot's peer joined

    def observers(index: int) -> list[Observer]:
        return [lambda e: sessions.append(sessions_open()) if isinstance(e, PeerJoined) else None]

    async def parent() -> FleetReport:
        with anyio.fail_after(GUARD):
            return await run_fleet(scenarios, speed=SPEED, observers=observers)

    with serving_all(files, SPEED):
        report = anyio.run(parent, backend=backend)
    assert sessions == [1, 1]  # one session for both robots' links, each to its own endpoint
    expected = alone()
    assert len(report.runs) == 2
    failed = [(i, g.goal, g.reason) for i, r in enumerate(report.runs) for g in r.summary.goals if g.reason]
    assert report.succeeded, failed
    for run in report.runs:
        assert_as_alone(run.summary, expected)


def test_a_killed_serving_process_fails_only_its_robot_and_the_fleet_ends_within_3_s(
    tmp_path: Path,
) -> None:
    files = fleet_files(tmp_path, 3)
    scenarios = [load_scenario(path) for path, _ in files]
    victim = 1
    traces: list[list[TraceEvent]] = [[] for _ in files]
    resumed = anyio.Event()  # the victim's guide resumed goto(n1): mid-run, its emergency done

    def observers(index: int) -> list[Observer]:
        def watch(event: TraceEvent) -> None:
            traces[index].append(event)
            if index == victim and isinstance(event, GoalResumed) and event.agent == "guide":
                resumed.set()

        return [watch]

    with serving_all(files, SPEED) as hosts:
        killed_at: list[float] = []

        async def kill() -> None:
            await resumed.wait()
            hosts[victim].send_signal(signal.SIGKILL)
            killed_at.append(time.monotonic())

        async def parent() -> tuple[FleetReport, float]:
            with anyio.fail_after(GUARD):
                async with anyio.create_task_group() as tg:
                    tg.start_soon(kill)
                    report = await run_fleet(scenarios, speed=SPEED, observers=observers)
                    ended = time.monotonic()
                    tg.cancel_scope.cancel()  # the killer, if its moment never came
            return report, ended

        report, ended = anyio.run(functools.partial(parent))
    assert killed_at, "the victim's goal was never resumed"
    assert ended - killed_at[0] < 3.0, f"{ended - killed_at[0]:.2f} s"
    expected = alone()
    # Expect: robot 1's goto(n1) failed (peer lost), its emergency goto(n28) had succeeded
    # before the kill; robots 0 and 2 end as in one process.
    for index, run in enumerate(report.runs):
        lost = [e for e in traces[index] if isinstance(e, PeerLost)]
        if index != victim:
            assert_as_alone(run.summary, expected)
            assert not lost
            continue
        first, emergency = run.summary.goals
        assert (first.goal, first.status) == ("goto(n1)", "failure")
        assert "peer lost" in first.reason, first.reason
        assert (emergency.goal, emergency.status) == ("goto(n28)", "success")
        assert [(e.agent, e.side) for e in lost] == [("navigator", "serving")]
    assert not report.succeeded and not report.interrupted


def test_a_fleet_with_a_robot_nobody_serves_is_a_start_up_error_not_a_hang(tmp_path: Path) -> None:
    from htnagent.errors import RemoteError

    paths = [remote_scenario(tmp_path, free_port(), robot=f"robot{i}", peer_wait=1) for i in range(2)]
    scenarios = [load_scenario(path) for path in paths]

    async def parent() -> FleetReport:
        with anyio.fail_after(GUARD):
            return await run_fleet(scenarios, speed=SPEED)

    # Raised as itself, as run_scenario raises it (not inside the fleet's exception group).
    with pytest.raises(RemoteError, match="no process serves agent navigator"):
        anyio.run(parent)
