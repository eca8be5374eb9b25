"""Random and extreme scenarios for reliability runs (``python -m bench reliability``, tests).

- :func:`storm_data` — a random museum, one or two agents, normal goals,
  emergencies at random times (often during other emergencies), doors shut and
  opened, moves that fail at random, a per-action timeout;
- :func:`nested_storm_data` — emergencies one a second to a robot too slow to
  finish anything, so that they nest as deep as there are emergencies.

Both return the scenario as parsed YAML (for :func:`~htnagent.scenario.parse_scenario`).
"""

from __future__ import annotations

import random
from typing import Any

from htnagent.domains.maps import generate_map, map_to_yaml_data


def agent_chain(two_levels: bool) -> tuple[list[dict[str, str]], str, str]:
    """The museum agents (guide over navigator, or the navigator alone), the agent that
    takes the goals, and the name of its task to go somewhere."""
    navigator = {"name": "navigator", "domain": "museum.nodes", "executor": "robot"}
    if not two_levels:
        return [navigator], "navigator", "goto_node"
    guide = {"name": "guide", "domain": "museum.areas", "executor": "navigator"}
    return [guide, navigator], "guide", "goto"


def storm_data(seed: int) -> dict[str, Any]:
    """A random scenario (as parsed YAML) for ``seed``."""
    rng = random.Random(seed)
    world = generate_map(rng.randint(1, 3), rng.randint(1, 3), rng.randint(2, 3), seed)
    nodes = sorted(world.nodes)
    arcs = sorted(world.arcs)
    two_levels = rng.random() < 0.7
    agents, top, task = agent_chain(two_levels)
    goals: list[dict[str, Any]] = [
        {"agent": top, "task": f"{task}({rng.choice(nodes)})"} for _ in range(rng.randint(1, 3))
    ]
    for _ in range(rng.randint(0, 4)):
        goals.append(
            {
                "agent": top,
                "task": f"{task}({rng.choice(nodes)})",
                "emergency": True,
                "when": {"time": round(rng.uniform(0.0, 40.0), 2)},
            }
        )
    events: list[dict[str, Any]] = []
    for _ in range(rng.randint(0, 4)):
        arc = rng.choice(arcs)
        shut = round(rng.uniform(0.0, 60.0), 2)
        events.append({"when": {"time": shut}, "close": arc})
        if rng.random() < 0.7:
            events.append({"when": {"time": round(shut + rng.uniform(1.0, 30.0), 2)}, "open": arc})
    return {
        "name": f"storm {seed}",
        "map": map_to_yaml_data(world),
        "robot": {
            "start": rng.choice(nodes),
            "speed": 1.0,
            "failure_rate": rng.choice([0.0, 0.0, 0.05, 0.15]),
            "seed": seed,
        },
        "agents": agents,
        "action_timeout": 200.0,
        "goals": goals,
        "events": events,
    }


def nested_storm_data(count: int) -> dict[str, Any]:
    """A navigator on the museum map given ``count`` emergencies, one a second, nesting."""
    nodes = ["n38", "n35", "n31", "n29"]  # never where the robot stands
    goals: list[dict[str, Any]] = [{"agent": "navigator", "task": "goto_node(n1)"}]
    goals += [
        {
            "agent": "navigator",
            "task": f"goto_node({nodes[i % 4]})",
            "emergency": True,
            "when": {"time": 1.0 + i},
        }
        for i in range(count)
    ]
    return {
        "name": f"{count} nested emergencies",
        "map": "museum_map.yaml",
        "robot": {"start": "n40", "speed": 0.001},  # so slow that every emergency nests
        "agents": [{"name": "navigator", "domain": "museum.nodes", "executor": "robot"}],
        "goals": goals,
    }
