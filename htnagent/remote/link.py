"""Zenoh sessions, safely configured and shared, and the bridge from their threads into the event loop.

- :func:`zenoh_config`: peer mode, no multicast or gossip scouting (nothing is
  discovered, nothing answers on the network), listening only on the
  endpoints given (none by default: Zenoh's own default listens on every
  interface), connecting only to those given, and a lease of 1 s, so that a
  frozen peer is noticed within about a second; with :class:`Security`, TLS
  (``tls/`` endpoints: the root certificate, each side's certificate and key,
  mutual authentication) and Zenoh's user/password authentication.
- :class:`Keys`: the key space of one remote agent, under the scenario's namespace.
- :class:`LoopBridge`: Zenoh calls back on threads of its own (the thread that
  received the sample: no Python thread per subscriber); items are handed to the
  event loop without waiting, queued, one wake-up (``call_soon_threadsafe``
  under asyncio, ``run_sync_soon`` under trio) for every batch that arrives
  while the loop is busy.  Waiting there (``from_thread.run_sync``) would
  deadlock closing the session, which waits for its callbacks.
- :class:`Outbox`: what one side sends at one instant, put as one payload.
- :class:`Mux`: the payloads of all the robots a session sends to one peer session in a
  round of the event loop, put together as one (``htnagent/~links/<peer's session id>``);
  the peer splits them and hands each to the link of its key, as if put there.
- :class:`Link`: one robot's use of a session, as an async context manager, with
  its subscribers, publishers and liveliness tokens (undeclared when it ends).
  The session itself is the process's: :data:`SESSIONS` opens one per set of
  settings (where it listens, how it is secured) and shares it among every link
  that fits -- all the robots a process serves, all the robots a fleet's parent
  runs -- opening it on a worker thread and closing it (with a time limit,
  shielded) when its last link ends.  :func:`sessions_open` counts them.
"""

from __future__ import annotations

import asyncio
import contextlib
import json
import struct
import threading
import weakref
from collections import deque
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from types import TracebackType
from typing import Any, Generic, Self, TypeVar

import anyio
import anyio.to_thread
import zenoh

from htnagent.errors import RemoteError
from htnagent.limits import MAX_PAYLOAD_BYTES
from htnagent.log import library_log

log = library_log()
T = TypeVar("T")

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
BATCH = 256
"""Items one payload of an :class:`Outbox` carries, at most."""
LINKS = "htnagent/~links"
"""Where a session is sent the payloads of many robots together: ``LINKS/<its session id>``
(a namespace has no ``~``: no robot's keys are there)."""
MUX_PARTS = 4096
"""Payloads one put of a :class:`Mux` may carry, at most."""


