"""What a task list can still reach from a state: relaxed composition kept to what lies
below the list's own tasks (docs/design.md §7.2, step 7).

Relaxed composition (:mod:`htnagent.planning.composition`, step 3) lets *any* ground action
fire once its precondition is reached, and step 6 (:mod:`htnagent.planning.below`) asks
only whether some action below the list *adds* a fact the list needs, not whether that
action's own precondition can still come true.  Woodworking's ``method16`` colours any
part while it grinds its own, so once a part has been glazed where the goal asks for it
varnished, the varnishing is still below the other parts' tasks: step 6 keeps the node.
But varnishing needs the part untreated, and only its own task, done already, could grind
or plane it back: no plan lies below the node.  Greedy search spent its 30 s among such
nodes on Woodworking's 14th problem; with this test it answers in under 1,000 expansions.

The test runs the relaxation again from the state with only the ground actions and
methods below the list's tasks (top down through the ground methods kept, as step 6): a
task of the list it does not reach cannot be done.  Sound as the grounding is: a plan from
the node takes only actions below its tasks, each of them grounded below them (step 1),
and every fact and task it reaches the relaxation reaches.

It runs in two halves, because only actions make facts true:

1. **The facts.**  The actions below the list fire from the state until nothing new comes
   true.  An action needs only facts, so this half never looks at a task.  The actions are
   bit sets (Python ints, bit ``k`` for action ``k``): a round is an ``or`` of what each fact
   not yet reached holds back and an ``and`` for what each fact could come from.
2. **The tasks.**  With those facts, a task below the list is reached where one of its
   methods has its precondition among them and its subtasks reached (or, primitive, where
   its action's precondition is among them).  Everything below such a task is below the
   list too, so the answer depends on the facts alone: it is one pass over the grounding,
   kept for each set of facts.  Along a search the facts the list can reach change far
   less often than the state: on Woodworking's 18th problem, 76 sets over 1,206 lists.

The searches ask it once for each node an action led to, as they take it off their open
list to expand (the planner's :attr:`~htnagent.planning.planner.PlannerSettings.prune`),
not for every child they make -- costing each child this way made greedy search 2-3 times
slower where children are many (AssemblyHierarchical, Entertainment; design §7.2, step 6).
"""

from __future__ import annotations

import sys
from collections.abc import Callable, Hashable, Iterable, Sequence
from typing import Generic, TypeVar

MAX_KEPT_BYTES = 50_000_000
"""About how many bytes each of :class:`WithinReach`'s two memories keeps (the actions below
each task asked; the tasks reached from each set of facts, with the set): past it, that
memory forgets what it holds and works it out again as lists ask -- time over memory."""


