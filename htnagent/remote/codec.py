"""The wire form of what a parent and a serving process exchange: JSON, Atoms in their text form.

Every payload is one JSON object, one item ``{"t": T, "type": TYPE, "body": {...},
"from": ID, "n": N}`` or several sent together ``{"items": [{"t": T, "type": TYPE,
"body": {...}}, ...], "from": ID, "n": N}`` (what one side sends in one round of its
event loop -- a result, the robot's state, the trace events around them -- goes in one
payload: one put, one hand-over to the receiver's event loop, not one each).  ``from``
is the sender's Zenoh session id and ``n`` counts its payloads on that key from 1
(:mod:`htnagent.remote.gate` admits them in order only); ``t`` is the sender's
simulated time when it sent the item (the receiver's clock keeps in step with it,
:meth:`htnagent.runtime.clock.Clock.call_from_peer`), ``type`` one of

- ``message``: a protocol message (:mod:`htnagent.runtime.messages`) — down, an order
  or a belief update; up, a result — its fields, ``kind`` first;
- ``progress``: how far an action has got (:class:`~htnagent.runtime.progress.Progress`),
  so that the parent's triggers follow a remote robot;
- ``event``: a trace event of the serving process, as ``run --json`` prints it;
- ``status``: where the robot is, the nodes it reached and how far it went;
- ``world``: a door shut or opened (``arc``, ``close``);
- ``relay``: down, the trace events (by name, ``events``) the parent wants relayed; without
  one, every event is.

What does not decode is refused with :class:`CodecError`, never half read: a payload
with one bad item is refused whole.

JSON is written and read by orjson (in the ``zenoh`` extra, pinned in constraints.txt):
the same JSON as the standard library's, in about a tenth of the time to write and a
third to read -- every trace event of a fleet's robots goes through here twice (written
by the serving process, read on the parent's Zenoh threads).  It is also stricter: no
``NaN`` or ``Infinity``, no lone surrogates, nesting at most 1024 deep (each refused).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import orjson

from htnagent.errors import HtnAgentError
from htnagent.model.terms import Atom, parse
from htnagent.runtime.events import TraceEvent, event_from_dict
from htnagent.runtime.messages import (
    BeliefUpdate,
    Clear,
    Execute,
    Failure,
    ParentLost,
    Prepare,
    Refused,
    Resume,
    Success,
    Suspend,
    Suspended,
)
from htnagent.runtime.progress import Phase, Progress

Wire = (
    Execute
    | Suspend
    | Resume
    | Clear
    | Prepare
    | ParentLost
    | BeliefUpdate
    | Success
    | Failure
    | Suspended
    | Refused
)
"""The protocol messages that cross processes."""

_MESSAGES: dict[str, type[Wire]] = {
    cls.model_fields["kind"].default: cls
    for cls in (
        Execute,
        Suspend,
        Resume,
        Clear,
        Prepare,
        ParentLost,
        BeliefUpdate,
        Success,
        Failure,
        Suspended,
        Refused,
    )
}
_ATOMS = frozenset({"action"})
_ATOM_TUPLES = frozenset({"add", "delete"})


class CodecError(HtnAgentError, ValueError):
    """A payload that is not one this module writes."""


@dataclass(frozen=True, slots=True)
class RobotStatus:
    """Where the robot of the serving process is: the summary's ``robot``, ``visited``, ``distance``."""

    robot: dict[str, str]
    visited: tuple[str, ...]
    distance: float


@dataclass(frozen=True, slots=True)
class WorldChange:
    """A door shut (``close``) or opened: the serving process's robot and agents learn it."""

    arc: str
    close: bool


@dataclass(frozen=True, slots=True)
class Relay:
    """The serving process's trace events the parent wants (by name, ``event``), from now on;
    the rest are not sent.  Without one, every event is."""

    events: frozenset[str]


RELAY_NAMES = 256
"""Event names a :class:`Relay` may carry, at most (each of at most 64 characters)."""