@dataclass(frozen=True)
class Security:
    """How a link is secured: TLS files and Zenoh's user/password authentication.

    Listening (a serving process): ``certificate`` and ``key`` are its own, and with
    ``mutual`` a connecting peer must show a certificate signed by ``root_ca``;
    ``users_file`` is Zenoh's dictionary of ``user:password`` lines a connecting peer
    must be in.  Connecting (a parent): ``root_ca`` checks the serving process's
    certificate, ``certificate`` and ``key`` (with ``mutual``) are shown to it, and
    ``user`` and ``password`` are given to it.  The password is never shown (repr).

    ``allow`` (listening): the certificate common names (with ``mutual``) or user names
    (with ``users_file``) that may use the link at all, and then only on ``keys`` (key
    expressions): Zenoh's access control, everything else denied, in and out.  A peer
    admitted by TLS under another name connects, and nothing it sends arrives."""

    root_ca: str | None = None
    certificate: str | None = None
    key: str | None = None
    mutual: bool = False
    user: str | None = None
    password: str | None = field(default=None, repr=False)
    users_file: str | None = None
    allow: tuple[str, ...] = ()
    keys: tuple[str, ...] = ()

    def settings(self, listening: bool) -> list[tuple[str, object]]:
        """Zenoh's configuration keys (``transport/link/tls``, ``transport/auth/usrpwd``)."""
        tls = "transport/link/tls/"
        side = "listen" if listening else "connect"
        found: list[tuple[str, object]] = []
        if self.root_ca is not None:
            found.append((tls + "root_ca_certificate", self.root_ca))
        if self.certificate is not None and self.key is not None:
            found += [(f"{tls}{side}_certificate", self.certificate), (f"{tls}{side}_private_key", self.key)]
        if self.mutual:
            # Both sides: the listener asks for the peer's certificate, the connector shows its own.
            found.append((tls + "enable_mtls", True))
        if self.user is not None and self.password is not None:
            found += [
                ("transport/auth/usrpwd/user", self.user),
                ("transport/auth/usrpwd/password", self.password),
            ]
        if self.users_file is not None:
            found.append(("transport/auth/usrpwd/dictionary_file", self.users_file))
        if listening and self.allow:
            found.append(("access_control", self._access_control()))
        return found

    def _access_control(self) -> dict[str, object]:
        # Zenoh's ACL: default deny; the allowed names may declare, put and query on the
        # served agents' keys only, both ways (what the parent sends, what it is sent).
        subject: dict[str, object] = {"id": "parents"}
        if self.mutual:
            subject["cert_common_names"] = list(self.allow)
        if self.users_file is not None:
            subject["usernames"] = list(self.allow)
        messages = ["put", "delete", "declare_subscriber", "query", "reply", "declare_queryable"]
        messages += ["liveliness_token", "liveliness_query", "declare_liveliness_subscriber"]
        return {
            "enabled": True,
            "default_permission": "deny",
            "rules": [
                {
                    "id": "served",
                    "messages": messages,
                    "flows": ["ingress", "egress"],
                    "permission": "allow",
                    "key_exprs": list(self.keys),
                }
            ],
            "subjects": [subject],
            "policies": [{"rules": ["served"], "subjects": ["parents"]}],
        }


def zenoh_config(
    listen: Sequence[str] = (), connect: Sequence[str] = (), security: Security | None = None
) -> zenoh.Config:
    """Peer mode, nothing scouted, listening and connecting only where told, secured as told."""
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
    if security is not None:
        settings += security.settings(listening=bool(listen))
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
        """The serving process's liveliness tokens: ``…/alive/host/<session id>``."""
        return f"{self.base}/alive/host"

    @property
    def parent_alive(self) -> str:
        """The parent process's liveliness tokens: ``…/alive/parent/<session id>``."""
        return f"{self.base}/alive/parent"


class _Handoff:
    """The calls Zenoh's threads hand to one event loop, queued and run in order: one wake-up
    of the loop (``call_soon_threadsafe``) for every batch that arrives while it is busy,
    not one per call.  Every link of the loop shares it (a fleet's messages, together)."""

    def __init__(self, submit: Callable[..., object]) -> None:
        self._submit = submit
        self._lock = threading.Lock()
        self._queue: deque[tuple[LoopBridge, Callable[..., None], tuple[Any, ...]]] = deque()
        self._scheduled = False
        self.ended = False

    def put(self, bridge: LoopBridge, fn: Callable[..., None], args: tuple[Any, ...]) -> None:
        with self._lock:
            if self.ended:
                return
            self._queue.append((bridge, fn, args))
            if self._scheduled:
                return  # the loop has been woken already: it runs this with the rest
            self._scheduled = True
        try:
            self._submit(self._run)
        except RuntimeError:  # the loop has ended (asyncio: closed; trio: RunFinishedError)
            with self._lock:
                self.ended = True
                self._queue.clear()

    def _run(self) -> None:
        with self._lock:
            batch, self._queue = self._queue, deque()
            self._scheduled = False
        for bridge, fn, args in batch:
            if not bridge.closed:
                fn(*args)


_HANDOFFS: weakref.WeakKeyDictionary[object, _Handoff] = weakref.WeakKeyDictionary()
"""Each running event loop's hand-off (asyncio: by loop; trio: by its token)."""


