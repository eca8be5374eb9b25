"""What an HDDL action has changed as soon as it starts: ``agents[].domain.started`` (docs/design.md §7.1).

The courier of ``scenarios/courier_hddl.yaml`` with a started-effects file: a move
takes the robot out of the room it leaves at once (``delete: [at(?r,?from)]``), so a
move stopped half way leaves the robot in no room, in the world and in the belief.
It must then be resumed (on to the next room) or rolled back (back to the first)
before anything else moves it.
"""

from __future__ import annotations

import functools
from pathlib import Path
from typing import Any

import anyio
import pytest
import yaml

from htnagent.cli.commands import main
from htnagent.model.terms import parse
from htnagent.runtime.events import ActionFinished, GoalFinished, RobotActing
from htnagent.scenario import load_scenario
from htnagent.system.simulation import run_scenario
from tests.test_hddl_agents import run_checked, scenario_file

LEAVES = {"move": {"delete": ["at(?r,?from)"]}}
"""A move takes the robot out of the room it leaves as soon as it starts."""


def courier(tmp_path: Path, started: object = LEAVES, **changes: Any) -> Path:
    """The shipped courier scenario with the started-effects file ``started``."""
    side = tmp_path / "started.yaml"
    side.write_text(yaml.safe_dump(started) if not isinstance(started, str) else started)
    agent = changes.pop("agent", {})
    domain = {
        "hddl": "courier_hddl_domain.hddl",
        "problem": "courier_hddl_problem.hddl",
        "started": side.name,
    }
    return scenario_file(tmp_path, agent={"domain": domain, **agent}, **changes)


def finished(events: list[Any]) -> list[tuple[str, str]]:
    return [
        (e.action, e.result) for e in events if isinstance(e, ActionFinished) and "__done" not in e.action
    ]


def test_a_stopped_move_leaves_the_robot_in_no_room_and_the_emergency_rolls_it_back(tmp_path: Path) -> None:
    # The emergency (p2 from the office to the hall) comes half way from the hall to the
    # kitchen.  The robot is in no room: the cheapest way on is back to the hall (0.5), then
    # through the office's door.
    path = courier(tmp_path, events=[])
    states: list[frozenset[str]] = []
    scenario = load_scenario(path)

    def world(event: object) -> None:
        if isinstance(event, ActionFinished) and event.result == "suspended":
            states.append(frozenset(str(f) for f in robot[0].bottom_executor.world.facts()))

    robot: list[Any] = []
    report = anyio.run(functools.partial(run_scenario, scenario, observers=[world], on_start=robot.append))
    assert report.succeeded
    # Expect: the world had the robot in no room while the move was stopped.
    assert states and not any(f.startswith("at(r1,") for f in states[0])
    # ... and the check of every belief against the world holds throughout.
    report, events, _ = run_checked(scenario)
    actions = finished(events)
    stopped = actions.index(("move(r1,hall,kitchen)", "suspended"))
    assert actions[stopped + 1] == ("rollback(move(r1,hall,kitchen))", "success")
    assert actions[stopped + 2] == ("move(r1,hall,office)", "success")
    goals = [(e.goal, e.status) for e in events if isinstance(e, GoalFinished)]
    assert goals == [("deliver(p2,hall)", "success"), ("deliver(p1,office)", "success")]


TO_THE_KITCHEN = [
    {"agent": "courier", "task": "deliver(p1,office)"},
    {
        "agent": "courier",
        "task": "goto(r1,kitchen)",
        "emergency": True,
        "when": {"action": "move(r1,hall,kitchen)", "progress": 0.5},
    },
]
"""The first delivery, and half way along its first move an emergency: to the kitchen."""


