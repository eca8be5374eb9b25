"""The typed messages agents and executors exchange (docs/design.md §4–§5).

Frozen pydantic models, each with a literal ``kind`` as discriminator; the
unions :data:`Order`, :data:`Result` and :data:`Message` type the mailboxes.
Going down to an executor: :class:`Execute`, :class:`Suspend`, :class:`Resume`,
:class:`Clear` (and the hint :class:`Prepare`; :class:`ParentLost` when the
parent crashed). Coming back: :class:`Success`, :class:`Failure`,
:class:`Suspended`, :class:`Refused` (the running action cannot be suspended:
it goes on). Into an agent from outside: :class:`Submit` (a goal) and
:class:`BeliefUpdate` (the world changed). ``seq`` ties a result to the order
it answers, so a late answer to an abandoned order is recognised and ignored.
"""

from __future__ import annotations

from typing import Literal

from pydantic import BaseModel, ConfigDict, InstanceOf

from htnagent.model.terms import Atom as _Atom

Atom = InstanceOf[_Atom]
"""A task or action in a message: an :class:`~htnagent.model.terms.Atom` taken as it is.

Checked by type only: validating it as the named tuple it is would rebuild it, argument
by argument — the better part of the cost of a message on the way to the robot,
and a copy where the very object was meant (text forms and hashes are worked out
once per object).  Messages from another process are parsed into atoms first
(:mod:`htnagent.remote.codec`)."""


class _Message(BaseModel):
    model_config = ConfigDict(frozen=True, arbitrary_types_allowed=True)


class Execute(_Message):
    """Carry out ``action`` (for an agent executor: achieve it as a goal)."""

    kind: Literal["execute"] = "execute"
    action: Atom
    seq: int


class Suspend(_Message):
    """Stop ``action`` half way if it can be; answer Suspended or Refused."""

    kind: Literal["suspend"] = "suspend"
    action: Atom
    seq: int


class Resume(_Message):
    """Finish the suspended ``action`` (the parent's ``resume(action)``)."""

    kind: Literal["resume"] = "resume"
    action: Atom
    seq: int


class Clear(_Message):
    """Forget what was kept to resume ``action``: it will not be resumed."""

    kind: Literal["clear"] = "clear"
    action: Atom


class Prepare(_Message):
    """A hint: ``action`` is likely to be ordered next; plan it ahead if there is time.

    An agent sends it to a child agent when it has prepared the plan it will resume
    with (docs/design.md §4: work off the critical path).  The child may ignore it;
    nothing answers it.
    """

    kind: Literal["prepare"] = "prepare"
    action: Atom


class ParentLost(_Message):
    """The parent agent is gone (it crashed): nothing it ordered will be awaited or resumed."""

    kind: Literal["parent_lost"] = "parent_lost"


class Success(_Message):
    """The order ``seq`` (``action``) finished with success."""

    kind: Literal["success"] = "success"
    action: Atom
    seq: int


class Failure(_Message):
    """The order ``seq`` (``action``) failed, and why."""

    kind: Literal["failure"] = "failure"
    action: Atom
    seq: int
    reason: str = ""
    permanent: bool = False
    """The executor cannot do the action from where it stands (a child agent found no
    plan for it): trying it again unchanged would fail the same way."""


class Suspended(_Message):
    """The order ``seq`` (``action``) was stopped half way and can be resumed."""

    kind: Literal["suspended"] = "suspended"
    action: Atom
    seq: int


class Refused(_Message):
    """The order ``seq`` (``action``) cannot be suspended; it goes on."""

    kind: Literal["refused"] = "refused"
    action: Atom
    seq: int


class Submit(_Message):
    """A goal for the agent; ``ticket`` names it in the outcome."""

    kind: Literal["submit"] = "submit"
    goal: Atom
    emergency: bool = False
    ticket: int


class BeliefUpdate(_Message):
    """Facts the agent learns from outside (a door shut or opened)."""

    kind: Literal["belief"] = "belief"
    add: tuple[Atom, ...] = ()
    delete: tuple[Atom, ...] = ()


class Timeout(_Message):
    """The order ``seq`` took longer than the action timeout (an agent's timer to itself)."""

    kind: Literal["timeout"] = "timeout"
    seq: int


Order = Execute | Suspend | Resume | Clear | Prepare | ParentLost
"""What a parent sends down to its executor."""

Result = Success | Failure | Suspended | Refused
"""What an executor answers an order with."""

ActionResult = Success | Failure | Suspended
"""How an ordered action ended (a Refused only says it goes on)."""

Message = Order | Result | Submit | BeliefUpdate | Timeout
"""Everything an actor's mailbox can hold: orders from above, results from below, goals and
belief updates from outside, and timers an actor set for itself."""
