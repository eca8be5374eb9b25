"""What a task list can still make true: the facts the actions below its tasks add
(docs/design.md §7.2, step 6).

Relaxed composition (:mod:`htnagent.planning.composition`) costs a task list from a state
by what *any* ground action can reach: a fact a task needs, or one the problem's goal asks
for, counts as cheap if some action adds it -- even one no task left in the list can come
down to.  But a plan from the node does only what its tasks decompose into.  Woodworking's
network colours each part in turn, a colour chosen where its part starts; its goal asks for
a part mauve.  Once that part is done in another colour, no task left can colour it again,
yet the goal's check was costed by the colouring action another part's task could do: a
node without a plan looked as good as one with (greedy search, its 8th problem: 132,000
expansions before a plan of 11 actions).

So a task list is a dead end where one of its tasks **needs at its start** a fact that the
state lacks and that no action below the tasks before it adds (PANDA's relaxed composition
keeps only what the task decomposition graph reaches from the network, which sees the
same):

- a primitive task needs its action's precondition (every variant's, where it has several);
- a compound task needs what every method of it needs: its precondition, and what its first
  subtask needs (the greatest fixed point, from "everything" down, so that a recursive
  method needs only what every finite decomposition needs);
- the actions below a task are those of the primitive tasks reachable from it, top down
  through the ground methods the grounder kept, and what they add is an over-approximation
  of what any decomposition of the task adds.

The goal's check (the ``__goal()`` task, whose method's precondition is the goal) needs every
goal fact: a goal fact false now that no task left can add drops the node where the choice
that lost it was made (Woodworking p03-part2: a plan in about 100 expansions).  Sound as the
grounding is: every action a plan below the tasks can take was grounded below them (design
§7.2, step 1).  Cheap: per list, a few look-ups for the facts its tasks need that the state
lacks; what lies below each task is worked out once, when a list first needs it.
"""

from __future__ import annotations

from collections import defaultdict
from collections.abc import Callable, Iterable, Mapping, Sequence

from htnagent.model.terms import Atom
from htnagent.planning.one_way import GroundSplit, GroundStep, greatest_fixed_point

_NONE: frozenset[int] = frozenset()

MAX_KEPT = 1_000_000
"""About how many ids (facts, or tasks), summed over the tasks worked out, each
:class:`Gathered` keeps (some tens of megabytes): past it (a large grounding whose every
task reaches most of the actions) it forgets them and works them out again as lists ask --
time over memory."""


class Below:
    """By the estimate's ids (:class:`~htnagent.planning.composition.Composition`'s): what
    each ground task needs at its start, and what the actions below it add."""

    def __init__(
        self,
        children: Mapping[int, Iterable[int]],
        adds: Mapping[int, Iterable[int]],
        first: Mapping[int, Iterable[int]],
    ) -> None:
        """``children``: each compound task's subtasks over all its ground methods;
        ``adds``: each primitive task's facts added (over its actions); ``first``: what
        each task needs at its start (:func:`starting_needs`)."""
        self.children: dict[int, tuple[int, ...]] = {t: tuple(set(subs)) for t, subs in children.items()}
        """Task id: its subtasks over all its ground methods, each once."""
        own_adds = {t: frozenset(facts) for t, facts in adds.items()}
        self.adds = Gathered(self.children, lambda t: own_adds.get(t, _NONE))
        """Task id: the facts the actions below the task add."""
        self.tasks_below = Gathered(self.children, lambda t: (t,))
        """Task id: the task and every task below it."""
        self.needs: dict[int, frozenset[int]] = {t: frozenset(f) for t, f in first.items() if f}
        """Task id: the facts it needs at its start (only the tasks that need some)."""

    @staticmethod
    def of(
        actions: Sequence[GroundStep],
        methods: Sequence[GroundSplit],
        fact_ids: Mapping[Atom, int],
        task_ids: Mapping[Atom, int],
    ) -> Below:
        """What the ground actions and methods give, by the estimate's ids."""
        children: dict[int, list[int]] = defaultdict(list)
        for me in methods:
            children[task_ids[me.task]].extend(task_ids[t] for t in me.subtasks)
        adds: dict[int, set[int]] = defaultdict(set)
        for a in actions:
            adds[task_ids[a.head]].update(fact_ids[f] for f in a.add)
        first = starting_needs(
            [(task_ids[a.head], [fact_ids[f] for f in a.pre]) for a in actions],
            [
                Split(task_ids[me.task], [fact_ids[f] for f in me.pre], [task_ids[t] for t in me.subtasks])
                for me in methods
            ],
        )
        return Below(children, adds, first)

    def lost(self, missing: frozenset[int], before: Sequence[int]) -> bool:
        """Whether some of the ``missing`` facts (that a task needs at its start and the
        state lacks) is added below none of the tasks ``before`` it."""
        adds = self.adds
        memo = adds.memo
        # The nearest task before it first: the likeliest to add what is missing.
        for e in reversed(before):
            missing -= memo.get(e) or adds(e)
            if not missing:
                return False
        return True