def test_a_move_stopped_on_the_way_to_where_the_emergency_goes_is_resumed(tmp_path: Path) -> None:
    # The emergency sends the robot to the kitchen, where the stopped move was going: the rest
    # of the move (0.5) is the way there.  Then the first goal goes on from the kitchen.
    report, events, _ = run_checked(load_scenario(courier(tmp_path, goals=TO_THE_KITCHEN, events=[])))
    assert report.succeeded
    actions = finished(events)
    stopped = actions.index(("move(r1,hall,kitchen)", "suspended"))
    assert actions[stopped + 1] == ("resume(move(r1,hall,kitchen))", "success")
    resumed = [(e.action, e.done) for e in events if isinstance(e, RobotActing) and e.resumed]
    assert resumed == [("move(r1,hall,kitchen)", 0.5)]
    assert ("pick(r1,p1,kitchen)", "success") in actions


def test_naive_mode_keeps_the_beliefs_with_the_world_too(tmp_path: Path) -> None:
    online = run_checked(load_scenario(courier(tmp_path, events=[])))
    naive = run_checked(load_scenario(courier(tmp_path, events=[], replanning="naive")))
    assert online[0].succeeded and naive[0].succeeded
    assert naive[2] == online[2] > 0  # as many comparisons of belief and world, all equal
    assert finished(naive[1]) == finished(online[1])


def test_a_resume_that_fails_leaves_the_move_half_done_to_be_rolled_back(tmp_path: Path) -> None:
    # The kitchen's door shuts (at 3 s) while the emergency resumes the move to the kitchen:
    # the resume fails at its end.  The move is still half done, in the world and the
    # belief: it is rolled back, and the robot goes round through the office and the lab.
    events = [{"when": {"time": 3}, "delete": ["door(hall,kitchen)", "door(kitchen,hall)"]}]
    path = courier(tmp_path, goals=TO_THE_KITCHEN, events=events)
    report, events_seen, _ = run_checked(load_scenario(path))
    assert report.succeeded
    actions = finished(events_seen)
    failed = actions.index(("resume(move(r1,hall,kitchen))", "failure"))
    assert actions[failed + 1 : failed + 5] == [
        ("rollback(move(r1,hall,kitchen))", "success"),
        ("move(r1,hall,office)", "success"),
        ("move(r1,office,lab)", "success"),
        ("move(r1,lab,kitchen)", "success"),
    ]


def test_resume_and_rollback_give_back_what_the_start_took(tmp_path: Path) -> None:
    # A start that takes away a fact the move does not change (the door behind it): resumed
    # or rolled back, the move ends where the move done at once ends, or where it began.
    from htnagent.hddl.reader import read_domain, read_problem
    from htnagent.planning.hddl_translation import Started, translate

    repo = Path(__file__).resolve().parents[1] / "scenarios"
    d = read_domain(repo / "courier_hddl_domain.hddl")
    p = read_problem(repo / "courier_hddl_problem.hddl", d)
    planning = translate(d, p, ["move"], {"move": Started(delete=("door(?from,?to)", "at(?r,?from)"))})
    domain, start = planning.domain, planning.state
    move = parse("move(r1,hall,kitchen)")
    half = domain.suspend(start, move)
    assert parse("door(hall,kitchen)") not in half.dynamic
    whole = domain.apply(start, move)
    resumed = domain.apply(half, parse("resume(move(r1,hall,kitchen))"))
    back = domain.apply(half, parse("rollback(move(r1,hall,kitchen))"))
    assert whole is not None and resumed is not None and back is not None
    assert resumed.dynamic == whole.dynamic
    assert back.dynamic == start.dynamic


def test_without_started_effects_a_stopped_move_has_changed_nothing(tmp_path: Path) -> None:
    # The same emergency as the first test, no started-effects file: the robot is still in
    # the hall as far as anyone knows, so nothing is rolled back -- the move is simply dropped.
    report, events, _ = run_checked(load_scenario(scenario_file(tmp_path, events=[])))
    assert report.succeeded
    actions = finished(events)
    assert not any(a.startswith("rollback(") for a, _ in actions)


