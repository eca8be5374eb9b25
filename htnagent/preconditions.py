"""Preconditions: literals, and matching them against a belief SHOP-style (docs/design.md §1).

An operator's or method's precondition is a conjunction of :class:`Literal`
values, positive or negated atoms with variables.  :func:`satisfiers` yields
every binding of the variables under which the conjunction holds in a
:class:`~htnagent.state.State`, binding left to right by matching facts (SHOP
unification); :func:`all_satisfiers` is its fast, list-returning form, which the
planner calls at every search step.
"""

from __future__ import annotations

from collections.abc import Callable, Iterable, Iterator, Mapping, Sequence
from dataclasses import dataclass, field
from operator import itemgetter
from typing import Any

from htnagent.state import FactBase, State
from htnagent.terms import Atom, Bindings, Term, atom, substitute

_new_atom = tuple.__new__


@dataclass(frozen=True, slots=True)
class Literal:
    """A positive or negated atom in a precondition."""

    atom: Atom
    positive: bool = True
    variables: frozenset[str] = field(init=False, repr=False, compare=False)

    def __post_init__(self) -> None:
        object.__setattr__(self, "variables", frozenset(self.atom.variables()))

    @classmethod
    def parse(cls, text: str | Literal | Atom) -> Literal:
        """Read ``"at(?x)"`` or ``"not at(?x)"``."""
        if isinstance(text, Literal):
            return text
        if isinstance(text, Atom):
            return cls(text)
        stripped = text.strip()
        if stripped.startswith("not "):
            return cls(atom(stripped[4:].strip()), positive=False)
        return cls(atom(stripped))

    def __str__(self) -> str:
        return str(self.atom) if self.positive else f"not {self.atom}"


def satisfiers(
    pre: Sequence[Literal], state: State, bindings: Bindings, start: int = 0
) -> Iterator[Bindings]:
    """Every binding under which the conjunction holds, SHOP-style, left to right.

    A negative literal holds when no fact matches it under the bindings so far.
    """
    # Literals whose variables are all bound are plain look-ups: check them in a row.
    n = len(pre)
    i = start
    while i < n:
        lit = pre[i]
        names = lit.variables
        if names and not all(v in bindings for v in names):
            break
        fact = substitute(lit.atom, bindings) if names else lit.atom
        if state.holds(fact) != lit.positive:
            return
        i += 1
    if i == n:
        yield bindings
        return
    lit = pre[i]
    if lit.positive:
        for b in state.match(lit.atom, bindings):
            yield from satisfiers(pre, state, b, i + 1)
    else:
        if next(state.match(lit.atom, bindings), None) is not None:
            return
        yield from satisfiers(pre, state, bindings, i + 1)


def all_satisfiers(pre: Sequence[Literal], state: State, bindings: Bindings) -> list[Bindings]:
    """Every binding of :func:`satisfiers`, as a list, in the same order — its fast form.

    The planner decomposes with it at every search step: no generators, and flat
    facts are matched argument by argument without building atoms.
    """
    out: list[Bindings] = []
    _collect(pre, 0, state, bindings, out)
    return out


def _collect(pre: Sequence[Literal], i: int, state: State, bindings: Bindings, out: list[Bindings]) -> None:
    n = len(pre)
    while i < n:
        lit = pre[i]
        names = lit.variables
        if names and not names <= bindings.keys():
            break
        fact = substitute(lit.atom, bindings) if names else lit.atom
        if state.holds(fact) != lit.positive:
            return
        i += 1
    if i == n:
        out.append(bindings)
        return
    lit = pre[i]
    if not lit.positive:
        if next(state.match(lit.atom, bindings), None) is None:
            _collect(pre, i + 1, state, bindings, out)
        return
    pattern = lit.atom
    args = pattern.args
    if any(not isinstance(a, str) for a in args):
        for b in state.match(pattern, bindings):
            _collect(pre, i + 1, state, b, out)
        return
    # Flat pattern: each argument is a constant, a bound variable or a free one.
    wanted: list[tuple[int, Term]] = []
    free: list[tuple[int, str]] = []
    for k, a in enumerate(args):
        assert isinstance(a, str)
        if a[:1] == "?":
            value = bindings.get(a)
            if value is None:
                free.append((k, a))
            else:
                wanted.append((k, value))
        else:
            wanted.append((k, a))
    name, arity = pattern.name, len(args)
    if name in state.dynamic_predicates:
        facts: Iterable[Atom] = sorted((f for f in state.dynamic if f.name == name), key=str)
    elif wanted:
        facts = state.static.candidates(name, wanted[0][0], wanted[0][1])
    else:
        facts = state.static.candidates(name, None, "")
    for f in facts:
        fargs = f.args
        if len(fargs) != arity or any(fargs[k] != v for k, v in wanted):
            continue
        b = dict(bindings)
        ok = True
        for k, var in free:
            seen = b.get(var)
            if seen is None:
                b[var] = fargs[k]
            elif seen != fargs[k]:  # the same free variable twice in the pattern
                ok = False
                break
        if ok:
            _collect(pre, i + 1, state, b, out)


