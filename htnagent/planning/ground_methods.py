"""The searches' decompositions of a ground task by the ground methods the grounder kept
(docs/design.md §7.2, "Decomposing by the ground methods").

The planner binds a method's parameters when it decomposes a task, as its precondition
binds them: by the task, by the state's facts, and -- for a parameter that only its
subtasks name -- by its type, every object of it.  Woodworking's learned methods have a
dozen such parameters, so one ``process`` task decomposes in up to 48,600 ways, nearly all
of them with a subtask nothing can do: the grounded estimate drops them, but only after
each has been made and estimated.  The grounder of :mod:`htnagent.planning.composition`
has bound those methods already, by joining their subtasks with the ground tasks that can
occur (:mod:`htnagent.planning.producible`), and pruned what no decomposition finishes.
Here, a search that has the grounding decomposes a ground task the grounder met by the
ground methods it kept for it, each one's precondition checked in the search's own state.
Where the grounder bound such a method by types (the join would have cost more), it pruned
its ways all the same, and the searches decompose it by those too.

Nothing a plan needs is lost.  The grounding is a delete relaxation from the start state:
a method that applies in a state the plan reaches, with subtasks it finishes, was grounded
for its task (its precondition holds among the facts reached) and kept (its subtasks
finish); a task the grounder never met is decomposed as before, by the lifted method.

A method the grounder split into independent groups (design §7.2, step 1: Woodworking's
``method16`` colours any part with any machine, whatever it grinds) comes back here as its
core's ground methods, each with one of its groups' ground methods for every group: the
decompositions are their combinations, each group's share of the precondition checked once.
"""

from __future__ import annotations

import itertools
from collections import defaultdict
from collections.abc import Container, Iterable, Mapping
from dataclasses import dataclass

from htnagent.model.domain import Method
from htnagent.model.preconditions import Decomposer, Literal, satisfiers
from htnagent.model.state import State
from htnagent.model.terms import Atom, Bindings


@dataclass(frozen=True, slots=True)
class GroundWay:
    """One ground method the grounder kept, of a method the search is to decompose by them:
    the whole method, or its core or one of its groups where the grounder split it."""

    method: Method
    task: Atom
    """The ground task it decomposes: the method's own, or a group's (a task of the grounder's)."""
    check: tuple[Literal, ...]
    """Its share of the method's precondition, in an order that binds what is left cheaply."""
    bindings: Bindings
    """The variables of its task and subtasks, bound."""
    subtasks: tuple[Atom, ...]
    positions: tuple[int, ...]
    """Where its subtasks stand among the method's, by index (a core's, but its groups' tasks
    that follow them)."""

    def holds(self, state: State) -> bool:
        """Whether its precondition holds in the state under its bindings."""
        return next(satisfiers(self.check, state, self.bindings), None) is not None


Decompositions = Mapping[Method, Decomposer]
"""The decomposers a search uses for these methods in place of their lifted ones
(:attr:`~htnagent.planning.planner.PlannerSettings.decompositions`)."""


def decompositions(ways: Iterable[GroundWay], met: Container[Atom]) -> dict[Method, Decomposer]:
    """A decomposer for each method of the ``ways``: a ground task the grounder ``met`` is
    decomposed by the ways kept for it (none: no decomposition); any other by the method's
    lifted decomposer."""
    cores: dict[Method, dict[Atom, list[GroundWay]]] = defaultdict(lambda: defaultdict(list))
    parts: dict[Atom, list[GroundWay]] = defaultdict(list)
    for way in ways:
        if way.task.name == way.method.head.name:
            cores[way.method][way.task].append(way)
        else:
            parts[way.task].append(way)
    # Searches go through ways in a fixed order, whatever order the grounding met them in.
    for listed in (*(w for by_task in cores.values() for w in by_task.values()), *parts.values()):
        listed.sort(key=lambda w: tuple(map(str, w.subtasks)))
    return {method: _decomposer(method, by_task, parts, met) for method, by_task in cores.items()}


def _decomposer(
    method: Method,
    cores: Mapping[Atom, list[GroundWay]],
    parts: Mapping[Atom, list[GroundWay]],
    met: Container[Atom],
) -> Decomposer:
    """The method's decomposer by its ground ways (``cores``: its own task's, by task;
    ``parts``: its groups', by a group's task); by the lifted method where nothing was met."""

    subtasks = method.subtasks

    def run(task: Atom, state: State) -> list[tuple[Atom, ...]]:
        listed = cores.get(task)
        if listed is None:
            if task in met:
                return []  # grounded, and no way of this method finishes it
            return method.compiled(state.dynamic_predicates)(task, state)
        out: dict[tuple[Atom, ...], None] = {}
        holding: dict[Atom, list[GroundWay]] = {}  # each group's ways that hold, checked once
        for core in listed:
            if not core.holds(state):
                continue
            choices = []
            for t in core.subtasks:
                if t in parts:
                    if t not in holding:
                        holding[t] = [g for g in parts[t] if g.holds(state)]
                    choices.append(holding[t])
            if not choices:
                out[core.subtasks] = None  # no groups: its subtasks are the method's, made ground
                continue
            # Each subtask of the method is the core's or one group's, made ground already:
            # the core's own come first among its subtasks, its groups' tasks after them.
            own = len(core.positions)
            filled: list[Atom] = [*subtasks]
            for i, t in zip(core.positions, core.subtasks[:own], strict=True):
                filled[i] = t
            for chosen in itertools.product(*choices):
                for g in chosen:
                    for i, t in zip(g.positions, g.subtasks, strict=True):
                        filled[i] = t
                out[tuple(filled)] = None
        return list(out)

    return run


__all__ = ["Decompositions", "GroundWay", "decompositions"]