class WithinReach:
    """The relaxed composition's graph, by the estimate's ids (facts, then tasks): for each
    action and method, how many inputs it needs, which nodes need it, what it reaches, and
    the task it belongs to; and what lies below each task."""

    def __init__(
        self,
        needs: Sequence[int],
        consumers: Sequence[Sequence[int]],
        outputs: Sequence[tuple[int, ...]],
        free: Sequence[int],
        below: Callable[[int], frozenset[int]],
        actions: int,
    ) -> None:
        """``needs[k]``: how many inputs action or method ``k`` waits for; ``consumers[n]``:
        the actions and methods that read node ``n``; ``outputs[k]``: what ``k`` reaches, its
        own task last; ``free``: those that need nothing; ``below``: a task and every task
        below it (:attr:`~htnagent.planning.below.Below.tasks_below`); ``actions``: how many
        of them, numbered first, are actions (the rest are methods, which reach only their
        task)."""
        self._needs = list(needs)
        self._consumers = consumers
        self._free = free
        self._owner = [out[-1] for out in outputs]  # the task each action or method reaches
        self._below = below
        # Half 1's graph: by fact, the actions that need it and those that add it.
        needing: dict[int, list[int]] = {}
        adding: dict[int, list[int]] = {}
        for k in range(actions):
            for f in outputs[k][:-1]:
                adding.setdefault(f, []).append(k)
        for n, readers in enumerate(consumers):
            ks = [k for k in readers if k < actions]
            if ks:
                needing[n] = ks
        self._needing = [(f, _bits(ks)) for f, ks in needing.items()]
        self._adding = [(f, _bits(ks)) for f, ks in adding.items()]
        self._read = frozenset(n for n, readers in enumerate(consumers) if readers)
        self._actions_of: dict[int, list[int]] = {}  # a primitive task: its actions
        for k in range(actions):
            self._actions_of.setdefault(self._owner[k], []).append(k)
        self._usable: _Kept[int, int] = _Kept()
        self._reached: _Kept[frozenset[int], bytearray] = _Kept()

    def lost(self, tasks: Sequence[int], start: Iterable[int]) -> bool:
        """Whether, from the nodes ``start`` (the state's facts), the relaxation kept to the
        actions and methods below ``tasks`` leaves one of those tasks unreached."""
        wanted = set(tasks)
        if not wanted:
            return False
        usable = 0
        for t in wanted:
            usable |= self._actions_below(t)
        reached = self._tasks_reached(self._facts_reached(start, usable))
        return not all(reached[t] for t in wanted)

    def _actions_below(self, task: int) -> int:
        """The actions below ``task``, as a bit set; kept for the tasks asked."""
        known = self._usable.get(task)
        if known is not None:
            return known
        actions_of = self._actions_of
        found = _bits([k for t in self._below(task) for k in actions_of.get(t, ())])
        return self._usable.keep(task, found, sys.getsizeof(found))

    def _facts_reached(self, start: Iterable[int], usable: int) -> frozenset[int]:
        """Half 1: the facts the actions ``usable`` (a bit set) make true from ``start``, a
        round at a time until a round adds none; only those some action or method reads."""
        reached = set(start)
        while True:
            held_back = 0  # the actions needing a fact not reached
            for f, needing in self._needing:
                if f not in reached:
                    held_back |= needing
            firing = usable & ~held_back
            new = [f for f, adding in self._adding if f not in reached and adding & firing]
            if not new:
                return frozenset(reached & self._read)
            reached.update(new)

    def _tasks_reached(self, facts: frozenset[int]) -> bytearray:
        """Half 2: by id, 1 for each node the relaxation reaches from ``facts`` where no
        action adds a fact (as they are all in); kept for each set of facts."""
        known = self._reached.get(facts)
        if known is not None:
            return known
        owner = self._owner
        consumers = self._consumers
        left = self._needs[:]
        reached = bytearray(len(consumers))
        todo = [*facts, *(owner[k] for k in self._free)]
        while todo:
            n = todo.pop()
            if reached[n]:
                continue
            reached[n] = 1
            for k in consumers[n]:
                left[k] -= 1
                if not left[k]:
                    todo.append(owner[k])
        return self._reached.keep(facts, reached, sys.getsizeof(reached) + sys.getsizeof(facts))


K = TypeVar("K", bound=Hashable)
V = TypeVar("V")


class _Kept(Generic[K, V]):
    """What was worked out, by key, up to about :data:`MAX_KEPT_BYTES`: past them it forgets
    all it holds but the newest."""

    def __init__(self) -> None:
        self._values: dict[K, V] = {}
        self._bytes = 0

    def get(self, key: K) -> V | None:
        return self._values.get(key)

    def keep(self, key: K, value: V, size: int) -> V:
        """Keep ``value`` (about ``size`` bytes, its key's included) and give it back."""
        self._bytes += size
        if self._bytes > MAX_KEPT_BYTES:
            self._values.clear()
            self._bytes = size
        self._values[key] = value
        return value


def _bits(ks: Iterable[int]) -> int:
    """The bit set (an int) with bit ``k`` set for each ``k``."""
    ks = list(ks)
    if not ks:
        return 0
    out = bytearray(max(ks) // 8 + 1)
    for k in ks:
        out[k >> 3] |= 1 << (k & 7)
    return int.from_bytes(out, "little")


__all__ = ["MAX_KEPT_BYTES", "WithinReach"]