Item = Wire | Progress | TraceEvent | RobotStatus | WorldChange | Relay
"""Anything a payload carries."""


MAX_ITEMS = 4096
"""Items one payload may carry, at most (besides :data:`~htnagent.limits.MAX_PAYLOAD_BYTES`)."""


@dataclass(frozen=True, slots=True)
class Received:
    """A payload read: its items, each with its sender's time, in the order sent; the sender's
    session id and the payload's number."""

    items: tuple[tuple[float, Item], ...]
    sender: str
    n: int

    def by_time(self) -> list[tuple[float, list[Item]]]:
        """The items, those sent at one time (one after the other) together, in order."""
        runs: list[tuple[float, list[Item]]] = []
        for t, item in self.items:
            if runs and runs[-1][0] == t:
                runs[-1][1].append(item)
            else:
                runs.append((t, [item]))
        return runs


def encode(t: float, item: Item, sender: str = "", n: int = 0) -> bytes:
    """The payload of ``item``, sent at simulated time ``t`` by session ``sender``, its ``n``-th."""
    kind, body = _wire(item)
    return orjson.dumps({"t": t, "type": kind, "body": body, "from": sender, "n": n})


def encode_batch(items: Sequence[tuple[float, Item]], sender: str = "", n: int = 0) -> bytes:
    """One payload of several ``(t, item)``, in order (of one, :func:`encode`'s form)."""
    if len(items) == 1:
        return encode(items[0][0], items[0][1], sender, n)
    listed = []
    for t, item in items:
        kind, body = _wire(item)
        listed.append({"t": t, "type": kind, "body": body})
    return orjson.dumps({"items": listed, "from": sender, "n": n})


def _wire(item: Item) -> tuple[str, dict[str, Any]]:
    body: dict[str, Any]
    if isinstance(item, TraceEvent):
        kind, body = "event", item.as_dict()  # a dict of its own
    elif isinstance(item, Progress):
        kind = "progress"
        body = {
            "actor": item.actor,
            "action": str(item.action),
            "phase": item.phase.value,
            "duration": item.duration,
            "done": item.done,
        }
    elif isinstance(item, RobotStatus):
        kind, body = "status", {"robot": item.robot, "visited": list(item.visited), "distance": item.distance}
    elif isinstance(item, WorldChange):
        kind, body = "world", {"arc": item.arc, "close": item.close}
    elif isinstance(item, Relay):
        kind, body = "relay", {"events": sorted(item.events)}
    else:
        kind, body = "message", _message_body(item)
    return kind, body


def _message_body(message: Wire) -> dict[str, Any]:
    body: dict[str, Any] = {}
    for name in type(message).model_fields:
        value = getattr(message, name)
        if isinstance(value, Atom):
            value = str(value)
        elif isinstance(value, tuple):
            value = [str(v) for v in value]
        body[name] = value
    return body


def decode(payload: bytes) -> tuple[float, Item]:
    """The sender's time and the item of a payload of one; :class:`CodecError` if it is not one."""
    got = receive(payload)
    if len(got.items) != 1:
        raise CodecError(f"{len(got.items)} items, not one: {payload[:80]!r}")
    return got.items[0]


def receive(payload: bytes) -> Received:
    """All a payload holds; :class:`CodecError` if it is not one this module writes."""
    try:
        data = orjson.loads(payload)  # orjson.JSONDecodeError is a ValueError
        if not isinstance(data, dict):
            raise CodecError(f"not a payload of htnagent: {payload[:80]!r}")
        sender, n = data.get("from", ""), data.get("n", 0)
        if not isinstance(sender, str) or len(sender) > 64:
            raise CodecError(f"from: not a session id: {str(sender)[:80]!r}")
        if not isinstance(n, int) or isinstance(n, bool) or not 0 <= n < 2**63:
            raise CodecError(f"n: not a payload number: {str(n)[:80]!r}")
        if "items" not in data:
            return Received((_timed(data, payload),), sender, n)
        listed = data["items"]
        if not isinstance(listed, list) or not 0 < len(listed) <= MAX_ITEMS:
            raise CodecError(f"items: not a list of 1 to {MAX_ITEMS} items: {payload[:80]!r}")
        return Received(tuple([_timed(one, payload) for one in listed]), sender, n)
    except CodecError:
        raise
    except (
        ValueError,
        KeyError,
        TypeError,
        AttributeError,
        RecursionError,
        OverflowError,
        HtnAgentError,
    ) as e:
        raise CodecError(f"not a payload of htnagent ({type(e).__name__}: {e}): {payload[:80]!r}") from None


