"""Preconditions: literals, and matching them against a belief SHOP-style (docs/design.md §1).

An operator's or method's precondition is a conjunction of :class:`Literal`
values, positive or negated atoms with variables.  :func:`satisfiers` yields
every binding of the variables under which the conjunction holds in a
:class:`~htnagent.state.State`, binding left to right by matching facts (SHOP
unification); :func:`all_satisfiers` is its fast, list-returning form, which the
planner calls at every search step.
"""

from __future__ import annotations

from collections.abc import Iterable, Iterator, Sequence
from dataclasses import dataclass, field

from htnagent.state import State
from htnagent.terms import Atom, Bindings, Term, atom, substitute


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


__all__ = ["Literal", "all_satisfiers", "bound_by", "literals", "satisfiers"]
