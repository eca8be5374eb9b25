"""Who may speak on a remote agent's link: the one peer bound by its token, in order.

Every payload carries its sender's Zenoh session id (``from``) and a number one
higher than the sender's last on that key (``n``); the receiving side binds one
peer at a time, the session whose liveliness token it saw (the parent, for a
serving process; the serving process, for a parent).  :meth:`Gate.admit` runs on
Zenoh's own threads, before anything reaches the event loop, so that a flood of
payloads from anyone else costs a JSON parse each and no memory: a payload is

- refused when it is larger than :data:`~htnagent.limits.MAX_PAYLOAD_BYTES`
  (unparsed), malformed, of a type that never travels this way (a result sent
  down; a payload of several items is refused whole if one of them is), from a
  session that is not the bound peer, or numbered at or below the last one
  admitted (replayed, or out of order);
- held, a little while and a bounded number and size at most, when nobody is
  bound yet: the peer's first payloads may come before its token (another
  Zenoh thread; a parent may send a burst at once), and are admitted, in
  order, when it binds (:meth:`Gate.bind`).

Refusals are counted per claimed sender (at most :data:`MAX_PEERS` of them, the
rest together as ``others``) and taken once a second by the side that owns the
gate (:meth:`Gate.refusals`), which traces them as ``peer_refused``: never one
event per payload.  The ``from`` a payload claims is not proof of who sent it:
the link's TLS and Zenoh's authentication decide who is on the link at all.
"""

from __future__ import annotations

import threading
import time
from collections import deque
from collections.abc import Callable
from dataclasses import dataclass

from htnagent.limits import MAX_PAYLOAD_BYTES
from htnagent.remote.codec import CodecError, Item, Received, receive

MAX_PEERS = 32
"""Senders whose refusals are counted apart; the rest are ``others`` (a forger may claim any id)."""
HOLD = 4096
"""Payloads kept while no peer is bound (the oldest go first, refused)."""
HOLD_BYTES = 8 * 1024 * 1024
"""Bytes of payloads kept while no peer is bound, at most."""
HOLD_S = 2.0
"""Wall-clock seconds a held payload waits for its sender's token."""
UNKNOWN = "unknown"
"""The sender of a payload that names none (it did not parse)."""
OTHERS = "others"


@dataclass(frozen=True, slots=True)
class Refusal:
    """``count`` payloads claimed to be from ``peer`` were refused since the last report; the last why."""

    peer: str
    reason: str
    count: int


@dataclass(slots=True)
class _Tally:
    count: int = 0
    reason: str = ""


class Gate:
    """Admits the bound peer's payloads, in order; refuses and counts the rest (thread-safe)."""

    def __init__(self, allowed: Callable[[Item], bool], what: str) -> None:
        """``allowed``: whether an item may travel this way; ``what``: what may (for the reason)."""
        self._allowed = allowed
        self._what = what
        self._lock = threading.Lock()
        self._peer: str | None = None
        self._last = 0
        self._held: deque[tuple[float, Received, int]] = deque()
        self._held_bytes = 0
        self._refused: dict[str, _Tally] = {}
        self.admitted = 0
        self.refused = 0

    @property
    def peer(self) -> str | None:
        """The bound peer's session id (None: nobody is bound)."""
        return self._peer

    def admit(self, payload: bytes | bytearray | memoryview) -> Received | None:
        """The payload's content if its sender is the bound peer and it is the next; else None
        (refused and counted, or held).  Called on Zenoh's threads."""
        if len(payload) > MAX_PAYLOAD_BYTES:
            self.refuse(UNKNOWN, f"oversized: {len(payload):,} bytes (at most {MAX_PAYLOAD_BYTES:,})")
            return None
        try:
            got = receive(bytes(payload))
        except CodecError as e:
            self.refuse(UNKNOWN, f"malformed: {' '.join(str(e).split())[:160]}")
            return None
        if not got.sender:
            self.refuse(UNKNOWN, "names no sender session")
            return None
        wrong = next((item for _, item in got.items if not self._allowed(item)), None)
        if wrong is not None:  # the whole payload: nothing of a sender that lies is acted on
            self.refuse(got.sender, f"wrongly typed: {_kind(wrong)} never travels this way ({self._what})")
            return None
        with self._lock:
            self._expire(time.monotonic())
            if self._peer is None:
                self._held.append((time.monotonic(), got, len(payload)))
                self._held_bytes += len(payload)
                while len(self._held) > HOLD or self._held_bytes > HOLD_BYTES:
                    self._drop_held()
                return None
            if got.sender != self._peer:
                self._count(got.sender, f"not from the bound peer (session {self._peer})")
                return None
            if got.n <= self._last:
                self._count(got.sender, f"replayed or out of order: number {got.n} after {self._last}")
                return None
            self._last = got.n
            self.admitted += 1
            return got

    def bind(self, peer: str) -> list[Received] | None:
        """Bind ``peer`` (its token appeared); what it sent meanwhile, in order (the rest held
        is refused).  None, and nothing done, if another peer is bound."""
        with self._lock:
            if self._peer is not None:
                return None
            self._peer, self._last = peer, 0
            held, self._held, self._held_bytes = self._held, deque(), 0
            admitted = []
            now = time.monotonic()
            for at, got, _ in held:
                if got.sender != peer:
                    self._count(got.sender, f"not from the bound peer (session {peer})")
                elif now - at > HOLD_S:
                    self._count(got.sender, "held too long: its sender never joined")
                elif got.n <= self._last:
                    self._count(got.sender, f"replayed or out of order: number {got.n} after {self._last}")
                else:
                    self._last = got.n
                    admitted.append(got)
            self.admitted += len(admitted)
            return admitted

    def unbind(self, peer: str) -> bool:
        """The bound peer's token went: nobody is bound.  False if ``peer`` was not the bound one."""
        with self._lock:
            if self._peer != peer:
                return False
            self._peer = None
            return True

    def refuse(self, peer: str, reason: str) -> None:
        """Count a payload from ``peer`` refused for ``reason`` (callable from any thread)."""
        with self._lock:
            self._count(peer, reason)

    def refusals(self) -> list[Refusal]:
        """The refusals counted since the last call, one per claimed sender."""
        with self._lock:
            self._expire(time.monotonic())
            taken, self._refused = self._refused, {}
        return [Refusal(peer, tally.reason, tally.count) for peer, tally in taken.items()]

    def _count(self, peer: str, reason: str) -> None:
        # Under the lock.  A forger may claim a new id every time: count apart a few only.
        self.refused += 1
        if peer not in self._refused and len(self._refused) >= MAX_PEERS:
            peer = OTHERS
        tally = self._refused.setdefault(peer, _Tally())
        tally.count += 1
        tally.reason = reason

    def _expire(self, now: float) -> None:
        while self._held and now - self._held[0][0] > HOLD_S:
            self._drop_held()

    def _drop_held(self) -> None:
        _, old, size = self._held.popleft()
        self._held_bytes -= size
        self._count(old.sender, "held too long: its sender never joined")


def _kind(item: Item) -> str:
    kind = getattr(item, "kind", None) or getattr(item, "event", None)
    return str(kind) if kind else type(item).__name__


__all__ = ["HOLD", "HOLD_BYTES", "HOLD_S", "MAX_PEERS", "Gate", "Refusal"]