def test_the_translation_resumes_without_what_the_start_undid() -> None:
    from htnagent.hddl.reader import read_domain, read_problem
    from htnagent.planning.hddl_translation import Started, translate

    repo = Path(__file__).resolve().parents[1] / "scenarios"
    d = read_domain(repo / "courier_hddl_domain.hddl")
    p = read_problem(repo / "courier_hddl_problem.hddl", d)
    planning = translate(d, p, ["move"], {"move": Started(delete=("at(?r,?from)",))})
    move = parse("move(r1,hall,kitchen)")
    state = planning.domain.suspend(planning.state, move)
    assert parse("at(r1,hall)") not in state.dynamic
    # Expect: resume(A) needs the door but not at(r1,hall), which the start took away.
    resumed = planning.domain.apply(state, parse("resume(move(r1,hall,kitchen))"))
    assert resumed is not None and parse("at(r1,kitchen)") in resumed.dynamic
    back = planning.domain.apply(state, parse("rollback(move(r1,hall,kitchen))"))
    assert back is not None and parse("at(r1,hall)") in back.dynamic
    assert planning.domain.actions.cost(parse("rollback(move(r1,hall,kitchen))")) == 0.5
    # A clear leaves the half-done move in the belief, to be resumed or rolled back later.
    assert planning.domain.clear(state, move) == state


BROKEN = [
    ("not-a-mapping", "- move\n", "", "maps actions to {add: [fact], delete: [fact]}, not a list"),
    ("unknown-action", {"fly": {"add": []}}, "fly", "domain courier has no action fly"),
    ("not-suspendable", {"pick": {"add": []}}, "pick", "pick is not in agents[0].suspendable"),
    ("unknown-predicate", {"move": {"add": ["flying(?r)"]}}, "move.add[0]", "has no predicate flying"),
    (
        "arity",
        {"move": {"delete": ["at(?r)"]}},
        "move.delete[0]",
        "predicate at takes 2 arguments in courier, not 1",
    ),
    (
        "unknown-variable",
        {"move": {"delete": ["at(?r,?x)"]}},
        "move.delete[0]",
        "'?x' is neither a parameter",
    ),
    ("unknown-object", {"move": {"add": ["in(p9,hall)"]}}, "move.add[0]", "'p9' is neither a parameter"),
    ("both", {"move": {"add": ["at(?r,?to)"], "delete": ["at(?r,?to)"]}}, "move", "both added and deleted"),
    ("unknown-key", {"move": {"adds": ["at(?r,?to)"]}}, "move.adds", "unknown key"),
    ("not-text", {"move": {"add": [5]}}, "move.add[0]", "expected text"),
    ("no-effects", {"move": None}, "move", "no add nor delete"),
    ("wrong-type", {"move": {"delete": ["at(?from,?r)"]}}, "move.delete[0]", "?from is a room, but at takes"),
    ("not-held", {"move": {"delete": ["in(p1,hall)"]}}, "move.delete[0]", "is not in move's precondition"),
    ("not-absent", {"move": {"add": ["at(?r,?to)"]}}, "move.add[0]", "must say (not at(?r,?to))"),
    ("bad-yaml", "move: [\n", "", ""),
    ("flow-list", "move: {delete: [at(?r,?from)]}\n", "move.delete[0]", "quote each fact"),
]


@pytest.mark.parametrize(("started", "where", "reason"), [b[1:] for b in BROKEN], ids=[b[0] for b in BROKEN])
def test_a_bad_started_effects_file_is_one_line_naming_its_place(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], started: object, where: str, reason: str
) -> None:
    path = courier(tmp_path, started=started)
    assert main(["check", str(path)]) == 2
    out, err = capsys.readouterr()
    assert out == ""
    assert err.count("\n") == 1, err
    assert err.startswith(f"htnagent: error: {tmp_path / 'started.yaml'}"), err
    if where:
        assert f": {where}: " in err, err
    assert reason in err, err


def test_a_missing_started_effects_file_is_one_line(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    path = courier(tmp_path)
    (tmp_path / "started.yaml").unlink()
    assert main(["check", str(path)]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "started.yaml" in err, err