class Gathered:
    """For each task asked, what ``own`` gives for the task and every task below it (top
    down through ``children``, each compound task's subtasks), kept for the tasks asked:
    past :data:`MAX_KEPT` ids in all it forgets them and works them out again as asked."""

    def __init__(self, children: Mapping[int, Sequence[int]], own: Callable[[int], Iterable[int]]) -> None:
        self._children = children
        self._own = own
        self.memo: dict[int, frozenset[int]] = {}
        """What has been worked out, by task id."""
        self._kept = 0

    def __call__(self, task: int) -> frozenset[int]:
        known = self.memo.get(task)
        if known is not None:
            return known
        memo = self.memo
        children = self._children
        own = self._own
        seen = {task}
        todo = [task]
        out: set[int] = set()
        while todo:
            t = todo.pop()
            done = memo.get(t)
            if done is not None:
                out |= done  # worked out already: all of it, whatever lies below
                continue
            out.update(own(t))
            for c in children.get(t, ()):
                if c not in seen:
                    seen.add(c)
                    todo.append(c)
        found = frozenset(out)
        self._kept += len(found)
        if self._kept > MAX_KEPT:
            memo.clear()
            self._kept = len(found)
        memo[task] = found
        return found


class Split:
    """What :func:`starting_needs` reads of a ground method (by ids)."""

    __slots__ = ("pre", "subtasks", "task")

    def __init__(self, task: int, pre: Iterable[int], subtasks: Sequence[int]) -> None:
        self.task = task
        self.pre = frozenset(pre)
        self.subtasks = subtasks


def starting_needs(
    actions: Iterable[tuple[int, Iterable[int]]], methods: Iterable[Split]
) -> dict[int, frozenset[int]]:
    """What each task needs at its start: ``actions`` are (task, precondition facts) pairs
    (one per variant), ``methods`` their tasks' decompositions.  The greatest fixed point
    from "everything" (a task not yet worked out, absent here) down: a method counts once its
    first subtask has a value; a task whose value shrinks sends the tasks it starts to be
    worked out again."""
    found: dict[int, frozenset[int]] = {}
    for task, pre in actions:
        mine = frozenset(pre)
        found[task] = found[task] & mine if task in found else mine
    of_task: dict[int, list[Split]] = defaultdict(list)
    starts: dict[int, set[int]] = defaultdict(set)  # a task: the tasks it is the first of
    for me in methods:
        of_task[me.task].append(me)
        if me.subtasks:
            starts[me.subtasks[0]].add(me.task)

    def way(me: Split, known: Mapping[int, frozenset[int]]) -> frozenset[int] | None:
        if not me.subtasks:
            return me.pre
        first = known.get(me.subtasks[0])
        return None if first is None else me.pre | first  # None: its first subtask still "everything"

    return greatest_fixed_point(of_task, starts, way, found)


__all__ = ["MAX_KEPT", "Below", "Gathered", "Split", "starting_needs"]
