"""The total-order HDDL model: domains and problems as immutable values.

What :mod:`htnagent.hddl.reader` makes of an HDDL file, and all that the
semantic checks (:mod:`htnagent.hddl.semantics`), the plan checker
(:mod:`htnagent.hddl.check`) and, later, grounding or translation into a
:class:`htnagent.model.domain.Domain` work from.  Everything is a frozen dataclass
or a tuple; names are lower case (HDDL names are case-insensitive).

The model keeps what the file says, not what a planner would make of it:
typed parameter lists, the type hierarchy with each type's direct supertypes,
formula trees (:data:`Formula`, :data:`Effect`) with their quantifiers and
conditional effects, and each method's subtasks in their (total) order.

Terms are plain strings: a variable starts with ``?``, anything else is an
object or constant.  A literal or a task call is an :class:`~htnagent.model.terms.Atom`
of such strings.  A parameter's type is a tuple of type names, one for a plain
type and several for ``(either a b)`` (a value of any of them).

Every element keeps ``at``, the character offset where it starts in its file;
``Domain.source`` / ``Problem.source`` turn an offset into ``FILE:LINE:COL``
for messages (``at`` takes no part in equality).
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field
from types import MappingProxyType

from htnagent.errors import HddlError
from htnagent.model.terms import Atom

OBJECT = "object"
"""The root type every type descends from (implicitly declared)."""


@dataclass(frozen=True, slots=True, eq=False)
class Source:
    """A file's name and text: where an offset is, as ``FILE:LINE:COL``."""

    file: str
    text: str = field(repr=False)

    def where(self, at: int) -> tuple[int, int]:
        """Line and column (both from 1) of the character at offset ``at``."""
        at = max(0, min(at, len(self.text)))
        line = self.text.count("\n", 0, at) + 1
        return line, at - (self.text.rfind("\n", 0, at) + 1) + 1

    def error(self, at: int | None, reason: str) -> HddlError:
        """An :class:`~htnagent.errors.HddlError` at offset ``at`` (None: the whole file)."""
        if at is None:
            return HddlError(self.file, reason)
        line, col = self.where(at)
        return HddlError(self.file, reason, line, col)


# -- names with types ------------------------------------------------------------------------------


@dataclass(frozen=True, slots=True)
class Typed:
    """A parameter, quantified variable, constant or object: ``name - type`` (``type`` has
    several names for ``(either ...)``)."""

    name: str
    types: tuple[str, ...] = (OBJECT,)
    at: int = field(default=0, compare=False, repr=False)

    def __str__(self) -> str:
        kind = self.types[0] if len(self.types) == 1 else f"(either {' '.join(self.types)})"
        return f"{self.name} - {kind}"


# -- formulas (preconditions, goals, constraints) --------------------------------------------------


@dataclass(frozen=True, slots=True)
class Pred:
    """A predicate applied to terms: ``(at ?x l1)``."""

    atom: Atom
    at: int = field(default=0, compare=False, repr=False)


@dataclass(frozen=True, slots=True)
class Equals:
    """``(= a b)``: the two terms name the same object."""

    left: str
    right: str
    at: int = field(default=0, compare=False, repr=False)


@dataclass(frozen=True, slots=True)
class SortOf:
    """``(sortof ?v - t)``, only in a method's ``:constraints``: the value of ``?v`` is of type ``t``."""

    var: str
    types: tuple[str, ...]
    at: int = field(default=0, compare=False, repr=False)


@dataclass(frozen=True, slots=True)
class Not:
    """``(not f)``."""

    arg: Formula
    at: int = field(default=0, compare=False, repr=False)


@dataclass(frozen=True, slots=True)
class And:
    """``(and f ...)``; ``()`` is the empty conjunction (true)."""

    args: tuple[Formula, ...] = ()
    at: int = field(default=0, compare=False, repr=False)


@dataclass(frozen=True, slots=True)
class Or:
    """``(or f ...)``; the empty disjunction is false."""

    args: tuple[Formula, ...] = ()
    at: int = field(default=0, compare=False, repr=False)


@dataclass(frozen=True, slots=True)
class Imply:
    """``(imply if then)``."""

    cond: Formula
    then: Formula
    at: int = field(default=0, compare=False, repr=False)


@dataclass(frozen=True, slots=True)
class Forall:
    """``(forall (?v - t ...) f)``: ``f`` holds for every object of the variables' types."""

    params: tuple[Typed, ...]
    body: Formula
    at: int = field(default=0, compare=False, repr=False)


@dataclass(frozen=True, slots=True)
class Exists:
    """``(exists (?v - t ...) f)``: ``f`` holds for some objects of the variables' types."""

    params: tuple[Typed, ...]
    body: Formula
    at: int = field(default=0, compare=False, repr=False)


Formula = Pred | Equals | SortOf | Not | And | Or | Imply | Forall | Exists
"""A goal description: precondition, goal or method constraint."""

TRUE: Formula = And()
"""The empty precondition."""


# -- effects ---------------------------------------------------------------------------------------


@dataclass(frozen=True, slots=True)
class Literal:
    """An effect literal: ``(p ...)`` adds, ``(not (p ...))`` deletes."""

    atom: Atom
    positive: bool = True
    at: int = field(default=0, compare=False, repr=False)


