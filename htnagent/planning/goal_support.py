"""Which tasks can still make the goal true: a sound dead-end test for state goals.

An HDDL problem with a ``:goal`` is checked only once the whole task network is done
(docs/design.md §7: the ``__goal()`` task at the end).  A search that undoes a goal fact
early -- Blocksworld's ``do_on_table`` puts a block already on its goal block back on the
table -- finds out only at the very end, thousands of actions later, and depth-first
search then backtracks through every choice made in between.

Yet the tasks left say what can still happen: only the actions some remaining task may
decompose into can add a fact.  This module works out, lifted (no grounding), which
facts each task name may add, with the task's own arguments where they pass down to the
action's effect (``do_put_on(?x,?y)`` may add ``on(?x,?y)``, through ``do_move(?x,?y)``
and ``stack(?x,?y)``; a variable its methods bind themselves may be anything).  A node at
which a goal fact is false and no task left may add it can never reach the goal: the
planner drops it (:meth:`GoalSupport.lost`; design §7.3).  An over-approximation of what
each task may add, so a node dropped has no plan below it.
"""

from __future__ import annotations

from collections.abc import Callable, Iterable, Sequence
from typing import Generic, TypeVar

from htnagent.model.domain import Domain
from htnagent.model.networks import is_network
from htnagent.model.terms import Atom, is_variable
from htnagent.planning.hddl_translation import GOAL

_T = TypeVar("_T")

_Spec = tuple[tuple[str, object] | None, ...]
"""How a fact's arguments come from a task's: ``("p", j)`` the task's j-th argument,
``("c", name)`` that constant, None anything."""
_Pattern = tuple[str, _Spec]
"""A fact a task may add: its predicate and where each argument comes from."""


def _spec_of(fact: Atom, head: Atom) -> _Spec:
    """Where ``fact``'s arguments come from, seen from a task ``head``."""
    out: list[tuple[str, object] | None] = []
    for a in fact.args:
        if not isinstance(a, str):
            out.append(None)  # a nested term: anything (never in HDDL)
        elif is_variable(a):
            out.append(("p", head.args.index(a)) if a in head.args else None)
        else:
            out.append(("c", a))
    return tuple(out)


def adders(domain: Domain) -> dict[str, frozenset[_Pattern]]:
    """For each task name, the facts it may add (lifted): a fixed point over the methods,
    from the actions' add lists up."""
    found: dict[str, set[_Pattern]] = {}
    for name, ops in domain.operators.items():
        out = found.setdefault(name, set())
        for op in ops:
            out.update((f.name, _spec_of(f, op.head)) for f in op.add)
    for name in domain.methods:
        found.setdefault(name, set())
    changed = True
    while changed:
        changed = False
        for name, methods in domain.methods.items():
            out = found[name]
            before = len(out)
            for method in methods:
                for sub in method.subtasks:
                    for pred, spec in tuple(found.get(sub.name, ())):
                        out.add((pred, _through(spec, sub, method.head)))
            changed |= len(out) != before
    return {name: frozenset(patterns) for name, patterns in found.items()}


def _through(spec: _Spec, sub: Atom, head: Atom) -> _Spec:
    """A subtask's pattern seen from the method's task: its arguments through the method."""
    out: list[tuple[str, object] | None] = []
    for where in spec:
        if where is None or where[0] == "c":
            out.append(where)
            continue
        j = where[1]
        assert isinstance(j, int)
        term = sub.args[j] if j < len(sub.args) else None
        if not isinstance(term, str):
            out.append(None)
        elif is_variable(term):
            out.append(("p", head.args.index(term)) if term in head.args else None)
        else:
            out.append(("c", term))
    return tuple(out)


class PerDomain(Generic[_T]):
    """What is worked out once for a domain (:meth:`GoalSupport.of`,
    :meth:`~htnagent.planning.landmarks.GoalLandmarks.of`), kept for the last ``keep``
    domains seen; each domain is held, so that its id is not reused while its entry lives."""

    def __init__(self, keep: int = 8) -> None:
        self._keep = keep
        self._made: dict[tuple[object, ...], tuple[Domain, _T]] = {}

    def get(self, domain: Domain, key: tuple[object, ...], make: Callable[[], _T]) -> _T:
        """The value for ``domain`` under ``key`` (which holds ``id(domain)``), made by
        ``make()`` the first time."""
        known = self._made.get(key)
        if known is not None and known[0] is domain:
            return known[1]
        made = make()
        self._made[key] = (domain, made)
        while len(self._made) > self._keep:
            del self._made[next(iter(self._made))]  # the oldest
        return made

    def clear(self) -> None:
        self._made.clear()


