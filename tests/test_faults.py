"""Faults inside the agent chain become reported failures, never hangs."""

from __future__ import annotations

from pathlib import Path

import anyio
import yaml

from htnagent import AgentConfig, GoalStatus, Runtime, State, parse
from htnagent.domains import areas_domain, nodes_domain
from htnagent.executors.scripted import ScriptedExecutor
from htnagent.scenario import parse_map
from tests.support import Event, record

ROOT = Path(__file__).resolve().parent.parent


async def test_a_child_agent_that_crashes_becomes_a_failed_action_for_its_parent() -> None:
    world = parse_map(yaml.safe_load((ROOT / "scenarios" / "museum_map.yaml").read_text()), "museum_map.yaml")
    areas, nodes = areas_domain(world), nodes_domain(world)

    def broken_estimate(task: object, state: State) -> float:
        raise RuntimeError("a bug in the navigator's domain")

    nodes.estimates["goto_node"] = broken_estimate
    events: list[Event] = []
    runtime = Runtime(
        [
            AgentConfig("guide", areas, areas.initial_state("n40")),
            AgentConfig("navigator", nodes, nodes.initial_state("n40")),
        ],
        lambda clock, trace: ScriptedExecutor("robot"),
    )
    with anyio.fail_after(5):  # real seconds: a hang fails the test
        async with runtime:
            runtime.subscribe(record(events))
            first = await runtime.achieve("guide", parse("goto(n38)"))
            second = await runtime.achieve("guide", parse("goto(n1)"))
    # Expect: the navigator crashes planning goto_node(n38); the guide's action fails with
    # the reason, the guide's goal fails after its retries, and the next goal still ends.
    crashed = [e for e in events if e["event"] == "agent_crashed"]
    assert [e["agent"] for e in crashed] == ["navigator"]
    assert "a bug in the navigator's domain" in crashed[0]["error"]
    failed = [e for e in events if e["event"] == "action_finished" and e["agent"] == "guide"]
    assert failed and all(e["result"] == "failure" for e in failed)
    assert "navigator crashed" in failed[0]["reason"]
    assert first.status is GoalStatus.FAILURE and "navigator crashed" in first.reason
    assert second.status is GoalStatus.FAILURE and "navigator crashed" in second.reason