class LoopBridge:
    """Hands calls from any thread to the event loop it was made in, never waiting for them.

    Made inside the event loop (asyncio or trio).  Calls keep their order (every bridge of
    one loop shares its queue).  After :meth:`close`, and once the loop has ended, calls
    are dropped.
    """

    def __init__(self) -> None:
        self.closed = False
        owner: object
        try:
            loop = asyncio.get_running_loop()
        except RuntimeError:
            import trio.lowlevel  # not asyncio: anyio runs on trio

            owner = trio.lowlevel.current_trio_token()
            submit: Callable[..., object] = owner.run_sync_soon
            self.soon: Callable[[Callable[[], None]], object] = submit
            """Run a function in the event loop soon, after what is ready now (from the loop only)."""
        else:
            owner, submit, self.soon = loop, loop.call_soon_threadsafe, loop.call_soon
        handoff = _HANDOFFS.get(owner)
        if handoff is None or handoff.ended:
            handoff = _HANDOFFS[owner] = _Handoff(submit)
        self._handoff = handoff

    def call_soon(self, fn: Callable[..., None], *args: Any) -> None:
        """Run ``fn(*args)`` in the event loop, soon (callable from any thread)."""
        if self.closed:
            return
        self._handoff.put(self, fn, args)
        if self._handoff.ended:
            self.closed = True

    def close(self) -> None:
        """Drop every call from now on."""
        self.closed = True


class Outbox(Generic[T]):
    """What one side sends on one key, gathered for a moment and put as one payload (or a
    few, none over :data:`BATCH` items or, if it can be helped,
    :data:`~htnagent.limits.MAX_PAYLOAD_BYTES`).

    ``soon`` says when the moment ends: by default after this round of the event loop; a
    remote agent's link, once its runtime has handled everything of the instant
    (:meth:`~htnagent.runtime.clock.Clock.when_settled`).  A result, the robot's state and
    the trace events around them come out together: one payload for them all is one put,
    one sample for the peer's gate and one hand-over to its event loop, where there were
    one each.  The items keep their order and each its time (``pack`` writes them).
    """

    def __init__(
        self,
        put: Callable[[bytes], None],
        pack: Callable[[Sequence[T], int], bytes],
        soon: Callable[[Callable[[], None]], object],
    ) -> None:
        """``pack(items, n)``: the ``n``-th payload, of ``items``; ``soon(flush)``: runs the
        flush when the moment ends."""
        self._put = put
        self._pack = pack
        self._soon = soon
        self._pending: list[T] = []
        self._scheduled = False
        self.sent = 0
        """Payloads put so far (the last one's number)."""
        self.closed = False

    def send(self, item: T) -> None:
        """Send ``item`` with the rest of this round's (never blocks; dropped once closed)."""
        if self.closed:
            return
        self._pending.append(item)
        if not self._scheduled:
            self._scheduled = True
            self._soon(self._flush_scheduled)
        if len(self._pending) >= BATCH:
            self.flush()  # a full payload goes at once (the flush to come finds the rest)

    def _flush_scheduled(self) -> None:
        self._scheduled = False
        self.flush()

    def flush(self) -> None:
        """Put what is gathered now."""
        items, self._pending = self._pending, []
        for start in range(0, len(items), BATCH):
            self._put_packed(items[start : start + BATCH])

    def _put_packed(self, items: list[T]) -> None:
        payload = self._pack(items, self.sent + 1)
        if len(payload) > MAX_PAYLOAD_BYTES and len(items) > 1:
            half = len(items) // 2  # too big together: the receiver would refuse them all
            self._put_packed(items[:half])
            self._put_packed(items[half:])
            return
        if self.closed:
            return
        self.sent += 1
        self._put(payload)


_MUX_MAGIC = b"htn1"
_PART = struct.Struct("<HI")  # a part's key length, its payload's length


