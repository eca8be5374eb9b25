"""Preconditions: literals, and matching them against a belief SHOP-style (docs/design.md §1).

An operator's or method's precondition is a conjunction of :class:`Literal`
values, positive or negated atoms with variables.  :func:`satisfiers` yields
every binding of the variables under which the conjunction holds in a
:class:`~htnagent.model.state.State`, binding left to right by matching facts (SHOP
unification); :func:`all_satisfiers` is its list-returning form.  The planner
decomposes at every search step with :func:`compile_method`: a method made once
into one function that gives, for a task and a state, the subtasks of every
satisfier in that same order.
"""

from __future__ import annotations

import functools
from collections.abc import Callable, Iterable, Iterator, Sequence
from dataclasses import dataclass, field
from types import CodeType
from typing import cast

from htnagent.model.state import FactBase, State
from htnagent.model.terms import Atom, Bindings, Term, atom, is_variable, substitute, unify


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


# -- compiled methods ---------------------------------------------------------------------
#
# The search decomposes with the same few methods at every step (docs/design.md §1).  Which
# of a literal's variables are already bound when it is reached, and whether its predicate
# is static or dynamic, do not change from one call to the next: worked out once, a method
# becomes one Python function, nested loops over exactly the facts each literal can match (a
# static literal with a bound argument through the fact base's index), with its variables in
# local names: no dictionary of bindings copied per fact, no generic unification, no call per
# literal.  The answers, and their order, are those of :func:`all_satisfiers`.
#
# The function's text is made from this module's own names and numbers only: every name,
# constant and pattern of the domain reaches it as a value in its namespace (``k0``, ``k1``
# ...), never as text, so no domain can put code into it.

Decomposer = Callable[[Atom, State], list[tuple[Atom, ...]]]
"""A compiled method: the subtask lists of a task in a state (none if the head does not match)."""
LazyDecomposer = Callable[[Atom, State], Iterator[tuple[Atom, ...]]]
"""A compiled method as a generator of the same subtask lists (:func:`compile_method_lazy`)."""


_last_named: list[tuple[frozenset[Atom] | None, dict[str, list[Atom]]]] = [(None, {})]
"""The dynamic facts of the last state met, by name: a method's nested loops ask for them
again and again.  One slot, replaced whole (never half), so threads at worst miss it."""


class _Texts(dict[Atom, str]):
    """Each fact's text form, made once: the facts of every new state are sorted by it
    (300 ``on`` facts a state in a large Blocksworld), and ``str`` is Python code."""

    def __missing__(self, atom: Atom) -> str:
        text = self[atom] = str(atom)
        return text


_texts = _Texts()


def _dynamic_named(dynamic: frozenset[Atom], name: str) -> list[Atom]:
    kept, by_name = _last_named[0]
    if kept is not dynamic:
        by_name = {}
        _last_named[0] = (dynamic, by_name)
    found = by_name.get(name)
    if found is None:
        found = [f for f in dynamic if f.name == name]
        if len(found) > 1:
            found.sort(key=_texts.__getitem__)  # a frozenset's order changes with the hash seed
        by_name[name] = found
    return found


def _indexer(name: str, position: int) -> Callable[[FactBase], dict[Term, list[Atom]]]:
    """The index of ``name`` facts by argument ``position`` in a fact base, kept for the last
    base met as one pair (replaced whole, never half): a search asks about one base."""
    last: list[tuple[FactBase | None, dict[Term, list[Atom]]]] = [(None, {})]

    def index(base: FactBase) -> dict[Term, list[Atom]]:
        kept, found = last[0]
        if kept is not base:
            found = base.index(name, position)
            last[0] = (base, found)
        return found

    return index


class _Source:
    """The text of a compiled method being written, and the values it names."""

    def __init__(self) -> None:
        self.lines: list[str] = []
        self.values: dict[str, object] = {}
        self.slot_of: dict[str, str] = {}  # variable -> local name

    def value(self, v: object) -> str:
        name = f"k{len(self.values)}"
        self.values[name] = v
        return name

    def line(self, depth: int, text: str) -> None:
        self.lines.append("    " * depth + text)

    def term(self, t: Term) -> str:
        """An expression for a term whose variables are all bound."""
        if isinstance(t, str):
            return self.slot_of[t] if is_variable(t) else self.value(t)
        return self.ground(t)

    def ground(self, pattern: Atom) -> str:
        """An expression making the pattern ground from the bound variables."""
        if not pattern.variables():
            return self.value(pattern)
        args = ", ".join(self.term(a) for a in pattern.args)
        return f"new(Atom, ({self.value(pattern.name)}, ({args},)))"