def literals(items: Iterable[str | Literal | Atom]) -> tuple[Literal, ...]:
    """Read each item as a :class:`Literal` (see :meth:`Literal.parse`)."""
    return tuple(Literal.parse(i) for i in items)


def bound_by(pre: Sequence[Literal]) -> set[str]:
    """The variables a precondition binds: those of its positive literals."""
    out: set[str] = set()
    for lit in pre:
        if lit.positive:
            out |= lit.atom.variables()
    return out




# -- compiled conjunctions ---------------------------------------------------------------
#
# The search matches the same few method preconditions at every step (docs/design.md §1).
# Which of a literal's variables are already bound when it is reached, and whether its
# predicate is static or dynamic, do not change from one call to the next: worked out once,
# each literal becomes a small function that looks its facts up directly (a static literal
# with a bound argument through the fact base's index) and writes what it binds into a list
# of slots, with no dictionary of bindings copied per fact and no generic unification.  The
# answers, and their order, are those of :func:`all_satisfiers`.

Slots = list[Term]
"""The values of a compiled conjunction's variables (and constants), by slot number."""
Emit = Callable[[Slots, State, list[Any]], None]
"""What a compiled conjunction does with each satisfier: gets the slots, the state, an output list."""


def atom_builder(pattern: Atom, slot_of: Mapping[str, int]) -> Callable[[Slots], Atom]:
    """A function making the pattern ground from the slots (every argument has a slot)."""
    args = pattern.args
    name = pattern.name
    if not args:
        return lambda slots: pattern
    if all(isinstance(a, str) for a in args):
        index = [slot_of[a] for a in args]  # type: ignore[index]
        if len(index) == 1:
            i = index[0]
            return lambda slots: _new_atom(Atom, (name, (slots[i],)))
        get = itemgetter(*index)
        return lambda slots: _new_atom(Atom, (name, get(slots)))
    parts = [itemgetter(slot_of[a]) if isinstance(a, str) else atom_builder(a, slot_of) for a in args]
    return lambda slots: _new_atom(Atom, (name, tuple([p(slots) for p in parts])))


def compile_conjunction(
    pre: Sequence[Literal],
    bound: Iterable[str],
    slot_of: Mapping[str, int],
    dynamic_predicates: frozenset[str],
    emit: Emit,
) -> Emit:
    """The conjunction as a function of the slots: for every satisfier, in the order of
    :func:`all_satisfiers`, ``emit`` is called with the slots holding it.

    ``bound`` are the variables whose slots hold values on entry; ``slot_of`` gives every
    variable and every constant of ``pre`` a slot (constants hold their own value).
    """
    known = set(bound)
    stages: list[tuple[Literal, frozenset[str]]] = []
    for lit in pre:
        stages.append((lit, frozenset(known)))
        if lit.positive:
            known |= lit.variables
    run = emit
    for lit, before in reversed(stages):
        run = _compile_literal(lit, before, slot_of, dynamic_predicates, run)
    return run