class Mux:
    """The payloads one session puts for many robots' links, together: one put per peer
    session and round of the event loop, instead of one per robot; and the other way, the
    parts of such a put handed each to the link of its key.

    A serving process's robots act at the same instants (one scenario, one pace), and so do
    a fleet's guides: every Zenoh put is a sample to route and a callback on the peer's
    Zenoh thread, which takes the GIL from the event loop for it (a 100-robot parent read
    2,400 samples a museum run; now about 330).  Nothing about who may speak changes: each
    part is one robot's numbered payload, as it would have been put on its key, and goes
    through that link's gate (:mod:`htnagent.remote.gate`) exactly as one put there would.
    A put that does not parse, is too large, or holds too many parts is dropped whole
    (counted in :attr:`refused`); a part for a key no link here listens on is dropped, as a
    put on such a key would be.  Wire form: ``htn1``, then per part its key's and its
    payload's lengths (little-endian ``uint16``, ``uint32``), the key (UTF-8), the payload.
    """

    def __init__(self, session: zenoh.Session) -> None:
        self._session = session
        self._routes: dict[bytes, list[Callable[[memoryview], None]]] = {}
        self._listening: Any = None
        self._pending: dict[str, list[tuple[bytes, bytes]]] = {}
        self._sizes: dict[str, int] = {}
        self._publishers: dict[str, Any] = {}
        self._scheduled = False
        self.refused = 0
        """Puts dropped whole, and parts for keys nobody here listens on."""

    # -- receiving (the route table is changed on the event loop, read on Zenoh's threads) --

    def route(self, key: str, arrived: Callable[[memoryview], None]) -> Callable[[], None]:
        """Hand ``arrived`` (on Zenoh's thread) every part for ``key``; returns the undo."""
        if self._listening is None:
            me = str(self._session.info.zid())
            self._listening = self._session.declare_subscriber(f"{LINKS}/{me}", _direct(self._arrived))
        name = key.encode()
        self._routes[name] = [*self._routes.get(name, ()), arrived]  # a new list: read elsewhere

        def unroute() -> None:
            left = [f for f in self._routes.get(name, ()) if f is not arrived]
            if left:
                self._routes[name] = left
            else:
                self._routes.pop(name, None)

        return unroute

    def _arrived(self, sample: zenoh.Sample) -> None:
        self.deliver(sample.payload.to_bytes())

    def deliver(self, data: bytes) -> None:
        """Hand each part of a put to the links of its key (on the calling thread)."""
        parts = self.split(data)
        if parts is None:
            self.refused += 1
            return
        for key, payload in parts:
            routes = self._routes.get(key)
            if routes is None:
                self.refused += 1
                continue
            for arrived in routes:
                arrived(payload)

    @staticmethod
    def split(data: bytes) -> list[tuple[bytes, memoryview]] | None:
        """The ``(key, payload)`` parts of a put, in order; None if it is not one :meth:`pack`
        makes (then nothing of it is acted on)."""
        if len(data) > MAX_PAYLOAD_BYTES + 64 * 1024 or not data.startswith(_MUX_MAGIC):
            return None
        view = memoryview(data)
        parts: list[tuple[bytes, memoryview]] = []
        at = len(_MUX_MAGIC)
        while at < len(data):
            if at + _PART.size > len(data) or len(parts) >= MUX_PARTS:
                return None
            key_len, size = _PART.unpack_from(data, at)
            at += _PART.size
            end = at + key_len + size
            if end > len(data):
                return None
            parts.append((data[at : at + key_len], view[at + key_len : end]))
            at = end
        return parts if parts else None

    @staticmethod
    def pack(parts: Sequence[tuple[bytes, bytes]]) -> bytes:
        """One put of ``(key, payload)`` parts (:meth:`split` reads it)."""
        out = bytearray(_MUX_MAGIC)
        for key, payload in parts:
            out += _PART.pack(len(key), len(payload))
            out += key
            out += payload
        return bytes(out)

    # -- sending (on the event loop's thread) --------------------------------------------

    def send(
        self, peer: str, key: bytes, payload: bytes, soon: Callable[[Callable[[], None]], object]
    ) -> None:
        """Put ``payload`` for ``key`` to session ``peer`` with the rest of this round's;
        ``soon(flush)`` runs the flush after this round."""
        pending = self._pending.setdefault(peer, [])
        size = self._sizes.get(peer, 0) + len(key) + len(payload) + _PART.size
        if pending and (size > MAX_PAYLOAD_BYTES or len(pending) >= MUX_PARTS):
            self._put(peer)  # full: this one starts the next put
            pending = self._pending.setdefault(peer, [])
            size = len(key) + len(payload) + _PART.size
        pending.append((key, payload))
        self._sizes[peer] = size
        if not self._scheduled:
            self._scheduled = True
            soon(self._flush_scheduled)

    def _flush_scheduled(self) -> None:
        self._scheduled = False
        self.flush()

    def flush(self) -> None:
        """Put everything gathered now."""
        for peer in list(self._pending):
            self._put(peer)

    def _put(self, peer: str) -> None:
        parts = self._pending.pop(peer, [])
        self._sizes.pop(peer, None)
        if not parts:
            return
        publisher = self._publishers.get(peer)
        if publisher is None:
            if len(self._publishers) >= MUX_PEERS:
                # Peers come and go (a parent restarts): forget the oldest's publisher.
                oldest = next(iter(self._publishers))
                with contextlib.suppress(zenoh.ZError):
                    self._publishers.pop(oldest).undeclare()
            publisher = self._session.declare_publisher(
                f"{LINKS}/{peer}", congestion_control=zenoh.CongestionControl.BLOCK
            )
            self._publishers[peer] = publisher
        publisher.put(self.pack(parts))


