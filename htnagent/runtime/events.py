"""Every trace event, as a typed record (docs/contracts.md "Trace events").

The trace tells people and tools what the agents did; nothing in the runtime
decides anything by reading it (triggers follow the robot's typed
:class:`~htnagent.runtime.progress.Progress` signal instead).  Each event kind is one
class below with a literal ``event`` name; :data:`EVENT_KINDS` lists them all,
and ``docs/contracts.md`` documents the same table (a test keeps the two equal).

An event is stamped with the simulated time ``t`` by
:meth:`htnagent.runtime.trace.Trace.emit`; :meth:`TraceEvent.as_dict` gives the JSON
object of ``run --json`` — ``t``, ``agent``, ``event``, then the kind's fields,
optional ones only when set.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from typing import ClassVar, Literal

from pydantic import TypeAdapter, ValidationError

from htnagent.errors import TraceFormatError, shown

JSONValue = str | int | float | bool | None | list["JSONValue"] | dict[str, "JSONValue"]
"""What an event's JSON form is made of."""


@dataclass(slots=True, kw_only=True)
class TraceEvent:
    """What every event has: who (``agent``), when (``t``, simulated seconds) and what (``event``)."""

    event: ClassVar[str]
    optional: ClassVar[frozenset[str]] = frozenset()
    """Fields left out of the JSON form when they are None or empty."""

    agent: str
    t: float = 0.0

    def as_dict(self) -> dict[str, JSONValue]:
        """The event's JSON object, as ``run --json`` prints it."""
        out: dict[str, JSONValue] = {"t": self.t, "agent": self.agent, "event": self.event}
        for name in _field_names(type(self)):
            value = getattr(self, name)
            if name in self.optional and (value is None or value == ""):
                continue
            out[name] = _json(value)
        return out


_FIELD_NAMES: dict[type[TraceEvent], tuple[str, ...]] = {}


def _field_names(cls: type[TraceEvent]) -> tuple[str, ...]:
    names = _FIELD_NAMES.get(cls)
    if names is None:
        names = tuple(f.name for f in dataclasses.fields(cls) if f.name not in ("agent", "t"))
        _FIELD_NAMES[cls] = names
    return names


_SCALARS = (str, int, float, bool)
_SEQUENCES = (tuple, list)  # tuples: ``A | B`` would build a union at every call (every field of every event)


def _json(value: object) -> JSONValue:
    if isinstance(value, _SCALARS) or value is None:
        return value
    if isinstance(value, _SEQUENCES):
        return [_json(v) for v in value]
    if isinstance(value, dict):
        return {str(k): _json(v) for k, v in value.items()}
    if dataclasses.is_dataclass(value) and not isinstance(value, type):
        return _json(_row(value))
    raise TypeError(f"no JSON form for {type(value).__name__}")


def _row(value: object) -> dict[str, object]:
    out: dict[str, object] = {}
    for f in dataclasses.fields(value):  # type: ignore[arg-type]
        v = getattr(value, f.name)
        if f.metadata.get("optional") and (v is None or v == ""):
            continue
        out[f.name] = v
    return out


# -- goals -----------------------------------------------------------------------------------


@dataclass(slots=True, kw_only=True)
class GoalReceived(TraceEvent):
    """An agent was given a goal: submitted (with its ``ticket``) or ordered by its parent."""

    event: ClassVar[Literal["goal_received"]] = "goal_received"
    optional: ClassVar[frozenset[str]] = frozenset({"ticket"})
    goal: str
    emergency: bool
    ticket: int | None = None


@dataclass(slots=True, kw_only=True)
class PlanSelected(TraceEvent):
    """The plan the agent follows for ``goal`` (text forms of its actions) and its cost."""

    event: ClassVar[Literal["plan_selected"]] = "plan_selected"
    goal: str
    plan: tuple[str, ...]
    cost: float


