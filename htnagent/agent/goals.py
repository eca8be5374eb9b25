"""The goals an agent holds: how a goal ended, and a goal with what it keeps (§4).

A :class:`GoalEntry` is one goal — running, waiting, an emergency not yet started, or
on the stack of suspended goals — with its plan set and, once suspended, the actions
it stopped half way.  :class:`Running` is the one action in flight.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from enum import Enum

from htnagent.agent.resumption import Foreseen
from htnagent.model.terms import Atom
from htnagent.runtime.clock import TimerHandle
from htnagent.upkeep import PlanSet


class GoalStatus(Enum):
    """How a goal ended."""

    SUCCESS = "success"
    """The goal was achieved: a plan for it ran to its end while it was the running goal, or
    a plan made for it from the belief has nothing left to do (it holds now, §2.8)."""
    FAILURE = "failure"
    """No plan was left for the goal, an action kept failing, or the agent could not go on."""


@dataclass(eq=False)
class GoalEntry:
    """A goal with its plans; on the stack it also keeps its suspended action.

    Entries compare by identity: the same goal may be on the stack twice.
    """

    goal: Atom
    plans: PlanSet
    emergency: bool = False
    ticket: int | None = None
    order_seq: int | None = None
    """The parent's order this goal carries out (Algorithm 5), if any."""
    suspended: list[Atom] = field(default_factory=list)
    """Actions of this goal stopped half way and kept for ``resume(A)`` (oldest first).

    Usually one; more when a resumed goal walks back to finish an action later and
    is suspended again on the way."""
    held: bool = False
    """On the stack by the parent's ``suspend``: it waits for the parent's resume or clear."""
    stop_requested: bool = False
    """The parent asked to suspend this goal; it stops after the running action."""
    failures: dict[Atom, tuple[tuple[object, ...], int]] = field(default_factory=dict)
    """Failures in a row per action, from one belief: (that belief, count)."""
    arrival: int = 0
    """When the goal arrived, as a count: only a later emergency suspends it."""
    foreseen: Foreseen | None = None
    """How it resumes, worked out ahead by the look-ahead while the action before ran (§4)."""


@dataclass
class Running:
    """The action in flight, as ordered to the executor."""

    seq: int
    action: Atom
    ordered: Atom
    """What the executor was told: A for ``resume(A)``, else the action itself."""
    timer: TimerHandle | None = None
    suspend_sent: bool = False
