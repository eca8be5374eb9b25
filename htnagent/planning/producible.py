"""The ground tasks that can be done at all, bottom up: what binds a method's parameters
that only its subtasks name (docs/design.md §7.2).

The grounder of :mod:`htnagent.planning.composition` works top down, from the tasks to
plan: a method's parameters are bound by its task, then by its precondition's facts.  A
parameter that only a subtask names has nothing to bind it but its type, and a learned
method (Woodworking's) has a dozen of them -- surfaces, colours, treatments, machines,
boards: the product of their types runs to millions of bindings, nearly all of them with a
subtask nothing can do.  PANDA grounds such methods against the ground tasks that can
actually occur; so does this module:

1. **Reachable actions.** From the start state, every ground action whose relaxed
   precondition (delete relaxation, as the grounder's) can come to hold, of a primitive
   task as a task to plan or a method's subtask names it -- with its constants, which
   matter: Woodworking's actions have parameters only their effects name, any colour or
   surface, which the methods fix.  The facts reached over-approximate those the
   hierarchy reaches.
2. **Producible tasks,** a bottom-up fixed point: a primitive task is producible when one of
   its actions is reachable; a compound task when one of its methods has every subtask
   producible and its relaxed precondition holding among the reached facts.  Each round
   joins a method's subtasks only where one of them is newly producible (semi-naive),
   a subtask at a time, as a hash join on the variables the subtasks share.
3. **Binding by joining** (:meth:`Producible.join`): a method's subtasks matched, one after
   the other, against the producible tasks -- the most constrained first, through an index
   on each argument -- binds every parameter the subtasks name.

Why the estimate does not change: whatever the top-down grounder can finish is producible
here (its facts are among these, and a finished task has a finished method), so a binding
the join leaves out has a subtask that costs ``inf`` and would have been pruned anyway (the
grounder's step 3).  The join only stops making those bindings.
"""

from __future__ import annotations

from collections import defaultdict
from collections.abc import Callable, Iterable, Iterator, Sequence
from dataclasses import dataclass

from htnagent.model.domain import Domain, Method, Operator
from htnagent.model.preconditions import Literal, satisfiers
from htnagent.model.state import FactBase, State
from htnagent.model.terms import Atom, Bindings, Term, is_variable, substitute, unify
from htnagent.planning.hddl_translation import EQ, TYPE

ANY = "__any"
"""An argument of a producible task that may be any object: a parameter of the method (or
action) nothing binds -- its task's declared type implies the method's, so the translation
gave it no literal (AssemblyHierarchical's ``finish`` of ``ValidatePortConnection(?p1 ?p2
?t)``).  Kept as one task, not one an object: a join leaves a subtask's variable there
unbound, for the method's own literals to bind."""

Order = Callable[[Sequence[Literal], Iterable[str]], tuple[Literal, ...]]
"""How the grounder orders a relaxed precondition's literals, given the variables bound."""


def enumerated(order: tuple[Literal, ...], bound: Iterable[str]) -> dict[str, str]:
    """The variables of an ordered precondition that only an enumeration binds, each with
    the predicate that enumerates it: first bound by a type (every object of it) or by an
    equality between two unbound variables (every object with itself), rather than by a
    fact.  The join binds them instead, where a subtask names them."""
    known = set(bound)
    out: dict[str, str] = {}
    for lit in order:
        new = lit.variables - known
        name = lit.atom.name
        if new and lit.positive and (name.startswith(TYPE) or (name == EQ and new == lit.variables)):
            out.update(dict.fromkeys(new, name))
        known |= lit.variables
    return out


