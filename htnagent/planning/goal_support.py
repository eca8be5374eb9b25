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
and ``stack(?x,?y)``; a variable its methods bind themselves may be anything), and for
which arguments: a method's equalities and static facts narrow them (only
``get_to(person_121967, ...)`` may lead to the observed ``p_2``).  A node at which a goal
fact is false and no task left may add it can never reach the goal: the planner drops it
(:meth:`GoalSupport.lost`; design §7.3).  So too for the *marks* behind the goal, the
landmarks (:mod:`~htnagent.planning.landmarks`) only one action adds.  An
over-approximation of what each task may add, so a node dropped has no plan below it.
"""

from __future__ import annotations

from collections.abc import Callable, Iterable, Sequence

from htnagent.model.domain import Domain, Method
from htnagent.model.networks import is_network
from htnagent.model.preconditions import Literal
from htnagent.model.state import FactBase
from htnagent.model.terms import Atom, is_variable, unify
from htnagent.planning.hddl_translation import EQ, GOAL
from htnagent.planning.landmarks import GoalLandmarks
from htnagent.planning.per_domain import PerDomain

_Spec = tuple[tuple[str, object] | None, ...]
"""How a fact's arguments come from a task's: ``("p", j)`` the task's j-th argument,
``("c", name)`` that constant, None anything."""
_Cond = tuple[tuple[int, frozenset[str]], ...]
"""What a task's arguments must be for it to add the fact: ``(j, names)``, its j-th argument
is one of those objects (sorted by j; empty: whatever they are)."""
_Pattern = tuple[str, _Spec, _Cond]
"""A fact a task may add: its predicate, where each argument comes from, and when."""

_MAX_PATTERNS = 512
"""Past this many patterns for one task name, its conditions are dropped (each pattern then
holds for any arguments): what the task may add stays over-approximated, and the fixed point
small whatever the domain."""


def adders(
    domain: Domain, static: FactBase | None = None, predicates: Iterable[str] | None = None
) -> dict[str, frozenset[_Pattern]]:
    """For each task name, the facts it may add (lifted): a fixed point over the methods,
    from the actions' add lists up (only facts on ``predicates``, if given).

    A pattern holds only for the tasks whose arguments meet its condition: what a method's
    equalities fix (Monroe-Partially-Observable's ``prefix_2`` does the observed action only
    for ``cclimb_in(person_121967, pvan2, marketplace)``) and its precondition's static facts
    (``static``: types, ``can_lift(?person, ?obj)``) narrow, passed up where the method's own
    arguments carry it.  A method whose static facts no object so narrowed meets adds nothing
    that way."""
    wanted = None if predicates is None else frozenset(predicates)
    dynamic = domain.dynamic_predicates
    found: dict[str, set[_Pattern]] = {}
    loose: set[str] = set()  # task names past _MAX_PATTERNS: conditions dropped

    def put(name: str, pattern: _Pattern) -> None:
        out = found[name]
        if name in loose:
            pattern = (pattern[0], pattern[1], ())
        out.add(pattern)
        if len(out) > _MAX_PATTERNS and name not in loose:
            loose.add(name)
            found[name] = {(pred, spec, ()) for pred, spec, _ in out}

    for name, ops in domain.operators.items():
        found.setdefault(name, set())
        for op in ops:
            fixed = _fixed(op.pre, {})
            allowed = None if fixed is None else _narrowed(op.pre, _sets(fixed), static, dynamic)
            if allowed is None:
                continue
            cond = _cond_of(op.head, allowed)
            for f in op.add:
                if wanted is None or f.name in wanted:
                    put(name, (f.name, _spec_of(f, op.head, _single(allowed)), cond))
    for name in domain.methods:
        found.setdefault(name, set())
    # A method's own equalities, once: None where they contradict each other.
    pins = {id(method): _fixed(method.pre, {}) for methods in domain.methods.values() for method in methods}
    seen: dict[tuple[_Pattern, int, int], _Pattern | None] = {}  # each pattern through each place once
    changed = True
    while changed:
        changed = False
        for name, methods in domain.methods.items():
            before = len(found[name])
            for method in methods:
                pinned = pins[id(method)]
                if pinned is None:
                    continue
                for at, sub in enumerate(method.subtasks):
                    for pattern in tuple(found.get(sub.name, ())):
                        key = (pattern, id(method), at)
                        if key in seen:
                            continue
                        up = seen[key] = _through(pattern, sub, method, pinned, static, dynamic)
                        if up is not None:
                            put(name, up)
            changed |= len(found[name]) != before
    return {name: frozenset(patterns) for name, patterns in found.items()}


def _fixed(pre: Sequence[Literal], given: dict[str, str]) -> dict[str, str] | None:
    """``given`` and the variables a precondition's equalities fix (``?obj = person_121967``,
    or equal to a variable fixed), or None where they contradict each other."""
    fixed = dict(given)
    grew = True
    while grew:
        grew = False
        for lit in pre:
            if not lit.positive or lit.atom.name != EQ or len(lit.atom.args) != 2:
                continue
            a, b = (fixed.get(x, x) if isinstance(x, str) else x for x in lit.atom.args)
            if not (isinstance(a, str) and isinstance(b, str)):
                continue
            if is_variable(a) and not is_variable(b):
                fixed[a], grew = b, True
            elif is_variable(b) and not is_variable(a):
                fixed[b], grew = a, True
            elif not is_variable(a) and a != b:
                return None
    return fixed


def _sets(fixed: dict[str, str]) -> dict[str, frozenset[str]]:
    return {v: frozenset((c,)) for v, c in fixed.items()}


def _single(allowed: dict[str, frozenset[str]]) -> dict[str, str]:
    """The variables left one object."""
    return {v: next(iter(c)) for v, c in allowed.items() if len(c) == 1}


def _narrowed(
    pre: Sequence[Literal],
    allowed: dict[str, frozenset[str]],
    static: FactBase | None,
    dynamic: frozenset[str],
) -> dict[str, frozenset[str]] | None:
    """The objects each variable may be under a precondition's unchanging part, from those
    ``allowed`` already: each static literal that names an object or a narrowed variable
    must match a static fact, and narrows its other variables to those facts' objects (the
    watched person fixed, ``can_lift(?person, ?obj)`` narrows ?obj to what they can lift).
    None where a literal matches no fact, or an inequality is broken."""
    out = dict(allowed)
    for _ in range(2):  # twice: a narrowing reaches a neighbour's neighbour
        narrower = False
        for lit in pre:
            name, args = lit.atom.name, lit.atom.args
            if name in dynamic:
                continue
            if name == EQ:
                if not lit.positive and len(args) == 2:
                    x, y = (_objects(a, out) for a in args)
                    if len(x) == len(y) == 1 and x == y:
                        return None
                continue
            if not lit.positive or static is None:
                continue
            known = [(i, seen) for i, a in enumerate(args) if (seen := _objects(a, out))]
            if not known:
                continue
            i, values = min(known, key=lambda k: len(k[1]))
            matching = [
                f
                for v in values
                for f in static.candidates(name, i, v)
                if all(f.args[j] in vs for j, vs in known)
            ]
            if not matching:
                return None
            for j, a in enumerate(args):
                if not (isinstance(a, str) and is_variable(a)):
                    continue
                there = frozenset(o for f in matching if isinstance(o := f.args[j], str))
                old = out.get(a)
                new = there if old is None else old & there
                if not new:
                    return None
                if new != old:
                    out[a], narrower = new, True
        if not narrower:
            break
    return out


def _objects(term: object, allowed: dict[str, frozenset[str]]) -> frozenset[str]:
    """The objects a term may be: a name itself, a narrowed variable its objects (empty: any)."""
    if not isinstance(term, str):
        return frozenset()
    if is_variable(term):
        return allowed.get(term, frozenset())
    return frozenset((term,))


def _cond_of(head: Atom, allowed: dict[str, frozenset[str]]) -> _Cond:
    """The condition on a task ``head``'s arguments: the objects its narrowed variables may be."""
    return tuple((j, allowed[a]) for j, a in enumerate(head.args) if isinstance(a, str) and a in allowed)