@dataclass(slots=True, kw_only=True)
class GoalSuspended(TraceEvent):
    """``goal`` was pushed on the stack; ``stack_depth`` goals are stacked now."""

    event: ClassVar[Literal["goal_suspended"]] = "goal_suspended"
    goal: str
    stack_depth: int


@dataclass(slots=True, kw_only=True)
class GoalResumed(TraceEvent):
    """``goal`` came off the stack; ``replan_ms`` is the wall-clock time its plan took."""

    event: ClassVar[Literal["goal_resumed"]] = "goal_resumed"
    goal: str
    replanning: Literal["online", "naive"]
    replan_ms: float


@dataclass(slots=True, kw_only=True)
class GoalCleared(TraceEvent):
    """A goal held for the parent's resume was dropped (the parent cleared it)."""

    event: ClassVar[Literal["goal_cleared"]] = "goal_cleared"
    goal: str


@dataclass(slots=True, kw_only=True)
class GoalFinished(TraceEvent):
    """``goal`` ended: ``status`` success or failure (then with a ``reason``)."""

    event: ClassVar[Literal["goal_finished"]] = "goal_finished"
    optional: ClassVar[frozenset[str]] = frozenset({"ticket", "reason"})
    goal: str
    status: Literal["success", "failure"]
    ticket: int | None = None
    reason: str = ""


# -- actions ---------------------------------------------------------------------------------


@dataclass(slots=True, kw_only=True)
class ActionStarted(TraceEvent):
    """The agent ordered ``action`` from its executor."""

    event: ClassVar[Literal["action_started"]] = "action_started"
    action: str


@dataclass(slots=True, kw_only=True)
class ActionFinished(TraceEvent):
    """The executor answered ``action``: ``result`` success, failure (with ``reason``) or suspended."""

    event: ClassVar[Literal["action_finished"]] = "action_finished"
    optional: ClassVar[frozenset[str]] = frozenset({"reason"})
    action: str
    result: Literal["success", "failure", "suspended"]
    reason: str = ""


@dataclass(slots=True, kw_only=True)
class SuspendRefused(TraceEvent):
    """The executor cannot stop ``action`` half way: it goes on."""

    event: ClassVar[Literal["suspend_refused"]] = "suspend_refused"
    action: str


@dataclass(slots=True, kw_only=True)
class MessageSent(TraceEvent):
    """A protocol message (``kind``: execute, suspend, …, success, failure, …) sent ``to`` an actor."""

    event: ClassVar[Literal["message"]] = "message"
    to: str
    kind: str
    action: str


# -- the robot and the world ------------------------------------------------------------------


@dataclass(slots=True, kw_only=True)
class RobotMoving(TraceEvent):
    """The robot starts a motion of ``action`` on ``arc`` lasting ``duration`` seconds.

    ``resumed``: it finishes a suspended move, of which ``done`` (a fraction) was covered.
    """

    event: ClassVar[Literal["robot_moving"]] = "robot_moving"
    optional: ClassVar[frozenset[str]] = frozenset({"arc"})
    action: str
    arc: str | None = None
    duration: float
    done: float = 0.0
    resumed: bool = False


@dataclass(slots=True, kw_only=True)
class RobotActing(TraceEvent):
    """The robot starts a timed activity (``explain``, say), fresh or ``resumed`` after ``done`` of it."""

    event: ClassVar[Literal["robot_acting"]] = "robot_acting"
    action: str
    duration: float
    done: float = 0.0
    resumed: bool = False


@dataclass(slots=True, kw_only=True)
class ArcClosed(TraceEvent):
    """A door shut: ``arc`` cannot be travelled (a scenario event)."""

    event: ClassVar[Literal["arc_closed"]] = "arc_closed"
    arc: str


@dataclass(slots=True, kw_only=True)
class ArcOpened(TraceEvent):
    """A door opened again: ``arc`` can be travelled."""

    event: ClassVar[Literal["arc_opened"]] = "arc_opened"
    arc: str


