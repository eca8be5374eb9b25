"""A grounded estimate for the searches where the lifted one sees nothing: relaxed composition.

The lifted estimate (:attr:`~htnagent.model.domain.Domain.task_costs`) knows only task
*names*: ``connect(p1,p2)`` costs what every ``connect`` costs, whatever the ports and
whatever the state.  Where a domain's choices are all about *which* objects (which cable,
which port, which shelf), that gives greedy search nothing to go on.  This module grounds
the problem -- where that is affordable -- and estimates each ground task from the state
itself, as PANDA's relaxed-composition heuristics do (docs/design.md §7.2):

1. **Relaxed reachability** (:func:`ground`, step 1): from the start state, every ground
   action whose precondition can come to hold when effects only add (delete relaxation;
   negative preconditions on facts that change are taken as satisfiable).  The facts so
   reached over-approximate every state a plan can pass through.
2. **The task decomposition graph** (step 2): from the tasks to plan, top down, every
   ground method whose precondition holds among the reached facts, and the ground tasks
   its subtasks name; a primitive task is one of the reached actions, or is dead.  Where
   types alone would bind a method's parameters by the thousand, they are bound by
   joining its subtasks with the ground tasks that can occur at all
   (:mod:`htnagent.planning.producible`; see :data:`JOIN_ABOVE`), and parameters in
   groups independent of each other are grounded apart (design §7.2).  Where the join goes
   past the cap, binding by types is tried.
3. **Pruning** (step 3): the least number of actions each ground task takes, bottom up
   over the graph (a fixed point: ``cost(task) = min over its methods of the sum of its
   subtasks' costs``, an action 1); a task that no decomposition finishes costs ``inf``,
   and the methods that need it go.  Only the actions left below the tasks are kept.
4. **Relaxed composition from a state** (:meth:`Composition.task_costs`): the compiled
   problem in which an action, once its precondition facts are reached, reaches its
   effects and its own task, and a method reaches its task once its precondition facts
   and all its subtasks are reached -- costed as h_add (a sum: what each needs, added),
   by a Dijkstra-like pass from the state's facts.  A task list's estimate
   (:meth:`Composition.estimate`) is the sum over its tasks; ``inf`` when one of them can
   no longer be done from the state, so the search drops that node (sound: a relaxation).
5. **One-way facts** (:mod:`htnagent.planning.one_way`): ``inf`` too where a task of the
   list needs a fact nothing makes true again that the state lacks, or that a task before
   it uses up -- which the delete relaxation of step 4 cannot see.
6. **What the list can still make true** (:mod:`htnagent.planning.below`): ``inf`` too where
   a task needs at its start a fact the state lacks that no action below the tasks before
   it adds -- step 4 lets any action add it, even one no task left comes down to.
7. **What the list can still reach** (:mod:`htnagent.planning.reach`): step 4's relaxation
   again, kept to the actions and methods below the list's tasks -- a task of the list it
   does not reach has no plan (:meth:`Composition.dead_end`).  The searches ask it of the
   nodes they expand where an action led to them, not of every child.

Everything is bounded by :data:`MAX_GROUND` ground actions and method bindings (or
:data:`MAX_GROUND_ALONE`, where :func:`lifted_is_lost`), each way of binding tried: past
that :func:`ground` gives None, and the searches keep the lifted estimate.  Grounding
reads ``checkpoint()`` as it goes, so a portfolio can pace it or stop it.
"""

from __future__ import annotations

import heapq
import math
from collections import Counter, defaultdict
from collections.abc import Callable, Iterable, Iterator, Mapping, Sequence
from dataclasses import dataclass

from htnagent.model.domain import Domain, Method
from htnagent.model.preconditions import Literal, satisfiers
from htnagent.model.state import FactBase, State
from htnagent.model.terms import Atom, Bindings, substitute, unify
from htnagent.planning.below import Below
from htnagent.planning.ground_methods import Decompositions, GroundWay, decompositions
from htnagent.planning.hddl_translation import EQ, TYPE
from htnagent.planning.one_way import OneWay
from htnagent.planning.producible import Producible, enumerated
from htnagent.planning.reach import WithinReach

MAX_GROUND = 100_000
"""The most ground actions plus bindings of methods' preconditions :func:`ground` goes
through, each way of binding, before it gives up.  In the portfolio the grounding also
stops after ``GROUNDING_SECONDS`` (2 s, :mod:`htnagent.planning.hddl_solving`) of its own
work: the cap bounds the memory, and the grounding of a caller without a clock.  Past it,
one estimate from a state (worked out anew for every state the search reaches) costs more
than the guidance is worth.  Woodworking's 17th problem needs 52,030 bindings (1.3 s);
AssemblyHierarchical's 25th-30th 21,388-30,468 (docs/benchmarks.md, "The cap")."""

MAX_GROUND_ALONE = 300_000
"""The cap the portfolio grounds under where :func:`lifted_is_lost`: there the grounded
searches are the only ones with a chance, so the grounding has no clock of its own but the
time limit, and this cap bounds only its memory (Woodworking's 19th problem, 250,812
bindings: about 200 MB, 8 s)."""

