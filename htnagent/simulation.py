"""Running a scenario file on the simulated robot, to the end (``htnagent run``).

:func:`run_scenario` builds the agent chain of the scenario over the simulated
robot, gives the goals at their triggers, applies the world events, waits
until every goal has ended (or nothing more can happen) and returns the
summary of CONTRACTS.md.
"""

from __future__ import annotations

from collections.abc import Callable, Iterable
from dataclasses import dataclass, field
from typing import Any

import anyio

from executors.robot import Robot, RobotWorld
from htnagent.agent import AgentConfig, GoalStatus
from htnagent.clock import Clock
from htnagent.messages import BeliefUpdate
from htnagent.planset import Replanning
from htnagent.runtime import Runtime
from htnagent.scenario import GoalSpec, Scenario, Trigger
from htnagent.terms import Atom
from htnagent.trace import Event, Observer, Trace

NEVER_TRIGGERED = "never given: its trigger did not happen"
STALLED = "stalled: nothing more could happen"
INTERRUPTED = "interrupted before it ended"


@dataclass
class RunReport:
    """The end of a run: the summary event and whether every goal succeeded."""

    summary: Event
    events: list[Event] = field(default_factory=list)
    interrupted: bool = False
    """The run was stopped (``stop`` was set) before every goal ended."""

    @property
    def succeeded(self) -> bool:
        """Every goal of the scenario succeeded."""
        return all(g["status"] == GoalStatus.SUCCESS.value for g in self.summary["goals"])


def build_runtime(
    scenario: Scenario, *, replanning: str | None = None, speed: float | None = None
) -> tuple[Runtime, RobotWorld]:
    """The scenario's agents over a simulated robot, ready to enter."""
    mode = Replanning(replanning or scenario.replanning)
    world = RobotWorld(scenario.world, at=scenario.robot.start)
    configs = [
        AgentConfig(
            name=spec.name,
            domain=scenario.domain_for(spec.name),
            belief=scenario.initial_state(spec.name),
            replanning=mode,
            settings=scenario.settings,
            action_timeout=scenario.action_timeout,
        )
        for spec in scenario.agents
    ]

    def robot(clock: Clock, trace: Trace) -> Robot:
        return Robot(
            "robot",
            clock,
            trace,
            world,
            scenario.robot.speed,
            scenario.robot.failure_rate,
            scenario.robot.seed,
            scenario.robot.durations,
        )

    return Runtime(configs, robot, speed=speed), world


async def run_scenario(
    scenario: Scenario,
    *,
    replanning: str | None = None,
    speed: float | None = None,
    observers: Iterable[Observer] = (),
    keep_events: bool = False,
    on_start: Callable[[Runtime], None] | None = None,
    stop: anyio.Event | None = None,
) -> RunReport:
    """Run the scenario to the end and return its summary (the last event published).

    ``on_start`` is called with the runtime before anything runs (for measurements).
    Setting ``stop`` ends the run early: goals not yet ended fail as interrupted,
    and the summary of what was done is still published.
    """
    interrupted = False
    runtime, world = build_runtime(scenario, replanning=replanning, speed=speed)
    if on_start is not None:
        on_start(runtime)
    events: list[Event] = []
    if keep_events:
        runtime.subscribe(events.append)
    for observer in observers:
        runtime.subscribe(observer)
    tickets: list[int | None] = [None] * len(scenario.goals)
    settled = anyio.Event()

    async with runtime:
        clock = runtime.clock

        def give(index: int, goal: GoalSpec) -> None:
            tickets[index] = runtime.submit(goal.agent, goal.task, emergency=goal.emergency)

        def apply_event(close: bool, arc: str) -> None:
            fact = Atom("closed", (arc,))
            if close:
                world.closed.add(arc)
            else:
                world.closed.discard(arc)
            runtime.trace.emit("world", "arc_closed" if close else "arc_opened", arc=arc)
            for agent in runtime.agents.values():
                agent.inbox.send(BeliefUpdate(add=(fact,)) if close else BeliefUpdate(delete=(fact,)))

        watchers: list[tuple[Trigger, Callable[[], None]]] = []

        def schedule(trigger: Trigger | None, fire: Callable[[], None]) -> None:
            if trigger is None:
                fire()
            elif trigger.time is not None:
                clock.call_at(trigger.time, fire)
            else:
                watchers.append((trigger, fire))

        def watch(event: Event) -> None:
            # An action trigger fires once, when the first robot motion (or timed
            # action) of that action reaches the given fraction of its duration.
            if event["event"] not in ("robot_moving", "robot_acting") or not watchers:
                return
            for item in list(watchers):
                trigger, fire = item
                if str(trigger.action) == event["action"]:
                    watchers.remove(item)
                    progress = trigger.progress if trigger.progress is not None else 1.0
                    clock.call_later(progress * float(event["duration"]), fire)

        runtime.subscribe(watch)
        for i, goal in enumerate(scenario.goals):
            schedule(goal.when, lambda i=i, goal=goal: give(i, goal))  # type: ignore[misc]
        for ev in scenario.events:
            schedule(ev.when, lambda ev=ev: apply_event(ev.closes, ev.arc))  # type: ignore[misc]

        def check_done() -> None:
            if all(t is not None and runtime.outcomes[t].done for t in tickets):
                settled.set()

        def on_idle() -> None:
            # Nothing is in flight and no timer is left: nothing more can happen.
            settled.set()

        clock.on_idle(on_idle)
        runtime.subscribe(lambda e: check_done() if e["event"] == "goal_finished" else None)
        check_done()

        async def interrupt(stop: anyio.Event) -> None:
            nonlocal interrupted
            await stop.wait()
            interrupted = not settled.is_set()
            settled.set()

        async with anyio.create_task_group() as waiting:
            if stop is not None:
                waiting.start_soon(interrupt, stop)
            await settled.wait()
            waiting.cancel_scope.cancel()
        runtime.fail_unfinished(INTERRUPTED if interrupted else STALLED)
        summary = _summary(scenario, runtime, world, tickets)
        runtime.trace.emit("runtime", "summary", **summary)
    final = events[-1] if keep_events else {"event": "summary", **summary}
    return RunReport(summary=final, events=events, interrupted=interrupted)


def _travelled(runtime: Runtime, world: RobotWorld) -> float:
    """Metres travelled, counting the part of an arc the robot is on when the run ends."""
    robot = runtime.executor
    return robot.travelled() if isinstance(robot, Robot) else world.distance


def _summary(
    scenario: Scenario, runtime: Runtime, world: RobotWorld, tickets: list[int | None]
) -> dict[str, Any]:
    goals = []
    for goal, ticket in zip(scenario.goals, tickets, strict=True):
        if ticket is None:
            status, reason = GoalStatus.FAILURE.value, NEVER_TRIGGERED
        else:
            outcome = runtime.outcomes[ticket]
            status = outcome.status.value if outcome.status is not None else GoalStatus.FAILURE.value
            reason = outcome.reason
        row: dict[str, Any] = {"agent": goal.agent, "goal": str(goal.task), "status": status}
        if status != GoalStatus.SUCCESS.value and reason:
            row["reason"] = reason
        goals.append(row)
    return {
        "goals": goals,
        "robot": world.where(),
        "visited": list(world.visited),
        "distance": round(_travelled(runtime, world), 6),
        "planning_ms": {name: round(a.stats.seconds * 1000, 3) for name, a in runtime.agents.items()},
    }
