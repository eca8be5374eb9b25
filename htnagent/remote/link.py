"""One Zenoh session, safely configured, and the bridge from its threads into the event loop.

- :func:`zenoh_config`: peer mode, no multicast or gossip scouting (nothing is
  discovered, nothing answers on the network), listening only on the
  endpoints given (none by default: Zenoh's own default listens on every
  interface), connecting only to those given, and a lease of 1 s, so that a
  frozen peer is noticed within about a second.
- :class:`Keys`: the key space of one remote agent, under the scenario's namespace.
- :class:`LoopBridge`: Zenoh calls back on threads of its own; items are
  handed to the event loop without waiting (``call_soon_threadsafe`` under
  asyncio, ``run_sync_soon`` under trio).  Waiting there (``from_thread.run_sync``)
  would deadlock closing the session, which waits for its callbacks.
- :class:`Link`: the session as an async context manager: opened and closed on a
  worker thread (closing with a time limit, shielded), with its subscribers,
  publishers and liveliness token.
"""

from __future__ import annotations

import asyncio
import json
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from types import TracebackType
from typing import Any, Self

import anyio
import anyio.to_thread
import zenoh

from htnagent.errors import RemoteError
from htnagent.log import library_log

log = library_log()

LEASE_MS = 1000
"""A peer that sends nothing for this long is gone (Zenoh's default is 10 s)."""
RETRY_MS = (100, 500)
"""How soon, and at most how seldom, a lost connection to a peer is tried again."""
OPEN_MS = 500
"""How long opening a connection to a peer may take (a frozen one never answers)."""
CLOSE_WITHIN = 2.0
"""Wall-clock seconds closing a session may take before it is left to finish alone."""
BLOCKED_PUT_MS = 2000
"""A put blocked this long by a peer that reads nothing closes the link (Zenoh's default: 5 s)."""


def zenoh_config(listen: Sequence[str] = (), connect: Sequence[str] = ()) -> zenoh.Config:
    """Peer mode, nothing scouted, listening and connecting only where told."""
    config = zenoh.Config()
    settings: list[tuple[str, object]] = [
        ("mode", "peer"),
        ("listen/endpoints", list(listen)),
        ("connect/endpoints", list(connect)),
        (
            "connect/retry",
            {"period_init_ms": RETRY_MS[0], "period_max_ms": RETRY_MS[1], "period_increase_factor": 2},
        ),
        ("scouting/multicast/enabled", False),
        ("scouting/gossip/enabled", False),
        # Opening a peer session may wait this long "for scouting" before it returns; with
        # scouting off it waited for nothing, yet now and then did (its default, 0.5 s: seen
        # when a fleet opens a link per robot at once).  Nothing here relies on the session
        # being connected when it opens: the parent waits for the serving process's token.
        ("scouting/delay", 0),
        ("transport/link/tx/lease", LEASE_MS),
        # A frozen peer accepts a connection and never answers: give up opening it soon
        # (the default, 10 s, would hold closing the session as long).
        ("transport/unicast/open_timeout", OPEN_MS),
        ("transport/unicast/accept_timeout", OPEN_MS),
        ("transport/link/tx/queue/congestion_control/block/wait_before_close", BLOCKED_PUT_MS * 1000),
    ]
    for key, value in settings:
        config.insert_json5(key, json.dumps(value))
    return config


@dataclass(frozen=True)
class Keys:
    """Where the messages to and from one remote agent go, under ``htnagent/<namespace>/<agent>``."""

    namespace: str
    agent: str

    @property
    def base(self) -> str:
        return f"htnagent/{self.namespace}/{self.agent}"

    @property
    def down(self) -> str:
        """Orders and world changes, parent to the serving process."""
        return f"{self.base}/down"

    @property
    def up(self) -> str:
        """Results, progress, trace events and the robot's state, back to the parent."""
        return f"{self.base}/up"

    @property
    def host_alive(self) -> str:
        """The serving process's liveliness token."""
        return f"{self.base}/alive/host"

    @property
    def parent_alive(self) -> str:
        """The parent process's liveliness token."""
        return f"{self.base}/alive/parent"