JOIN_ABOVE = 0.02
"""The share of the cap (of :data:`MAX_GROUND` at most) past which the bindings some method's
types make for one task send the grounder to bind methods by joining their subtasks with the
producible tasks (:mod:`htnagent.planning.producible`) first: 2,000 bindings of one task at
the default cap, which leaves room for 50 such tasks at most.  Working out what can be
produced is a pass over the whole problem, which costs more than it saves where the types
add only a few ways (Entertainment's methods: six bindings); Woodworking's make up to
48,600.  It is a guess from one task: where the join goes past the cap, :func:`ground` binds
by types (where one task's bindings fit under the cap).  AssemblyHierarchical has one task
whose method takes any two ports (2,304 bindings in its 12th problem, 14,400 in its 30th),
and bottom up the join pairs every plugged port with every pair of devices: past its 22nd
problem the join goes past the cap (55,565 bindings in the 18th, 217,000 in the 30th), where
binding by types takes 11,364 to 30,468.  The other way round never helped: of the 210
problems of both suites past a cap of 20,000 by types, none fits by the join."""

MAX_WHOLE = 100
"""The dearest action, in whole numbers, for which :meth:`Composition.task_costs` lists nodes
by cost (a list a cost) instead of keeping a heap."""

CACHED_COSTS = 2_000_000
"""About how many task and fact costs :meth:`Composition.task_costs` keeps for the states
it has seen (tens of megabytes)."""

CHECK_EVERY = 256
"""Units of work between two calls of ``checkpoint``: a binding, a task decomposed or an
action tried."""

_INF = float("inf")
_NONE: frozenset[str] = frozenset()


class TooLarge(Exception):
    """The grounding went past its cap, or its ``checkpoint`` said stop."""


NOT = "__not_"
"""The prefix of a negated fact (``__not_pGuard()``: ``pGuard()`` is false), for the
predicates some precondition negates: a negative precondition becomes a positive one on
it, which an action deleting the fact reaches (as PANDA compiles negation away)."""


@dataclass(frozen=True, slots=True)
class _GroundAction:
    head: Atom
    cost: float
    pre: tuple[Atom, ...]  # the preconditions on facts that change (negated ones as NOT facts)
    add: tuple[Atom, ...]  # the added facts, and NOT facts for the deleted ones that matter
    delete: tuple[Atom, ...]  # the facts it makes false, and NOT facts for the added ones that matter


@dataclass(frozen=True, slots=True)
class _GroundMethod:
    task: Atom
    pre: tuple[Atom, ...]  # as an action's
    subtasks: tuple[Atom, ...]
    way: GroundWay | None = None  # for the searches, where they decompose by ground methods


