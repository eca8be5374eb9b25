"""Remote agents in scenario files, and the ``zenoh`` extra being optional (no zenoh needed here).

Without the extra, ``serve`` and a scenario naming a ``remote:`` agent give one
line naming the extra and exit 2 (the import failure is simulated); the scenario
fields are checked like any other.
"""

from __future__ import annotations

import sys
from collections.abc import Callable
from pathlib import Path

import pytest

from htnagent.cli.commands import main
from htnagent.errors import ScenarioError
from htnagent.scenario import Scenario, load_scenario, parse_scenario
from tests.remote_support import SCENARIOS, remote_scenario

MAP = str(SCENARIOS / "museum_map.yaml")


def scenario_data(**navigator: object) -> dict[str, object]:
    return {
        "name": "museum, remote navigator",
        "map": MAP,
        "robot": {"start": "n40", "speed": 1.0},
        "agents": [
            {"name": "guide", "domain": "museum.areas", "executor": "navigator"},
            {"name": "navigator", "domain": "museum.nodes", "executor": "robot", **navigator},
        ],
        "goals": [{"agent": "guide", "task": "goto(n1)"}],
    }


@pytest.fixture
def no_zenoh(monkeypatch: pytest.MonkeyPatch) -> None:
    """Importing zenoh fails, as without the extra; htnagent.remote is imported afresh."""
    monkeypatch.setitem(sys.modules, "zenoh", None)  # None makes importing it fail
    for name in [m for m in sys.modules if m == "htnagent.remote" or m.startswith("htnagent.remote.")]:
        monkeypatch.delitem(sys.modules, name)


