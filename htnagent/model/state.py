"""Beliefs: what an agent holds true, as a :class:`State` over a shared :class:`FactBase`.

A belief is a set of ground facts (docs/design.md §1, "Belief").  A :class:`State`
splits it in two: *static* facts (predicates no operator changes, such as the
map) live in an indexed :class:`FactBase` shared by every state that grew from
the same start, and *dynamic* facts (predicates some effect changes) in a small
frozenset of the state's own, so that applying an action copies only what
actions can change.  Which predicates are dynamic is the domain's to say
(:attr:`htnagent.model.domain.Domain.dynamic_predicates`).

Both are values: an update gives a new state, never changes one.  (A fact base
builds its indexes lazily on first look-up; that cache is invisible from outside.)
"""

from __future__ import annotations

import itertools
from collections import defaultdict
from collections.abc import Iterable, Iterator

from htnagent.model.terms import Atom, Bindings, Term, atom, unify


class FactBase:
    """An immutable set of ground facts, indexed by predicate and argument on demand.

    Facts keep the order they were given in: SHOP tries them in that order, so ties
    between equal-cost plans are broken the same way in every run.
    """

    __slots__ = ("_by_name", "_index", "_order", "facts")

    def __init__(self, facts: Iterable[Atom] = ()) -> None:
        self._order: tuple[Atom, ...] = tuple(dict.fromkeys(facts))
        self.facts: frozenset[Atom] = frozenset(self._order)
        """The facts as a frozenset (read only)."""
        self._by_name: dict[str, list[Atom]] | None = None
        self._index: dict[tuple[str, int], dict[Term, list[Atom]]] = {}

    def __contains__(self, fact: object) -> bool:
        return fact in self.facts

    def __iter__(self) -> Iterator[Atom]:
        return iter(self._order)

    def __len__(self) -> int:
        return len(self.facts)

    def with_changes(self, add: Iterable[Atom] = (), delete: Iterable[Atom] = ()) -> FactBase:
        """A new fact base with ``delete`` removed and ``add`` added."""
        gone = frozenset(delete)
        return FactBase(itertools.chain((f for f in self._order if f not in gone), add))

    def named(self, name: str) -> list[Atom]:
        """The facts named ``name``, in order."""
        if self._by_name is None:
            by_name: dict[str, list[Atom]] = defaultdict(list)
            for f in self._order:
                by_name[f.name].append(f)
            self._by_name = dict(by_name)
        return self._by_name.get(name, [])

    def index(self, name: str, position: int) -> dict[Term, list[Atom]]:
        """The facts named ``name`` by their argument ``position``, each list in order (built
        on first use; the compiled preconditions keep it for the look-ups of a search)."""
        found = self._index.get((name, position))
        if found is None:
            found = self._index[(name, position)] = {}
            for f in self.named(name):
                if position < len(f.args):
                    found.setdefault(f.args[position], []).append(f)
        return found

    def candidates(self, name: str, position: int | None, value: Term) -> list[Atom]:
        """Facts named ``name`` (whose argument ``position`` is ``value``, if given)."""
        if position is None:
            return self.named(name)
        return self.index(name, position).get(value, [])


class State:
    """A belief: static facts (shared, indexed) plus dynamic facts (small, per state)."""

    __slots__ = ("dynamic", "dynamic_predicates", "static")

    def __init__(
        self, static: FactBase, dynamic: frozenset[Atom], dynamic_predicates: frozenset[str]
    ) -> None:
        self.static = static
        self.dynamic = dynamic
        self.dynamic_predicates = dynamic_predicates

    @classmethod
    def from_facts(cls, facts: Iterable[Atom | str], dynamic_predicates: frozenset[str]) -> State:
        """Split ``facts`` into static and dynamic parts: a fact is dynamic when its predicate
        is one of ``dynamic_predicates`` (a domain's, :attr:`Domain.dynamic_predicates
        <htnagent.model.domain.Domain.dynamic_predicates>`: those some effect changes)."""
        parsed = [atom(f) for f in facts]
        dyn = dynamic_predicates
        return cls(
            FactBase(f for f in parsed if f.name not in dyn),
            frozenset(f for f in parsed if f.name in dyn),
            dyn,
        )

    def key(self) -> tuple[object, ...]:
        """What tells this belief from others, cheaply: its dynamic facts and its static
        fact base by identity (a fact base compares by identity; the key keeps it alive)."""
        return (self.dynamic, self.static)

    def holds(self, fact: Atom) -> bool:
        """Whether the ground fact is true in this state."""
        if fact.name in self.dynamic_predicates:
            return fact in self.dynamic
        return fact in self.static.facts

    def with_dynamic(self, dynamic: frozenset[Atom]) -> State:
        """The same static facts with other dynamic facts."""
        return State(self.static, dynamic, self.dynamic_predicates)

    def updated(self, add: Iterable[Atom] = (), delete: Iterable[Atom] = ()) -> State:
        """A new state with facts deleted then added (a belief change from outside)."""
        add, delete = list(add), list(delete)
        dyn = self.dynamic_predicates
        static = self.static
        s_add = [f for f in add if f.name not in dyn]
        s_del = [f for f in delete if f.name not in dyn]
        if s_add or s_del:
            static = static.with_changes(s_add, s_del)
        d_del = frozenset(f for f in delete if f.name in dyn)
        d_add = frozenset(f for f in add if f.name in dyn)
        return State(static, (self.dynamic - d_del) | d_add, dyn)

    def facts(self) -> frozenset[Atom]:
        """Every fact of the state."""
        return self.static.facts | self.dynamic

    def match(self, pattern: Atom, bindings: Bindings) -> Iterator[Bindings]:
        """Every extension of ``bindings`` under which ``pattern`` is a fact of the state."""
        if pattern.name in self.dynamic_predicates:
            found = [f for f in self.dynamic if f.name == pattern.name]
            if len(found) > 1:
                # A frozenset's order changes with the hash seed: bind in text order instead.
                found.sort(key=str)
            for f in found:
                b = unify(pattern, f, bindings)
                if b is not None:
                    yield b
            return
        position: int | None = None
        value: Term = ""
        for i, a in enumerate(pattern.args):
            if isinstance(a, str):
                if a.startswith("?"):
                    bound = bindings.get(a)
                    if bound is None:
                        continue
                    a = bound
                position, value = i, a
                break
        for f in self.static.candidates(pattern.name, position, value):
            b = unify(pattern, f, bindings)
            if b is not None:
                yield b

    def __eq__(self, other: object) -> bool:
        return (
            isinstance(other, State)
            and self.dynamic == other.dynamic
            and (self.static is other.static or self.static.facts == other.static.facts)
        )

    def __hash__(self) -> int:
        return hash(self.dynamic)

    def __repr__(self) -> str:
        return f"State(dynamic={sorted(map(str, self.dynamic))}, static={len(self.static)} facts)"


__all__ = ["FactBase", "State"]