class Composition:
    """A grounded problem compiled for relaxed composition (the module's steps 3 and 4).

    ``least`` holds each ground task's least number of actions whatever the state (step 3);
    :meth:`task_costs` and :meth:`estimate` work from a state (step 4).
    """

    def __init__(
        self,
        actions: Sequence[_GroundAction],
        methods: Sequence[_GroundMethod],
        least: dict[Atom, float],
        fallback: dict[str, float],
        producible: Producible | None = None,
        by_ground: Decompositions | None = None,
        stop_if_asked: Callable[[], None] = lambda: None,
    ) -> None:
        """``stop_if_asked`` is called between the steps of the compiling, each up to about
        a second on the largest groundings: it raises to stop it."""
        self.least = least
        self.decompositions: Decompositions = by_ground or {}
        """The decomposers of the methods the grounder bound by the join, or by types where
        their types made many bindings, for the searches
        (:mod:`htnagent.planning.ground_methods`): empty where there are none."""
        self.actions = len(actions)
        self.methods = len(methods)
        self._fallback = fallback
        self._producible = producible
        # One id space for what can be reached: facts first, then tasks.
        ids: dict[Atom, int] = {}
        task_ids: dict[Atom, int] = {}

        def fact_id(f: Atom) -> int:
            return ids.setdefault(f, len(ids))

        for a in actions:
            for f in (*a.pre, *a.add):
                fact_id(f)
        for me in methods:
            for f in me.pre:
                fact_id(f)
        self._facts = {f: i for f, i in ids.items() if not f.name.startswith(NOT)}
        # A negated fact holds from the start where its fact does not.
        self._negated = [
            (Atom(f.name[len(NOT) :], f.args), i) for f, i in ids.items() if f.name.startswith(NOT)
        ]
        n_facts = len(ids)
        for t in least:
            task_ids[t] = n_facts + len(task_ids)
        self._tasks = task_ids
        self._size = n_facts + len(task_ids)
        # Consumers: each action and method, with what it needs (one entry per occurrence),
        # what firing it costs on top, and what it reaches.
        needs: list[int] = []
        base: list[float] = []
        outputs: list[tuple[int, ...]] = []
        consumers: list[list[int]] = [[] for _ in range(self._size)]
        for a in actions:
            k = len(needs)
            inputs = [ids[f] for f in a.pre]
            needs.append(len(inputs))
            base.append(a.cost)
            outputs.append((*(ids[f] for f in a.add), task_ids[a.head]))
            for i in inputs:
                consumers[i].append(k)
        for me in methods:
            k = len(needs)
            inputs = [ids[f] for f in me.pre] + [task_ids[t] for t in me.subtasks]
            needs.append(len(inputs))
            base.append(0.0)
            outputs.append((task_ids[me.task],))
            for i in inputs:
                consumers[i].append(k)
        self._needs = needs
        self._base = base
        # Whole-number costs (the IPC's actions cost 1): the costs' Dijkstra by buckets.
        self._whole = all(b == int(b) and 0 <= b <= MAX_WHOLE for b in base)
        self._int_base = [int(b) for b in base] if self._whole else []
        self._outputs = outputs
        self._consumers = [tuple(c) for c in consumers]
        self._free = [k for k, n in enumerate(needs) if n == 0]
        self._cache: dict[frozenset[Atom], list[float]] = {}
        # States' costs kept: about CACHED_COSTS numbers in all (each a Python float).
        self._cache_size = max(64, CACHED_COSTS // max(self._size, 1))
        self._last: tuple[frozenset[Atom] | None, list[float], frozenset[int]] = (None, [], frozenset())
        # What the delete relaxation cannot see run out (step 5): a fact's id is its index in
        # ``dist``, where a fact nothing adds costs 0 exactly when the state holds it.  By
        # task id, what it needs and what it ends (a list: looked up for every task of every
        # list estimated); None for every task where no task needs any.
        stop_if_asked()
        one_way = OneWay.of(actions, methods, ids, task_ids)
        self._one_way: list[tuple[tuple[int, ...], frozenset[int]] | None] | None = None
        if one_way:
            self._one_way = [None] * self._size
            for i in {*one_way.needs, *one_way.ends}:
                self._one_way[i] = (one_way.needs.get(i, ()), one_way.ends.get(i, frozenset()))
        # What the list can still make true (step 6).
        stop_if_asked()
        self._below = Below.of(actions, methods, ids, task_ids)
        needed = set().union(*self._below.needs.values())
        self._needed = {f: i for f, i in self._facts.items() if i in needed}
        self._needed_negated = [(f, i) for f, i in self._negated if i in needed]
        # By task id, what it needs at its start (None: nothing); None where no task needs any.
        self._starts: list[frozenset[int] | None] | None = None
        if self._below.needs:
            self._starts = [None] * self._size
            for i, need in self._below.needs.items():
                self._starts[i] = need
        # What the list can still reach (step 7), on the same graph.
        stop_if_asked()
        self._reach = WithinReach(
            needs, self._consumers, outputs, self._free, self._below.tasks_below, actions=len(actions)
        )

    def task_costs(self, dynamic: frozenset[Atom]) -> list[float]:
        """Each ground task's relaxed-composition cost (h_add) from a state whose changing
        facts are ``dynamic``, by task id (``inf``: not reached); cached per state."""
        found = self._cache.get(dynamic)
        if found is not None:
            return found
        if len(self._cache) >= self._cache_size:
            self._cache.clear()  # a bound on memory: the searches revisit few states late
        dist = self._by_buckets(dynamic) if self._whole else self._by_heap(dynamic)
        self._cache[dynamic] = dist
        return dist

    def _by_buckets(self, dynamic: frozenset[Atom]) -> list[float]:
        """:meth:`task_costs` where every action costs a whole number: Dijkstra's algorithm
        with a list of what each cost reaches in place of the heap (Dial's), which reads
        every cost in turn -- h_add's are sums of whole numbers, few and small.  A node may
        be listed more than once; it is settled at its first, cheapest, listing."""
        dist: list[float] = [_INF] * self._size
        left = self._needs[:]
        acc = [0] * len(left)
        base = self._int_base
        outputs = self._outputs
        consumers = self._consumers
        buckets: list[list[int]] = [self._start(dynamic)]
        for k in self._free:
            v = base[k]
            while len(buckets) <= v:
                buckets.append([])
            buckets[v].extend(outputs[k])
        cost = 0
        while cost < len(buckets):
            # The list grows as it is read: a method (cost 0) reaches its task at the cost
            # its subtasks reached.
            for n in buckets[cost]:
                if dist[n] != _INF:
                    continue
                dist[n] = cost
                for k in consumers[n]:
                    acc[k] += cost
                    left[k] -= 1
                    if not left[k]:
                        v = acc[k] + base[k]
                        while len(buckets) <= v:
                            buckets.append([])
                        buckets[v].extend(outputs[k])
            cost += 1
        return dist

    def _by_heap(self, dynamic: frozenset[Atom]) -> list[float]:
        """:meth:`task_costs` by Dijkstra's algorithm on a heap: for any action costs."""
        dist = [_INF] * self._size
        pushed = [_INF] * self._size
        left = self._needs[:]
        acc = [0.0] * len(left)
        base = self._base
        outputs = self._outputs
        consumers = self._consumers
        heap: list[tuple[float, int]] = []
        push, pop = heapq.heappush, heapq.heappop
        for i in self._start(dynamic):
            pushed[i] = 0.0
            heap.append((0.0, i))
        heapq.heapify(heap)
        for k in self._free:
            v = base[k]
            for o in outputs[k]:
                if v < pushed[o]:
                    pushed[o] = v
                    push(heap, (v, o))
        while heap:
            c, n = pop(heap)
            if dist[n] != _INF:
                continue
            dist[n] = c
            for k in consumers[n]:
                acc[k] += c
                left[k] -= 1
                if left[k] == 0:
                    v = acc[k] + base[k]
                    for o in outputs[k]:
                        if v < pushed[o]:
                            pushed[o] = v
                            push(heap, (v, o))
        return dist

    def _start(self, dynamic: frozenset[Atom]) -> list[int]:
        """The nodes a state whose changing facts are ``dynamic`` holds from the start, by id:
        its facts, and the negated facts whose fact it lacks."""
        facts = self._facts
        start = [i for f in dynamic if (i := facts.get(f)) is not None]
        start += [i for f, i in self._negated if f not in dynamic]
        return start

    def dead_end(self, tasks: Sequence[Atom], dynamic: frozenset[Atom]) -> bool:
        """Whether the task list cannot be done from the state (step 7): the relaxation kept
        to the actions and methods below its tasks does not reach them all.  False where a
        task of the list is one the grounding never met: what it does is unknown.  For the
        nodes a search expands, not for every child it makes (:mod:`htnagent.planning.reach`)."""
        ids = self._tasks
        wanted: list[int] = []
        for t in tasks:
            i = ids.get(t)
            if i is None:
                return False
            wanted.append(i)
        return self._reach.lost(wanted, self._start(dynamic))

    def _holding(self, dynamic: frozenset[Atom]) -> frozenset[int]:
        """The facts some task needs at its start (step 6) that hold in the state whose
        changing facts are ``dynamic``, by id (a negated fact where its fact is false)."""
        needed = self._needed
        here = [i for f in dynamic if (i := needed.get(f)) is not None]
        here += [i for f, i in self._needed_negated if f not in dynamic]
        return frozenset(here)

    def estimate(self, tasks: Sequence[Atom], dynamic: frozenset[Atom]) -> float:
        """The task list's estimate from the state: the sum of its tasks' costs; ``inf``
        when one of them cannot be done any more.  A task the grounding never met (it
        cannot come from the tasks grounded) counts its name's least cost -- or ``inf``
        where the grounding worked out what can be produced at all and it is not."""
        # The children of one node mostly share its state: the same object, asked again.
        last_dynamic, dist, holds = self._last
        if dynamic is not last_dynamic:
            dist = self.task_costs(dynamic)
            holds = self._holding(dynamic)
            self._last = (dynamic, dist, holds)
        ids = self._tasks
        total = 0.0
        one_way = self._one_way
        ended: set[int] = set()  # the one-way facts the primitive tasks so far make false
        starts = self._starts
        before: list[int] = []  # the tasks so far, by id (step 6)
        for t in tasks:
            i = ids.get(t)
            if i is not None:
                total += dist[i]
                if starts is not None:
                    # Step 6: what the task needs at its start, the state lacks and no
                    # task before it adds, no plan makes true in time.
                    need = starts[i]
                    if need is not None and not need <= holds and self._below.lost(need - holds, before):
                        return _INF
                    before.append(i)
                if one_way is None or (found := one_way[i]) is None:
                    continue
                # Step 5: a one-way fact the task needs must hold now and not be ended
                # before it by a task of the list (a fact nothing adds costs 0 only when
                # the state holds it).
                one_way_need, gone = found
                for f in one_way_need:
                    if dist[f] != 0.0 or f in ended:
                        return _INF
                ended |= gone
            elif self._producible is not None and t not in self._producible:
                # The grounder no longer meets what a join left out (the search still
                # makes it, binding by types): it costs what the old grounding gave it.
                return _INF
            else:
                total += self._fallback.get(t.name, 0.0)
                # What it does is unknown (it might renew or add any fact): no more checks.
                one_way = starts = None
        return total


def ground(
    domain: Domain,
    state: State,
    tasks: Sequence[Atom],
    *,
    cap: int = MAX_GROUND,
    checkpoint: Callable[[], bool] | None = None,
) -> Composition | None:
    """The problem grounded and compiled for relaxed composition (the module's steps 1-3),
    or None when that takes more than ``cap`` ground actions and method bindings -- by the
    join where :data:`JOIN_ABOVE` chooses it, and then by types where one task's types
    alone do not pass the cap -- or when ``checkpoint()`` (called every
    :data:`CHECK_EVERY` of them) says stop."""
    first = _Grounder(domain, state, cap, checkpoint)
    try:
        return first.run(tasks)
    except TooLarge:
        if first.stopped or not first.joining or first.most > cap:
            return None
    # Past the cap by the join, binding by types may fit where one task's bindings do
    # (design §7.2, step 1): the join's pass over the whole problem can cost more than the
    # enumerations it saves (AssemblyHierarchical's one ``ConnectDevices`` task, whose
    # method ``m1`` takes any two ports).
    try:
        return _Grounder(domain, state, cap, checkpoint, joining=False).run(tasks)
    except TooLarge:
        return None


def lifted_is_lost(domain: Domain, state: State) -> bool:
    """Whether the types of some method's parameters that only its subtasks name make more
    than :data:`JOIN_ABOVE` of :data:`MAX_GROUND` bindings of one task (2,000): the lifted
    searches, binding them so, make that many children of each such decomposition, nearly
    all dead (Woodworking: up to millions).  There the grounder binds them by the join, and
    the searches decompose by its ground methods (design §7.2)."""
    return _Grounder(domain, state, MAX_GROUND, None).most > MAX_GROUND * JOIN_ABOVE


class _Grounder:
    def __init__(
        self,
        domain: Domain,
        state: State,
        cap: int,
        checkpoint: Callable[[], bool] | None,
        joining: bool | None = None,
    ) -> None:
        self.domain = domain
        self.dyn = state.dynamic_predicates
        pres = [op.pre for ops in domain.operators.values() for op in ops]
        pres += [me.pre for ms in domain.methods.values() for me in ms]
        self.negated = {lit.atom.name for pre in pres for lit in pre if not lit.positive} & self.dyn
        self.start = state
        self.cap = cap
        self.checkpoint = checkpoint
        self.made = 0
        self.work = 0
        self._producible: Producible | None = None
        self.roots: tuple[Atom, ...] = ()
        self.by_ground: set[Method] = set()
        """The methods the searches decompose by their ground methods: those bound by the
        join, or -- bound by types -- those whose types alone make many bindings."""
        self.stopped = False
        """Whether ``checkpoint()`` said stop (rather than the cap being passed)."""
        facts = self.start.facts()
        # How many objects each enumeration goes through: every object of a type, or every
        # object (an equality).
        sizes = Counter(f.name for f in facts if f.name.startswith(TYPE) or f.name == EQ)
        every = [me for ms in domain.methods.values() for me in ms]
        self.by_types = [(me, _by_types(me, self.relaxed, sizes)) for me in every]
        """Each method, with how many bindings of one task its types alone make."""
        self.most = max((n for _, n in self.by_types), default=0)
        """The most bindings of one task some method's types make."""
        # Working out what can be produced is a pass over the whole problem: worth it where
        # some method's types alone would use a good share of the cap on one task; once
        # done, every method that would enumerate is joined (the join also drops the
        # bindings nothing can finish, which keeps the rest of the grounding small).
        many = min(self.cap, MAX_GROUND) * JOIN_ABOVE
        self.joining = self.most > many if joining is None else joining
        if not self.joining:
            # Bound by types, the method's many ground ways, most of which nothing can
            # finish, are pruned here: the searches need not make and estimate them.
            self.by_ground = {me for me, n in self.by_types if n > many}

    def producible(self) -> Producible:
        """The ground tasks that can be produced at all, worked out the first time a method
        needs them (its cost counts against the cap like the rest)."""
        if self._producible is None:
            self._producible = Producible(
                self.domain, self.start, self.roots, self.relaxed, _binding_order, self.count, self.tick
            )
        return self._producible

    def bindings(self, way: _Way, task: Atom, reached: State) -> Iterator[Bindings]:
        """The method's bindings for the task whose relaxed precondition holds among the
        facts reached (design §7.2, step 1).  A method with parameters only an enumeration
        would bind (by type) is first joined with the producible tasks, then checked."""
        b0 = unify(way.head, task, {})
        if b0 is None:
            return
        if way.joined is None:
            yield from satisfiers(way.order, reached, b0)
            return
        for b in self.producible().join(way.subtasks, b0):
            yield from satisfiers(way.joined, reached, b)

    def count(self) -> None:
        """One more ground action or method binding: past the cap, give up."""
        self.made += 1
        if self.made > self.cap:
            raise TooLarge
        self.tick()

    def tick(self) -> None:
        """One more unit of work: every :data:`CHECK_EVERY`, ask the checkpoint."""
        self.work += 1
        if self.checkpoint is not None and not self.work % CHECK_EVERY and self.checkpoint():
            self.stopped = True
            raise TooLarge

    def stop_if_asked(self) -> None:
        """Ask the checkpoint now, where work comes in large steps: stop if it says so."""
        if self.checkpoint is not None and self.checkpoint():
            self.stopped = True
            raise TooLarge

    def relaxed(self, pre: Sequence[Literal]) -> tuple[Literal, ...]:
        """The precondition under delete relaxation: negative literals on changing facts go."""
        return tuple(lit for lit in pre if lit.positive or lit.atom.name not in self.dyn)

    def changing(self, pre: Sequence[Literal], b: Bindings) -> tuple[Atom, ...]:
        """The literals on changing facts, made ground (a negative one as its NOT fact)."""
        out = []
        for lit in pre:
            if lit.atom.name in self.dyn:
                f = substitute(lit.atom, b)
                out.append(f if lit.positive else Atom(NOT + f.name, f.args))
        return tuple(out)

    def run(self, roots: Sequence[Atom]) -> Composition:
        self.roots = tuple(roots)
        actions, methods, tasks = self.reachable(roots)
        return self.pruned(actions, methods, tasks)

    # -- steps 1 and 2: relaxed reachability below the tasks ---------------------------------

    def reachable(
        self, roots: Sequence[Atom]
    ) -> tuple[dict[Atom, list[_GroundAction]], list[_GroundMethod], list[Atom]]:
        """The ground actions, ground methods and ground tasks below the roots that the
        delete relaxation reaches (steps 1 and 2 as one fixed point).

        Only what the hierarchy can reach is grounded: a method is grounded where its
        relaxed precondition holds among the facts reached so far, a primitive subtask
        becomes an action where its relaxed precondition does, and the action's effects
        join the facts.  When new facts come, the methods and actions whose preconditions
        name them are tried again, until nothing new is reached.
        """
        domain = self.domain
        facts: set[Atom] = set(self.start.facts())
        reached = State(FactBase(facts), frozenset(), _NONE)
        orders: dict[str, list[_Way]] = defaultdict(list)
        for index, (me, _) in enumerate(self.by_types):
            if not self.joining:
                order = _binding_order(self.relaxed(me.pre), me.head.variables())
                whole = tuple(range(len(me.subtasks)))
                orders[me.head.name].append(_Way(me, me.head, me.pre, order, me.subtasks, None, whole))
                continue
            ways_of = _ways(me, self.relaxed, f"__{me.name}#{index}")
            if any(way.joined is not None for way in ways_of):
                # Bound by the join: the searches decompose its tasks by its ground methods.
                self.by_ground.add(me)
            for way in ways_of:
                orders[way.head.name].append(way)
        op_orders = {
            name: [(op, _binding_order(self.relaxed(op.pre), op.head.variables())) for op in ops]
            for name, ops in domain.operators.items()
        }
        # The predicates each method or operator reads: what makes it worth trying again.
        reads: dict[str, set[str]] = defaultdict(set)
        for name, pres in (
            *((n, [way.order for way in ways]) for n, ways in orders.items()),
            *((n, [pre for _, pre in pairs]) for n, pairs in op_orders.items()),
        ):
            for pre in pres:
                reads[name] |= {lit.atom.name for lit in pre if lit.positive}
        actions: dict[Atom, list[_GroundAction]] = {}
        methods: list[_GroundMethod] = []
        made: set[tuple[Atom, str, tuple[Atom, ...], tuple[Atom, ...]]] = set()
        met: dict[Atom, None] = dict.fromkeys(roots)
        primitive: list[Atom] = []  # tried again as new facts come: more ways may hold
        ways: set[tuple[Atom, int, tuple[Atom, ...]]] = set()
        new_facts: list[Atom] = []

        def act(task: Atom) -> None:
            """Ground the primitive task's ways where their relaxed precondition holds: each
            operator (an action with alternatives has several) and each binding of
            variables its precondition alone has, told apart by the facts they need."""
            self.tick()
            for index, (op, pre) in enumerate(op_orders[task.name]):
                b0 = unify(op.head, task, {})
                if b0 is None:
                    continue
                for b in satisfiers(pre, reached, b0):
                    self.count()
                    needs = self.changing(op.pre, b)
                    if (task, index, needs) in ways:
                        continue
                    ways.add((task, index, needs))
                    add = tuple(substitute(x, b) for x in op.add)
                    deleted = [f for x in op.delete if (f := substitute(x, b)) not in add]
                    gone = [f for f in deleted if f.name in self.negated]
                    reaches = add + tuple(Atom(NOT + f.name, f.args) for f in gone)
                    ended = (*deleted, *(Atom(NOT + f.name, f.args) for f in add if f.name in self.negated))
                    actions.setdefault(task, []).append(
                        _GroundAction(task, op.action_cost(task), needs, reaches, ended)
                    )
                    new_facts.extend(f for f in add if f not in facts)

        def decompose(task: Atom, queue: list[Atom]) -> None:
            self.tick()
            for way in orders.get(task.name, ()):
                kept = way.method in self.by_ground
                for b in self.bindings(way, task, reached):
                    self.count()  # every binding: a method with free variables may have millions
                    subtasks = tuple(substitute(t, b) for t in way.subtasks)
                    # Two bindings with the same subtasks may need other facts (a variable
                    # of the precondition alone): each is a way of its own.
                    needs = self.changing(way.pre, b)
                    key = (task, way.name, subtasks, needs)
                    if key in made or not all(t.is_ground for t in subtasks):
                        continue
                    made.add(key)
                    ground_way = way.ground(task, b, subtasks) if kept else None
                    methods.append(_GroundMethod(task, needs, subtasks, ground_way))
                    for t in subtasks:
                        if t in met:
                            continue
                        met[t] = None
                        if t.name in orders:
                            queue.append(t)
                        elif t.name in domain.operators:
                            primitive.append(t)
                            act(t)

        queue = [t for t in met if t.name in orders]
        for t in met:
            if t.name in domain.operators:
                primitive.append(t)
                act(t)
        while True:
            while queue:
                decompose(queue.pop(), queue)
            fresh = {f for f in new_facts if f not in facts}
            new_facts.clear()
            if not fresh:
                break
            facts |= fresh
            reached = State(FactBase(facts), frozenset(), _NONE)
            changed = {f.name for f in fresh}
            for t in primitive:
                if reads[t.name] & changed:
                    act(t)
            queue = [t for t in met if t.name in orders and reads[t.name] & changed]
        return actions, methods, list(met)

    # -- step 3: least costs, and what is left ----------------------------------------------

    def pruned(
        self, actions: dict[Atom, list[_GroundAction]], methods: list[_GroundMethod], tasks: list[Atom]
    ) -> Composition:
        least = _least_costs(actions, methods, tasks)
        self.stop_if_asked()
        kept = [
            me
            for me in methods
            if least.get(me.task, _INF) < _INF and all(least.get(t, _INF) < _INF for t in me.subtasks)
        ]
        used = {t for me in kept for t in me.subtasks} | {t for t in tasks if t in actions}
        kept_actions = [a for t in used if t in actions for a in actions[t]]
        # Every task met keeps its id (a task no decomposition finishes is never reached):
        # only a task the grounding never met falls back on its name's least cost.
        fallback = self.domain.task_costs or {}
        ground_ways = [me.way for me in kept if me.way is not None]
        by_ground = decompositions(ground_ways, least) if self.by_ground else {}
        self.stop_if_asked()
        return Composition(
            kept_actions, kept, least, fallback, self._producible, by_ground, stop_if_asked=self.stop_if_asked
        )


@dataclass(frozen=True, slots=True)
class _Way:
    """A method as the grounder binds it (design §7.2, step 1): its relaxed precondition in
    binding order from its task's variables (``order``); and -- where that order would
    enumerate a parameter's type and a subtask names the parameter -- in binding order from
    the subtasks' variables too (``joined``), for after the join of its subtasks with the
    producible tasks."""

    method: Method  # the method it binds (all of it, or a share: its core or one group)
    head: Atom
    pre: tuple[Literal, ...]  # the whole precondition: its literals on changing facts are needs
    order: tuple[Literal, ...]
    subtasks: tuple[Atom, ...]
    joined: tuple[Literal, ...] | None
    positions: tuple[int, ...]  # where its own subtasks stand among the method's (not a group's task)

    @property
    def name(self) -> str:
        return self.method.name

    def ground(self, task: Atom, b: Bindings, subtasks: tuple[Atom, ...]) -> GroundWay:
        """The ground method of ``task`` under ``b`` for the searches: its task's and
        subtasks' variables bound, and its precondition in the real state checked from there."""
        bound = self.head.variables().union(*(t.variables() for t in self.subtasks))
        check = _binding_order(self.pre, bound)
        return GroundWay(self.method, task, check, {v: b[v] for v in bound}, subtasks, self.positions)


def _ways(
    method: Method, relaxed: Callable[[Sequence[Literal]], tuple[Literal, ...]], prefix: str
) -> list[_Way]:
    """The ways the grounder binds the method: itself, or -- where the join binds its
    parameters and they fall into groups that share none but the task's (Woodworking's
    ``method16`` colours any part with any machine, whatever it grinds) -- one way per group,
    each of a task of its own (``__method16#15_2(?colour)``: the group's subtasks, under its
    share of the precondition), and the method's own way doing those tasks.  The tasks'
    names begin with ``prefix``, one of this method's own (methods made of one ``or`` share
    their name).

    Grounded together, the groups' bindings multiply; apart, they add up.  The estimate is
    the same: a method's cost is what its precondition and subtasks cost, summed, least over
    its bindings -- and the least of a sum over independent groups is the sum of their
    least.
    """
    bound = method.head.variables()
    n = len(method.subtasks)
    whole = _way(method, method.head, method.pre, method.subtasks, relaxed, tuple(range(n)))
    if whole.joined is None:
        return [whole]
    groups = _groups([*method.subtasks, *(lit.atom for lit in method.pre)], bound)
    if len(groups) <= 1:
        return [whole]
    ways: list[_Way] = []
    tasks: list[Atom] = []
    for k, members in enumerate(groups, 1):
        subtasks = tuple(t for i, t in enumerate(method.subtasks) if i in members)
        pre = tuple(lit for i, lit in enumerate(method.pre, n) if i in members)
        shared = bound & set().union(*(t.variables() for t in subtasks), *(x.variables for x in pre))
        head = Atom(f"{prefix}_{k}", tuple(sorted(shared)))
        tasks.append(head)
        ways.append(_way(method, head, pre, subtasks, relaxed, tuple(i for i in sorted(members) if i < n)))
    grouped = set().union(*groups)
    core = tuple(lit for i, lit in enumerate(method.pre, n) if i not in grouped)
    own = tuple(i for i in range(n) if i not in grouped)
    ground = tuple(method.subtasks[i] for i in own)
    return [_way(method, method.head, core, (*ground, *tasks), relaxed, own), *ways]


def _way(
    method: Method,
    head: Atom,
    pre: tuple[Literal, ...],
    subtasks: tuple[Atom, ...],
    relaxed: Callable[[Sequence[Literal]], tuple[Literal, ...]],
    positions: tuple[int, ...],
) -> _Way:
    """The way to bind a method: joined where it has parameters its subtasks name that only
    an enumeration would bind.  ``positions``: where its subtasks, but a group's tasks, stand
    among the method's."""
    bound = head.variables()
    order = _binding_order(relaxed(pre), bound)
    named = {v for t in subtasks for v in t.variables()}
    if not set(enumerated(order, bound)) & named:
        return _Way(method, head, pre, order, subtasks, None, positions)
    return _Way(method, head, pre, order, subtasks, _binding_order(relaxed(pre), bound | named), positions)


def _by_types(
    method: Method, relaxed: Callable[[Sequence[Literal]], tuple[Literal, ...]], sizes: Mapping[str, int]
) -> int:
    """How many bindings of one task the types of the method's parameters its subtasks name
    (and nothing else binds) make: the product of their numbers of objects."""
    bound = method.head.variables()
    named = {v for t in method.subtasks for v in t.variables()}
    kinds = [
        k for v, k in enumerated(_binding_order(relaxed(method.pre), bound), bound).items() if v in named
    ]
    return math.prod(sizes.get(k, 0) for k in kinds) if kinds else 0


def _groups(items: Sequence[Atom], bound: set[str]) -> list[set[int]]:
    """The items (by index) in groups linked by the variables outside ``bound`` they share;
    items with none of those are in no group."""
    owner: dict[str, int] = {}
    parent = list(range(len(items)))

    def root(i: int) -> int:
        while parent[i] != i:
            parent[i] = parent[parent[i]]
            i = parent[i]
        return i

    for i, item in enumerate(items):
        for v in item.variables() - bound:
            if v in owner:
                parent[root(i)] = root(owner[v])
            else:
                owner[v] = i
    out: dict[int, set[int]] = defaultdict(set)
    for i, item in enumerate(items):
        if item.variables() - bound:
            out[root(i)].add(i)
    return sorted(out.values(), key=min)


def _binding_order(pre: Sequence[Literal], bound: Iterable[str]) -> tuple[Literal, ...]:
    """The literals in an order that binds their variables cheaply from ``bound``: each
    literal as soon as its variables are bound (a check), else the fact literal sharing the
    most bound variables, an equality, and a type (which enumerates its objects) last.

    The planner's own order suits a task whose head is bound; grounding binds from nothing,
    where a type first would enumerate every object of it.
    """
    bound = set(bound)
    todo = list(pre)
    out: list[Literal] = []

    def flush() -> None:
        for x in [x for x in todo if x.variables <= bound]:
            todo.remove(x)
            out.append(x)

    def rank(x: Literal) -> tuple[int, int, int]:
        name = x.atom.name
        kind = 2 if name.startswith(TYPE) else 1 if name == EQ else 0
        if not x.positive:
            kind = 3
        return (kind, -len(x.variables & bound), len(x.variables - bound))

    flush()
    while todo:
        x = min(todo, key=rank)
        todo.remove(x)
        out.append(x)
        bound |= x.variables
        flush()
    return tuple(out)


def _least_costs(
    actions: dict[Atom, list[_GroundAction]], methods: Sequence[_GroundMethod], tasks: Sequence[Atom]
) -> dict[Atom, float]:
    """Each ground task's least number of actions whatever the state (``inf`` when no
    decomposition finishes it): Knuth's generalisation of Dijkstra's algorithm to the
    and-or graph of methods and subtasks."""
    cost: dict[Atom, float] = {t: _INF for t in tasks}
    heap: list[tuple[float, int, Atom]] = []
    tie = 0
    for t in tasks:
        if t in actions:
            heap.append((min(a.cost for a in actions[t]), tie, t))
            tie += 1
    waiting: dict[Atom, list[int]] = defaultdict(list)
    left = [len(me.subtasks) for me in methods]
    acc = [0.0] * len(methods)
    for k, me in enumerate(methods):
        for t in me.subtasks:
            waiting[t].append(k)
        if not me.subtasks:
            heap.append((0.0, tie, me.task))
            tie += 1
    heapq.heapify(heap)
    done: set[Atom] = set()
    while heap:
        c, _, t = heapq.heappop(heap)
        if t in done:
            continue
        done.add(t)
        cost[t] = c
        for k in waiting.get(t, ()):
            acc[k] += c
            left[k] -= 1
            if left[k] == 0 and methods[k].task not in done:
                tie += 1
                heapq.heappush(heap, (acc[k], tie, methods[k].task))
    return cost


__all__ = ["MAX_GROUND", "MAX_GROUND_ALONE", "Composition", "ground", "lifted_is_lost"]
