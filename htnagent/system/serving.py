"""The serving side: one agent of a scenario, with everything below it, for a parent elsewhere.

``python -m htnagent serve SCENARIO --agent NAME --listen ENDPOINT`` runs
:func:`serve`: the agents from NAME down (to the robot, or to the next agent
served elsewhere) in a runtime of their own, keeping wall-clock time.  Orders
from the parent's process go to NAME's mailbox at their sender's time; NAME's
results go back, each after the robot's state (what the parent's summary
shows), and so do the runtime's progress reports and trace events.  When the
parent's process goes (its liveliness token does), NAME is told
:class:`~htnagent.runtime.messages.ParentLost`, as when a parent in the same process
crashes: what it ordered is dropped.  A parent may connect again later.
"""

from __future__ import annotations

import functools
from collections.abc import Callable, Iterable

import anyio

from htnagent.errors import ScenarioError
from htnagent.executors.robot import RobotWorld
from htnagent.log import library_log
from htnagent.model.terms import Atom
from htnagent.remote.codec import CodecError, Item, RobotStatus, WorldChange, decode, encode
from htnagent.remote.link import Keys, Link
from htnagent.remote.proxy import RemoteChild
from htnagent.runtime.clock import Mailbox
from htnagent.runtime.events import PeerJoined, PeerLost, Summary, TraceEvent
from htnagent.runtime.messages import (
    BeliefUpdate,
    Clear,
    Execute,
    Failure,
    Message,
    ParentLost,
    Prepare,
    Refused,
    Resume,
    Success,
    Suspend,
    Suspended,
)
from htnagent.runtime.progress import Progress
from htnagent.runtime.trace import Observer
from htnagent.scenario import Scenario
from htnagent.system.runtime import Runtime
from htnagent.system.simulation import build_runtime, robot_status, world_changed

log = library_log()


def check_served(scenario: Scenario, agent: str) -> None:
    """Raise ScenarioError (``--agent``) unless ``agent`` is one a process may serve."""
    names = scenario.agent_names
    if agent not in names:
        raise ScenarioError(
            scenario.file, "--agent", f"no agent named {agent!r}; the agents are {', '.join(names)}"
        )
    if names.index(agent) == 0:
        raise ScenarioError(
            scenario.file,
            "--agent",
            f"{agent} is the first agent: goals are given to it by run; serve an agent below it",
        )


class Host:
    """Serves ``agent`` of ``runtime`` (its top agent) to a parent in another process."""

    def __init__(self, runtime: Runtime, world: RobotWorld, agent: str, parent: str, keys: Keys, listen: str):
        self.runtime = runtime
        self.world = world
        self.agent = runtime.agents[agent]
        self.keys = keys
        self.listen = listen
        self.parent_up = False
        self._answers: Mailbox[Message] = Mailbox(runtime.clock, parent)
        self.agent.connect(self._answers)  # the agent answers its parent here
        self._in_flight: set[int] = set()
        self._put: Callable[[bytes], None] | None = None

    async def serve(self, *, ready: Callable[[], None] | None = None) -> None:
        """Serve until cancelled; ``ready`` is called once the parent can connect."""
        async with Link(listen=[self.listen]) as link:
            link.on_sample(self.keys.down, self._arrived)
            link.on_liveliness(self.keys.parent_alive, self._liveliness)
            self._put = link.publisher(self.keys.up)
            self.runtime.subscribe(self._event)
            self.runtime.on_progress(self._progress)
            link.token(self.keys.host_alive)  # last: what the parent sends from now on is heard
            if ready is not None:
                ready()
            while True:
                answer = await self._answers.receive()
                if isinstance(answer, Success | Failure | Suspended):
                    self._in_flight.discard(answer.seq)
                    robot, visited, distance = robot_status(self.runtime, self.world)
                    self._publish(RobotStatus(robot=robot, visited=visited, distance=distance))
                if isinstance(answer, Success | Failure | Suspended | Refused):
                    self._publish(answer)

    def _publish(self, item: Item) -> None:
        if self._put is not None and self.parent_up:
            self._put(encode(self.runtime.clock.now(), item))

    def _event(self, event: TraceEvent) -> None:
        if not isinstance(event, PeerLost | PeerJoined | Summary):
            self._publish(event)

    def _progress(self, progress: Progress) -> None:
        self._publish(progress)

    def _arrived(self, payload: bytes) -> None:
        try:
            t, item = decode(payload)
        except CodecError as e:
            log.warning("%s: dropping a payload: %s", self.agent.name, e)
            return
        # A payload from the parent proves it is there, and its subscriber (declared before
        # anything it sends) is known here.  Its liveliness token comes through another of
        # Zenoh's threads and may reach the event loop after its first order: without this,
        # what that order causes (the robot's progress, which the parent's triggers follow,
        # and the trace) would not be sent up.  Seen under load, with several robots.
        self._liveliness(True)
        self.runtime.clock.call_from_peer(t, functools.partial(self._handle, item))

    def _handle(self, item: Item) -> None:
        if isinstance(item, WorldChange):
            self._world_changed(item.arc, item.close)
        elif isinstance(item, Execute | Resume):
            self._in_flight.add(item.seq)
            self.agent.inbox.send(item)
        elif isinstance(item, Suspend | Clear | Prepare | ParentLost | BeliefUpdate):
            self.agent.inbox.send(item)
        # Nothing else comes down: results go up only.

    def _world_changed(self, arc: str, close: bool) -> None:
        if close:
            self.world.closed.add(arc)
        else:
            self.world.closed.discard(arc)
        fact = Atom("closed", (arc,))
        for agent in self.runtime.agents.values():
            agent.inbox.send(BeliefUpdate(add=(fact,)) if close else BeliefUpdate(delete=(fact,)))
        world_changed(self.runtime, arc, close)

    def _liveliness(self, alive: bool) -> None:
        trace = self.runtime.trace
        if alive and not self.parent_up:
            self.parent_up = True
            trace.emit(PeerJoined(agent=self.agent.name, side="parent", endpoint=self.listen))
        elif not alive and self.parent_up:
            self.parent_up = False
            orders = len(self._in_flight)
            self._in_flight.clear()
            trace.emit(PeerLost(agent=self.agent.name, side="parent", endpoint=self.listen, orders=orders))
            # After whatever of its came before, as a crashed parent's would (docs/design.md §5).
            clock = self.runtime.clock
            clock.call_from_peer(clock.now(), lambda: self.agent.inbox.send(ParentLost()))


async def serve(
    scenario: Scenario,
    agent: str,
    listen: str,
    *,
    speed: float | None = None,
    observers: Iterable[Observer] = (),
    ready: Callable[[], None] | None = None,
    stop: anyio.Event | None = None,
) -> None:
    """Serve ``agent`` of the scenario (and the agents below it) at ``listen`` until ``stop``
    is set or the task is cancelled."""
    check_served(scenario, agent)
    names = scenario.agent_names
    parent = names[names.index(agent) - 1]
    runtime, world = build_runtime(scenario, speed=1.0 if speed is None else speed, first=agent)
    for observer in observers:
        runtime.subscribe(observer)
    host = Host(runtime, world, agent, parent, Keys(scenario.key_space, agent), listen)
    async with runtime, anyio.create_task_group() as tg:
        tg.start_soon(functools.partial(host.serve, ready=ready))
        if stop is None:
            await anyio.sleep_forever()
        else:
            await stop.wait()
        tg.cancel_scope.cancel()


__all__ = ["Host", "RemoteChild", "check_served", "serve"]