class Producible:
    """The ground tasks the problem can produce from its start state (the module's steps 1
    and 2), and the join of a method's subtasks against them (step 3).

    ``count`` is called for every ground action, binding kept and task found, ``tick`` for
    every other unit of work, so the caller's cap and checkpoint bound this work too
    (:class:`~htnagent.planning.composition.TooLarge` comes through).
    """

    def __init__(
        self,
        domain: Domain,
        start: State,
        roots: Sequence[Atom],
        relaxed: Callable[[Sequence[Literal]], tuple[Literal, ...]],
        order: Order,
        count: Callable[[], None],
        tick: Callable[[], None],
    ) -> None:
        self._count = count
        self._masks: dict[str, set[tuple[int, ...]]] = defaultdict(set)
        self._tick = tick
        self._tasks: dict[str, set[Atom]] = defaultdict(set)
        self._index: dict[tuple[str, int, Term], list[Atom]] = defaultdict(list)
        reached = self._reachable_actions(domain, start, roots, relaxed, order)
        self._producible_tasks(domain, reached, relaxed, order)

    def __contains__(self, task: Atom) -> bool:
        known = self._tasks.get(task.name, ())
        if task in known:
            return True
        for mask in self._masks.get(task.name, ()):
            args = list(task.args)
            for i in mask:
                args[i] = ANY
            if Atom(task.name, tuple(args)) in known:
                return True
        return False

    def __len__(self) -> int:
        return sum(len(s) for s in self._tasks.values())

    def _add(self, task: Atom) -> bool:
        """Record a producible task; False when it was known already."""
        known = self._tasks[task.name]
        if task in known:
            return False
        known.add(task)
        for i, a in enumerate(task.args):
            self._index[(task.name, i, a)].append(task)
        if ANY in task.args:
            self._masks[task.name].add(tuple(i for i, a in enumerate(task.args) if a == ANY))
        return True

    # -- step 1: reachable actions, of the primitive tasks the methods name -----------------

    def _reachable_actions(
        self,
        domain: Domain,
        start: State,
        roots: Sequence[Atom],
        relaxed: Callable[[Sequence[Literal]], tuple[Literal, ...]],
        order: Order,
    ) -> State:
        """Every ground action reachable under the delete relaxation as a task to plan or a
        method's subtask names it (the module's step 1), recorded as producible tasks;
        gives the facts reached."""
        facts: set[Atom] = set(start.facts())
        patterns = {t for t in roots if t.name in domain.operators}
        subtasks = (t for ms in domain.methods.values() for me in ms for t in me.subtasks)
        patterns |= {t for t in subtasks if t.name in domain.operators}
        ways: list[tuple[Atom, Operator, Bindings, tuple[Literal, ...]]] = []
        for pattern in sorted(patterns, key=str):
            for op in domain.operators[pattern.name]:
                b0 = _fixed(op.head, pattern)
                if b0 is not None:
                    ways.append((pattern, op, b0, order(relaxed(op.pre), b0)))
        reads = [{lit.atom.name for lit in pre if lit.positive} for *_, pre in ways]
        todo: Iterable[int] = range(len(ways))
        while True:
            reached = State(FactBase(facts), frozenset(), frozenset())
            fresh: set[Atom] = set()
            for k in todo:
                pattern, op, b0, pre = ways[k]
                for b in satisfiers(pre, reached, b0):
                    task = _instance(op.head, b)
                    if _match(pattern, task, {}) is None:
                        continue  # a pattern's repeated variable, bound twice apart
                    self._count()
                    self._add(task)
                    # (A parameter an effect names has a literal: these are ground.)
                    fresh.update(f for f in (substitute(x, b) for x in op.add) if f not in facts)
            if not fresh:
                return reached
            facts |= fresh
            changed = {f.name for f in fresh}
            todo = [k for k in range(len(ways)) if reads[k] & changed]

    # -- step 2: producible compound tasks, a semi-naive fixed point ------------------------

    def _producible_tasks(
        self,
        domain: Domain,
        reached: State,
        relaxed: Callable[[Sequence[Literal]], tuple[Literal, ...]],
        order: Order,
    ) -> None:
        self._reached = reached
        self._kinds: dict[str, frozenset[Term]] = {}
        methods = [_Bottom.of(me, relaxed(me.pre), order) for ms in domain.methods.values() for me in ms]
        # The first round joins every method in full; later ones only where a subtask has
        # a task new in the round before, that subtask going over the new tasks alone.
        delta: dict[str, list[Atom]] = {name: list(ts) for name, ts in self._tasks.items()}
        first = True
        while delta or first:
            new: dict[str, list[Atom]] = defaultdict(list)
            for way in methods:
                for b in self._new_bindings(way, delta, first):
                    for full in satisfiers(way.pre, reached, b):
                        head = _instance(way.method.head, full)
                        self._tick()
                        if self._add(head):
                            self._count()
                            new[head.name].append(head)
            delta, first = dict(new), False

    def _new_bindings(self, way: _Bottom, delta: dict[str, list[Atom]], first: bool) -> Iterator[Bindings]:
        """The method's subtasks joined with the producible tasks, where (after the first
        round) at least one of them is a task of ``delta``."""
        subtasks = list(way.method.subtasks)
        if first:
            yield from self._project_join([{}], subtasks, way)
            return
        for i, t in enumerate(subtasks):
            typed = [task for task in delta.get(t.name, ()) if self._typed(way, t, task)]
            starts = [b for b in (_match(t, task, {}) for task in typed) if b is not None]
            if starts:
                yield from self._project_join(starts, subtasks[:i] + subtasks[i + 1 :], way)

    def _typed(self, way: _Bottom, t: Atom, task: Atom) -> bool:
        """Whether the task, as the method's subtask ``t``, has arguments of the types the
        method gives their variables."""
        args = task.args
        return all(args[i] in self._objects(kind) or args[i] == ANY for i, kind in way.types[t])

    def _objects(self, kind: str) -> frozenset[Term]:
        """The objects of a type (its static type predicate's facts)."""
        found = self._kinds.get(kind)
        if found is None:
            pattern = Atom(kind, ("?x",))
            found = self._kinds[kind] = frozenset(b["?x"] for b in self._reached.match(pattern, {}))
        return found

    def _project_join(self, rows: list[Bindings], subtasks: list[Atom], way: _Bottom) -> list[Bindings]:
        """The join, a subtask at a time over all the partial bindings at once, each step
        dropping the variables nothing later reads (neither the head, nor the precondition,
        nor a subtask to come), and then the repeats: bindings that differ only in a
        subtask's own variables (method16's any part coloured by any machine) count once."""
        bound: set[str] = set().union(*rows)  # (a row may leave unbound what an ANY did not bind)
        todo = list(subtasks)
        while todo and rows:
            t = max(todo, key=lambda x: (len(x.variables() & bound), -len(x.variables())))
            todo.remove(t)
            shared = tuple(sorted(t.variables() & bound))
            bound |= t.variables()
            live = way.kept.union(*(x.variables() for x in todo))
            rows = self._join_step(rows, t, way, shared, tuple(sorted(live & bound)))
        return rows

    def _join_step(
        self, rows: list[Bindings], t: Atom, way: _Bottom, shared: tuple[str, ...], kept: tuple[str, ...]
    ) -> list[Bindings]:
        """One subtask joined, as a hash join: each producible task of its name is first
        projected on the variables that matter -- those the rows have bound (``shared``, the
        key) and the new ones ``kept`` -- and the projections, each counted once, are then
        looked up by each row's key.  A Woodworking method's subtask matches a thousand
        tasks a row that differ only in variables nothing reads: projected first, the step
        goes through the tasks once, not once a row.  A value None is an argument
        :data:`ANY`: it matches whatever the row has, and binds nothing."""
        fresh = tuple(v for v in kept if v not in shared and v in t.variables())
        by_key: dict[tuple[Term | None, ...], dict[tuple[Term | None, ...], None]] = defaultdict(dict)
        loose: dict[tuple[tuple[Term | None, ...], tuple[Term | None, ...]], None] = {}  # ANY in the key
        for task in self._tasks.get(t.name, ()):
            self._tick()
            if not self._typed(way, t, task):
                continue
            b = _match(t, task, {})
            if b is None:
                continue
            key = tuple([b.get(v) for v in shared])
            out = tuple([b.get(v) for v in fresh])
            if None in key:
                loose[(key, out)] = None
            else:
                by_key[key][out] = None
        seen: dict[tuple[Term | None, ...], None] = {}
        for row in rows:
            row_key = tuple([row.get(v) for v in shared])
            if None in row_key:  # a variable an ANY left unbound: the task binds it, if it can
                matches = [(k, out) for k, outs in by_key.items() for out in outs if _fits(row_key, k)]
            else:
                matches = [(row_key, out) for out in by_key.get(row_key, ())]
            matches += [(k, out) for k, out in loose if _fits(row_key, k)]
            for k, out in matches:
                self._tick()
                b = dict(row)
                for v, x in (*zip(shared, k, strict=True), *zip(fresh, out, strict=True)):
                    if x is not None:
                        b.setdefault(v, x)
                key = tuple([b.get(v) for v in kept])
                if key not in seen:
                    self._count()  # a binding kept: the work that grows with the problem
                    seen[key] = None
        return [{v: x for v, x in zip(kept, key, strict=True) if x is not None} for key in seen]

    # -- step 3: the join --------------------------------------------------------------------

    def candidates(self, pattern: Atom, b: Bindings) -> Sequence[Atom]:
        """The producible tasks the pattern may match under ``b``: through the index on its
        most selective bound argument (all of them, when none is bound)."""
        known = self._tasks.get(pattern.name)
        if not known:
            return ()
        task = substitute(pattern, b)
        best: Sequence[Atom] | None = None
        for i, a in enumerate(task.args):
            if isinstance(a, str) and not is_variable(a):
                found = self._index.get((task.name, i, a), ())
                if task.name in self._masks:
                    found = [*found, *self._index.get((task.name, i, ANY), ())]
                if best is None or len(found) < len(best):
                    best = found
        if best is None:
            return tuple(known)
        return best

    def join(self, subtasks: Sequence[Atom], b: Bindings) -> Iterator[Bindings]:
        """Every extension of ``b`` under which each subtask is a producible task: the
        subtask with the fewest candidates first, then again with what it bound."""
        if not subtasks:
            yield b
            return
        sizes = [(len(self.candidates(t, b)), i) for i, t in enumerate(subtasks)]
        _, i = min(sizes)
        first, rest = subtasks[i], [*subtasks[:i], *subtasks[i + 1 :]]
        for task in self.candidates(first, b):
            matched = _match(first, task, b)
            if matched is not None:
                yield from self.join(rest, matched)