def _compile_literal(
    lit: Literal, bound: frozenset[str], slot_of: Mapping[str, int], dyn: frozenset[str], then: Emit
) -> Emit:
    pattern = lit.atom
    name = pattern.name
    dynamic = name in dyn
    positive = lit.positive
    if lit.variables <= bound:
        # A plain look-up.
        build = atom_builder(pattern, slot_of)

        def check(slots: Slots, st: State, out: list[Any]) -> None:
            fact = build(slots)
            if (fact in (st.dynamic if dynamic else st.static.facts)) is positive:
                then(slots, st, out)

        return check
    if not all(isinstance(a, str) for a in pattern.args):
        return _compile_nested(lit, bound, slot_of, then)
    # Flat pattern: each argument is a constant or a bound variable (wanted), or free.
    arity = len(pattern.args)
    wanted: list[tuple[int, int]] = []
    free: list[tuple[int, int]] = []
    same: list[tuple[int, int]] = []  # a free variable met twice: both positions must agree
    first_at: dict[str, int] = {}
    for k, a in enumerate(pattern.args):
        assert isinstance(a, str)
        if a[:1] == "?" and a not in bound:
            if a in first_at:
                same.append((k, first_at[a]))
            else:
                first_at[a] = k
                free.append((k, slot_of[a]))
        else:
            wanted.append((k, slot_of[a]))
    position: int | None = None
    value_slot = 0
    if wanted and not dynamic:
        # The fact base's index gives the facts whose first wanted argument fits.
        (position, value_slot), *rest = wanted
    else:
        rest = wanted

    facts_of: Callable[[Slots, State], Sequence[Atom]]
    if dynamic:

        def facts_of(slots: Slots, st: State) -> Sequence[Atom]:
            found = [f for f in st.dynamic if f.name == name]
            if len(found) > 1:
                found.sort(key=str)  # a frozenset's order changes with the hash seed
            return found

    elif position is None:

        def facts_of(slots: Slots, st: State) -> Sequence[Atom]:
            return st.static.named(name)

    else:
        # The index of the last fact base met, kept as one pair (replaced whole, never
        # half): a search asks it thousands of times about the same base.
        last: list[tuple[FactBase | None, dict[Term, list[Atom]]]] = [(None, {})]
        at = position

        def facts_of(slots: Slots, st: State) -> Sequence[Atom]:
            base, index = last[0]
            if base is not st.static:
                base = st.static
                index = base.index(name, at)
                last[0] = (base, index)
            return index.get(slots[value_slot], ())

    if not positive:

        def none_matches(slots: Slots, st: State, out: list[Any]) -> None:
            for f in facts_of(slots, st):
                fargs = f.args
                if (
                    len(fargs) == arity
                    and all(fargs[k] == slots[s] for k, s in rest)
                    and all(fargs[k] == fargs[j] for k, j in same)
                ):
                    return
            then(slots, st, out)

        return none_matches
    if not rest and not same:

        def each_match(slots: Slots, st: State, out: list[Any]) -> None:
            for f in facts_of(slots, st):
                fargs = f.args
                if len(fargs) == arity:
                    for k, s in free:
                        slots[s] = fargs[k]
                    then(slots, st, out)

        return each_match

    def each_checked_match(slots: Slots, st: State, out: list[Any]) -> None:
        for f in facts_of(slots, st):
            fargs = f.args
            if (
                len(fargs) == arity
                and all(fargs[k] == slots[s] for k, s in rest)
                and all(fargs[k] == fargs[j] for k, j in same)
            ):
                for k, s in free:
                    slots[s] = fargs[k]
                then(slots, st, out)

    return each_checked_match


def _compile_nested(lit: Literal, bound: frozenset[str], slot_of: Mapping[str, int], then: Emit) -> Emit:
    """A pattern with nested atoms: matched by :meth:`State.match` (rare in preconditions)."""
    pattern = lit.atom
    given = sorted(lit.variables & bound)
    binds = sorted(lit.variables - bound)

    def bindings_of(slots: Slots) -> Bindings:
        return {v: slots[slot_of[v]] for v in given}

    if not lit.positive:

        def none_matches(slots: Slots, st: State, out: list[Any]) -> None:
            if next(st.match(pattern, bindings_of(slots)), None) is None:
                then(slots, st, out)

        return none_matches

    def each_match(slots: Slots, st: State, out: list[Any]) -> None:
        for b in st.match(pattern, bindings_of(slots)):
            for v in binds:
                slots[slot_of[v]] = b[v]
            then(slots, st, out)

    return each_match


__all__ = [
    "Emit",
    "Literal",
    "Slots",
    "all_satisfiers",
    "atom_builder",
    "bound_by",
    "compile_conjunction",
    "literals",
    "satisfiers",
]