def compile_method(
    head: Atom,
    pre: Sequence[Literal],
    subtasks: Sequence[Atom],
    dynamic_predicates: frozenset[str],
    *,
    label: str = "",
) -> Decomposer:
    """The method ``head`` / ``pre`` / ``subtasks`` as one function, for states with these
    dynamic predicates: for every satisfier of ``pre`` after the head is matched with the
    task, in the order of :func:`all_satisfiers`, the subtasks made ground.  ``label`` names
    the function in tracebacks and profiles."""
    return cast(Decomposer, _compile(head, pre, subtasks, dynamic_predicates, label, lazy=False))


def compile_method_lazy(
    head: Atom,
    pre: Sequence[Literal],
    subtasks: Sequence[Atom],
    dynamic_predicates: frozenset[str],
    *,
    label: str = "",
) -> LazyDecomposer:
    """:func:`compile_method` as a generator: the same subtask lists in the same order, one
    at a time, so that a search may take only the first few of a great many."""
    return cast(LazyDecomposer, _compile(head, pre, subtasks, dynamic_predicates, label, lazy=True))


def _compile(
    head: Atom,
    pre: Sequence[Literal],
    subtasks: Sequence[Atom],
    dynamic_predicates: frozenset[str],
    label: str,
    *,
    lazy: bool,
) -> object:
    src = _Source()
    fail = "return" if lazy else "return []"
    src.line(0, "def decompose(task, st):")
    src.line(1, "args = task.args")
    bound: set[str] = set()
    if all(isinstance(a, str) for a in head.args):
        checks = [f"task.name != {src.value(head.name)}", f"len(args) != {len(head.args)}"]
        binds: list[str] = []
        for i, a in enumerate(head.args):
            assert isinstance(a, str)
            if not is_variable(a):
                checks.append(f"args[{i}] != {src.value(a)}")
            elif a in src.slot_of:
                checks.append(f"args[{i}] != {src.slot_of[a]}")
            else:
                src.slot_of[a] = f"s{len(src.slot_of)}"
                binds.append(f"{src.slot_of[a]} = args[{i}]")
                bound.add(a)
        # Conditions in order: a later one may read a variable bound by an earlier one's line.
        src.line(1, f"if {checks[0]} or {checks[1]}:")
        src.line(2, fail)
        for text in binds:
            src.line(1, text)
        for text in checks[2:]:
            src.line(1, f"if {text}:")
            src.line(2, fail)
    else:
        src.line(1, f"b = unify({src.value(head)}, task, {{}})")
        src.line(1, "if b is None:")
        src.line(2, fail)
        for v in sorted(head.variables()):
            src.slot_of[v] = f"s{len(src.slot_of)}"
            src.line(1, f"{src.slot_of[v]} = b[{src.value(v)}]")
            bound.add(v)
    src.line(1, "dynamic = st.dynamic")
    src.line(1, "static = st.static")
    src.line(1, "facts = static.facts")
    if not lazy:
        src.line(1, "out = []")
    depth = 1
    for n, lit in enumerate(pre):
        depth = _literal(src, n, lit, bound, dynamic_predicates, depth)
        if lit.positive:
            bound |= lit.variables
    # A subtask that is the head again (goto(?n) ... goto(?n)) is the task itself: equal to it
    # once the head matched, and not made anew.
    made = ", ".join("task" if t == head else src.ground(t) for t in subtasks)
    made = f"({made}{',' if len(subtasks) == 1 else ''})"
    src.line(depth, f"yield {made}" if lazy else f"out.append({made})")
    src.line(1, "return" if lazy else "return out")
    namespace: dict[str, object] = {
        "Atom": Atom,
        "new": tuple.__new__,
        "unify": unify,
        "dynamic_named": _dynamic_named,
        **src.values,
    }
    try:
        code = _code("\n".join(src.lines), f"<{label or head}>")
    except (SyntaxError, RecursionError, MemoryError):
        # Python nests at most 20 loops (and 100 indents) in one function: a precondition
        # that long is matched the generic way.
        return _generic(head, pre, subtasks, lazy)
    exec(code, namespace)  # text of our own: see above
    return namespace["decompose"]


