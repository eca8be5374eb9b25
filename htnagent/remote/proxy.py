"""The parent's side: an executor actor standing in for an agent another process serves.

:class:`RemoteChild` is, to its parent agent, an executor like any other — and,
like a child agent, one whose orders are whole goals (its ``agent_domain`` is
the remote agent's).  It forwards the parent's orders (and the world's changes)
to the serving process and relays what comes back: results to the parent,
progress to the runtime's listeners (what triggers follow), trace events to the
runtime's trace, the robot's state for the summary.

A lost peer is a reported failure, never a hang (docs/contracts.md "Agents in
other processes"): when the serving process's liveliness token goes — its
process died, or it froze and its lease ran out — every order in flight fails
with ``peer lost`` and ``peer_lost`` is traced; until the token is back
(``peer_joined``), new orders fail at once.  Only the serving process whose
token it bound to is heard (:mod:`htnagent.remote.gate`): anything else on the
``up`` key is refused and traced as ``peer_refused``, at most once a second per
sender.  Start-up waits
``scenario.peer_wait`` seconds for the peer, then raises
:class:`~htnagent.errors.RemoteError`.
"""

from __future__ import annotations

import functools
from collections.abc import Callable, Sequence

import anyio
from anyio.abc import TaskStatus

from htnagent.errors import RemoteError
from htnagent.log import library_log
from htnagent.model.domain import Domain
from htnagent.remote.codec import Item, Received, Relay, RobotStatus, WorldChange, encode_batch
from htnagent.remote.gate import Gate
from htnagent.remote.link import Keys, Link, Outbox, Security
from htnagent.runtime.clock import Clock
from htnagent.runtime.events import PeerJoined, PeerLost, PeerRefused, TraceEvent
from htnagent.runtime.executor import ExecutorActor
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
from htnagent.runtime.trace import Trace

log = library_log()

PEER_LOST = "peer lost"
"""The start of the reason of every order that failed because its peer went."""
REPORT_EVERY = 1.0
"""Wall-clock seconds between two ``peer_refused`` events about one peer, at least."""


_UP = (Success, Failure, Suspended, Refused, Progress, TraceEvent, RobotStatus)
"""What may come up from a serving process (a tuple: ``A | B`` would build a union every call)."""
_RESULTS = (Success, Failure, Suspended, Refused)
_THEIR_SIDE = (PeerLost, PeerJoined)


def _goes_up(item: Item) -> bool:
    return isinstance(item, _UP)


async def report_refusals(gate: Gate, emit: Callable[[PeerRefused], None], agent: str, side: str) -> None:
    """Trace what ``gate`` refused, once every :data:`REPORT_EVERY` seconds (until cancelled)."""
    while True:
        await anyio.sleep(REPORT_EVERY)
        for r in gate.refusals():
            emit(PeerRefused(agent=agent, side=side, peer=r.peer, reason=r.reason, count=r.count))


