"""The command line: ``check`` and ``plan`` (docs/contracts.md "Command line").

Everything runs in-process through :func:`htnagent.cli.commands.main`, reading what it
printed with capsys.
"""

from __future__ import annotations

import json
import shutil
import uuid
from pathlib import Path

import pytest
import yaml

from htnagent.cli.commands import main
from tests.support import one_error_line

REPO = Path(__file__).resolve().parents[1]
SCENARIOS = REPO / "scenarios"
FROM_N1 = SCENARIOS / "paper_n1_n40_n13.yaml"  # the robot starts at n1

GUIDE_TO_N40 = [
    "move_area(area1,area3)",
    "move_area(area3,area5)",
    "move_area(area5,area7)",
    "move_area(area7,area8)",
    "goto_node(n40)",
]


# -- check ----------------------------------------------------------------------------------


def test_check_prints_ok_and_nothing_else(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["check", str(SCENARIOS / "museum.yaml")]) == 0
    assert capsys.readouterr() == ("ok\n", "")


# -- plan -------------------------------------------------------------------------------------


def test_plan_prints_the_guides_plan_numbered_with_its_cost(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["plan", str(FROM_N1), "--agent", "guide", "--task", "goto(n40)"]) == 0
    out, err = capsys.readouterr()
    assert err == ""
    numbered = [line.split(". ", 1) for line in out.splitlines() if line.startswith("  ")]
    assert [n.strip() for n, _ in numbered] == ["1", "2", "3", "4", "5"]
    assert [a for _, a in numbered] == GUIDE_TO_N40
    assert "cost 43.31" in out
    # Four alternatives (the default K), the best first.
    assert "2 plans found" in out
    assert "costs 43.31, " in out


def test_plan_json_is_one_line_with_plan_cost_and_alternatives(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["plan", str(FROM_N1), "--agent", "guide", "--task", "goto(n40)", "--json"]) == 0
    out, err = capsys.readouterr()
    assert err == ""
    assert out.endswith("\n") and out.count("\n") == 1
    result = json.loads(out)
    assert set(result) == {"plan", "cost", "alternatives"}
    assert result["plan"] == GUIDE_TO_N40
    assert result["cost"] == pytest.approx(43.3110, abs=1e-3)
    assert result["alternatives"] == 2


def test_plan_for_the_navigator_crosses_the_door(capsys: pytest.CaptureFixture[str]) -> None:
    argv = ["plan", str(FROM_N1), "--agent", "navigator", "--task", "move_area(area1,area3)", "--json"]
    assert main(argv) == 0
    result = json.loads(capsys.readouterr().out)
    assert result["plan"] == ["move(n1,n6,arc5)", "move(n6,n10,arc12)"]
    assert result["cost"] == pytest.approx(10.0)


def test_plan_with_no_plan_exits_1_with_a_message(capsys: pytest.CaptureFixture[str]) -> None:
    # From area1 no door leads straight into area8.
    argv = ["plan", str(FROM_N1), "--agent", "navigator", "--task", "move_area(area1,area8)"]
    assert main(argv) == 1
    out, err = capsys.readouterr()
    assert out == ""
    assert err.count("\n") == 1
    assert "move_area(area1,area8)" in err


