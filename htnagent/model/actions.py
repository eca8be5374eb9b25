"""Ground actions: what each does to a belief, worked out once per domain.

A :class:`~htnagent.model.domain.Domain` says what operators exist; this module says
what a ground action such as ``move(n1,n6,arc5)`` *does*.  Every domain owns one
:class:`Actions` (``domain.actions``), which finds the operator implementing an
action (grounding), caches the action with its precondition and effects made
ground (:class:`CompiledAction`), and computes the belief after it.

One name per transition — each is a method of :class:`Actions`:

- **apply**: the precondition is checked first; ``None`` when it does not hold.
  :meth:`Actions.apply` gives the whole state; :meth:`Actions.apply_dynamic`
  (and :meth:`CompiledAction.apply_dynamic`) only the dynamic facts, the fast
  form the planner's search and plan re-checks (docs/design.md §2.4) run on.
- **progress**: the belief follows an action the executor *reports done*,
  whether or not the belief thought it could run (the executor is the authority).
- **suspend**: the belief after the running action is stopped half way, by its
  suspension effect (docs/design.md §3, Algorithm 1, step 1).
- **clear**: the belief once a suspended action will never be resumed.

The recovery actions of a suspended action A are ``resume(A)`` (finish the rest)
and ``rollback(A)`` (undo the half done); an *undo* is the inverse of a finished
action (docs/design.md §1).  Their names are defined here once, as :data:`RESUME`
and :data:`ROLLBACK`, with helpers to make and read such actions.

The caches are filled as actions are met and emptied when an operator is added
to the domain; they are the only mutable part, and never change an answer.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from typing import Final, Protocol

from htnagent.errors import PlanningError
from htnagent.model.operators import Operator
from htnagent.model.preconditions import satisfiers
from htnagent.model.state import State
from htnagent.model.terms import Atom, Bindings, substitute, unify

RESUME: Final = "resume"
"""The name of ``resume(A)``: finish the rest of the suspended action A."""
ROLLBACK: Final = "rollback"
"""The name of ``rollback(A)``: undo what was done of the suspended action A."""
RECOVERY: Final = (RESUME, ROLLBACK)
"""The names of the actions that finish or undo a suspended action (reserved in every domain)."""


def resume_action(action: Atom) -> Atom:
    """``resume(action)``."""
    return Atom(RESUME, (action,))


def rollback_action(action: Atom) -> Atom:
    """``rollback(action)``."""
    return Atom(ROLLBACK, (action,))


def action_recovered_by(action: Atom) -> Atom | None:
    """A for ``resume(A)`` or ``rollback(A)``; None for any other action."""
    if action.name in RECOVERY and len(action.args) == 1 and isinstance(action.args[0], Atom):
        return action.args[0]
    return None


def action_resumed_by(action: Atom) -> Atom | None:
    """A for ``resume(A)``; None for any other action (``rollback(A)`` included)."""
    return action_recovered_by(action) if action.name == RESUME else None


def action_rolled_back_by(action: Atom) -> Atom | None:
    """A for ``rollback(A)``; None for any other action (``resume(A)`` included)."""
    return action_recovered_by(action) if action.name == ROLLBACK else None


_Way = tuple[tuple[tuple[Atom, bool], ...], frozenset[Atom], frozenset[Atom]]
"""One way a ground action can run: its ground dynamic checks, delete and add effects."""

_STATIC_BASES = 4
"""How many static fact bases an action keeps its ways for (they change rarely)."""


@dataclass(frozen=True, slots=True)
class CompiledAction:
    """A ground action's operator, bindings, ground precondition and effects, and cost.

    ``checks`` is None when the precondition binds variables the head does not.
    When only static facts bind them (``move_area(A,B)`` finds its door's arc in
    the map), the ways the action can run are worked out once per static fact
    base: each a binding of those variables, in the order SHOP tries them, with
    the dynamic literals and the effects made ground.  Otherwise the precondition
    is matched against each state (and ``add``/``delete`` are unused).
    """

    op: Operator
    bindings: Bindings
    checks: tuple[tuple[Atom, bool], ...] | None
    delete: frozenset[Atom]
    add: frozenset[Atom]
    cost: float
    static_bound: bool = False
    """Only static literals bind the variables the head leaves free (see above)."""
    _ways: dict[int, tuple[object, tuple[_Way, ...]]] = field(default_factory=dict, repr=False, compare=False)

    def apply_dynamic(self, state: State) -> frozenset[Atom] | None:
        """The dynamic facts after the action, or None when its precondition is false.

        Returns ``state.dynamic`` itself when the action changes nothing.
        """
        if self.checks is None:
            if self.static_bound:
                return self._apply_ways(state)
            full = self.op.applicable(state, self.bindings)
            return None if full is None else self.op.effects_on(state.dynamic, full)
        return self.after(state.dynamic, state.static.facts, state.dynamic_predicates)

    def after(
        self, dynamic: frozenset[Atom], static: frozenset[Atom], dynamic_predicates: frozenset[str]
    ) -> frozenset[Atom] | None:
        """:meth:`apply_dynamic` on a state given by its parts (the search's every action,
        with no :class:`State` made); only for an action whose ``checks`` are not None."""
        assert self.checks is not None
        for fact, positive in self.checks:  # State.holds, inlined
            if (fact in (dynamic if fact.name in dynamic_predicates else static)) != positive:
                return None
        if not self.delete and not self.add:
            return dynamic
        return (dynamic - self.delete) | self.add

    def _apply_ways(self, state: State) -> frozenset[Atom] | None:
        dynamic = state.dynamic
        for checks, delete, add in self._ways_in(state):
            if all((fact in dynamic) == positive for fact, positive in checks):
                return (dynamic - delete) | add if delete or add else dynamic
        return None

    def _ways_in(self, state: State) -> tuple[_Way, ...]:
        """The ways the action can run on ``state``'s static facts (kept per fact base)."""
        static = state.static
        kept = self._ways.get(id(static))
        if kept is not None and kept[0] is static:  # the entry holds the base: its id is not reused
            return kept[1]
        op, dyn = self.op, state.dynamic_predicates
        fixed = [lit for lit in op.pre if lit.atom.name not in dyn]
        ways = []
        for b in satisfiers(fixed, state, self.bindings):
            checks = tuple((substitute(lit.atom, b), lit.positive) for lit in op.pre if lit.atom.name in dyn)
            delete = frozenset(substitute(a, b) for a in op.delete)
            add = frozenset(substitute(a, b) for a in op.add)
            ways.append((checks, delete, add))
        if len(self._ways) >= _STATIC_BASES:
            self._ways.pop(next(iter(self._ways)))
        self._ways[id(static)] = (static, tuple(ways))
        return tuple(ways)


