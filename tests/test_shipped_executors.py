"""The shipped executors stand on the public :class:`~htnagent.runtime.executor.Executor`.

As httpx's ``MockTransport`` is a transport, the scripted executor and the
simulated robots are executors as a user writes one: they run through the same
adapter, and what they use (the clock, progress reports, the trace) a user's
executor has too.  The second test is such a user's robot: written against the
public interface alone, it drives a museum run, with an emergency triggered by
its progress, to exactly the trace the shipped robot gives.
"""

from __future__ import annotations

import functools
import importlib
import inspect
import pkgutil
from typing import Any

import anyio
import pytest

import htnagent.executors
import htnagent.system.simulation
from htnagent.executors.hddl_robot import HddlRobot
from htnagent.executors.robot import Robot, RobotWorld
from htnagent.executors.scripted import ScriptedExecutor
from htnagent.model.actions import action_rolled_back_by
from htnagent.model.terms import Atom
from htnagent.runtime.events import RobotMoving
from htnagent.runtime.executor import ActionOutcome, Alarm, Executor, ExecutorActor
from htnagent.runtime.progress import Phase
from htnagent.scenario import parse_scenario
from htnagent.system.simulation import run_scenario
from tests.support import events_of, half_way_emergency, summary_of, without_wall_clock
from tests.test_triggers import MOVE_LENGTH, SCENARIOS


def shipped_executor_classes() -> set[type]:
    """Every executor class defined in the ``htnagent.executors`` package."""
    found: set[type] = set()
    for info in pkgutil.iter_modules(htnagent.executors.__path__):
        module = importlib.import_module(f"htnagent.executors.{info.name}")
        for _, cls in inspect.getmembers(module, inspect.isclass):
            if cls.__module__ == module.__name__ and issubclass(cls, Executor | ExecutorActor):
                found.add(cls)
    return found


def test_every_shipped_executor_is_a_public_executor_not_an_actor() -> None:
    shipped = shipped_executor_classes()
    assert shipped >= {ScriptedExecutor, Robot, HddlRobot}
    for cls in shipped:
        assert issubclass(cls, Executor), cls
        assert ExecutorActor not in cls.__mro__, cls


# -- a user's robot, written against the public interface only ----------------------------------


class Walker(Executor):
    """A user's museum robot: it walks arcs at ``speed``, stops half way when asked, and walks
    the rest (``resume``) or back (``rollback``) later.  Doors and talk are not its business."""

    def __init__(self, world: RobotWorld, speed: float, *_: Any, name: str = "robot") -> None:
        self.name = name
        self.world = world
        self.speed = speed
        self.walking: tuple[Atom, Atom, Alarm, float, float] | None = None  # action, move, alarm, from, to
        self.half: dict[Atom, float] = {}  # moves stopped half way: the fraction covered
        self.distance = 0.0
        if world.at is not None:
            world.visited.append(world.at)

    def travelled(self) -> float:
        return self.distance

    async def execute(self, action: Atom) -> ActionOutcome:
        move = action_rolled_back_by(action)
        if move is not None:
            return await self._walk(action, move, self.half.pop(move), 0.0, resumed=False)
        return await self._walk(action, action, 0.0, 1.0, resumed=False)

    async def resume(self, action: Atom) -> ActionOutcome:
        return await self._walk(action, action, self.half.pop(action), 1.0, resumed=True)

    def _length(self, move: Atom) -> float:
        return self.world.world.arcs[str(move.args[2])].length

    async def _walk(
        self, action: Atom, move: Atom, start: float, end: float, *, resumed: bool
    ) -> ActionOutcome:
        seconds = abs(end - start) * self._length(move) / self.speed
        alarm = self.context.alarm(seconds)
        self.walking = (action, move, alarm, start, end)
        done = start if resumed else 0.0
        self.context.report_progress(action, Phase.STARTED, seconds, done)
        self.context.emit(
            RobotMoving(
                agent=self.name,
                action=str(action),
                arc=str(move.args[2]),
                duration=round(seconds, 6),
                done=round(done, 6),
                resumed=resumed,
            )
        )
        if not await alarm.wait():
            return ActionOutcome.SUSPENDED
        self.walking = None
        self.distance += abs(end - start) * self._length(move)
        self.world.at = str(move.args[1] if end >= 1.0 else move.args[0])
        self.world.visited.append(self.world.at)
        return ActionOutcome.SUCCESS

    def can_suspend(self, action: Atom) -> bool:
        return self.walking is not None and self.walking[0] == action and not self.walking[2].rang

    async def suspend(self, action: Atom) -> None:
        assert self.walking is not None
        _, move, alarm, start, end = self.walking
        alarm.stop()
        self.walking = None
        covered = (self.context.now() - alarm.started_at) / alarm.seconds if alarm.seconds else 1.0
        fraction = start + (end - start) * covered
        self.half[move] = fraction
        self.distance += abs(fraction - start) * self._length(move)
        self.world.at = None
        self.context.report_progress(action, Phase.STOPPED)


# The emergency comes half way through the walk (its progress): the walk stops, is rolled
# back or resumed, and both goals end.
HALF_WAY = {"name": "half way", "map": "museum_map.yaml", **half_way_emergency()}


def test_a_users_executor_with_the_clock_progress_and_trace_runs_as_the_robot_does(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    scenario = parse_scenario(HALF_WAY, "half_way.yaml", SCENARIOS)
    run = functools.partial(run_scenario, scenario, keep_events=True)
    shipped = anyio.run(run)
    monkeypatch.setattr(htnagent.system.simulation, "Robot", Walker)
    users = anyio.run(run)
    # Expect: the emergency comes when the walk is half done (its progress), and the whole
    #         run — every event, its time, the nodes reached, the distance — is the robot's.
    emergency = [e for e in events_of(users) if e["event"] == "goal_received" and e["emergency"]]
    assert [e["t"] for e in emergency] == [pytest.approx(MOVE_LENGTH / 2)]  # arc59 at 1 m/s
    assert without_wall_clock(events_of(users)) == without_wall_clock(events_of(shipped))
    assert without_wall_clock(summary_of(users)["goals"]) == without_wall_clock(summary_of(shipped)["goals"])
    assert all(g["status"] == "success" for g in summary_of(users)["goals"])