@dataclass(slots=True, kw_only=True)
class FactsChanged(TraceEvent):
    """The world of an HDDL agent's robot changed: facts deleted, then added (a scenario event)."""

    event: ClassVar[Literal["facts_changed"]] = "facts_changed"
    add: tuple[str, ...] = ()
    delete: tuple[str, ...] = ()


# -- faults ------------------------------------------------------------------------------------


@dataclass(slots=True, kw_only=True)
class ExecutorError(TraceEvent):
    """A user's executor raised while suspending or clearing (the runtime goes on)."""

    event: ClassVar[Literal["executor_error"]] = "executor_error"
    error: str


@dataclass(slots=True, kw_only=True)
class AgentCrashed(TraceEvent):
    """An agent or executor crashed; what it served fails from now on."""

    event: ClassVar[Literal["agent_crashed"]] = "agent_crashed"
    error: str


@dataclass(slots=True, kw_only=True)
class EventsDropped(TraceEvent):
    """A reader of :meth:`Runtime.events` fell behind: ``count`` older events were dropped."""

    event: ClassVar[Literal["events_dropped"]] = "events_dropped"
    count: int


# -- agents in other processes ---------------------------------------------------------------


@dataclass(slots=True, kw_only=True)
class PeerLost(TraceEvent):
    """The process on the ``side`` of remote agent ``agent``'s link (``serving``: the process
    serving it, seen from its parent's; ``parent``: the parent's, seen from the serving one),
    at ``endpoint``, is gone or frozen; ``orders`` of the parent's orders were in flight."""

    event: ClassVar[Literal["peer_lost"]] = "peer_lost"
    side: str
    endpoint: str
    orders: int


@dataclass(slots=True, kw_only=True)
class PeerJoined(TraceEvent):
    """The process on the ``side`` of remote agent ``agent``'s link (as for ``peer_lost``) is back."""

    event: ClassVar[Literal["peer_joined"]] = "peer_joined"
    side: str
    endpoint: str


@dataclass(slots=True, kw_only=True)
class PeerRefused(TraceEvent):
    """Payloads on remote agent ``agent``'s link were refused, never acted on: ``count`` of
    them since the last such event (at most one a second per peer), the last for ``reason``,
    claimed to be from Zenoh session ``peer`` (``unknown``: it named none; ``others``: past
    the senders counted apart).  ``side`` is whose payloads they claimed to be (``parent``
    on the serving process, ``serving`` on the parent's)."""

    event: ClassVar[Literal["peer_refused"]] = "peer_refused"
    side: str
    peer: str
    reason: str
    count: int


# -- the start and the end of a run ---------------------------------------------------------------


@dataclass(slots=True, kw_only=True)
class RunStarted(TraceEvent):
    """The first event of a run of a scenario (agent ``runtime``, at t 0): what runs, and how.

    A trace saved before this event existed has no header; readers do without it.
    """

    event: ClassVar[Literal["run_started"]] = "run_started"
    scenario: str
    mode: str
    version: str


@dataclass(frozen=True, slots=True)
class ResumeRow:
    """One resumption of a goal in the summary: when (``t``, simulated seconds); the agents'
    own replanning then (``replan_ms``) and the window from the emergency's end to the
    resumed goal's first order at the robot (``window_ms``, None if no order followed),
    both on the wall clock (see :mod:`htnagent.system.goal_times`)."""

    t: float
    replan_ms: float
    window_ms: float | None = None


