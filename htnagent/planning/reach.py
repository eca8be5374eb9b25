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
and every fact and task it reaches the relaxation reaches.  It is one pass over the
grounding a list, so the searches ask it once for each node they take off their open list
to expand (the planner's :attr:`~htnagent.planning.planner.PlannerSettings.prune`), not for
every child they make -- costing each child this way made greedy search 2-3 times slower
where children are many (AssemblyHierarchical, Entertainment; design §7.2, step 6).
"""

from __future__ import annotations

from collections.abc import Callable, Iterable, Sequence


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
    ) -> None:
        """``needs[k]``: how many inputs action or method ``k`` waits for; ``consumers[n]``:
        the actions and methods that read node ``n``; ``outputs[k]``: what ``k`` reaches, its
        own task last; ``free``: those that need nothing; ``below``: a task and every task
        below it (:attr:`~htnagent.planning.below.Below.tasks_below`)."""
        self._needs = list(needs)
        self._consumers = consumers
        self._outputs = outputs
        self._free = free
        self._owner = [out[-1] for out in outputs]  # the task each action or method reaches
        self._below = below

    def lost(self, tasks: Sequence[int], start: Iterable[int]) -> bool:
        """Whether, from the nodes ``start`` (the state's facts), the relaxation kept to the
        actions and methods below ``tasks`` leaves one of those tasks unreached."""
        wanted = set(tasks)
        if not wanted:
            return False
        allowed: set[int] = set()
        below = self._below
        for t in wanted:
            allowed |= below(t)
        owner = self._owner
        outputs = self._outputs
        consumers = self._consumers
        left = self._needs[:]
        reached = bytearray(len(consumers))
        todo = list(start)
        for k in self._free:
            if owner[k] in allowed:
                todo.extend(outputs[k])
        while todo:
            n = todo.pop()
            if reached[n]:
                continue
            reached[n] = 1
            if n in wanted:
                wanted.discard(n)
                if not wanted:
                    return False  # all reached: the rest of the pass would tell nothing more
            for k in consumers[n]:
                left[k] -= 1
                if not left[k] and owner[k] in allowed:
                    todo.extend(outputs[k])
        return True


__all__ = ["WithinReach"]