def _static_bound(op: Operator, bindings: Bindings, dynamic: frozenset[str]) -> bool:
    """Whether only static literals bind the precondition's variables the head leaves free:
    every dynamic literal is ground where it stands (so, a check that binds nothing)."""
    bound = set(bindings)
    for lit in op.pre:
        if lit.atom.name in dynamic:
            if not lit.variables <= bound:
                return False
        elif lit.positive:
            bound |= lit.variables
    return True


_MISSING: object = object()


class Operators(Protocol):
    """What :class:`Actions` reads of its domain, at the time it reads it (a domain is
    a builder: it gains operators, and may be renamed, after its actions were made)."""

    @property
    def name(self) -> str: ...

    @property
    def operators(self) -> Mapping[str, Sequence[Operator]]: ...

    @property
    def dynamic_predicates(self) -> frozenset[str]: ...


class Actions:
    """The ground actions of one domain: found, compiled and cached, and what they do.

    Made by the :class:`~htnagent.model.domain.Domain` itself (``domain.actions``);
    :meth:`forget` empties the caches when the domain gains an operator.
    """

    __slots__ = ("_compiled", "_domain", "_ground", "_undo")

    def __init__(self, domain: Operators) -> None:
        self._domain = domain
        self._ground: dict[Atom, tuple[Operator, Bindings] | None] = {}
        self._compiled: dict[Atom, CompiledAction] = {}
        self._undo: dict[Atom, Atom | None] = {}

    def forget(self) -> None:
        """Empty the caches (the domain's operators changed)."""
        self._ground.clear()
        self._compiled.clear()
        self._undo.clear()

    # -- grounding --------------------------------------------------------------

    def ground(self, action: Atom) -> tuple[Operator, Bindings]:
        """The operator implementing the ground action, and its head bindings.

        Raises :class:`~htnagent.errors.PlanningError` when no operator does.
        """
        cached = self._ground.get(action, _MISSING)
        if cached is _MISSING:
            cached = None
            for op in self._domain.operators.get(action.name, ()):
                b = unify(op.head, action, {})
                if b is not None:
                    cached = (op, b)
                    break
            self._ground[action] = cached
        if cached is None:
            raise PlanningError(f"domain {self._domain.name}: no operator for action {action}")
        return cached  # type: ignore[return-value]

    def compiled(self, action: Atom) -> CompiledAction:
        """The ground action with its precondition and effects worked out once (cached)."""
        found = self._compiled.get(action)
        if found is None:
            op, b = self.ground(action)
            checks: tuple[tuple[Atom, bool], ...] | None = None
            delete: frozenset[Atom] = frozenset()
            add: frozenset[Atom] = frozenset()
            static_bound = False
            if all(lit.variables <= b.keys() for lit in op.pre):
                checks = tuple((substitute(lit.atom, b), lit.positive) for lit in op.pre)
                delete = frozenset(substitute(a, b) for a in op.delete)
                add = frozenset(substitute(a, b) for a in op.add)
            else:
                static_bound = _static_bound(op, b, self._domain.dynamic_predicates)
            found = CompiledAction(op, b, checks, delete, add, op.action_cost(action), static_bound)
            self._compiled[action] = found
        return found

    def compiled_or_none(self, action: Atom) -> CompiledAction | None:
        """:meth:`compiled`, or None when no operator implements the action."""
        found = self._compiled.get(action)
        if found is not None:
            return found
        if self._ground.get(action, _MISSING) is None:
            return None
        try:
            return self.compiled(action)
        except PlanningError:
            return None

    def known(self, action: Atom) -> CompiledAction | None:
        """The compiled ground action if it was compiled before (a plain look-up)."""
        return self._compiled.get(action)

    def cost(self, action: Atom) -> float:
        """The cost of a ground action."""
        return self.compiled(action).cost

    # -- transitions --------------------------------------------------------------

    def apply(self, state: State, action: Atom) -> State | None:
        """The state after the action, or None when its precondition is false."""
        dynamic = self.compiled(action).apply_dynamic(state)
        return None if dynamic is None else state.with_dynamic(dynamic)

    def apply_dynamic(self, state: State, action: Atom) -> frozenset[Atom] | None:
        """:meth:`apply`, giving only the dynamic facts after (the same static ones follow)."""
        return self.compiled(action).apply_dynamic(state)

    def progress(self, state: State, action: Atom) -> State:
        """The state after an action reported done, even if the belief doubted it could run.

        The executor is the authority on what happened: the effects are applied
        with the precondition's bindings when it holds, the head's otherwise.  Of
        several operators of the action (an HDDL ``or`` or ``when`` makes one per
        case, docs/design.md §7.1), the first whose precondition holds gives the effects.
        """
        found = self.running_way(state, action)
        op, b = found if found is not None else self.ground(action)
        return state.with_dynamic(op.effects_on(state.dynamic, b))

    def running_way(self, state: State, action: Atom) -> tuple[Operator, Bindings] | None:
        """The operator that runs the ground action in the state, with the precondition's
        bindings: the first of the action's operators whose precondition holds (an HDDL
        ``or`` or ``when`` makes one per case, docs/design.md §7.1); None when none does."""
        for op in self._domain.operators.get(action.name, ()):
            head = unify(op.head, action, {})
            full = op.applicable(state, head) if head is not None else None
            if full is not None:
                return op, full
        return None

    def can_suspend(self, action: Atom) -> bool:
        """Whether the belief can follow the ground action being stopped half way.

        True when its operator declares a suspension, and for ``resume(A)`` and
        ``rollback(A)`` of such an A: stopping either leaves A suspended, with
        less (or more) of it left to do (docs/design.md §4, Algorithm 3).
        """
        target = action_recovered_by(action) or action
        try:
            op, _ = self.ground(target)
        except PlanningError:
            return False
        return op.suspendable

    def suspend(self, state: State, action: Atom) -> State:
        """The belief after the running action is stopped half way (docs/design.md §3, step 1).

        Stopping ``resume(A)`` or ``rollback(A)`` leaves A suspended as it was before
        they started: the belief already says so, and stays as it is.  Raises
        :class:`~htnagent.errors.PlanningError` for an action that cannot be suspended.
        """
        if action_recovered_by(action) is not None:
            return state
        op, b = self.ground(action)
        if not op.suspendable:
            raise PlanningError(f"domain {self._domain.name}: action {action} is not suspendable")
        full = next(satisfiers(op.pre, state, b), b)
        return state.with_dynamic(op.suspension_on(state.dynamic, full))

    def clear(self, state: State, action: Atom) -> State:
        """The belief once a suspended action will never be resumed.

        The facts that only recorded that it could be resumed (its suspension's
        ``cleared``) go; facts about the world stay.
        """
        op, b = self.ground(action)
        gone = {substitute(a, b) for a in op.clear_delete}
        if not gone & state.dynamic:
            return state
        return state.with_dynamic(state.dynamic - gone)

    # -- recovery and undo ----------------------------------------------------------

    def undo_of(self, action: Atom) -> Atom | None:
        """The action that undoes a finished action, if the domain declares one."""
        # Cached: the tidy-up rules (docs/design.md §2.6) ask for every pair of steps.
        found = self._undo.get(action, _MISSING)
        if found is _MISSING:
            found = None
            if action.name not in RECOVERY:  # undoing a resumed half would not lead back to it
                op, b = self.ground(action)
                if op.undo is not None:
                    found = substitute(op.undo, b)
            self._undo[action] = found
        return found  # type: ignore[return-value]

    def resume_of(self, action: Atom) -> Atom | None:
        """``resume(action)`` when the action's operator can resume."""
        op, _ = self.ground(action)
        return resume_action(action) if op.resume is not None else None

    def rollback_of(self, action: Atom) -> Atom | None:
        """``rollback(action)`` when the action's operator can roll back."""
        op, _ = self.ground(action)
        return rollback_action(action) if op.rollback is not None else None


__all__ = [
    "RECOVERY",
    "RESUME",
    "ROLLBACK",
    "Actions",
    "CompiledAction",
    "action_recovered_by",
    "action_resumed_by",
    "action_rolled_back_by",
    "resume_action",
    "rollback_action",
]
