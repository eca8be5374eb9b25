"""What must hold of an HDDL model beyond its syntax, checked once so later stages can trust it.

:func:`check_domain` and :func:`check_problem` run as part of reading
(:mod:`htnagent.hddl.reader`); each raises the first problem as an
:class:`~htnagent.errors.HddlError` at the offending element:

- every type named exists (the reader has refused cycles in the hierarchy);
- every predicate, task and action is used with as many arguments as it declares;
- every variable is declared where it is used (the parameters, a quantifier);
  every other term is a constant of the domain (or, in the problem, an object);
- a method decomposes a declared compound task (not an action) and names no
  task or action that does not exist;
- the problem's objects are of known types, its facts are ground over them and
  its initial task network names known tasks.

Argument types are not checked against parameter types: the IPC domains pass
variables of a supertype where a subtype is declared, and pandaPIparser reads
them; a plan's actual arguments are checked by :mod:`htnagent.hddl.check`.
"""

from __future__ import annotations

from collections.abc import Iterable, Mapping

from htnagent.errors import HddlError
from htnagent.hddl.model import (
    And,
    AndEffect,
    Domain,
    Effect,
    Equals,
    Exists,
    Forall,
    ForallEffect,
    Formula,
    Imply,
    Literal,
    Not,
    Or,
    Pred,
    Problem,
    SortOf,
    Source,
    Subtask,
    Typed,
    When,
)
from htnagent.model.terms import Atom, Term

__all__ = ["check_domain", "check_problem"]


def check_domain(domain: Domain) -> None:
    """Raise HddlError at the first thing in ``domain`` that is not well formed."""
    _Checker(domain, domain.source, {c.name for c in domain.constants}).domain()


def check_problem(domain: Domain, problem: Problem) -> None:
    """Raise HddlError at the first thing in ``problem`` that does not fit ``domain``."""
    _Checker(domain, problem.source, {c.name for c in domain.constants}).problem(problem)