def _spec_of(fact: Atom, head: Atom, fixed: dict[str, str] | None = None) -> _Spec:
    """Where ``fact``'s arguments come from, seen from a task ``head`` (a variable ``fixed``
    fixes: that object)."""
    out: list[tuple[str, object] | None] = []
    for a in fact.args:
        if not isinstance(a, str):
            out.append(None)  # a nested term: anything (never in HDDL)
        elif fixed and a in fixed:
            out.append(("c", fixed[a]))
        elif is_variable(a):
            out.append(("p", head.args.index(a)) if a in head.args else None)
        else:
            out.append(("c", a))
    return tuple(out)


def _through(
    pattern: _Pattern,
    sub: Atom,
    method: Method,
    pinned: dict[str, str],
    static: FactBase | None,
    dynamic: frozenset[str],
) -> _Pattern | None:
    """A subtask's pattern seen from the method's task: its arguments through the method,
    its condition on them with the method's equalities and static facts (None: the method
    never meets it)."""
    pred, spec, cond = pattern
    allowed = _sets(pinned)
    for j, values in cond:
        term = sub.args[j] if j < len(sub.args) else None
        if not isinstance(term, str):
            continue
        if not is_variable(term):
            if term not in values:
                return None
            continue
        new = allowed[term] & values if term in allowed else values
        if not new:
            return None
        allowed[term] = new
    if allowed:
        narrowed = _narrowed(method.pre, allowed, static, dynamic)
        if narrowed is None:
            return None
        allowed = narrowed
    fixed = _single(allowed)
    head = method.head
    out: list[tuple[str, object] | None] = []
    for where in spec:
        if where is None or where[0] == "c":
            out.append(where)
            continue
        k = where[1]
        assert isinstance(k, int)
        term = sub.args[k] if k < len(sub.args) else None
        if not isinstance(term, str):
            out.append(None)
        elif term in fixed:
            out.append(("c", fixed[term]))
        elif is_variable(term):
            out.append(("p", head.args.index(term)) if term in head.args else None)
        else:
            out.append(("c", term))
    return pred, tuple(out), _cond_of(head, allowed)


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
    """The facts the goal may still need that each task may add, for the search's dead-end
    tests (:meth:`lost_at_start`, :meth:`lost_after_action`, :meth:`lost_after_decomposing`):
    the goal facts, and the marks behind them (the landmarks of
    :mod:`~htnagent.planning.landmarks` only one action adds); and, for greedy search, what
    the tasks ahead of the next mark cost (:meth:`before_next_marks`).

    Made once for a domain and its goal (:meth:`of`): working it out is a fixed point over
    the whole domain (0.25 ms for Snake, 1.6 ms for Barman), and plan repair searches
    again and again, each time with the goal's check at the end of its list."""

    @classmethod
    def of(
        cls, domain: Domain, static: FactBase | None = None, dynamic: frozenset[str] | None = None
    ) -> GoalSupport:
        """The test for ``domain``'s goal over the static facts ``static`` (None: any), made
        once for the last few domains seen (an HDDL domain is complete when the translation
        hands it over; the key also holds its size and goal, so that a domain built on after a
        search gets a new one, and the static facts by identity).  ``dynamic``: the changing
        predicates (the domain's, if not given)."""
        dyn = domain.dynamic_predicates if dynamic is None else dynamic
        key = (id(domain), domain.goal_facts, len(domain.operators), len(domain.methods), static, dyn)
        return _MADE.get(domain, key, lambda: cls(domain, GoalLandmarks.of(domain, dyn), static))

    def __init__(self, domain: Domain, landmarks: GoalLandmarks, static: FactBase | None = None) -> None:
        self.landmarks = landmarks
        self.goals = frozenset(landmarks.goals)
        # The landmarks watched beside the goal facts: those only one action adds (an observed
        # action's mark, Monroe's l1 ... l7, behind the goal).  A fact many actions add
        # (Blocksworld's clear(b)) is hardly ever one no task left may add, and watching it
        # would cost a walk over the needed facts at every state.
        self.marks = frozenset(f for f in landmarks.facts - self.goals if _adding_operators(domain, f) == 1)
        self.watched = self.goals | self.marks
        self._marks_behind = {m: pre & self.marks for m, pre in landmarks.needs.items() if m in self.marks}
        self._adders = adders(domain, static, {f.name for f in self.watched})
        by_pred: dict[str, set[Atom]] = {}
        at: dict[tuple[str, int, str], set[Atom]] = {}
        for f in self.watched:
            by_pred.setdefault(f.name, set()).add(f)
            for i, a in enumerate(f.args):
                if isinstance(a, str):
                    at.setdefault((f.name, i, a), set()).add(f)
        self._by_pred = {k: frozenset(v) for k, v in by_pred.items()}
        self._at = {k: frozenset(v) for k, v in at.items()}
        self._cache: dict[Atom, frozenset[Atom]] = {}
        self._last_next: tuple[frozenset[Atom] | None, frozenset[Atom]] = (None, frozenset())
        wanted = {f.name for f in self.watched}
        # The actions that may delete a fact watched: only after them can more be needed.
        self.deleters = frozenset(
            name
            for name, ops in domain.operators.items()
            if any(d.name in wanted for op in ops for d in op.delete)
        )

    def needed(self, dynamic: frozenset[Atom]) -> frozenset[Atom]:
        """The facts watched that must still be made true in a state of changing facts
        ``dynamic``: the false goal facts, and the marks still needed behind them."""
        if not self.marks:
            return self.goals.difference(dynamic)
        return self.landmarks.needed(dynamic) & self.watched

    def before_next_marks(
        self, tasks: Sequence[Atom], dynamic: frozenset[Atom], cost: Callable[[str], float]
    ) -> float:
        """What the tasks ahead of the next mark cost: the least cost (``cost`` of a task
        name) of the tasks before the first that may add a mark still needed with no mark
        needed behind it (the next observed action's; where marks do not follow one another,
        Robot's ``holding(o)`` for each object, the nearest of them)."""
        waiting = self._next_marks(self.landmarks.needed(dynamic))
        before = 0.0
        if waiting:
            for t in tasks:
                if not waiting.isdisjoint(self.may_add(t)):
                    return before
                before += cost(t.name)
        return 0.0

    def _next_marks(self, need: frozenset[Atom]) -> frozenset[Atom]:
        """The marks still needed (among ``need``, the facts needed) with no mark needed behind
        them; the children of one node share their state, and so ask again for the same."""
        if self._last_next[0] is need:
            return self._last_next[1]
        behind = self._marks_behind
        found = frozenset(m for m in need & self.marks if need.isdisjoint(behind.get(m, ())))
        self._last_next = (need, found)
        return found

    def lost_at_start(self, dynamic: frozenset[Atom], tasks: Sequence[Atom]) -> bool:
        """Whether a fact still needed in the state (changing facts ``dynamic``) is added by
        no task of ``tasks``: then there is no plan."""
        return self.lost(self.needed(dynamic), tasks)

    def lost_after_action(
        self, action: Atom, before: frozenset[Atom], after: frozenset[Atom], rest: Sequence[Atom]
    ) -> bool:
        """After ``action`` took the state's changing facts from ``before`` to ``after``: a fact
        still needed that it may have added and did not, or that it deleted (or, deleting a
        mark, made needed), which no task of ``rest`` may add."""
        adds = self.may_add(action)
        deleter = action.name in self.deleters
        if not adds and not deleter:
            return False
        if not self.marks:  # the goal facts alone, without a walk over them
            missing = [g for g in adds if g not in after]
            if deleter:
                missing.extend(self.goals.intersection(before).difference(after))
        else:  # (what an action may add is watched: needed or not is all that is asked)
            need = self.landmarks.needed_after(before, after)
            missing = [f for f in adds if f in need]
            if deleter:
                newly = need.difference(self.landmarks.needed(before))
                missing.extend(f for f in newly if f in self.watched)
        return self.lost(missing, rest)

    def lost_after_decomposing(
        self, task: Atom, dynamic: frozenset[Atom], child_tasks: Sequence[Atom]
    ) -> bool:
        """After decomposing ``task``: a fact still needed that it may add and none of its
        subtasks and later tasks (``child_tasks``) may."""
        adds = self.may_add(task)
        if not adds:
            return False
        if not self.marks:
            return self.lost([g for g in adds if g not in dynamic], child_tasks)
        return self.lost(adds & self.landmarks.needed(dynamic), child_tasks)

    def may_add(self, task: Atom) -> frozenset[Atom]:
        """The facts watched (goal facts and landmarks) that ``task`` may add (a variable
        among its arguments: any value)."""
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
        for pred, spec, cond in self._adders.get(task.name, ()):
            pool = self._by_pred.get(pred)
            if not pool or any(not _meets(_arg(task, j), values) for j, values in cond):
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
        """Whether one of the ``missing`` facts (needed in the node's state) is added
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


def _meets(arg: str | None, values: frozenset[str]) -> bool:
    return arg is None or arg in values


def _adding_operators(domain: Domain, fact: Atom) -> int:
    """How many operators have an add effect that may be ``fact``."""
    return sum(
        any(unify(added, fact, {}) is not None for added in op.add)
        for ops in domain.operators.values()
        for op in ops
    )


def _arg(task: Atom, j: object) -> str | None:
    """The task's j-th argument, None for a variable (or a term that is not a name)."""
    assert isinstance(j, int)
    if j >= len(task.args):
        return None
    a = task.args[j]
    return a if isinstance(a, str) and not is_variable(a) else None


__all__ = ["GoalSupport", "adders", "checks_goal"]
