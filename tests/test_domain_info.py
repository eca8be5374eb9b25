"""Each domain declares what its arguments name on the map and which actions are the robot's moves.

The generic scenario checks ask the domain (``DomainInfo``) instead of
knowing the museum: the built-in domains declare theirs beside their factories,
a user's factory declares its own with ``@domain_factory(...)`` or nothing.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import pytest

from htnagent.domains import (
    BUILTIN,
    ROBOT_TRAVEL,
    DomainInfo,
    declared_info,
    domain_factory,
    is_domain_factory,
)
from htnagent.domains.guide_talk import talk_domain
from htnagent.domains.maps import WorldMap
from htnagent.errors import DomainError, HtnAgentError, ScenarioError
from htnagent.model.domain import Domain
from htnagent.model.terms import parse
from htnagent.scenario import Scenario, load_scenario, parse_scenario, read_yaml

SCENARIOS = Path(__file__).resolve().parents[1] / "scenarios"


def test_the_built_in_domains_declare_their_map_arguments_and_robot_moves() -> None:
    areas, nodes = BUILTIN["museum.areas"], BUILTIN["museum.nodes"]
    assert areas.kinds_of("goto") == ("node",)
    assert areas.kinds_of("move_area") == ("area", "area")
    assert areas.robot_moves == frozenset()
    assert nodes.robot_moves == frozenset({"move"})
    assert nodes.kinds_of("move") == ("node", "node", "arc")
    assert nodes.kinds_of("no_such_task") is None


def test_a_marked_factory_has_the_defaults_unless_told() -> None:
    @domain_factory
    def plain(world: WorldMap) -> Domain:
        return Domain("plain")

    info = declared_info(plain)
    assert info is not None and is_domain_factory(plain)
    assert info.factory is plain
    # No argument is checked against the map; the robot travels on move, as before domains declared it.
    assert info.argument_kinds == {} and info.robot_moves == ROBOT_TRAVEL == frozenset({"move"})


def test_a_factory_may_declare_its_arguments_and_moves() -> None:
    @domain_factory(argument_kinds={"visit": ["area"]}, robot_moves={"move"})
    def walker(world: WorldMap) -> Domain:
        return Domain("walker")

    info = declared_info(walker)
    assert info is not None
    assert info.kinds_of("visit") == ("area",)
    assert info.kinds_of("move") == ("node", "node", "arc")
    assert declared_info(talk_domain) is not None
    assert declared_info(talk_domain).robot_moves == frozenset({"move"})  # type: ignore[union-attr]


def test_an_unmarked_function_declares_nothing() -> None:
    def unmarked(world: WorldMap) -> Domain:
        return Domain("x")

    assert declared_info(unmarked) is None
    assert declared_info(BUILTIN) is None


@pytest.mark.parametrize(
    ("kwargs", "reason"),
    [
        ({"argument_kinds": {"visit": ("room",)}}, "'room' is not one of node, arc, area"),
        ({"argument_kinds": {"move": ("node",)}}, "robot move move takes"),
    ],
)
def test_a_wrong_declaration_is_a_domain_error(kwargs: dict[str, Any], reason: str) -> None:
    with pytest.raises(DomainError, match=reason):
        DomainInfo(lambda world: Domain("x"), **kwargs)


def museum(**changes: Any) -> dict[str, Any]:
    data: dict[str, Any] = read_yaml(SCENARIOS / "greeting.yaml", "scenario")
    data.update(changes)
    return data


def test_the_talk_domains_moves_are_checked_against_the_map_as_it_declares() -> None:
    data = museum()
    data["goals"].append(
        {"agent": "guide", "task": "greet(zoe)", "when": {"action": "move(n1,n2,arc999)", "progress": 0.5}}
    )
    with pytest.raises(ScenarioError, match="unknown arc 'arc999'"):
        parse_scenario(data, "greeting.yaml", SCENARIOS)


def test_a_scenario_not_built_by_the_loader_says_so() -> None:
    built = load_scenario(SCENARIOS / "museum.yaml")
    bare = Scenario.model_validate(built.model_dump(mode="json"))
    for ask in (
        lambda: bare.world,
        lambda: bare.domain_for("guide"),
        lambda: bare.robot_does(parse("move(a,b,c)")),
    ):
        with pytest.raises(HtnAgentError, match="not built by load_scenario"):
            ask()


GREETER = """
from htnagent.domains import domain_factory
from htnagent.domains.museum import nodes_domain


@domain_factory
def greeter(world):
    d = nodes_domain(world)
    d.operator("greet(?v)", add=["greeted(?v)"], cost=1.0)
    return d
"""


def test_an_undeclared_user_domain_keeps_the_robots_move(tmp_path: Path) -> None:
    # The greeter of docs/howto/own-domain.md declares nothing: the robot still travels on its move,
    # part way included.
    (tmp_path / "my_greeter.py").write_text(GREETER)
    data = museum(map=str(SCENARIOS / "museum_map.yaml"))
    data["agents"] = [{"name": "guide", "domain": "my_greeter:greeter", "executor": "robot"}]
    data["robot"]["durations"] = {"greet": 3}
    data["goals"] = [
        {"agent": "guide", "task": "goto_node(n38)"},
        {"agent": "guide", "task": "greet(bob)", "when": {"action": "move(n40,n38,arc58)", "progress": 0.5}},
    ]
    scenario = parse_scenario(data, str(tmp_path / "s.yaml"), tmp_path)
    assert scenario.robot_does(parse("move(n40,n38,arc58)"))
    assert scenario.robot_does(parse("greet(bob)"))
    assert not scenario.robot_does(parse("goto_node(n38)"))