MUX_PEERS = 64
"""Peer sessions a :class:`Mux` keeps a publisher for (the oldest is forgotten first)."""


class _Shared:
    """One open (or opening) session and how many links use it."""

    def __init__(self, listen: tuple[str, ...], connect: tuple[str, ...], security: Security | None):
        self.listen = listen
        self.connect = connect
        self.security = security
        self.users = 0
        self.session: zenoh.Session | None = None
        self.mux: Mux | None = None
        self.error: RemoteError | None = None
        self.ready = anyio.Event()

    def fits(self, listen: tuple[str, ...], connect: tuple[str, ...], security: Security | None) -> bool:
        return self.listen == listen and self.security == security and set(connect) <= set(self.connect)


class Sessions:
    """The process's Zenoh sessions: one per set of settings, shared by every link that fits.

    Used from one event loop at a time (a session outlives no ``anyio.run``: it closes
    with its last link).  A link connecting to an endpoint no open session connects to
    opens a session of its own; :meth:`hold` opens one for a whole fleet first."""

    def __init__(self) -> None:
        self._shared: list[_Shared] = []
        self.opened = 0
        """Sessions opened by this process so far."""

    @property
    def count(self) -> int:
        """Sessions open now."""
        return sum(1 for s in self._shared if s.session is not None)

    async def acquire(
        self, listen: tuple[str, ...], connect: tuple[str, ...], security: Security | None
    ) -> _Shared:
        for shared in self._shared:
            if shared.fits(listen, connect, security):
                shared.users += 1
                await shared.ready.wait()
                if shared.error is not None:
                    shared.users -= 1
                    raise shared.error
                return shared
        shared = _Shared(listen, connect, security)
        shared.users = 1
        self._shared.append(shared)  # before the first await: a link meanwhile waits for this one
        try:
            config = zenoh_config(listen, connect, security)
            shared.session = await anyio.to_thread.run_sync(zenoh.open, config)
            shared.mux = Mux(shared.session)
        except zenoh.ZError as e:
            where = ", ".join(listen or connect)
            shared.error = RemoteError(f"cannot open a Zenoh session at {where}: {' '.join(str(e).split())}")
            self._shared.remove(shared)
            raise shared.error from None
        finally:
            shared.ready.set()
        self.opened += 1
        return shared

    async def release(self, shared: _Shared) -> None:
        shared.users -= 1
        if shared.users > 0:
            return
        if shared in self._shared:
            self._shared.remove(shared)
        session, shared.session = shared.session, None
        if session is None:
            return
        # Closing waits for Zenoh's threads; under a time limit, and shielded so that a
        # cancelled runtime still closes its session (the cancellation goes on after).
        with anyio.CancelScope(shield=True), anyio.move_on_after(CLOSE_WITHIN):
            await anyio.to_thread.run_sync(session.close, abandon_on_cancel=True)

    def hold(
        self, *, listen: Sequence[str] = (), connect: Sequence[str] = (), security: Security | None = None
    ) -> Link:
        """A link that declares nothing: held open around a fleet's runs, it makes their
        links share one session connecting to every endpoint given."""
        return Link(listen=listen, connect=connect, security=security)