@dataclass(frozen=True, slots=True)
class _Bottom:
    """A method as the bottom-up pass binds it: its subtasks first (each with the types of
    the variables it names, checked as it is joined), then what is left of its relaxed
    precondition, in binding order from the subtasks' variables."""

    method: Method
    types: dict[Atom, tuple[tuple[int, str], ...]]
    pre: tuple[Literal, ...]
    kept: frozenset[str]
    """The variables the head or the precondition left reads: the only ones kept."""

    @staticmethod
    def of(method: Method, relaxed: Sequence[Literal], order: Order) -> _Bottom:
        named = {v for t in method.subtasks for v in t.variables()}
        placed = {a for t in method.subtasks for a in t.args}
        types = [
            lit
            for lit in relaxed
            if lit.positive
            and lit.atom.name.startswith(TYPE)
            and len(lit.atom.args) == 1
            and lit.atom.args[0] in placed
        ]
        rest = [lit for lit in relaxed if lit not in types]
        # Each subtask's type checks: the argument at a place, of the type of its variable.
        by_subtask = {
            t: tuple((t.args.index(x.atom.args[0]), x.atom.name) for x in types if x.atom.args[0] in t.args)
            for t in method.subtasks
        }
        kept = method.head.variables().union(*(lit.variables for lit in rest))
        return _Bottom(method, by_subtask, order(rest, named), frozenset(kept))