class _Checker:
    def __init__(self, domain: Domain, source: Source, names: set[str]) -> None:
        self.d = domain
        self.source = source
        self.names = names  # the constants (and, for a problem, the objects) a term may name

    def error(self, at: int, reason: str) -> HddlError:
        return self.source.error(at, reason)

    # -- types ------------------------------------------------------------------------------------

    def typed(self, params: Iterable[Typed]) -> None:
        for p in params:
            for t in p.types:
                if t not in self.d.types:
                    raise self.error(p.at, f"{p.name}: unknown type {t}")

    # -- the domain ------------------------------------------------------------------------------------

    def domain(self) -> None:
        d = self.d
        self.typed(d.constants)
        seen: dict[str, Typed] = {}
        for c in d.constants:
            if c.name in seen:
                raise self.error(c.at, f"constant {c.name} is declared twice")
            seen[c.name] = c
        for p in d.predicates.values():
            self.typed(p.params)
        for t in d.tasks.values():
            self.typed(t.params)
        for a in d.actions.values():
            self.typed(a.params)
            scope = frozenset(p.name for p in a.params)
            self.formula(a.precondition, scope, f"action {a.name}")
            self.effect(a.effect, scope, f"action {a.name}")
        for m in d.methods.values():
            what = f"method {m.name}"
            self.typed(m.params)
            scope = frozenset(p.name for p in m.params)
            task = d.tasks.get(m.task.name)
            if task is None:
                kind = "an action, not a compound task" if m.task.name in d.actions else "no declared task"
                raise self.error(m.at, f"{what} decomposes {m.task.name}, which is {kind}")
            self.arity(m.task, len(task.params), m.at, "task", what)
            self.terms(m.task.args, scope, m.at, what)
            self.formula(m.precondition, scope, what)
            self.formula(m.constraints, scope, what)
            self.network(m.subtasks, scope, what)

    def network(self, subtasks: Iterable[Subtask], scope: frozenset[str], what: str) -> None:
        for s in subtasks:
            op = self.d.tasks.get(s.call.name) or self.d.actions.get(s.call.name)
            if op is None:
                raise self.error(s.at, f"{what}: no task or action is named {s.call.name}")
            self.arity(s.call, len(op.params), s.at, "task", what)
            self.terms(s.call.args, scope, s.at, what)

    def arity(self, call: Atom, n: int, at: int, kind: str, what: str) -> None:
        if len(call.args) != n:
            raise self.error(
                at, f"{what}: {kind} {call.name} takes {n} argument{'s' * (n != 1)}, given {len(call.args)}"
            )

    def terms(self, args: Iterable[Term], scope: frozenset[str], at: int, what: str) -> None:
        for a in args:
            assert isinstance(a, str)  # the reader makes no nested atoms
            if a[0] == "?":
                if a not in scope:
                    raise self.error(at, f"{what}: variable {a} is not declared")
            elif a not in self.names:
                noun = "constant or object" if self.objects else "constant"
                raise self.error(at, f"{what}: {a} is no declared {noun}")

    objects = False

    def formula(self, f: Formula, scope: frozenset[str], what: str) -> None:
        if isinstance(f, Pred):
            p = self.d.predicates.get(f.atom.name)
            if p is None:
                raise self.error(f.at, f"{what}: unknown predicate {f.atom.name}")
            self.arity(f.atom, len(p.params), f.at, "predicate", what)
            self.terms(f.atom.args, scope, f.at, what)
        elif isinstance(f, Equals):
            self.terms((f.left, f.right), scope, f.at, what)
        elif isinstance(f, SortOf):
            self.terms((f.var,), scope, f.at, what)
            for t in f.types:
                if t not in self.d.types:
                    raise self.error(f.at, f"{what}: unknown type {t}")
        elif isinstance(f, Not):
            self.formula(f.arg, scope, what)
        elif isinstance(f, And | Or):
            for x in f.args:
                self.formula(x, scope, what)
        elif isinstance(f, Imply):
            self.formula(f.cond, scope, what)
            self.formula(f.then, scope, what)
        elif isinstance(f, Forall | Exists):
            self.typed(f.params)
            self.formula(f.body, scope | {p.name for p in f.params}, what)

    def effect(self, e: Effect, scope: frozenset[str], what: str) -> None:
        if isinstance(e, Literal):
            p = self.d.predicates.get(e.atom.name)
            if p is None:
                raise self.error(e.at, f"{what}: unknown predicate {e.atom.name}")
            self.arity(e.atom, len(p.params), e.at, "predicate", what)
            self.terms(e.atom.args, scope, e.at, what)
        elif isinstance(e, AndEffect):
            for x in e.args:
                self.effect(x, scope, what)
        elif isinstance(e, ForallEffect):
            self.typed(e.params)
            self.effect(e.body, scope | {p.name for p in e.params}, what)
        elif isinstance(e, When):
            self.formula(e.cond, scope, what)
            self.effect(e.body, scope, what)

    # -- the problem -------------------------------------------------------------------------------------

    def problem(self, p: Problem) -> None:
        self.objects = True
        if p.domain and p.domain != self.d.name:
            raise self.error(
                p.domain_at, f"the problem is for domain {p.domain}, but the domain is {self.d.name}"
            )
        self.typed(p.objects)
        constants: Mapping[str, Typed] = {c.name: c for c in self.d.constants}
        seen: dict[str, Typed] = {}
        for o in p.objects:
            if o.name in seen:
                raise self.error(o.at, f"object {o.name} is declared twice")
            seen[o.name] = o
        self.names = set(constants) | set(seen)
        predicates = self.d.predicates
        names = self.names
        for fact, at in zip(p.init, p.init_at, strict=True):
            pred = predicates.get(fact.name)
            if pred is None:
                raise self.error(at, f":init: unknown predicate {fact.name}")
            if len(fact.args) != len(pred.params):
                self.arity(fact, len(pred.params), at, "predicate", ":init")
            for a in fact.args:
                if a not in names:
                    raise self.error(at, f":init: {a} is no declared object or constant")
        self.typed(p.htn_params)
        scope = frozenset(x.name for x in p.htn_params)
        self.network(p.htn, scope, ":htn")
        self.formula(p.htn_constraints, scope, ":htn")
        self.formula(p.goal, frozenset(), ":goal")
