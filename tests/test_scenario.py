"""Scenario files: the published ones load, and every broken one is a one-line error.

A broken scenario must give exit code 2 and exactly one line on stderr naming
the file, the place in it (key path or line) and what is wrong — never a
traceback (docs/contracts.md "Command line").
"""

from __future__ import annotations

import copy
import os
import shutil
import subprocess
import sys
from collections.abc import Callable
from pathlib import Path
from typing import Any

import pytest
import yaml

from htnagent.cli.commands import main
from htnagent.errors import ScenarioError
from htnagent.model.terms import Atom, parse
from htnagent.planning.planner import PlannerSettings, Search
from htnagent.scenario import Scenario, load_scenario

REPO = Path(__file__).resolve().parents[1]
SCENARIOS = REPO / "scenarios"
SCENARIO_FILES = sorted(p for p in SCENARIOS.glob("*.yaml") if not p.name.endswith("_map.yaml"))


# -- the shipped scenarios -------------------------------------------------------------


def test_every_published_experiment_has_a_scenario_file() -> None:
    names = {p.name for p in SCENARIO_FILES}
    for case in ("n40_n1_n38", "n40_n1_n28", "n40_n1_n29", "n1_n40_n13", "n1_n40_n4", "n1_n40_n12"):
        assert f"paper_{case}.yaml" in names
    assert {"museum.yaml", "navigator_only.yaml"} <= names


@pytest.mark.parametrize("path", SCENARIO_FILES, ids=lambda p: p.name)
def test_every_scenario_file_loads(path: Path) -> None:
    s = load_scenario(path)
    assert s.robot.start in s.world.nodes or s.hddl_robot is not None  # HDDL: no map (§7.1)
    assert s.agents[-1].executor == "robot"
    for agent in s.agent_names:
        assert s.initial_state(agent).dynamic


@pytest.mark.parametrize("path", SCENARIO_FILES, ids=lambda p: p.name)
def test_check_accepts_every_scenario_file(path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["check", str(path)]) == 0
    out, err = capsys.readouterr()
    assert out == "ok\n"
    assert err == ""


def test_museum_scenario_reads_as_the_contract_writes_it() -> None:
    s = load_scenario(SCENARIOS / "museum.yaml")
    assert s.robot.start == "n40"
    assert s.robot.speed == 1.0
    assert s.agent_names == ("guide", "navigator")
    assert [a.executor for a in s.agents] == ["navigator", "robot"]
    assert s.replanning == "online"
    first, emergency = s.goals
    assert first.task == parse("goto(n1)")
    assert not first.emergency
    assert first.when is None
    assert emergency.task == parse("goto(n28)")
    assert emergency.emergency
    # The flow mapping {action: move(n40,n35,arc59), progress: 0.5} is read whole,
    # although YAML alone would split it at the commas.
    assert emergency.when is not None
    assert emergency.when.action == parse("move(n40,n35,arc59)")
    assert emergency.when.progress == 0.5
    assert emergency.when.time is None
    assert s.events == ()


def test_paper_scenarios_trigger_on_the_first_arc() -> None:
    for path in SCENARIOS.glob("paper_*.yaml"):
        s = load_scenario(path)
        trigger = s.goals[1].when
        assert trigger is not None
        expected = "move(n40,n35,arc59)" if s.robot.start == "n40" else "move(n1,n6,arc5)"
        assert trigger.action == parse(expected), path.name
        assert trigger.progress == 0.5


def test_domains_are_built_once_and_states_start_at_the_robot() -> None:
    s = load_scenario(SCENARIOS / "museum.yaml")
    assert s.domain_for("guide") is s.domain_for("guide")
    assert s.domain_for("guide").name == "museum.areas"
    assert s.domain_for("navigator").name == "museum.nodes"
    assert s.initial_state("navigator").holds(Atom("at", ("n40",)))
    assert s.initial_state("guide").holds(Atom("at", ("area8",)))
    assert s.settings == PlannerSettings()
    assert len(s.world.nodes) == 40
    assert len(s.world.arcs) == 59
    with pytest.raises(ScenarioError, match="no agent named 'nobody'"):
        s.domain_for("nobody")