class LoopBridge:
    """Hands calls from any thread to the event loop it was made in, never waiting for them.

    Made inside the event loop (asyncio or trio).  After :meth:`close`, and once the
    loop has ended, calls are dropped.
    """

    def __init__(self) -> None:
        self.closed = False
        try:
            loop = asyncio.get_running_loop()
        except RuntimeError:
            import trio.lowlevel  # not asyncio: anyio runs on trio

            self._submit: Callable[..., object] = trio.lowlevel.current_trio_token().run_sync_soon
        else:
            self._submit = loop.call_soon_threadsafe

    def call_soon(self, fn: Callable[..., None], *args: Any) -> None:
        """Run ``fn(*args)`` in the event loop, soon (callable from any thread)."""
        if self.closed:
            return
        try:
            self._submit(self._run, fn, args)
        except RuntimeError:  # the loop has ended (asyncio: closed; trio: RunFinishedError)
            self.closed = True

    def _run(self, fn: Callable[..., None], args: tuple[Any, ...]) -> None:
        if not self.closed:
            fn(*args)

    def close(self) -> None:
        """Drop every call from now on."""
        self.closed = True


class Link:
    """A Zenoh session for one remote agent's link; ``async with`` opens and closes it."""

    def __init__(self, *, listen: Sequence[str] = (), connect: Sequence[str] = ()) -> None:
        self.listen = tuple(listen)
        self.connect = tuple(connect)
        self._session: zenoh.Session | None = None
        self._bridge: LoopBridge | None = None
        self._keep: list[object] = []  # what Zenoh undeclares when dropped

    async def __aenter__(self) -> Self:
        self._bridge = LoopBridge()
        config = zenoh_config(self.listen, self.connect)
        try:
            self._session = await anyio.to_thread.run_sync(zenoh.open, config)
        except zenoh.ZError as e:
            where = ", ".join(self.listen or self.connect)
            raise RemoteError(f"cannot open a Zenoh session at {where}: {' '.join(str(e).split())}") from None
        return self

    async def __aexit__(
        self, exc_type: type[BaseException] | None, exc: BaseException | None, tb: TracebackType | None
    ) -> None:
        if self._bridge is not None:
            self._bridge.close()
        session, self._session = self._session, None
        self._keep.clear()
        if session is None:
            return
        # Closing waits for Zenoh's threads; under a time limit, and shielded so that a
        # cancelled runtime still closes its session (the cancellation goes on after).
        with anyio.CancelScope(shield=True), anyio.move_on_after(CLOSE_WITHIN):
            await anyio.to_thread.run_sync(session.close, abandon_on_cancel=True)

    @property
    def session(self) -> zenoh.Session:
        if self._session is None:
            raise RemoteError("the Zenoh session is not open")
        return self._session

    @property
    def bridge(self) -> LoopBridge:
        assert self._bridge is not None, "the link is not open"
        return self._bridge

    def on_sample(self, key: str, handler: Callable[[bytes], None]) -> None:
        """Call ``handler`` in the event loop with the payload of every sample put on ``key``."""
        bridge = self.bridge

        def arrived(sample: zenoh.Sample) -> None:  # a Zenoh thread: hand over, never wait
            bridge.call_soon(handler, sample.payload.to_bytes())

        self._keep.append(self.session.declare_subscriber(key, arrived))

    def on_liveliness(self, key: str, handler: Callable[[bool], None]) -> None:
        """Call ``handler(True)`` when a liveliness token on ``key`` appears (or is there
        already), ``handler(False)`` when it goes (its session closed, or its lease ran out)."""
        bridge = self.bridge

        def changed(sample: zenoh.Sample) -> None:
            bridge.call_soon(handler, sample.kind == zenoh.SampleKind.PUT)

        self._keep.append(self.session.liveliness().declare_subscriber(key, changed, history=True))

    def publisher(self, key: str) -> Callable[[bytes], None]:
        """A function putting a payload on ``key``: reliable, in order, sent at once."""
        publisher = self.session.declare_publisher(
            key, congestion_control=zenoh.CongestionControl.BLOCK, express=True
        )
        self._keep.append(publisher)
        return lambda payload: publisher.put(payload)

    def token(self, key: str) -> None:
        """Declare this process alive on ``key`` (last: after the subscribers it answers with)."""
        self._keep.append(self.session.liveliness().declare_token(key))