_MADE: PerDomain[GoalSupport] = PerDomain()


def checks_goal(domain: Domain, tasks: Sequence[Atom]) -> bool:
    """Whether the test applies to a search of ``tasks``: the domain has goal facts and the
    list ends with the task that checks them (:data:`~htnagent.planning.hddl_translation.GOAL`),
    so that they must hold once every task before it is done.  Another list (an agent's
    emergency task alone) need not make the problem's goal true.  A goal given as a network
    (``tasks(t1,...,tn,__goal)``, an agent's ``tasks: problem``) ends the way its last task
    does."""
    if not domain.goal_facts or not tasks:
        return False
    last: object = tasks[-1]
    while isinstance(last, Atom) and is_network(last):
        last = last.args[-1]
    return isinstance(last, Atom) and last.name == GOAL


class GoalSupport:
    """The goal facts each task may add, for the search's dead-end test (:meth:`lost`).

    Made once for a domain and its goal (:meth:`of`): working it out is a fixed point over
    the whole domain (0.25 ms for Snake, 1.6 ms for Barman), and plan repair searches
    again and again, each time with the goal's check at the end of its list."""

    @classmethod
    def of(cls, domain: Domain) -> GoalSupport:
        """The test for ``domain``'s goal facts, made once for the last few domains seen
        (an HDDL domain is complete when the translation hands it over; the key also holds
        its size and goal, so that a domain built on after a search gets a new one)."""
        key = (id(domain), domain.goal_facts, len(domain.operators), len(domain.methods))
        return _MADE.get(domain, key, lambda: cls(domain, domain.goal_facts))

    def __init__(self, domain: Domain, goals: Sequence[Atom]) -> None:
        self.goals = frozenset(goals)
        self._adders = adders(domain)
        by_pred: dict[str, set[Atom]] = {}
        at: dict[tuple[str, int, str], set[Atom]] = {}
        for g in self.goals:
            by_pred.setdefault(g.name, set()).add(g)
            for i, a in enumerate(g.args):
                if isinstance(a, str):
                    at.setdefault((g.name, i, a), set()).add(g)
        self._by_pred = {k: frozenset(v) for k, v in by_pred.items()}
        self._at = {k: frozenset(v) for k, v in at.items()}
        self._cache: dict[Atom, frozenset[Atom]] = {}
        wanted = {g.name for g in self.goals}
        # The actions that may delete a goal fact: only after them is a lost fact possible.
        self.deleters = frozenset(
            name
            for name, ops in domain.operators.items()
            if any(d.name in wanted for op in ops for d in op.delete)
        )

    def may_add(self, task: Atom) -> frozenset[Atom]:
        """The goal facts ``task`` may add (a variable among its arguments: any value)."""
        known = self._cache.get(task)
        if known is not None:
            return known
        out: set[Atom] = set()
        if is_network(task):
            # A network may add what its tasks may; its method is one the scenario adds to the
            # domain, perhaps after this test was made, so it is not read from the fixed point.
            for sub in task.args:
                assert isinstance(sub, Atom)
                out.update(self.may_add(sub))
            known = self._cache[task] = frozenset(out)
            return known
        for pred, spec in self._adders.get(task.name, ()):
            pool = self._by_pred.get(pred)
            if not pool:
                continue
            chosen: frozenset[Atom] | None = None
            for i, where in enumerate(spec):
                if where is None:
                    continue
                value = where[1] if where[0] == "c" else _arg(task, where[1])
                if not isinstance(value, str):
                    continue  # a variable: any value
                some = self._at.get((pred, i, value), frozenset())
                chosen = some if chosen is None else chosen & some
                if not chosen:
                    break
            out.update(pool if chosen is None else chosen)
        known = self._cache[task] = frozenset(out)
        return known

    def lost(self, missing: Iterable[Atom], tasks: Sequence[Atom]) -> bool:
        """Whether one of the ``missing`` goal facts (false in the node's state) is added
        by no task of ``tasks`` (the node's list): then the node is a dead end."""
        need = set(missing)
        if not need:
            return False
        may_add = self.may_add
        for t in tasks:
            need.difference_update(may_add(t))
            if not need:
                return False
        return True


def _arg(task: Atom, j: object) -> str | None:
    """The task's j-th argument, None for a variable (or a term that is not a name)."""
    assert isinstance(j, int)
    if j >= len(task.args):
        return None
    a = task.args[j]
    return a if isinstance(a, str) and not is_variable(a) else None


__all__ = ["GoalSupport", "adders", "checks_goal"]
