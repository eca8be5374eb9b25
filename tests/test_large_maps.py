"""Large maps: a generated museum of 102,400 nodes and some 175,000 arcs (a 10 MB file) loads whole.

``check`` on such a map took 94 s and 1.28 GB, nine tenths of it in PyYAML's
pure-Python parser.  The loader now reads libyaml's events straight into data
and the map checks cost a few operations per node.
"""

from __future__ import annotations

from pathlib import Path

import pytest

from htnagent.domains.maps import WorldMap, generate_map
from htnagent.scenario import load_scenario


def write_map(world: WorldMap, path: Path) -> None:
    """The map in the style of scenarios/museum_map.yaml (a mapping per node, a list per arc)."""
    lines = ["areas:"]
    lines += [f"  {a}: {{col: {c}, row: {r}}}" for a, (c, r) in world.area_grid.items()]
    lines += ["nodes:"]
    lines += [f"  {n.name}: {{area: {n.area}, x: {n.x}, y: {n.y}}}" for n in world.nodes.values()]
    lines += ["arcs:"]
    lines += [f"  {a.name}: [{a.a}, {a.b}]" for a in world.arcs.values()]
    path.write_text("\n".join(lines) + "\n")


SCENARIO = """\
name: a large museum
map: large_map.yaml
robot: {start: n1, speed: 1.0}
agents:
  - {name: guide, domain: museum.areas, executor: navigator}
  - {name: navigator, domain: museum.nodes, executor: robot}
goals:
  - {agent: guide, task: goto(n102400)}
  - {agent: guide, task: goto(n7), emergency: true, when: {action: move_area(area1,area2), progress: 1}}
"""


@pytest.mark.timeout(120)
def test_a_100000_node_map_loads_and_checks_whole(tmp_path: Path) -> None:
    world = generate_map(32, 32, 10, seed=7)
    assert len(world.nodes) == 102_400
    write_map(world, tmp_path / "large_map.yaml")
    (tmp_path / "large.yaml").write_text(SCENARIO)
    # (How fast: python -m bench scaling; timings are not asserted here, machines are noisy.)
    scenario = load_scenario(tmp_path / "large.yaml")
    assert len(scenario.world.nodes) == 102_400
    assert len(scenario.world.arcs) == len(world.arcs)
    assert scenario.world.nodes["n102400"] == world.nodes["n102400"]
