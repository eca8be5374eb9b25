"""Operators: the primitive tasks of a domain, as values that check themselves when built.

An :class:`Operator` is a precondition, add and delete effects and a cost; a suspendable
one also says what stopping it half way does to the belief and carries its ``resume(A)``
and ``rollback(A)`` operators (docs/design.md §1).  :class:`Suspension` and :class:`Effect`
are how a domain declares those; :class:`~htnagent.model.domain.Domain` turns the
declarations into operators.  What a *ground* action does to a belief is
:mod:`htnagent.model.actions`.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass

from htnagent.errors import DomainError
from htnagent.model.preconditions import Literal, bound_by, satisfiers
from htnagent.model.state import State
from htnagent.model.terms import Atom, Bindings, substitute

CostSpec = float | int | Callable[[Atom], float]
"""An operator's cost: a number, or a function of the ground action."""


@dataclass(frozen=True, slots=True)
class Effect:
    """Precondition, effects and cost of a resume or rollback operator."""

    add: tuple[str, ...] = ()
    delete: tuple[str, ...] = ()
    pre: tuple[str, ...] | None = None
    cost: CostSpec | None = None


@dataclass(frozen=True, slots=True)
class Suspension:
    """What stopping an action half way does, and how to finish or undo the half.

    ``add``/``delete`` are the suspension effect on the belief (applied to the
    state before the action); ``resume`` and ``rollback`` describe the operators
    ``resume(A)`` and ``rollback(A)``, whose precondition defaults to the facts
    the suspension added.  ``cleared`` names the facts that only record that A
    can be resumed — they leave the belief when the suspension is cleared —
    as opposed to facts about the world (a robot on an arc stays there).
    """

    add: tuple[str, ...] = ()
    delete: tuple[str, ...] = ()
    resume: Effect | None = None
    rollback: Effect | None = None
    cleared: tuple[str, ...] = ()


@dataclass(frozen=True, slots=True)
class Operator:
    """A primitive task: precondition, add and delete effects, cost.

    For suspension it may carry ``suspend_add``/``suspend_delete`` (the suspension
    effect), ``resume``/``rollback`` operators and an ``undo`` pattern naming the
    inverse action.
    """

    head: Atom
    pre: tuple[Literal, ...] = ()
    add: tuple[Atom, ...] = ()
    delete: tuple[Atom, ...] = ()
    cost: CostSpec = 1.0
    suspendable: bool = False
    suspend_add: tuple[Atom, ...] = ()
    suspend_delete: tuple[Atom, ...] = ()
    clear_delete: tuple[Atom, ...] = ()
    resume: Operator | None = None
    rollback: Operator | None = None
    undo: Atom | None = None

    def __post_init__(self) -> None:
        known = self.head.variables() | bound_by(self.pre)
        for part, items in (
            ("add", self.add),
            ("delete", self.delete),
            ("suspension add", self.suspend_add),
            ("suspension delete", self.suspend_delete),
            ("suspension cleared", self.clear_delete),
        ):
            for a in items:
                unknown = a.variables() - known
                if unknown:
                    raise DomainError(
                        f"operator {self.head}: {part} effect {a} uses unbound {sorted(unknown)}"
                    )
        if self.undo is not None and self.undo.variables() - self.head.variables():
            raise DomainError(f"operator {self.head}: undo {self.undo} uses unbound variables")
        if isinstance(self.cost, int | float) and not (0 <= self.cost < math.inf):
            raise DomainError(
                f"operator {self.head}: cost {self.cost}: a cost is a finite number, not negative"
            )

    @property
    def name(self) -> str:
        """The task name this operator implements."""
        return self.head.name

    def action_cost(self, action: Atom) -> float:
        """The cost of the ground action."""
        c = self.cost
        value = float(c(action)) if callable(c) else float(c)
        if not 0 <= value < math.inf:  # NaN too: plans could no longer be put in cost order
            raise DomainError(
                f"operator {self.head}: cost {value} for {action}: a cost is a finite number, not negative"
            )
        return value

    def applicable(self, state: State, bindings: Bindings) -> Bindings | None:
        """The first extension of ``bindings`` that satisfies the precondition, or None."""
        return next(satisfiers(self.pre, state, bindings), None)

    def effects_on(self, dynamic: frozenset[Atom], bindings: Bindings) -> frozenset[Atom]:
        """The dynamic facts after the delete then add effects, unchecked (the precondition
        is the caller's to test: see :mod:`htnagent.model.actions` for the checked forms)."""
        return _changed(dynamic, self.delete, self.add, bindings)

    def suspension_on(self, dynamic: frozenset[Atom], bindings: Bindings) -> frozenset[Atom]:
        """The dynamic facts after the action is stopped half way (its suspension effect)."""
        return _changed(dynamic, self.suspend_delete, self.suspend_add, bindings)


def _changed(
    dynamic: frozenset[Atom],
    delete: tuple[Atom, ...],
    add: tuple[Atom, ...],
    bindings: Bindings,
) -> frozenset[Atom]:
    if not delete and not add:
        return dynamic
    out = set(dynamic)
    for d in delete:
        out.discard(substitute(d, bindings))
    for a in add:
        out.add(substitute(a, bindings))
    return frozenset(out)


__all__ = ["CostSpec", "Effect", "Operator", "Suspension"]
