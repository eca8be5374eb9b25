"""One-way facts: what the grounded estimate's delete relaxation cannot see run out
(docs/design.md §7.2, step 5).

Relaxed composition (:mod:`htnagent.planning.composition`) costs every task of a list from
the same state, and under delete relaxation: a fact, once reached, stays.  Where a fact
that nothing can make true again is used up by one task and needed by a later one, the
list has no plan, and the estimate cannot tell until the first task has used it up.
Factories builds each factory on a free location, and nothing frees a location again: a
list that builds two factories on the same location is estimated as well as one that
builds them apart -- and below it, before the first is built, lies a whole region of
decompositions, hundreds of actions deep, none of which finishes (its 6th problem: greedy
search stuck there, at an estimate of 177, for 100,000 expansions).

A **one-way fact** is one that no ground action adds, or the negation of one that no ground
action deletes (``__not_factory-constructed(f)``: nothing takes a factory down).  Once
false it stays false.  So, over a task list in order:

- a task **needs** a one-way fact when every decomposition of it needs it somewhere -- an
  action's or a method's precondition; the fact must then hold in the state, since nothing
  can make it true before the task gets to it;
- a primitive task **ends** a one-way fact its action deletes (every variant of it, where it
  has several): no task after it can have it.

A list whose task needs a one-way fact that is false in the state, or that a primitive task
before it ends, has no plan: the estimate is ``inf`` and the search drops it, a decomposition
after the one that made the clash.  Sound like the rest of the grounding: every action and
method a plan can use below the tasks was grounded (design §7.2, step 1), so what no ground
action adds, no plan adds.  A task the grounding never met might do anything; past one, the
list is not checked further.

What each task needs is the greatest fixed point of ``needs(task) = intersection over its
methods of (their one-way preconditions, and what their subtasks need)``, worked out from
"everything" downwards, so that a recursive method (a route of moves) needs only what every
finite decomposition needs.
"""

from __future__ import annotations

from collections import defaultdict
from collections.abc import Callable, Iterable, Mapping, Sequence
from dataclasses import dataclass
from typing import Protocol, TypeVar

from htnagent.model.terms import Atom

_T = TypeVar("_T")
_W = TypeVar("_W")
_F = TypeVar("_F")


class GroundStep(Protocol):
    """What this module reads of a ground action: its task, the changing facts its
    precondition needs and those it surely adds and deletes (negations as the
    grounder's ``__not_`` facts: a negated fact is added where its fact is deleted)."""

    @property
    def head(self) -> Atom: ...
    @property
    def pre(self) -> tuple[Atom, ...]: ...
    @property
    def add(self) -> tuple[Atom, ...]: ...
    @property
    def delete(self) -> tuple[Atom, ...]: ...


class GroundSplit(Protocol):
    """What this module reads of a ground method: its task, the changing facts its
    precondition needs, its subtasks."""

    @property
    def task(self) -> Atom: ...
    @property
    def pre(self) -> tuple[Atom, ...]: ...
    @property
    def subtasks(self) -> tuple[Atom, ...]: ...


@dataclass(frozen=True, slots=True)
class OneWay:
    """The one-way facts each ground task needs and each primitive task ends, by the
    estimate's ids (a fact's and a task's id in :class:`~htnagent.planning.composition.Composition`)."""

    needs: Mapping[int, tuple[int, ...]]
    """Task id: the ids of the one-way facts every decomposition of it needs (only tasks
    that need some)."""
    ends: Mapping[int, frozenset[int]]
    """Primitive task id: the ids of the one-way facts its action surely makes false (only
    tasks that end some)."""

    def __bool__(self) -> bool:
        return bool(self.needs)

    @staticmethod
    def of(
        actions: Sequence[GroundStep],
        methods: Sequence[GroundSplit],
        fact_ids: Mapping[Atom, int],
        task_ids: Mapping[Atom, int],
    ) -> OneWay:
        """The one-way facts among ``fact_ids`` (the facts some precondition names), what
        each task needs of them and what each primitive task ends."""
        added = {f for a in actions for f in a.add}
        one_way = {f for f in fact_ids if f not in added}
        need: dict[Atom, frozenset[Atom]] = {}
        ends: dict[int, frozenset[int]] = {}
        variants: dict[Atom, list[GroundStep]] = defaultdict(list)
        for a in actions:
            variants[a.head].append(a)
        for task, steps in variants.items():
            need[task] = _common(frozenset(a.pre) & one_way for a in steps)
            ended = _common(frozenset(a.delete) & one_way for a in steps)
            if ended:
                ends[task_ids[task]] = frozenset(fact_ids[f] for f in ended)
        for task, found in _method_needs(methods, one_way, need).items():
            need[task] = found
        needs = {task_ids[t]: tuple(fact_ids[f] for f in found) for t, found in need.items() if found}
        return OneWay(needs, ends)


def _common(sets: Iterable[frozenset[Atom]]) -> frozenset[Atom]:
    """What all the sets hold (at least one set)."""
    it = iter(sets)
    out = next(it)
    for s in it:
        out &= s
    return out


def _method_needs(
    methods: Sequence[GroundSplit], one_way: set[Atom], primitive: Mapping[Atom, frozenset[Atom]]
) -> dict[Atom, frozenset[Atom]]:
    """The one-way facts each compound task needs: the greatest fixed point, from "all"
    (a task not yet worked out, absent here) down.  A method counts once every subtask of
    it has a value; a task whose value shrinks sends its parents to be worked out again."""
    of_task: dict[Atom, list[GroundSplit]] = defaultdict(list)
    parents: dict[Atom, set[Atom]] = defaultdict(set)
    for me in methods:
        of_task[me.task].append(me)
        for sub in me.subtasks:
            parents[sub].add(me.task)

    def way(me: GroundSplit, known: Mapping[Atom, frozenset[Atom]]) -> frozenset[Atom] | None:
        subs = [known.get(sub, primitive.get(sub)) for sub in me.subtasks]
        if any(s is None for s in subs):
            return None  # a subtask still "all": so is this way, which the meet ignores
        return frozenset(f for f in me.pre if f in one_way).union(*(s for s in subs if s is not None))

    return greatest_fixed_point(of_task, parents, way, {})


def greatest_fixed_point(
    ways: Mapping[_T, Sequence[_W]],
    readers: Mapping[_T, Iterable[_T]],
    way: Callable[[_W, Mapping[_T, frozenset[_F]]], frozenset[_F] | None],
    found: dict[_T, frozenset[_F]],
) -> dict[_T, frozenset[_F]]:
    """Each task's set of facts: the intersection of what its ``ways`` give (``way``: None
    while what it reads is still "everything"), worked out from "everything" (a task absent
    from ``found``) downwards -- so that a recursive method counts only what every finite
    decomposition has.  A task whose set shrinks sends its ``readers`` to be worked out
    again.  ``found`` holds the tasks known from the start (primitive ones), and is filled."""
    todo = list(ways)
    queued = set(todo)
    while todo:
        task = todo.pop()
        queued.discard(task)
        value: frozenset[_F] | None = None
        for me in ways[task]:
            given = way(me, found)
            if given is not None:
                value = given if value is None else value & given
        if value is None or value == found.get(task):
            continue
        found[task] = value
        for up in readers.get(task, ()):
            if up not in queued:
                queued.add(up)
                todo.append(up)
    return found


__all__ = ["GroundSplit", "GroundStep", "OneWay", "greatest_fixed_point"]
