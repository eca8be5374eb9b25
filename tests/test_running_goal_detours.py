"""A plan repaired while the running goal's action ran is weighed again where the action ends.

A door shuts on the route while the robot walks an arc.  On-line repairs the plan at once,
from the belief it has while the move runs (the robot at the move's start): the best way
from there may not begin with the move under way.  When the move ends, §2.1 keeps that plan
valid by putting the move's undo in front — a walk back.  Naive, whose plan broke, plans
afresh where the move ended.  On-line must be no worse (§2.4): the undo detour is weighed
against the goal's own way from there (found by an outside check: 45.61 m against 28.87 m).
"""

from __future__ import annotations

from typing import Any

import pytest

from htnagent.scenario import parse_scenario
from htnagent.system.simulation import run_scenario


def _door_shuts_during_a_move() -> dict[str, Any]:
    # n1 -> n4.  The robot walks n1 -> n2 (10 m) for n2-n3-n4; at 2 s aX (n3-n4) shuts.
    # From n1 the best way is then n1-n5-n4; from n2, where the move ends, n2-n6-n4.
    return {
        "name": "a door shuts while the robot walks",
        "map": {
            "areas": {"area1": {"col": 0, "row": 0}},
            "nodes": {
                "n1": {"area": "area1", "x": 0, "y": 0},
                "n2": {"area": "area1", "x": 10, "y": 0},
                "n3": {"area": "area1", "x": 15, "y": 0},
                "n4": {"area": "area1", "x": 20, "y": 0},
                "n5": {"area": "area1", "x": 10, "y": -8},
                "n6": {"area": "area1", "x": 15, "y": 8},
            },
            "arcs": {
                "a12": ["n1", "n2"],
                "a23": ["n2", "n3"],
                "aX": ["n3", "n4"],
                "a15": ["n1", "n5"],
                "a54": ["n5", "n4"],
                "a26": ["n2", "n6"],
                "a64": ["n6", "n4"],
            },
        },
        "robot": {"start": "n1", "speed": 1.0},
        "agents": [{"name": "navigator", "domain": "museum.nodes", "executor": "robot"}],
        "goals": [{"agent": "navigator", "task": "goto_node(n4)"}],
        "events": [{"when": {"time": 2}, "close": "aX"}],
    }


async def test_a_repair_made_while_the_move_ran_does_not_walk_back_when_it_ends() -> None:
    scenario = parse_scenario(_door_shuts_during_a_move(), "<test>")
    online = await run_scenario(scenario, replanning="online")
    naive = await run_scenario(scenario, replanning="naive")
    assert online.succeeded and naive.succeeded
    assert list(online.summary.visited) == ["n1", "n2", "n6", "n4"] == list(naive.summary.visited)
    assert online.summary.distance == pytest.approx(naive.summary.distance)