@dataclass(frozen=True, slots=True)
class AndEffect:
    """``(and e ...)``; ``()`` changes nothing."""

    args: tuple[Effect, ...] = ()
    at: int = field(default=0, compare=False, repr=False)


@dataclass(frozen=True, slots=True)
class ForallEffect:
    """``(forall (?v - t ...) e)``: ``e`` for every object of the variables' types."""

    params: tuple[Typed, ...]
    body: Effect
    at: int = field(default=0, compare=False, repr=False)


@dataclass(frozen=True, slots=True)
class When:
    """``(when cond e)``: ``e`` happens if ``cond`` holds in the state before the action."""

    cond: Formula
    body: Effect
    at: int = field(default=0, compare=False, repr=False)


Effect = Literal | AndEffect | ForallEffect | When
"""An action's effect."""

NO_EFFECT: Effect = AndEffect()
"""The empty effect."""


# -- domain elements -------------------------------------------------------------------------------


@dataclass(frozen=True, slots=True)
class Predicate:
    """``(:predicates (name ?p - t ...))``."""

    name: str
    params: tuple[Typed, ...]
    at: int = field(default=0, compare=False, repr=False)


@dataclass(frozen=True, slots=True)
class Task:
    """A compound task: ``(:task name :parameters (...))``."""

    name: str
    params: tuple[Typed, ...]
    at: int = field(default=0, compare=False, repr=False)


@dataclass(frozen=True, slots=True)
class Action:
    """A primitive task: ``(:action name :parameters (...) :precondition f :effect e)``."""

    name: str
    params: tuple[Typed, ...]
    precondition: Formula = TRUE
    effect: Effect = NO_EFFECT
    at: int = field(default=0, compare=False, repr=False)


@dataclass(frozen=True, slots=True)
class Subtask:
    """One step of a method or of the initial task network: ``(id (name args))`` or ``(name args)``.

    ``id`` is None when the file gives none.
    """

    call: Atom
    id: str | None = None
    at: int = field(default=0, compare=False, repr=False)


@dataclass(frozen=True, slots=True)
class Method:
    """``(:method name :parameters (...) :task (t ...) :precondition f :ordered-subtasks (...))``.

    ``subtasks`` are in their total order (``:subtasks`` with ``:ordering`` is
    read into that order).  ``constraints`` is the ``:constraints`` formula
    (equalities and ``sortof``), :data:`TRUE` when absent.
    """

    name: str
    params: tuple[Typed, ...]
    task: Atom
    precondition: Formula = TRUE
    subtasks: tuple[Subtask, ...] = ()
    constraints: Formula = TRUE
    at: int = field(default=0, compare=False, repr=False)


def _frozen(mapping: Mapping[str, object]) -> Mapping[str, object]:
    return MappingProxyType(dict(mapping))


@dataclass(frozen=True, slots=True)
class Domain:
    """An HDDL domain.

    ``types`` maps each declared type to its direct supertypes (``object`` has
    none; a type declared without one has ``("object",)``).  The mappings are
    read-only and keep the file's order.
    """

    name: str
    requirements: tuple[str, ...]
    types: Mapping[str, tuple[str, ...]]
    constants: tuple[Typed, ...]
    predicates: Mapping[str, Predicate]
    tasks: Mapping[str, Task]
    actions: Mapping[str, Action]
    methods: Mapping[str, Method]
    source: Source = field(compare=False, repr=False)

    def __post_init__(self) -> None:
        for name in ("types", "predicates", "tasks", "actions", "methods"):
            object.__setattr__(self, name, _frozen(getattr(self, name)))

    def methods_for(self, task: str) -> tuple[Method, ...]:
        """The methods that decompose the compound task named ``task``, in file order."""
        return tuple(m for m in self.methods.values() if m.task.name == task)

    def supertypes(self, kind: str) -> frozenset[str]:
        """``kind`` and every type above it (``object`` included)."""
        seen = {kind}
        todo = [kind]
        while todo:
            for parent in self.types.get(todo.pop(), ()):
                if parent not in seen:
                    seen.add(parent)
                    todo.append(parent)
        seen.add(OBJECT)
        return frozenset(seen)


@dataclass(frozen=True, slots=True)
class Problem:
    """An HDDL problem.

    ``htn`` is the initial task network's subtasks in order, with its
    ``:parameters`` in ``htn_params`` (variables the tasks may leave open).
    ``init`` holds the initial facts (``init_at`` where each is written,
    ``domain_at`` where the domain is named);
    ``goal`` is :data:`TRUE` when the problem has none.
    """

    name: str
    domain: str
    requirements: tuple[str, ...]
    objects: tuple[Typed, ...]
    htn_params: tuple[Typed, ...]
    htn: tuple[Subtask, ...]
    htn_constraints: Formula
    init: tuple[Atom, ...]
    goal: Formula
    source: Source = field(compare=False, repr=False)
    init_at: tuple[int, ...] = field(default=(), compare=False, repr=False)
    domain_at: int = field(default=0, compare=False, repr=False)