def test_plan_honours_the_scenarios_planner_settings(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    shutil.copy(SCENARIOS / "museum_map.yaml", tmp_path)
    path = tmp_path / "one.yaml"
    path.write_text(FROM_N1.read_text() + "planner: {alternatives: 1}\n")
    assert main(["plan", str(path), "--agent", "guide", "--task", "goto(n40)", "--json"]) == 0
    assert json.loads(capsys.readouterr().out)["alternatives"] == 1


@pytest.mark.parametrize(
    ("agent", "task", "place", "reason"),
    [
        ("butler", "goto(n1)", "--agent", "no agent named 'butler'; the agents are guide, navigator"),
        ("guide", "goto(n1", "--task", "missing ')'"),
        ("guide", "goto n1", "--task", "no spaces"),
        ("guide", "fly(n1)", "--task", "has no task fly"),
        ("guide", "goto(n99)", "--task", "unknown node 'n99'"),
        ("navigator", "goto_node(n1,n2)", "--task", "takes 1 argument"),
    ],
)
def test_plan_with_a_bad_agent_or_task_is_a_one_line_error(
    capsys: pytest.CaptureFixture[str], agent: str, task: str, place: str, reason: str
) -> None:
    assert main(["plan", str(FROM_N1), "--agent", agent, "--task", task]) == 2
    out, err = capsys.readouterr()
    assert out == ""
    line = one_error_line(err)
    assert line.startswith(f"htnagent: error: {FROM_N1}: {place}: ")
    assert reason in line


@pytest.mark.parametrize(
    "argv",
    [
        [],
        ["fly"],
        ["check"],
        ["plan", "scenarios/museum.yaml", "--agent", "guide"],
        ["plan", "scenarios/museum.yaml", "--task", "goto(n1)"],
        ["run", "scenarios/museum.yaml", "--replanning", "lazy"],
        ["run", "scenarios/museum.yaml", "--speed", "-2"],
        ["run", "scenarios/museum.yaml", "--speed", "fast"],
        ["check", "scenarios/museum.yaml", "--verbose"],
    ],
)
def test_usage_errors_exit_2_with_one_line(capsys: pytest.CaptureFixture[str], argv: list[str]) -> None:
    assert main(argv) == 2
    out, err = capsys.readouterr()
    assert out == ""
    one_error_line(err)


def test_help_exits_0(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["--help"]) == 0
    assert "check" in capsys.readouterr().out


# -- a user's domain as package.module:attribute --------------------------------------------

USER_DOMAIN = '''
from htnagent import Domain
from htnagent.domains import domain_factory
from htnagent.model.terms import atoms


@domain_factory
def make(world):
    """A tiny domain: greet(X) is said aloud, one say per visitor."""
    d = Domain("greeter")
    d.operator("say(?x)", pre=["visitor(?x)"], cost=2.0)
    d.method("greet(?x)", "aloud", when=["visitor(?x)"], do=["say(?x)"])
    d.facts = tuple(d.facts) + tuple(atoms(["visitor(bob)"]))
    return d


READY = make(None)
NOT_A_DOMAIN = 42


@domain_factory
def wrong_kind(world):
    return "a string"


@domain_factory
def broken(world):
    raise RuntimeError("no map for me")


def not_marked(world):
    return make(world)
'''


@pytest.fixture
def user_module(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> str:
    """A module defining user domains, importable under a fresh name."""
    name = f"user_domain_{uuid.uuid4().hex[:8]}"
    (tmp_path / f"{name}.py").write_text(USER_DOMAIN)
    monkeypatch.syspath_prepend(str(tmp_path))
    return name


def user_scenario(tmp_path: Path, domain: str) -> Path:
    shutil.copy(SCENARIOS / "museum_map.yaml", tmp_path)
    data = {
        "name": "a user's domain",
        "map": "museum_map.yaml",
        "robot": {"start": "n1", "speed": 1.0},
        "agents": [{"name": "host", "domain": domain, "executor": "robot"}],
        "goals": [{"agent": "host", "task": "greet(bob)"}],
    }
    path = tmp_path / "user.yaml"
    path.write_text(yaml.safe_dump(data))
    return path


@pytest.mark.parametrize("attribute", ["make", "READY"])
def test_a_user_domain_given_as_module_attribute_plans(
    tmp_path: Path, user_module: str, capsys: pytest.CaptureFixture[str], attribute: str
) -> None:
    path = user_scenario(tmp_path, f"{user_module}:{attribute}")
    assert main(["check", str(path)]) == 0
    assert capsys.readouterr().out == "ok\n"
    assert main(["plan", str(path), "--agent", "host", "--task", "greet(bob)", "--json"]) == 0
    assert json.loads(capsys.readouterr().out) == {"plan": ["say(bob)"], "cost": 2.0, "alternatives": 1}


@pytest.mark.parametrize(
    ("attribute", "reason"),
    [
        ("NOT_A_DOMAIN", ":NOT_A_DOMAIN is a int, not a Domain"),
        ("wrong_kind", ":wrong_kind(map) returned a str, not a Domain"),
        ("broken", ":broken(map) failed: RuntimeError: no map for me"),
        ("missing", "has no attribute 'missing'"),
        ("not_marked", ":not_marked is a function, not a Domain nor a function marked @htnagent.domains"),
    ],
)
def test_a_user_domain_that_is_not_a_domain_is_refused(
    tmp_path: Path, user_module: str, capsys: pytest.CaptureFixture[str], attribute: str, reason: str
) -> None:
    path = user_scenario(tmp_path, f"{user_module}:{attribute}")
    assert main(["check", str(path)]) == 2
    line = one_error_line(capsys.readouterr().err)
    assert line.startswith(f"htnagent: error: {path}: agents[0].domain: ")
    assert reason in line