SESSIONS = Sessions()
"""The process's sessions."""


def sessions_open() -> int:
    """How many Zenoh sessions this process has open now (one per set of settings in use)."""
    return SESSIONS.count


def _direct(callback: Callable[[zenoh.Sample], None]) -> zenoh.handlers.Callback[zenoh.Sample]:
    """``callback`` run on the Zenoh thread that received the sample.  Zenoh's default runs a
    Python callback on a thread of its own, one per subscriber (two per robot): every sample
    then cost one more thread switch and a contended hand-over of the GIL, and a fleet's
    parent ran hundreds of such threads.  Ours never wait (the gate's lock is held for a
    few lines, the event loop is handed the call): Zenoh's thread is not held up."""
    return zenoh.handlers.Callback(callback, indirect=False)


class Link:
    """One robot's use of the process's Zenoh session; ``async with`` opens (or shares) and ends it."""

    def __init__(
        self,
        *,
        listen: Sequence[str] = (),
        connect: Sequence[str] = (),
        security: Security | None = None,
    ) -> None:
        self.listen = tuple(listen)
        self.connect = tuple(connect)
        self.security = security
        self._shared: _Shared | None = None
        self._bridge: LoopBridge | None = None
        self._keep: list[Any] = []  # what this link declared, undeclared when it ends
        self._outboxes: list[Outbox[Any]] = []
        self._unroute: list[Callable[[], None]] = []

    async def __aenter__(self) -> Self:
        self._bridge = LoopBridge()
        self._shared = await SESSIONS.acquire(self.listen, self.connect, self.security)
        return self

    async def __aexit__(
        self, exc_type: type[BaseException] | None, exc: BaseException | None, tb: TracebackType | None
    ) -> None:
        if self._bridge is not None:
            self._bridge.close()
        for outbox in self._outboxes:
            # What this round sent goes before the token (undeclared below) does.
            with contextlib.suppress(zenoh.ZError, RemoteError):  # the session closed under it
                outbox.flush()
            outbox.closed = True
        for unroute in self._unroute:
            unroute()
        self._unroute.clear()
        shared, self._shared = self._shared, None
        kept, self._keep = self._keep, []
        if shared is None:
            return
        if self._outboxes and shared.mux is not None:
            with contextlib.suppress(zenoh.ZError):  # the session closed under it
                shared.mux.flush()  # this link's last payloads, gathered with others', go now too
        with anyio.CancelScope(shield=True):
            if shared.users > 1:
                # The session goes on for other links: undeclare ours (the token last but
                # first undeclared: the peer learns at once that this side is gone).
                for declared in reversed(kept):
                    with contextlib.suppress(zenoh.ZError):  # the session is closing under it
                        declared.undeclare()
            kept.clear()
            await SESSIONS.release(shared)

    @property
    def session(self) -> zenoh.Session:
        if self._shared is None or self._shared.session is None:
            raise RemoteError("the Zenoh session is not open")
        return self._shared.session

    @property
    def session_id(self) -> str:
        """The session's Zenoh id: what the peer binds to (:mod:`htnagent.remote.gate`)."""
        return str(self.session.info.zid())

    @property
    def bridge(self) -> LoopBridge:
        assert self._bridge is not None, "the link is not open"
        return self._bridge

    def on_sample(self, key: str, handler: Callable[[T], None], admit: Callable[[bytes], T | None]) -> None:
        """Call ``handler`` in the event loop with ``admit(payload)`` of every payload put on
        ``key`` (or sent for it with others', :class:`Mux`) unless that is None.  ``admit``
        runs on Zenoh's thread: what it refuses never reaches the event loop."""
        bridge = self.bridge
        assert self._shared is not None and self._shared.mux is not None  # the session is open
        mux = self._shared.mux

        def admitted(payload: bytes) -> None:  # a Zenoh thread: hand over, never wait
            got = admit(payload)
            if got is not None:
                bridge.call_soon(handler, got)

        def arrived(sample: zenoh.Sample) -> None:
            data = sample.payload.to_bytes()
            if data.startswith(_MUX_MAGIC):
                # A put the peer made on LINKS/<this session> (Mux), handed to this key's
                # subscriber: Zenoh 1.10 now and then does so with the first put of a serving
                # process thawed after a freeze (seen: the sample's key was this one, its
                # payload the peer's Mux put).  Its parts go to their links' gates, as if it
                # had come the right way; refused here, it was a spurious peer_refused.
                mux.deliver(data)
                return
            admitted(data)

        def part(payload: memoryview) -> None:
            admitted(bytes(payload))

        self._keep.append(self.session.declare_subscriber(key, _direct(arrived)))
        self._unroute.append(mux.route(key, part))

    def on_liveliness(self, key: str, handler: Callable[[bool, str], None]) -> None:
        """Call ``handler(True, ID)`` when a liveliness token ``KEY/ID`` appears (or is there
        already), ``handler(False, ID)`` when it goes (its session closed, or its lease ran out)."""
        bridge = self.bridge
        prefix = key + "/"

        def changed(sample: zenoh.Sample) -> None:
            name = str(sample.key_expr)
            if name.startswith(prefix):
                bridge.call_soon(handler, sample.kind == zenoh.SampleKind.PUT, name[len(prefix) :])

        liveliness = self.session.liveliness()
        self._keep.append(liveliness.declare_subscriber(prefix + "*", _direct(changed), history=True))

    def publisher(self, key: str) -> Callable[[bytes], None]:
        """A function putting a payload on ``key``: reliable, in order, sent at once."""
        # Not ``express``: Zenoh then sends at once too, but may put the payloads that wait
        # for the link together in one batch (one TLS record, one write): the robots of a
        # serving process act at the same instants, and an express put was a record and a
        # system call each, made on the event loop's thread.  Batching waits only when the
        # link is congested (Zenoh's ``tx/batching``); the round trip stays as it was
        # (bench/results/remote.json).
        publisher = self.session.declare_publisher(key, congestion_control=zenoh.CongestionControl.BLOCK)
        self._keep.append(publisher)
        return lambda payload: publisher.put(payload)

    def outbox(
        self,
        key: str,
        pack: Callable[[Sequence[T], int], bytes],
        soon: Callable[[Callable[[], None]], object] | None = None,
        peer: Callable[[], str | None] | None = None,
    ) -> Outbox[T]:
        """An :class:`Outbox` putting on ``key`` (flushed, then closed, when the link ends);
        ``soon`` runs its flush (by default after this round of the event loop).

        ``peer`` gives the session id of the one peer this link speaks to (None while there
        is none): its payloads then go to that session with the other links' of this round
        (:class:`Mux`), one put for them all, and arrive as if put on ``key``."""
        if peer is None:
            put = self.publisher(key)
        else:
            mux, name, after = self._shared.mux if self._shared else None, key.encode(), self.bridge.soon
            assert mux is not None  # the session is open
            # The key's own publisher is declared when first needed: with a peer bound, never.
            # A declaration goes to every peer session (a fleet's parent: one per serving
            # process), and a 100-robot fleet's parent made one per robot as it started.
            direct: list[Callable[[bytes], None]] = []

            def put(payload: bytes) -> None:
                to = peer()
                if to is not None:
                    mux.send(to, name, payload, after)
                    return
                if not direct:
                    direct.append(self.publisher(key))
                direct[0](payload)  # nobody bound: to whoever listens on the key

        outbox = Outbox(put, pack, self.bridge.soon if soon is None else soon)
        self._outboxes.append(outbox)
        return outbox

    def token(self, key: str) -> None:
        """Declare this link alive at ``KEY/<session id>`` (last: after the subscribers it
        answers with)."""
        self._keep.append(self.session.liveliness().declare_token(f"{key}/{self.session_id}"))
