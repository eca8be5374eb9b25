"""The serving side: one agent of a scenario, with everything below it, for a parent elsewhere.

``python -m htnagent serve SCENARIO --agent NAME --listen ENDPOINT`` runs
:func:`serve`: the agents from NAME down (to the robot, or to the next agent
served elsewhere) in a runtime of their own, keeping wall-clock time.  Orders
from the parent's process go to NAME's mailbox at their sender's time; NAME's
results go back, each after the robot's state (what the parent's summary
shows), and so do the runtime's progress reports and trace events.  When the
parent's process goes (its liveliness token does), NAME is told
:class:`~htnagent.runtime.messages.ParentLost`, as when a parent in the same process
crashes: what it ordered is dropped.  A parent may connect again later, and is
served under its new session id.

Only the parent commands (docs/contracts.md "Agents in other processes"): the
host binds to one parent at a time, the Zenoh session whose liveliness token
appeared under the served agent's keys, and admits only its payloads, each
numbered one after the last (:mod:`htnagent.remote.gate`: replays, payloads out
of order, oversized, malformed or wrongly typed ones, and anyone else's are
refused on Zenoh's thread, before the event loop).  An order whose ``seq`` is
not above every order this parent gave before is refused too: nothing executes
twice.  What is refused is traced as ``peer_refused``, at most once a second per
sender, and never acted on.

One process may serve the agent of several scenarios (a robot each, each in a
namespace of its own) at one endpoint: their hosts share the process's one
Zenoh session (:data:`htnagent.remote.link.SESSIONS`).
"""

from __future__ import annotations

import contextlib
import dataclasses
import functools
from collections.abc import Callable, Iterable, Sequence

import anyio
from anyio.abc import TaskStatus

from htnagent.errors import ScenarioError
from htnagent.executors.robot import RobotWorld
from htnagent.log import library_log
from htnagent.model.terms import Atom
from htnagent.remote.codec import Item, Received, Relay, RobotStatus, WorldChange, encode_batch
from htnagent.remote.gate import Gate
from htnagent.remote.link import LINKS, Keys, Link, Outbox, Security
from htnagent.remote.proxy import RemoteChild, report_refusals
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
from htnagent.system.fleet import share_domains
from htnagent.system.heap import long_lived
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


_DOWN = (Execute, Suspend, Resume, Clear, Prepare, ParentLost, BeliefUpdate, WorldChange, Relay)
WAITING = 16
"""Other parents' sessions remembered while one is served (the next to serve when it goes)."""


_KEPT_HERE = (PeerLost, PeerJoined, Summary)
"""Trace events not relayed: this side of the link (the parent traces its own), the summary."""


def _goes_down(item: Item) -> bool:
    return isinstance(item, _DOWN)