def test_scenario_models_are_frozen() -> None:
    s = load_scenario(SCENARIOS / "museum.yaml")
    with pytest.raises(ValueError, match="frozen"):
        s.name = "other"
    with pytest.raises(ValueError, match="frozen"):
        s.robot.speed = 2.0


# -- a scenario with every optional part, written to a temporary directory ----------------


def base() -> dict[str, Any]:
    """A valid scenario using every feature; the broken cases below each spoil one thing."""
    return {
        "name": "test scenario",
        "map": "museum_map.yaml",
        "robot": {"start": "n40", "speed": 1.0, "failure_rate": 0.0, "seed": 3},
        "agents": [
            {"name": "guide", "domain": "museum.areas", "executor": "navigator"},
            {"name": "navigator", "domain": "museum.nodes", "executor": "robot"},
        ],
        "replanning": "naive",
        "planner": {"alternatives": 2, "budget": 5000, "search": "gbfs"},
        "action_timeout": 60,
        "goals": [
            {"agent": "guide", "task": "goto(n1)"},
            {
                "agent": "guide",
                "task": "goto(n28)",
                "emergency": True,
                "when": {"action": "move(n40,n35,arc59)", "progress": 0.5},
            },
            {"agent": "navigator", "task": "goto_node(n38)", "when": {"time": 12.5}},
        ],
        "events": [
            {"when": {"time": 30}, "close": "arc51"},
            {"when": {"action": "move(n31,n29,arc50)", "progress": 1.0}, "open": "arc51"},
        ],
    }


def write(tmp_path: Path, data: Any, name: str = "scenario.yaml") -> Path:
    if not (tmp_path / "museum_map.yaml").exists():
        shutil.copy(SCENARIOS / "museum_map.yaml", tmp_path / "museum_map.yaml")
    path = tmp_path / name
    path.write_text(data if isinstance(data, str) else yaml.safe_dump(data, sort_keys=False))
    return path


def test_a_scenario_with_every_optional_part_loads(tmp_path: Path) -> None:
    s = load_scenario(write(tmp_path, base()))
    assert isinstance(s, Scenario)
    assert s.replanning == "naive"
    assert s.settings == PlannerSettings(alternatives=2, budget=5000, search=Search.GBFS)
    assert s.action_timeout == 60
    assert s.robot.seed == 3
    assert s.goals[2].when is not None and s.goals[2].when.time == 12.5
    close, open_ = s.events
    assert (close.arc, close.closes) == ("arc51", True)
    assert (open_.arc, open_.closes) == ("arc51", False)
    assert open_.when.action == parse("move(n31,n29,arc50)")


def test_defaults_fill_the_optional_parts(tmp_path: Path) -> None:
    data = base()
    for key in ("replanning", "planner", "action_timeout", "events"):
        del data[key]
    del data["robot"]["failure_rate"], data["robot"]["seed"]
    s = load_scenario(write(tmp_path, data))
    assert s.replanning == "online"
    assert s.settings == PlannerSettings(alternatives=2, budget=200_000)
    assert s.action_timeout is None
    assert s.robot.failure_rate == 0.0
    assert s.robot.seed == 0
    assert s.events == ()


def test_an_inline_map_is_accepted(tmp_path: Path) -> None:
    data = base()
    data["map"] = yaml.safe_load((SCENARIOS / "museum_map.yaml").read_text())
    s = load_scenario(write(tmp_path, data))
    assert len(s.world.nodes) == 40


def test_text_forms_in_flow_collections_are_read_whole(tmp_path: Path) -> None:
    text = (SCENARIOS / "museum.yaml").read_text()
    text += "  - {agent: navigator, task: move_area(area8,area7), emergency: false}\n"
    text += "  - {agent: guide, task: goto(n2), when: {action: move_area(area8,area7), progress: 1}}\n"
    s = load_scenario(write(tmp_path, text))
    assert s.goals[2].task == parse("move_area(area8,area7)")
    assert s.goals[3].when is not None
    assert s.goals[3].when.action == parse("move_area(area8,area7)")
    # A nested text form is read whole too (and then refused: a trigger names the action itself).
    text += "  - {agent: guide, task: goto(n3), when: {action: resume(move(n40,n35,arc59)), progress: 1}}\n"
    with pytest.raises(ScenarioError, match=r"resume\(move\(n40,n35,arc59\)\): a trigger names") as info:
        load_scenario(write(tmp_path, text))
    assert info.value.where == "goals[4].when.action"