@pytest.mark.usefixtures("no_zenoh")
@pytest.mark.parametrize("command", ["serve", "run"])
def test_without_the_extra_serve_and_remote_agents_are_one_line_naming_it(
    command: str, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    path = remote_scenario(tmp_path, 7447)
    args = ["serve", str(path), "--agent", "navigator"] if command == "serve" else ["run", str(path)]
    assert main(args) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert err == [
        "htnagent: error: agents in other processes need the zenoh extra: pip install 'htnagent[zenoh]'"
    ]


@pytest.mark.usefixtures("no_zenoh")
def test_without_the_extra_a_scenario_in_one_process_runs(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["run", str(SCENARIOS / "navigator_only.yaml"), "--json"]) == 0


def test_a_remote_agent_is_read_with_its_endpoint_and_the_namespace_defaults_to_the_name() -> None:
    s = parse_scenario(scenario_data(remote="tcp/127.0.0.1:7447"), "s.yaml")
    assert s.agent("navigator").endpoint == "tcp/127.0.0.1:7447"
    assert s.key_space == "museum-remote-navigator"
    assert s.remote and s.peer_wait == 10.0
    local, served = s.chain_from()
    assert [a.name for a in local] == ["guide"] and served is not None and served.name == "navigator"
    assert [a.name for a in s.chain_from("navigator")[0]] == ["navigator"]


@pytest.mark.parametrize(
    ("change", "where"),
    [
        ({"navigator": {"remote": "udp/127.0.0.1:7447"}}, "agents[1].remote.endpoint"),
        ({"navigator": {"remote": "tcp/127.0.0.1"}}, "agents[1].remote.endpoint"),
        ({"guide": {"remote": "tcp/127.0.0.1:7447"}}, "agents[0].remote"),
        ({"goal_to": "navigator"}, "goals[0].agent"),
        ({"namespace": "a b"}, "namespace"),
        ({"peer_wait": 0}, "peer_wait"),
    ],
)
def test_remote_settings_are_checked(change: dict[str, object], where: str) -> None:
    data = scenario_data(remote="tcp/127.0.0.1:7447")
    agents = data["agents"]
    assert isinstance(agents, list)
    for i, name in enumerate(("guide", "navigator")):
        extra = change.get(name)
        if isinstance(extra, dict):
            agents[i] = {**agents[i], **extra}
    if "goal_to" in change:
        data["goals"] = [{"agent": "navigator", "task": "goto_node(n1)"}]
    for key in ("namespace", "peer_wait"):
        if key in change:
            data[key] = change[key]
    with pytest.raises(ScenarioError) as caught:
        parse_scenario(data, "s.yaml")
    assert caught.value.where == where


def test_a_fleet_whose_robots_would_share_a_served_agents_keys_is_refused() -> None:
    from htnagent.system.fleet import check_fleet

    def robot(file: str, port: int, namespace: str) -> Scenario:
        data = {**scenario_data(remote=f"tcp/127.0.0.1:{port}"), "namespace": namespace}
        return parse_scenario(data, file)

    # Told apart by endpoint or by namespace: each robot's keys are its own.
    check_fleet([robot("a.yaml", 7447, "fleet/a"), robot("b.yaml", 7448, "fleet/a")])
    check_fleet([robot("a.yaml", 7447, "fleet/a"), robot("b.yaml", 7447, "fleet/b")])
    with pytest.raises(ScenarioError) as caught:
        check_fleet([robot("a.yaml", 7447, "fleet/a"), robot("b.yaml", 7447, "fleet/a")])
    assert (caught.value.file, caught.value.where) == ("b.yaml", "agents[1].remote")
    assert "another robot's too (a.yaml)" in str(caught.value)
    assert "\n" not in str(caught.value)


def test_serving_the_first_agent_is_refused(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    pytest.importorskip("zenoh", reason="the zenoh extra is not installed")
    path = remote_scenario(tmp_path, 7447)
    assert load_scenario(path).remote
    assert main(["serve", str(path), "--agent", "guide"]) == 2
    assert "serve an agent below it" in capsys.readouterr().err


def test_a_listen_endpoint_that_is_not_tcp_host_port_is_a_usage_error(
    capsys: pytest.CaptureFixture[str],
) -> None:
    assert main(["serve", "x.yaml", "--agent", "navigator", "--listen", "tcp/0.0.0.0"]) == 2
    assert "expected tcp/HOST:PORT" in capsys.readouterr().err


# -- the clock's side of it: peers' time, answers awaited from outside -----------------------------


def test_a_peers_message_moves_a_paced_clock_on_to_its_time_at_once() -> None:
    import anyio

    from htnagent.runtime.clock import Clock

    async def main() -> tuple[list[float], float]:
        clock = Clock(speed=1.0)
        got: list[float] = []
        handled = [anyio.Event(), anyio.Event()]

        def at(i: int) -> None:
            got.append(clock.now())
            handled[i].set()

        async with anyio.create_task_group() as tg:
            tg.start_soon(clock.keep_time)
            start = anyio.current_time()
            with anyio.fail_after(5):
                clock.call_from_peer(100.0, lambda: at(0))
                await handled[0].wait()
                clock.call_from_peer(50.0, lambda: at(1))  # behind this clock now: handled at once
                await handled[1].wait()
            waited = anyio.current_time() - start
            tg.cancel_scope.cancel()
        return got, waited

    got, waited = anyio.run(main)
    assert got == [100.0, 100.0]
    assert waited < 1.0  # not 100 s of pacing


def test_an_answer_awaited_from_outside_keeps_the_runtime_from_being_idle_for_good() -> None:
    import anyio

    from htnagent.runtime.clock import Clock

    async def main() -> list[str]:
        clock = Clock(speed=1000.0)
        seen: list[str] = []
        fired, idle = anyio.Event(), anyio.Event()

        def on_idle() -> None:
            seen.append("idle")
            idle.set()

        def timer() -> None:
            seen.append("timer")
            fired.set()

        clock.add_outside()
        clock.on_idle(on_idle)
        async with anyio.create_task_group() as tg:
            tg.start_soon(clock.keep_time)
            with anyio.fail_after(5):
                clock.call_later(1.0, timer)  # time goes on meanwhile
                await fired.wait()
                for _ in range(10):  # the time keeper looks again: still not idle for good
                    await anyio.lowlevel.checkpoint()
                seen.append("answer")
                clock.done_outside()
                await idle.wait()
            tg.cancel_scope.cancel()
        return seen

    assert anyio.run(main) == ["timer", "answer", "idle"]


def test_a_settled_callback_runs_once_when_the_runtime_is_idle_before_time_moves_on() -> None:
    import anyio

    from htnagent.runtime.clock import Clock, Mailbox

    async def main() -> list[tuple[str, float]]:
        clock = Clock(speed=100.0)
        seen: list[tuple[str, float]] = []
        box: Mailbox[str] = Mailbox(clock, "box")
        done = anyio.Event()

        async def receiver() -> None:
            while True:
                seen.append((await box.receive(), clock.now()))

        def later() -> None:
            seen.append(("timer", clock.now()))
            done.set()

        async with anyio.create_task_group() as tg:
            tg.start_soon(clock.keep_time)
            tg.start_soon(receiver)
            with anyio.fail_after(5):
                clock.call_later(1.0, later)
                box.send("work")  # handled before the callback: the runtime is busy with it
                clock.when_settled(lambda: seen.append(("settled", clock.now())))
                await done.wait()
                clock.when_settled(lambda: seen.append(("settled again", clock.now())))
                for _ in range(10):
                    await anyio.lowlevel.checkpoint()
            tg.cancel_scope.cancel()
        return seen

    assert anyio.run(main) == [("work", 0.0), ("settled", 0.0), ("timer", 1.0), ("settled again", 1.0)]


@pytest.mark.parametrize("backend", ["asyncio", "trio"])
def test_a_paced_wait_ends_at_its_wall_time_or_at_once_when_a_peers_message_comes(backend: str) -> None:
    # The time keeper's wait for the wall clock (asyncio: the loop's timer pokes it; trio: a
    # cancel scope's deadline) ends early for a peer's message, and the timer still fires
    # no sooner than its wall time.
    import anyio

    from htnagent.runtime.clock import Clock

    async def main() -> tuple[list[tuple[str, float, float]], float]:
        clock = Clock(speed=10.0)
        seen: list[tuple[str, float, float]] = []
        done = anyio.Event()
        start = anyio.current_time()

        def note(name: str) -> None:
            seen.append((name, clock.now(), anyio.current_time() - start))
            if name == "timer":
                done.set()

        async with anyio.create_task_group() as tg:
            tg.start_soon(clock.keep_time)
            with anyio.fail_after(5):
                clock.call_at(3.0, lambda: note("timer"))  # 0.3 s of wall time away
                await anyio.sleep(0.05)  # the time keeper waits for the wall clock
                clock.call_from_peer(1.0, lambda: note("peer"))
                await done.wait()
            tg.cancel_scope.cancel()
        return seen, anyio.current_time() - start

    seen, waited = anyio.run(main, backend=backend)
    assert [(name, t) for name, t, _ in seen] == [("peer", 1.0), ("timer", 3.0)]
    assert seen[0][2] < 0.25  # handled at once, not at the timer's time
    # The peer's time was reached at once: the timer is 2 s of simulated time (0.2 s) after it.
    assert seen[1][2] >= seen[0][2] + 0.19
    assert waited < 2.0


@pytest.mark.parametrize("backend", ["asyncio", "trio"])
def test_a_peers_message_waits_for_no_loop_round_a_timer_of_ours_waits_three(backend: str) -> None:
    # The time keeper lets the event loop run three rounds before a timer of its own fires (a
    # task woken but not counted as work acts first); a peer's message, whose moment is the
    # network's, is handled as soon as nothing is in flight.  Rounds counted by a task that
    # does nothing else (trio orders a round's tasks at random: the time keeper's wake-up
    # takes one round or two).
    import anyio
    import anyio.lowlevel

    from htnagent.runtime.clock import Clock

    async def main() -> tuple[int, int]:
        clock = Clock(speed=1000.0)
        rounds = 0
        at: dict[str, int] = {}

        async def count_rounds() -> None:
            nonlocal rounds
            while True:
                rounds += 1
                await anyio.lowlevel.checkpoint()

        async def rounds_until(name: str, give: Callable[[Callable[[], None]], object]) -> int:
            for _ in range(10):  # the time keeper settles into its wait
                await anyio.lowlevel.checkpoint()
            start = rounds

            def handled() -> None:
                at.setdefault(name, rounds)

            give(handled)
            with anyio.fail_after(5):
                while name not in at:
                    await anyio.lowlevel.checkpoint()
            return at[name] - start

        async with anyio.create_task_group() as tg:
            tg.start_soon(clock.keep_time)
            tg.start_soon(count_rounds)
            timer = await rounds_until("timer", lambda fire: clock.call_later(0.0, fire))
            peer = await rounds_until("peer", lambda fire: clock.call_from_peer(clock.now(), fire))
            tg.cancel_scope.cancel()
        return peer, timer

    peer, timer = anyio.run(main, backend=backend)
    assert timer >= 3
    assert peer <= 2  # woken, then handled at once (with the rounds: 4 or 5)


def test_robots_loaded_from_files_of_their_own_on_one_map_share_its_built_in_domains(tmp_path: Path) -> None:
    import anyio

    from htnagent.system.fleet import run_fleet, share_domains

    first, second = (parse_scenario(scenario_data(), f"robot{i}.yaml", SCENARIOS) for i in range(2))
    other_map = scenario_data()
    small = tmp_path / "map.yaml"
    small.write_text(
        (SCENARIOS / "museum_map.yaml")
        .read_text()
        .replace("n1: {area: area1, x: 1, y: 1}", "n1: {area: area1, x: 1, y: 0}")
    )
    other_map["map"] = str(small)
    elsewhere = parse_scenario(other_map, "elsewhere.yaml", SCENARIOS)
    assert first.domain_for("guide") is not second.domain_for("guide")
    share_domains([first, second, elsewhere])
    for agent in ("guide", "navigator"):
        assert second.domain_for(agent) is first.domain_for(agent)
        assert elsewhere.domain_for(agent) is not first.domain_for(agent)  # another map: its own
        # One start belief: what is kept per fact base (indexes, an action's ways) made once.
        assert second.initial_state(agent).static is first.initial_state(agent).static
    report = anyio.run(run_fleet, [first, second])
    assert report.succeeded
    assert report.runs[0].summary.distance == report.runs[1].summary.distance