@functools.lru_cache(maxsize=4096)
def _code(text: str, label: str) -> CodeType:
    """The compiled text.  A method's text names its constants only by slot (``k0``, ...):
    the same method of a domain read again compiles to the same code, so a run of a
    scenario read afresh (a benchmark's, a fleet's robot's) does not compile its methods
    again (0.4 ms each: a run on a small IPC problem spent 3 ms so)."""
    return compile(text, label, "exec")


def _generic(head: Atom, pre: Sequence[Literal], subtasks: Sequence[Atom], lazy: bool) -> object:
    """:func:`compile_method`'s answers by :func:`all_satisfiers` and substitution."""

    def decompose(task: Atom, st: State) -> list[tuple[Atom, ...]]:
        b = unify(head, task, {})
        if b is None:
            return []
        return [tuple(substitute(t, found) for t in subtasks) for found in all_satisfiers(pre, st, b)]

    def each(task: Atom, st: State) -> Iterator[tuple[Atom, ...]]:
        yield from decompose(task, st)

    return each if lazy else decompose


def _literal(src: _Source, n: int, lit: Literal, bound: set[str], dyn: frozenset[str], depth: int) -> int:
    """Write the test of literal ``n`` at ``depth``; the depth its continuation is written at."""
    pattern = lit.atom
    facts = "dynamic" if pattern.name in dyn else "facts"
    if lit.variables <= bound:
        # A plain look-up.
        src.line(depth, f"if {src.ground(pattern)} {'in' if lit.positive else 'not in'} {facts}:")
        return depth + 1
    if not all(isinstance(a, str) for a in pattern.args):
        return _nested(src, n, lit, bound, depth)
    # Flat pattern: each argument is a constant or a bound variable (wanted), or free.
    wanted: list[tuple[int, str]] = []
    free: list[tuple[int, str]] = []
    same: list[tuple[int, int]] = []  # a free variable met twice: both positions must agree
    first_at: dict[str, int] = {}
    for k, a in enumerate(pattern.args):
        assert isinstance(a, str)
        if is_variable(a) and a not in bound:
            if a in first_at:
                same.append((k, first_at[a]))
            else:
                first_at[a] = k
                free.append((k, a))
        else:
            wanted.append((k, src.term(a)))
    name = src.value(pattern.name)
    if facts == "dynamic":
        source, rest = f"dynamic_named(dynamic, {name})", wanted
    elif wanted:
        (position, value), *rest = wanted  # the index gives the facts whose argument fits
        source = f"{src.value(_indexer(pattern.name, position))}(static).get({value}, ())"
    else:
        source, rest = f"static.named({name})", wanted
    f, a = f"f{n}", f"a{n}"
    fits = [f"len({a}) == {len(pattern.args)}"]
    fits += [f"{a}[{k}] == {value}" for k, value in rest]
    fits += [f"{a}[{k}] == {a}[{j}]" for k, j in same]
    src.line(depth, f"for {f} in {source}:")
    src.line(depth + 1, f"{a} = {f}.args")
    if not lit.positive:
        src.line(depth + 1, f"if {' and '.join(fits)}:")
        src.line(depth + 2, "break")
        src.line(depth, "else:")  # no fact matches
        return depth + 1
    src.line(depth + 1, f"if {' and '.join(fits)}:")
    for k, var in free:
        src.slot_of[var] = src.slot_of.get(var) or f"s{len(src.slot_of)}"
        src.line(depth + 2, f"{src.slot_of[var]} = {a}[{k}]")
    return depth + 2


def _nested(src: _Source, n: int, lit: Literal, bound: set[str], depth: int) -> int:
    """A pattern with nested atoms: matched by :meth:`State.match` (rare in preconditions)."""
    given = ", ".join(f"{src.value(v)}: {src.slot_of[v]}" for v in sorted(lit.variables & bound))
    call = f"st.match({src.value(lit.atom)}, {{{given}}})"
    if not lit.positive:
        src.line(depth, f"if next({call}, None) is None:")
        return depth + 1
    src.line(depth, f"for b{n} in {call}:")
    for v in sorted(lit.variables - bound):
        src.slot_of[v] = src.slot_of.get(v) or f"s{len(src.slot_of)}"
        src.line(depth + 1, f"{src.slot_of[v]} = b{n}[{src.value(v)}]")
    return depth + 1


__all__ = [
    "Decomposer",
    "LazyDecomposer",
    "Literal",
    "all_satisfiers",
    "bound_by",
    "compile_method",
    "compile_method_lazy",
    "literals",
    "satisfiers",
]