def _instance(head: Atom, b: Bindings) -> Atom:
    """The head under ``b``, with :data:`ANY` for a parameter nothing bound."""
    task = substitute(head, b)
    if task.is_ground:
        return task
    return Atom(task.name, tuple(ANY if isinstance(a, str) and is_variable(a) else a for a in task.args))


def _match(pattern: Atom, task: Atom, b: Bindings) -> Bindings | None:
    """``unify``, where an argument :data:`ANY` of the task matches whatever the pattern has
    there, and binds nothing."""
    if ANY not in task.args:
        return unify(pattern, task, b)
    if pattern.name != task.name or len(pattern.args) != len(task.args):
        return None
    out = dict(b)
    for p, a in zip(pattern.args, task.args, strict=True):
        if a == ANY:
            continue
        if isinstance(p, str) and is_variable(p):
            if out.setdefault(p, a) != a:
                return None
        elif isinstance(p, Atom) and isinstance(a, Atom):
            inner = unify(p, a, out)
            if inner is None:
                return None
            out = dict(inner)
        elif p != a:
            return None
    return out


def _fits(row_key: tuple[Term | None, ...], task_key: tuple[Term | None, ...]) -> bool:
    """Whether a row and a projected task agree on the variables both have bound (None is
    unbound in the row, :data:`ANY` in the task)."""
    return all(r is None or x is None or r == x for r, x in zip(row_key, task_key, strict=True))


def _fixed(head: Atom, pattern: Atom) -> Bindings | None:
    """The bindings of the action's parameters that the pattern's constants fix; None when
    the two cannot match."""
    if len(head.args) != len(pattern.args):
        return None
    out: Bindings = {}
    for h, p in zip(head.args, pattern.args, strict=True):
        if is_variable(p) or (isinstance(p, Atom) and not p.is_ground):
            continue  # nothing fixed here (a term with variables fixes too little to keep)
        if not isinstance(h, str) or not is_variable(h):
            if h != p:
                return None
        elif out.setdefault(h, p) != p:
            return None
    return out


__all__ = ["Producible", "enumerated"]