# -- broken scenarios ----------------------------------------------------------------------

Edit = Callable[[dict[str, Any]], Any]


def edited(edit: Edit) -> Callable[[], Any]:
    """The base scenario with one edit applied in place (what the edit returns is ignored)."""

    def make() -> Any:
        data = copy.deepcopy(base())
        edit(data)
        return data

    return make


def raw(text: str) -> Callable[[], Any]:
    return lambda: text


GOOD_TEXT = """\
name: broken
map: museum_map.yaml
robot: {start: n40, speed: 1.0}
agents:
  - {name: navigator, domain: museum.nodes, executor: robot}
goals:
  - {agent: navigator, task: goto_node(n1)}
"""

# (id, the file's content, the place the error must name, a part of the reason)
BROKEN: list[tuple[str, Callable[[], Any], str, str]] = [
    (
        "yaml-unclosed-bracket",
        raw(GOOD_TEXT.replace("goals:", "goals:\n  bad: [unclosed")),
        "line 8",
        "while parsing a flow sequence at line 7",
    ),
    (
        "yaml-colon-in-value",
        raw(GOOD_TEXT.replace("map: museum_map.yaml", "map: museum: map.yaml")),
        "line 2",
        "mapping values are not allowed",
    ),
    (
        "yaml-bad-indent",
        raw(GOOD_TEXT.replace("robot: {", "  robot: {")),
        "line 3",
        "invalid YAML",
    ),
    (
        "yaml-tab",
        raw(GOOD_TEXT + "events:\n\t- {when: {time: 1}, close: arc1}\n"),
        "line 9, column 1",
        "a tab character is not allowed for indentation in YAML; use spaces",
    ),
    (
        "yaml-tab-after-spaces",
        raw(GOOD_TEXT.replace("robot: {start: n40, speed: 1.0}", "robot:\n  start: n40\n  \tspeed: 1.0")),
        "line 5, column 3",
        "a tab character is not allowed for indentation in YAML; use spaces",
    ),
    ("duplicate-key", raw(GOOD_TEXT + "robot: {start: n1, speed: 2}\n"), "line 8", "duplicate key 'robot'"),
    ("empty-file", raw(""), "", "empty"),
    ("only-comments", raw("# nothing here\n"), "", "empty"),
    ("top-level-list", raw("- name: x\n"), "", "must be a mapping"),
    ("top-level-text", raw("just words\n"), "", "must be a mapping"),
    ("a-map-not-a-scenario", raw((SCENARIOS / "museum_map.yaml").read_text()), "", "this is a map"),
    ("unknown-top-key", edited(lambda d: d.update(colour="red")), "colour", "unknown key; expected one of"),
    (
        "misspelt-key",
        edited(lambda d: d["robot"].update(sped=2)),
        "robot.sped",
        "unknown key; did you mean speed? expected one of start, speed,",
    ),
    (
        # The required key it replaces is missing too: the typo is what is told.
        "misspelt-required-key",
        edited(lambda d: d.update(agentz=d.pop("agents"))),
        "agentz",
        "unknown key; did you mean agents?",
    ),
    ("missing-name", edited(lambda d: d.pop("name")), "name", "required"),
    ("missing-robot", edited(lambda d: d.pop("robot")), "robot", "required"),
    ("robot-not-a-mapping", edited(lambda d: d.update(robot="n40")), "robot", "expected a mapping"),
    ("robot-unknown-key", edited(lambda d: d["robot"].update(wheels=4)), "robot.wheels", "expected one of"),
    ("speed-missing", edited(lambda d: d["robot"].pop("speed")), "robot.speed", "required"),
    ("speed-zero", edited(lambda d: d["robot"].update(speed=0)), "robot.speed", "at least 1e-06, got 0"),
    (
        "speed-text",
        edited(lambda d: d["robot"].update(speed="fast")),
        "robot.speed",
        "expected a finite number",
    ),
    (
        "speed-bool",
        edited(lambda d: d["robot"].update(speed=True)),
        "robot.speed",
        "expected a finite number",
    ),
    (
        "failure-rate-above-one",
        edited(lambda d: d["robot"].update(failure_rate=1.5)),
        "robot.failure_rate",
        "at most 1",
    ),
    ("seed-not-whole", edited(lambda d: d["robot"].update(seed=1.5)), "robot.seed", "whole number"),
    ("start-not-a-node", edited(lambda d: d["robot"].update(start="n99")), "robot.start", "'n99'"),
    ("no-agents", edited(lambda d: d.update(agents=[])), "agents", "must not be empty"),
    ("agents-not-a-list", edited(lambda d: d.update(agents="guide")), "agents", "expected a list"),
    ("agent-without-domain", edited(lambda d: d["agents"][1].pop("domain")), "agents[1].domain", "required"),
    (
        "duplicate-agent",
        edited(lambda d: d["agents"][1].update(name="guide")),
        "agents[1].name",
        "duplicate agent name 'guide'",
    ),
    (
        "agent-called-robot",
        edited(lambda d: d["agents"][1].update(name="robot")),
        "agents[1].name",
        "names the robot",
    ),
    (
        "chain-broken",
        edited(lambda d: d["agents"][0].update(executor="robot")),
        "agents[0].executor",
        "'navigator'",
    ),
    (
        "last-not-on-robot",
        edited(lambda d: d["agents"][1].update(executor="guide")),
        "agents[1].executor",
        "'robot'",
    ),
    (
        "unknown-domain",
        edited(lambda d: d["agents"][0].update(domain="museum.rooms")),
        "agents[0].domain",
        "unknown domain 'museum.rooms'",
    ),
    (
        "domain-module-missing",
        edited(lambda d: d["agents"][0].update(domain="no_such_module_xyz:make")),
        "agents[0].domain",
        "cannot import module 'no_such_module_xyz'",
    ),
    (
        "domain-attribute-missing",
        edited(lambda d: d["agents"][0].update(domain="htnagent.domains:no_such_domain")),
        "agents[0].domain",
        "has no attribute 'no_such_domain'",
    ),
    (
        "domain-not-a-domain",
        edited(lambda d: d["agents"][0].update(domain="htnagent.domains:BUILTIN")),
        "agents[0].domain",
        "is a dict, not a Domain",
    ),
    (
        "domain-from-the-standard-library",
        edited(lambda d: d["agents"][0].update(domain="builtins:repr")),
        "agents[0].domain",
        "builtins is a standard-library module, not a domain",
    ),
    (
        "replanning-unknown",
        edited(lambda d: d.update(replanning="smart")),
        "replanning",
        "'online' or 'naive'",
    ),
    (
        "alternatives-zero",
        edited(lambda d: d["planner"].update(alternatives=0)),
        "planner.alternatives",
        "at least 1",
    ),
    (
        "search-unknown",
        edited(lambda d: d["planner"].update(search="bogo")),
        "planner.search",
        "'astar', 'gbfs', 'dfs' or 'grounded'",
    ),
    ("timeout-negative", edited(lambda d: d.update(action_timeout=-5)), "action_timeout", "greater than 0"),
    ("no-goals", edited(lambda d: d.update(goals=[])), "goals", "must not be empty"),
    (
        "goal-agent-unknown",
        edited(lambda d: d["goals"][1].update(agent="butler")),
        "goals[1].agent",
        "no agent named 'butler'",
    ),
    (
        "task-malformed",
        edited(lambda d: d["goals"][0].update(task="goto(n1")),
        "goals[0].task",
        "missing ')'",
    ),
    ("task-with-spaces", edited(lambda d: d["goals"][0].update(task="goto( n1)")), "goals[0].task", "spaces"),
    ("task-not-text", edited(lambda d: d["goals"][0].update(task=42)), "goals[0].task", "expected text"),
    (
        "task-unknown-to-domain",
        edited(lambda d: d["goals"][0].update(task="fly(n1)")),
        "goals[0].task",
        "has no task fly",
    ),
    (
        "task-unknown-node",
        edited(lambda d: d["goals"][0].update(task="goto(n99)")),
        "goals[0].task",
        "unknown node 'n99'",
    ),
    (
        "task-unknown-area",
        edited(lambda d: d["goals"][2].update(task="move_area(area8,area9)")),
        "goals[2].task",
        "unknown area 'area9'",
    ),
    (
        "task-wrong-arity",
        edited(lambda d: d["goals"][0].update(task="goto(n1,n2)")),
        "goals[0].task",
        "goto takes 1 argument in museum.areas, not 2",
    ),
    (
        "task-with-variable",
        edited(lambda d: d["goals"][0].update(task="goto(?x)")),
        "goals[0].task",
        "ground",
    ),
    (
        "emergency-not-bool",
        edited(lambda d: d["goals"][1].update(emergency="sometimes")),
        "goals[1].emergency",
        "true or false",
    ),
    (
        "goal-unknown-key",
        edited(lambda d: d["goals"][0].update(deadline=3)),
        "goals[0].deadline",
        "unknown key",
    ),
    (
        "progress-above-one",
        edited(lambda d: d["goals"][1]["when"].update(progress=1.5)),
        "goals[1].when.progress",
        "at most 1",
    ),
    (
        "progress-zero",
        edited(lambda d: d["goals"][1]["when"].update(progress=0)),
        "goals[1].when.progress",
        "greater than 0",
    ),
    (
        "progress-missing",
        edited(lambda d: d["goals"][1]["when"].pop("progress")),
        "goals[1].when",
        "needs progress",
    ),
    (
        "when-time-and-action",
        edited(lambda d: d["goals"][1]["when"].update(time=3)),
        "goals[1].when",
        "not both",
    ),
    ("when-empty", edited(lambda d: d["goals"][1].update(when={})), "goals[1].when", "expected {time: T}"),
    (
        "when-negative-time",
        edited(lambda d: d["goals"][2].update(when={"time": -1})),
        "goals[2].when.time",
        "at least 0",
    ),
    (
        "trigger-action-malformed",
        edited(lambda d: d["goals"][1]["when"].update(action="move(n40,n35")),
        "goals[1].when.action",
        "missing ')'",
    ),
    (
        "trigger-action-unknown",
        edited(lambda d: d["goals"][1]["when"].update(action="jump(n40)")),
        "goals[1].when.action",
        "no agent has an action named jump",
    ),
    (
        "trigger-action-wrong-arc",
        edited(lambda d: d["goals"][1]["when"].update(action="move(n40,n35,arc5)")),
        "goals[1].when.action",
        "arc5 joins n1 and n6",
    ),
    (
        "event-unknown-arc",
        edited(lambda d: d["events"][0].update(close="arc999")),
        "events[0].close",
        "unknown arc 'arc999'",
    ),
    (
        "event-close-and-open",
        edited(lambda d: d["events"][0].update(open="arc51")),
        "events[0]",
        "exactly one of close, open",
    ),
    ("event-without-when", edited(lambda d: d["events"][1].pop("when")), "events[1].when", "required"),
    (
        "event-trigger-bad",
        edited(lambda d: d["events"][1]["when"].update(action="move(n31,n29,arc99)")),
        "events[1].when.action",
        "unknown arc 'arc99'",
    ),
    ("map-missing-file", edited(lambda d: d.update(map="nowhere.yaml")), "map", "not found"),
    ("map-not-text", edited(lambda d: d.update(map=5)), "map", "expected a map file name"),
    (
        "inline-map-bad-node",
        edited(
            lambda d: d.update(map={"areas": {"a": None}, "nodes": {"n1": {"area": "a", "x": "far", "y": 0}}})
        ),
        "map.nodes.n1.x",
        "expected a finite number, got 'far'",
    ),
]