ATOMS_KEPT = 1024
"""Atoms read back from their text kept for the next payload (short texts only; all
forgotten when full): a robot's actions come again and again, progress reports above all."""
_ATOMS_READ: dict[str, Atom] = {}


def _atom(text: object) -> Atom:
    # Atoms are immutable values: one read serves every payload naming it.  Called on
    # Zenoh's threads; a dict's get and set are atomic, and a lost entry is read again.
    if not isinstance(text, str) or len(text) > 200:
        return parse(text)  # type: ignore[arg-type]  # parse names what is wrong
    atom = _ATOMS_READ.get(text)
    if atom is None:
        atom = parse(text)
        if len(_ATOMS_READ) >= ATOMS_KEPT:
            _ATOMS_READ.clear()
        _ATOMS_READ[text] = atom
    return atom


_PHASES = {phase.value: phase for phase in Phase}
"""Each phase by its name (a dictionary look-up: ``Phase(name)`` cost more, for every report)."""
_NUMBER = (int, float)  # a tuple: ``int | float`` would build a union for every item


def _timed(data: object, payload: bytes) -> tuple[float, Item]:
    if not isinstance(data, dict):
        raise CodecError(f"not a payload of htnagent: {payload[:80]!r}")
    t, kind, body = data["t"], data["type"], data["body"]
    if not isinstance(t, _NUMBER) or isinstance(t, bool) or not isinstance(body, dict):
        raise CodecError(f"not a payload of htnagent: {payload[:80]!r}")
    if not math.isfinite(t):
        raise CodecError(f"t: not a finite time: {t!r}")
    return float(t), _item(kind, body)


def _item(kind: object, body: dict[str, Any]) -> Item:
    if kind == "event":  # first: most items are (about 7 in 10 of what a serving process sends)
        return event_from_dict(body)
    if kind == "message":
        cls = _MESSAGES.get(body.get("kind"))  # type: ignore[arg-type]
        if cls is None:
            raise CodecError(f"unknown message kind {body.get('kind')!r}")
        fields = dict(body)
        for name in _ATOMS & fields.keys():
            fields[name] = _atom(fields[name])
        for name in _ATOM_TUPLES & fields.keys():
            fields[name] = tuple(_atom(v) for v in fields[name])
        return cls.model_validate(fields)
    if kind == "progress":
        return Progress(
            actor=str(body["actor"]),
            action=_atom(body["action"]),
            phase=_PHASES[body["phase"]],  # a KeyError (refused) if it is none of them
            duration=float(body["duration"]),
            done=float(body["done"]),
        )
    if kind == "status":
        robot = body["robot"]
        if not isinstance(robot, dict):
            raise CodecError("status: robot is not an object")
        return RobotStatus(
            robot={str(k): str(v) for k, v in robot.items()},
            visited=tuple(str(v) for v in body["visited"]),
            distance=float(body["distance"]),
        )
    if kind == "world":
        return WorldChange(arc=str(body["arc"]), close=bool(body["close"]))
    if kind == "relay":
        names = body["events"]
        if not isinstance(names, list) or len(names) > RELAY_NAMES:
            raise CodecError(f"relay: events is not a list of at most {RELAY_NAMES} names")
        if not all(isinstance(name, str) and len(name) <= 64 for name in names):
            raise CodecError("relay: an event name is not a string of at most 64 characters")
        return Relay(events=frozenset(names))
    raise CodecError(f"unknown payload type {kind!r}")
