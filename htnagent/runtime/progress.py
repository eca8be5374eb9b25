"""How far an action has got: the typed signal that action triggers follow.

A scenario goal may wait for an action to reach a fraction of its way
(``when: {action: move(...), progress: 0.5}``).  The actor carrying the action
out tells :class:`ProgressListeners` when a motion or timed activity starts,
when it is stopped half way, and when an agent's action ends — this, not the
trace, is what triggers read, so the trace's wording can change freely.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from enum import Enum

from htnagent.model.terms import Atom
from htnagent.runtime.listeners import Listeners


class Phase(Enum):
    """What happened to the action."""

    STARTED = "started"
    """A timed motion or activity of the action starts now and lasts ``duration``."""
    STOPPED = "stopped"
    """The robot stopped the action half way (it was suspended)."""
    SUCCEEDED = "succeeded"
    """An agent's action (or the resume finishing it) ended with success."""


@dataclass(frozen=True, slots=True)
class Progress:
    """One step of an action's progress, as its actor reports it."""

    actor: str
    action: Atom
    """The action in the plan (for a resumed or rolled-back move, ``resume(A)``/``rollback(A)``)."""
    phase: Phase
    duration: float = 0.0
    """STARTED: simulated seconds the motion or activity lasts from now."""
    done: float = 0.0
    """STARTED: the fraction of the action covered before this motion (a resumed rest)."""


ProgressListener = Callable[[Progress], None]


class ProgressListeners(Listeners[Progress]):
    """The listeners of one runtime's actors; a listener must not block."""

    def __init__(self) -> None:
        super().__init__("progress listener")