@pytest.mark.parametrize(("content", "where", "reason"), [c[1:] for c in BROKEN], ids=[c[0] for c in BROKEN])
def test_a_broken_scenario_is_one_line_on_stderr(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], content: Callable[[], Any], where: str, reason: str
) -> None:
    path = write(tmp_path, content())
    assert main(["check", str(path)]) == 2
    out, err = capsys.readouterr()
    assert out == ""
    assert "Traceback" not in err
    lines = err.splitlines()
    assert len(lines) == 1, err
    line = lines[0]
    assert line.startswith(f"htnagent: error: {path}: "), line
    if where:
        assert f"{path}: {where}" in line, line
        # the key path is the whole place, not a prefix of a longer one
        after = line.split(f"{path}: {where}", 1)[1]
        assert after.startswith((": ", ", column")), line
    assert reason in line, line


def test_there_are_at_least_twenty_kinds_of_broken_scenario() -> None:
    assert len({c[0] for c in BROKEN}) >= 20


@pytest.mark.parametrize(
    ("name", "place", "reason"),
    [("missing.yaml", "", "no such file"), ("a_directory", "", "is a directory")],
)
def test_a_missing_file_or_a_directory_is_one_line(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], name: str, place: str, reason: str
) -> None:
    (tmp_path / "a_directory").mkdir()
    path = tmp_path / name
    assert main(["check", str(path)]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1
    assert err.startswith(f"htnagent: error: {path}: {reason}")


def test_a_file_that_is_not_text_is_one_line(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    path = tmp_path / "binary.yaml"
    path.write_bytes(b"name: \xff\xfe\x00\x01")
    assert main(["check", str(path)]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1
    assert "UTF-8" in err


def test_an_error_in_the_map_file_names_the_map_file(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    bad_map = yaml.safe_load((SCENARIOS / "museum_map.yaml").read_text())
    bad_map["arcs"]["arc5"] = ["n1", "n77"]
    (tmp_path / "bad_map.yaml").write_text(yaml.safe_dump(bad_map))
    data = base()
    data["map"] = "bad_map.yaml"
    path = write(tmp_path, data)
    assert main(["check", str(path)]) == 2
    err = capsys.readouterr().err
    assert err == f"htnagent: error: {tmp_path / 'bad_map.yaml'}: arcs.arc5: unknown node 'n77'\n"


def test_a_yaml_error_in_the_map_file_gives_its_line(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    (tmp_path / "bad_map.yaml").write_text("areas:\n  a1:\nnodes: [\n")
    data = base()
    data["map"] = "bad_map.yaml"
    path = write(tmp_path, data)
    assert main(["check", str(path)]) == 2
    err = capsys.readouterr().err
    assert err.startswith(f"htnagent: error: {tmp_path / 'bad_map.yaml'}: line 4")


def test_load_scenario_raises_scenario_error_with_its_parts(tmp_path: Path) -> None:
    data = base()
    data["goals"][1]["when"]["progress"] = 2
    path = write(tmp_path, data)
    with pytest.raises(ScenarioError) as info:
        load_scenario(path)
    assert info.value.file == str(path)
    assert info.value.where == "goals[1].when.progress"
    assert "at most 1" in info.value.reason


# -- through a real process ---------------------------------------------------------------


def test_python_m_htnagent_check_in_a_subprocess(tmp_path: Path) -> None:
    ok = subprocess.run(
        [sys.executable, "-m", "htnagent", "check", "scenarios/museum.yaml"],
        cwd=REPO,
        capture_output=True,
        text=True,
        timeout=60,
        check=False,
    )
    assert (ok.returncode, ok.stdout, ok.stderr) == (0, "ok\n", "")
    data = base()
    data["robot"]["start"] = "n99"
    path = write(tmp_path, data)
    bad = subprocess.run(
        [sys.executable, "-m", "htnagent", "check", str(path)],
        cwd=REPO,
        capture_output=True,
        text=True,
        timeout=60,
        check=False,
    )
    assert bad.returncode == 2
    assert bad.stdout == ""
    assert bad.stderr.count("\n") == 1
    assert bad.stderr.startswith(f"htnagent: error: {path}: robot.start: ")
    assert "Traceback" not in bad.stderr


def test_an_unreadable_file_is_one_line(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], monkeypatch: pytest.MonkeyPatch
) -> None:
    path = write(tmp_path, base())
    real_open = os.open

    def refuse(name: str, *args: Any, **kwargs: Any) -> int:
        if name == str(path):
            raise PermissionError(13, "Permission denied", name)
        return real_open(name, *args, **kwargs)

    # Tests may run as root, for whom chmod cannot make a file unreadable.
    monkeypatch.setattr(os, "open", refuse)
    assert main(["check", str(path)]) == 2
    err = capsys.readouterr().err
    assert err == f"htnagent: error: {path}: cannot read the file: Permission denied\n"