class Host:
    """Serves ``agent`` of ``runtime`` (its top agent) to a parent in another process."""

    def __init__(
        self,
        runtime: Runtime,
        world: RobotWorld,
        agent: str,
        parent: str,
        keys: Keys,
        listen: str,
        security: Security | None = None,
    ):
        self.runtime = runtime
        self.world = world
        self.agent = runtime.agents[agent]
        self.keys = keys
        self.listen = listen
        self.security = security
        self.parent_up = False
        self.gate = Gate(_goes_down, "orders and the world's changes go down")
        self._answers: Mailbox[Message] = Mailbox(runtime.clock, parent)
        self.agent.connect(self._answers)  # the agent answers its parent here
        self._in_flight: set[int] = set()
        self._last_seq = 0
        self._waiting: dict[str, None] = {}  # other parents' live sessions, oldest first
        self._out: Outbox[tuple[float, Item]] | None = None
        self._me = ""
        self._relay: frozenset[str] | None = None  # the events the parent wants (None: all)

    async def serve(self, *, task_status: TaskStatus[None] = anyio.TASK_STATUS_IGNORED) -> None:
        """Serve until cancelled; started once the parent can connect."""
        async with (
            Link(listen=[self.listen], security=self.security) as link,
            anyio.create_task_group() as tg,
        ):
            self._me = link.session_id
            link.on_sample(self.keys.down, self._arrived, self.gate.admit)
            link.on_liveliness(self.keys.parent_alive, self._liveliness)
            # To the parent bound to, with the payloads of the process's other robots of the round.
            settled = self.runtime.clock.when_settled
            self._out = link.outbox(self.keys.up, self._pack, settled, peer=self._peer)
            self.runtime.subscribe(self._event)
            self.runtime.on_progress(self._progress)
            link.token(self.keys.host_alive)  # last: what the parent sends from now on is heard
            tg.start_soon(report_refusals, self.gate, self.runtime.trace.emit, self.agent.name, "parent")
            task_status.started()
            while True:
                answer = await self._answers.receive()
                if isinstance(answer, Success | Failure | Suspended):
                    self._in_flight.discard(answer.seq)
                    robot, visited, distance = robot_status(self.runtime, self.world)
                    self._publish(RobotStatus(robot=robot, visited=visited, distance=distance))
                if isinstance(answer, Success | Failure | Suspended | Refused):
                    self._publish(answer)

    def _peer(self) -> str | None:
        return self.gate.peer

    def _pack(self, items: Sequence[tuple[float, Item]], n: int) -> bytes:
        return encode_batch(items, self._me, n)

    def _publish(self, item: Item) -> None:
        if self._out is not None and self.parent_up:
            self._out.send((self.runtime.clock.now(), item))

    def _event(self, event: TraceEvent) -> None:
        # Only what the parent asked for (Relay): the rest would cost encoding here, and
        # reading, checking and tracing there, for nobody (most are the robot's actions).
        if not isinstance(event, _KEPT_HERE) and (self._relay is None or event.event in self._relay):
            self._publish(event)

    def _progress(self, progress: Progress) -> None:
        self._publish(progress)

    def _arrived(self, got: Received) -> None:
        # Admitted by the gate: the bound parent's, in order.  At the sender's time.
        for t, items in got.by_time():
            self.runtime.clock.call_from_peer(t, functools.partial(self._handle_all, items))

    def _handle_all(self, items: list[Item]) -> None:
        for item in items:
            self._handle(item)

    def _handle(self, item: Item) -> None:
        if isinstance(item, WorldChange):
            self._world_changed(item.arc, item.close)
        elif isinstance(item, Relay):
            self._relay = item.events
        elif isinstance(item, Execute | Resume):
            if item.seq <= self._last_seq:
                # The parent numbers its orders upwards: this one was ordered before.
                peer = self.gate.peer or "unknown"
                self.gate.refuse(peer, f"order {item.seq} again: nothing executes twice")
                return
            self._last_seq = item.seq
            self._in_flight.add(item.seq)
            self.agent.inbox.send(item)
        elif isinstance(item, Suspend | Clear | Prepare | ParentLost | BeliefUpdate):
            self.agent.inbox.send(item)
        # Nothing else comes down: the gate let nothing else through.

    def _world_changed(self, arc: str, close: bool) -> None:
        if close:
            self.world.closed.add(arc)
        else:
            self.world.closed.discard(arc)
        fact = Atom("closed", (arc,))
        for agent in self.runtime.agents.values():
            agent.inbox.send(BeliefUpdate(add=(fact,)) if close else BeliefUpdate(delete=(fact,)))
        world_changed(self.runtime, arc, close)

    def _liveliness(self, alive: bool, session: str) -> None:
        if alive:
            self._bind(session)
            return
        self._waiting.pop(session, None)
        if not self.gate.unbind(session):
            return  # another parent's session, never served
        self._parent_lost()
        # A parent that restarted may have joined before the old one's lease ran out.
        while self._waiting and not self.parent_up:
            waiting = next(iter(self._waiting))
            del self._waiting[waiting]
            self._bind(waiting)

    def _bind(self, session: str) -> None:
        held = self.gate.bind(session)
        if held is None:
            if session != self.gate.peer:
                # Another parent while one is served: remembered, never heard meanwhile.
                if len(self._waiting) < WAITING:
                    self._waiting[session] = None
                self.gate.refuse(session, f"another parent while session {self.gate.peer} is served")
            return
        self.parent_up = True
        self._last_seq = 0
        self._relay = None  # a new parent is sent every event until it says otherwise
        self.runtime.trace.emit(PeerJoined(agent=self.agent.name, side="parent", endpoint=self.listen))
        for got in held:
            self._arrived(got)

    def _parent_lost(self) -> None:
        self.parent_up = False
        orders = len(self._in_flight)
        self._in_flight.clear()
        self.runtime.trace.emit(
            PeerLost(agent=self.agent.name, side="parent", endpoint=self.listen, orders=orders)
        )
        # After whatever of its came before, as a crashed parent's would (docs/design.md §5).
        clock = self.runtime.clock
        clock.call_from_peer(clock.now(), lambda: self.agent.inbox.send(ParentLost()))


async def serve(
    scenario: Scenario | Sequence[Scenario],
    agent: str,
    listen: str,
    *,
    speed: float | None = None,
    observers: Iterable[Observer] = (),
    ready: Callable[[], None] | None = None,
    stop: anyio.Event | None = None,
    security: Security | None = None,
) -> None:
    """Serve ``agent`` of the scenario (and the agents below it) at ``listen`` until ``stop``
    is set or the task is cancelled; of each scenario, if several (a robot each, one
    Zenoh session for all).  ``ready`` is called once every one can be connected to."""
    scenarios = [scenario] if isinstance(scenario, Scenario) else list(scenario)
    for one in scenarios:
        check_served(one, agent)
    share_domains(scenarios)  # robots on one map: one domain each, built once
    if security is not None and security.allow:
        # Zenoh's access control: the allowed parents on these robots' keys, nothing else.
        # And the sessions' own keys, where each side puts its robots' payloads together.
        keys = (*(f"{Keys(one.key_space, agent).base}/**" for one in scenarios), f"{LINKS}/**")
        security = dataclasses.replace(security, keys=keys)
    hosts = []
    for one in scenarios:
        names = one.agent_names
        parent = names[names.index(agent) - 1]
        runtime, world = build_runtime(one, speed=1.0 if speed is None else speed, first=agent)
        for observer in observers:
            runtime.subscribe(observer)
        hosts.append(Host(runtime, world, agent, parent, Keys(one.key_space, agent), listen, security))
    async with contextlib.AsyncExitStack() as stack:
        stack.enter_context(long_lived())  # the scenarios, built: alive while serving
        for host in hosts:
            await stack.enter_async_context(host.runtime)
        async with anyio.create_task_group() as tg:
            for host in hosts:
                await tg.start(host.serve)
            if ready is not None:
                ready()
            if stop is None:
                await anyio.sleep_forever()
            else:
                await stop.wait()
            tg.cancel_scope.cancel()


__all__ = ["Host", "RemoteChild", "check_served", "serve"]