class RemoteChild(ExecutorActor):
    """Stands in, in the parent's process, for the agent ``name`` served at ``endpoint``."""

    def __init__(
        self,
        name: str,
        clock: Clock,
        trace: Trace,
        *,
        endpoint: str,
        keys: Keys,
        domain: Domain | None = None,
        wait: float = 10.0,
        where: str = "",
        security: Security | None = None,
        relay: frozenset[str] | None = None,
    ) -> None:
        """``where``: the scenario file and key naming the endpoint, for the start-up error;
        ``relay``: the serving process's trace events (by name) to relay here (None: all)."""
        super().__init__(name, clock, trace)
        self.agent_domain = domain
        self.endpoint = endpoint
        self.keys = keys
        self.wait = wait
        self.where = where
        self.status: RobotStatus | None = None
        """The robot's state as the serving process last told it."""
        self.up = False
        """Whether the serving process is there now."""
        self._in_flight: dict[int, Execute | Resume] = {}
        self._joined = anyio.Event()
        self._lost_once = False
        self._out: Outbox[tuple[float, Item]] | None = None
        self.security = security
        self.relay = relay
        self.gate = Gate(_goes_up, "results, progress, events and the robot's state go up")
        self._me = ""

    async def run(self, *, task_status: TaskStatus[None] = anyio.TASK_STATUS_IGNORED) -> None:
        async with Link(connect=[self.endpoint], security=self.security) as link:
            # Subscribers first, the token last: the peer, once it sees the token, knows
            # that what it sends will be heard (a put before that would be lost).
            self._me = link.session_id
            link.on_sample(self.keys.up, self._arrived, self.gate.admit)
            link.on_liveliness(self.keys.host_alive, self._liveliness)
            # To the serving process bound to, with the other robots' payloads of the round.
            self._out = link.outbox(self.keys.down, self._pack, self.clock.when_settled, peer=self._peer)
            link.token(self.keys.parent_alive)
            with anyio.move_on_after(self.wait):
                await self._joined.wait()
            if not self.up:
                place = f"{self.where}: " if self.where else ""
                raise RemoteError(
                    f"{place}no process serves agent {self.name} at {self.endpoint} (namespace "
                    f"{self.keys.namespace}) within {self.wait:g} s; start it first: python -m htnagent "
                    f"serve SCENARIO --agent {self.name} --listen {self.endpoint}"
                )
            task_status.started()
            async with anyio.create_task_group() as tg:
                tg.start_soon(report_refusals, self.gate, self.trace.emit, self.name, "serving")
                while True:
                    self._forward(await self.inbox.receive())

    def _peer(self) -> str | None:
        return self.gate.peer

    # -- down ------------------------------------------------------------------------------------

    def _pack(self, items: Sequence[tuple[float, Item]], n: int) -> bytes:
        return encode_batch(items, self._me, n)

    def _publish(self, item: Item) -> None:
        if self._out is not None:
            self._out.send((self.clock.now(), item))

    def _forward(self, message: Message) -> None:
        if isinstance(message, Execute | Resume):
            if not self.up:
                self._fail(message, "new orders fail until it is back")
                return
            self._in_flight[message.seq] = message
            self.clock.add_outside()  # the answer comes from outside: the run is not over meanwhile
        elif isinstance(message, Suspend | Clear | Prepare | ParentLost | BeliefUpdate):
            if not self.up:
                return  # what it would stop or forget has failed already
        else:
            return  # results, goals and timers are not sent down
        self._publish(message)

    def world_changed(self, arc: str, close: bool) -> None:
        """A door shut or opened: tell the serving process (its robot and agents)."""
        if self.up:
            self._publish(WorldChange(arc=arc, close=close))

    def _fail(self, order: Execute | Resume, why: str) -> None:
        reason = f"{PEER_LOST}: {self.name} at {self.endpoint} is gone or frozen; {why}"
        self.reply(Failure(action=order.action, seq=order.seq, reason=reason))

    # -- up --------------------------------------------------------------------------------------

    def _arrived(self, got: Received) -> None:
        # Admitted by the gate: from the serving process bound to, in order.  Handled in the
        # sender's order, at the sender's time (the clocks keep in step).
        for t, items in got.by_time():
            self.clock.call_from_peer(t, functools.partial(self._handle_all, items))

    def _handle_all(self, items: list[Item]) -> None:
        for item in items:
            self._handle(item)

    def _handle(self, item: Item) -> None:
        # Trace events first: most of what comes up is one (about 7 in 10 of a robot's items).
        if isinstance(item, TraceEvent):
            if not isinstance(item, _THEIR_SIDE):  # its side of the link: ours is traced here
                self.trace.emit(item)
        elif isinstance(item, Progress):
            self.progress.report(item)
        elif isinstance(item, _RESULTS):
            order = self._in_flight.get(item.seq)
            if order is None:
                return  # an answer to an order that failed when the peer was lost
            if not isinstance(item, Refused):
                del self._in_flight[item.seq]
                self.clock.done_outside()
            if self.reply_to is not None:
                self.reply_to.send(item)  # the serving process traced the message
        elif isinstance(item, RobotStatus):
            self.status = item

    def _liveliness(self, alive: bool, session: str) -> None:
        if alive:
            held = self.gate.bind(session)
            if held is None:
                if session != self.gate.peer:
                    self.gate.refuse(session, f"another serving process while {self.gate.peer} serves")
                return
            self._joined_as(held)
        elif self.gate.unbind(session):
            self._lost()

    def _joined_as(self, held: list[Received]) -> None:
        if not self.up:
            self.up = True
            self._joined.set()
            self.trace.emit(PeerJoined(agent=self.name, side="serving", endpoint=self.endpoint))
            if self.relay is not None:
                self._publish(Relay(events=self.relay))  # first: before anything it would trace
            if self._lost_once:
                # It may be the same process, come back from a freeze, still holding what was
                # ordered before: nobody awaits that any more.
                self._publish(ParentLost())
        for got in held:
            self._arrived(got)

    def _lost(self) -> None:
        if self.up:
            self.up = False
            self._lost_once = True
            failed = list(self._in_flight.values())
            self._in_flight.clear()
            if failed:
                self.clock.done_outside(len(failed))
            self.trace.emit(
                PeerLost(agent=self.name, side="serving", endpoint=self.endpoint, orders=len(failed))
            )
            for order in failed:
                self._fail(order, "the order in flight is lost")
