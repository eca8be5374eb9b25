"""The map file's schema and the scenario's share one wording: ``FILE: key.path: reason``.

``parse_map`` is checked by pydantic models and worded by the same translator
as the scenario file (htnagent.scenario.wording), inline (``map.`` in front of
the key path) or in a map file of its own; what refers to what (a node's area,
an arc's ends) is checked while the map is built.
"""

from __future__ import annotations

import copy
from pathlib import Path
from typing import Any

import pytest
import yaml
from pydantic import ValidationError

from htnagent.errors import HtnAgentError, ScenarioError
from htnagent.scenario import MapFile, parse_map

SMALL: dict[str, Any] = {
    "areas": {"a1": {"col": 0, "row": 0}, "a2": None},
    "nodes": {
        "n1": {"area": "a1", "x": 0, "y": 0},
        "n2": {"area": "a1", "x": 3, "y": 4},
        "n3": {"area": "a2", "x": 3.5, "y": 4.0},
    },
    "arcs": {"arc1": ["n1", "n2"], "arc2": {"ends": ["n2", "n3"], "length": 2.5}},
}


def small(**changes: Any) -> dict[str, Any]:
    data = copy.deepcopy(SMALL)
    data.update(changes)
    return data


def refused(data: object, where: str = "") -> ScenarioError:
    with pytest.raises(ScenarioError) as info:
        parse_map(data, "m.yaml", where)
    assert "\n" not in str(info.value)
    return info.value


def test_a_small_map_reads_as_written() -> None:
    world = parse_map(SMALL, "m.yaml", "")
    assert world.areas == ("a1", "a2")
    assert world.area_grid == {"a1": (0, 0)}
    assert world.nodes["n3"].x == 3.5
    assert world.arcs["arc1"].length == 5.0  # the distance of its ends
    assert world.arcs["arc2"].length == 2.5  # as given


def test_names_written_as_numbers_are_their_text() -> None:
    data = small(nodes={12: {"area": "a1", "x": 0, "y": 0}, "n2": {"area": "a1", "x": 1, "y": 0}})
    data["arcs"] = {7: [12, "n2"]}
    world = parse_map(data, "m.yaml", "")
    assert set(world.nodes) == {"12", "n2"}
    assert (world.arcs["7"].a, world.arcs["7"].b) == ("12", "n2")


@pytest.mark.parametrize(
    ("data", "where", "reason"),
    [
        ([1, 2], "map", "a map must be a mapping with areas, nodes and arcs, not a list"),
        (small(doors=[]), "map.doors", "unknown key; expected one of areas, nodes, arcs"),
        ({"areas": {"a": None}, "nodes": SMALL["nodes"]}, "map.arcs", "required, but missing"),
        (small(nodes={}), "map.nodes", "must not be empty"),
        (small(areas={"a b": None}), "map.areas.a b", "'a b' is not a valid name (no spaces"),
        (small(areas={True: None}), "map.areas", "True is not a valid name (expected text)"),
        (small(areas={1: None, "1": None}), "map.areas.1", "a second area named 1"),
        (small(areas={"a1": {"col": 1, "row": 2.5}}), "map.areas.a1.row", "expected a whole number"),
        (
            small(areas={"a1": {"colour": 1}}),
            "map.areas.a1.colour",
            "unknown key; did you mean col? expected one of col, row",
        ),
        (
            small(nodes={"n1": {"area": "a1", "x": 0, "y": 0, "z": 1}}),
            "map.nodes.n1.z",
            "unknown key; expected one of area, x, y",
        ),
        (small(nodes={"n1": {"area": "a9", "x": 0, "y": 0}}), "map.nodes.n1.area", "unknown area 'a9'"),
        (
            small(nodes={"n1": {"area": "a1", "x": True, "y": 0}}),
            "map.nodes.n1.x",
            "expected a finite number",
        ),
        (small(nodes={"n1": "a1"}), "map.nodes.n1", "expected a mapping, got text 'a1'"),
        (small(arcs={"arc1": ["n1", "n2", "n3"]}), "map.arcs.arc1", "expected 2 items, got 3"),
        (
            small(arcs={"arc1": 7}),
            "map.arcs.arc1",
            "expected [node, node] or {ends: [node, node], length: L}, got 7",
        ),
        (small(arcs={"arc1": {"ends": ["n1"]}}), "map.arcs.arc1.ends[1]", "required, but missing"),
        (small(arcs={"arc1": ["n1", None]}), "map.arcs.arc1[1]", "expected text, got None"),
        (small(arcs={"arc1": ["n1", "n9"]}), "map.arcs.arc1", "unknown node 'n9'"),
        (small(arcs={"arc1": ["n1", "n1"]}), "map.arcs.arc1", "not n1 to itself"),
        (
            small(arcs={"arc1": {"ends": ["n1", "n2"], "len": 3}}),
            "map.arcs.arc1.len",
            "expected one of ends, length",
        ),
        (small(arcs={"arc1": {"ends": ["n1", "n2"], "length": 0}}), "map.arcs.arc1.length", "greater than 0"),
    ],
)
def test_map_errors_name_the_key_path_and_the_reason(data: object, where: str, reason: str) -> None:
    error = refused(data, "map")
    assert error.file == "m.yaml"
    assert error.where == where
    assert reason in error.reason, error.reason


def test_a_map_file_of_its_own_has_no_prefix() -> None:
    error = refused(small(nodes={"n1": {"area": "a1", "x": "far", "y": 0}}))
    assert str(error) == "m.yaml: nodes.n1.x: expected a finite number, got 'far'"


def test_map_and_scenario_errors_are_htnagent_errors() -> None:
    assert issubclass(ScenarioError, HtnAgentError)
    with pytest.raises(HtnAgentError):
        parse_map(None, "m.yaml")


def test_validation_stops_at_the_first_bad_entry() -> None:
    # Only the first error is told; a hostile map of many bad nodes must not collect them all first.
    bad = {f"n{i}": {"area": "a1", "x": "far", "y": 0, "extra": 1} for i in range(10_000)}
    with pytest.raises(ValidationError) as info:
        MapFile.model_validate(small(nodes=bad))
    assert info.value.error_count() <= 2  # the first node's errors, no other node's


def test_robots_on_one_map_file_share_the_map_it_read_and_a_changed_file_is_read_again(
    tmp_path: Path,
) -> None:
    from htnagent.scenario import load_scenario
    from htnagent.system.fleet import share_domains

    (tmp_path / "map.yaml").write_text(yaml.safe_dump(small()))

    def robot(i: int) -> Path:
        path = tmp_path / f"robot{i}.yaml"
        path.write_text(
            "name: r\nmap: map.yaml\nrobot: {start: n1, speed: 1.0}\n"
            "agents: [{name: nav, domain: museum.nodes, executor: robot}]\n"
            "goals: [{agent: nav, task: goto_node(n2)}]\n"
        )
        return path

    one, two = load_scenario(robot(1)), load_scenario(robot(2))
    assert one.world is two.world  # a value, read once: equal maps are one object
    share_domains([one, two])
    assert one.domain_for("nav") is two.domain_for("nav")
    changed = small()
    changed["nodes"]["n2"]["x"] = 9.0
    (tmp_path / "map.yaml").write_text(yaml.safe_dump(changed))
    three = load_scenario(robot(3))
    assert three.world is not one.world and three.world.nodes["n2"].x == 9.0