@dataclass(frozen=True, slots=True)
class GoalRow:
    """A scenario goal's line in the summary: ``reason`` only when it did not succeed.

    ``given``, ``started``, ``ended`` (simulated seconds; None when it never was) and
    ``waited_s`` (seconds suspended on its agent's stack) are the same at any speed;
    ``resumes`` holds wall-clock figures.  A trace saved before these fields existed reads
    back with their defaults.
    """

    agent: str
    goal: str
    status: Literal["success", "failure"]
    reason: str = dataclasses.field(default="", metadata={"optional": True})
    emergency: bool = False
    given: float | None = None
    started: float | None = None
    ended: float | None = None
    waited_s: float = 0.0
    resumes: tuple[ResumeRow, ...] = ()

    @property
    def outcome(self) -> tuple[str, str, str, str]:
        """Agent, goal, status and reason: what another run of the scenario must repeat."""
        return (self.agent, self.goal, self.status, self.reason)


@dataclass(slots=True, kw_only=True)
class Summary(TraceEvent):
    """A run's last event: every goal's status, where the robot is, where it went."""

    event: ClassVar[Literal["summary"]] = "summary"
    goals: tuple[GoalRow, ...]
    robot: dict[str, str]
    """``{"at": node}`` or ``{"on": arc}``; ``{}`` for an HDDL agent's robot (on no map)."""
    visited: tuple[str, ...]
    distance: float
    planning_ms: dict[str, float]

    @property
    def succeeded(self) -> bool:
        """Every goal succeeded."""
        return all(g.status == "success" for g in self.goals)

    @property
    def outcomes(self) -> tuple[tuple[str, str, str, str], ...]:
        """Each goal's :attr:`GoalRow.outcome`, in the scenario's order (no times, no wall clock)."""
        return tuple(g.outcome for g in self.goals)


EVENT_KINDS: dict[str, type[TraceEvent]] = {
    cls.event: cls
    for cls in (
        RunStarted,
        GoalReceived,
        PlanSelected,
        GoalSuspended,
        GoalResumed,
        GoalCleared,
        GoalFinished,
        ActionStarted,
        ActionFinished,
        SuspendRefused,
        MessageSent,
        RobotMoving,
        RobotActing,
        ArcClosed,
        ArcOpened,
        FactsChanged,
        ExecutorError,
        AgentCrashed,
        EventsDropped,
        PeerLost,
        PeerJoined,
        PeerRefused,
        Summary,
    )
}
"""Every event kind by its ``event`` name."""


def event_from_dict(data: Mapping[str, object]) -> TraceEvent:
    """The typed event a JSON object of ``run --json`` stands for (a saved trace read back).

    Raises :class:`~htnagent.errors.TraceFormatError` naming what is wrong: not an object,
    an unknown ``event``, a missing or mistyped field.
    """
    # A dict (what JSON reads) is known without the abstract class's slower check: every
    # event a serving process relays comes through here.
    if type(data) is not dict and not isinstance(data, Mapping):
        raise TraceFormatError(f"expected an event object, got {shown(data)}")
    kind = data.get("event")
    cls = EVENT_KINDS.get(kind) if isinstance(kind, str) else None
    if cls is None:
        raise TraceFormatError(f"unknown event {shown(kind)}")
    validate = _VALIDATORS.get(cls)
    if validate is None:
        validate = _VALIDATORS[cls] = TypeAdapter(cls).validator.validate_python
    try:
        # ``event`` is a class variable, not a field: validation ignores it (as any key
        # that is not a field), so the object is read as it is, not copied without it
        # first.  The adapter's own validator, called straight (its Python wrapper cost as
        # much again as the checks of a small event).
        event = validate(data)
    except ValidationError as e:
        first = e.errors()[0]
        where = ".".join(str(p) for p in first["loc"])
        raise TraceFormatError(f"{cls.event}: {where}: {first['msg']}".replace(": : ", ": ")) from None
    return event


_VALIDATORS: dict[type[TraceEvent], Callable[[object], TraceEvent]] = {}
"""Each event kind's validation (its type adapter's own), made when first needed."""


def fields_of(kind: str) -> tuple[str, ...]:
    """The fields an event kind adds to ``t``, ``agent`` and ``event`` (for documentation checks)."""
    return _field_names(EVENT_KINDS[kind])
