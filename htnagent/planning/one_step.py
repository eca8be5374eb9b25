"""One step ahead: what greedy search adds to the lifted estimate for the next
decomposition (docs/design.md §7.5).

The lifted estimate counts each task at its name's least cost, whatever the state.  A
task that is done by moving first -- Logistics' ``ACHIEVE-AT2(plane, airport)``: done at
once where the plane already is, else by flying to any airport and trying again -- counts
0 wherever the plane is, so the ways to fly all tie, and greedy search, going on from where
it just was, takes the first: a plane flies from airport to airport in the order they were
declared until it happens on the right one (1,235 actions for a Logistics problem PANDA
plans in 470).

One step ahead looks at the decomposition a list comes to next: its actions first, done in
order from the state (where one of them cannot be done, the list has no plan), then its
first compound task, in the state they lead to, at the least cost of a method that applies
there.  What that costs above the name's least cost is added to the estimate.  A plane sent
to the right airport adds nothing; sent anywhere else, it still has a flight to take, and
adds 1.

Never an over-estimate: the first compound task is decomposed in exactly that state, by a
method that applies there, into subtasks that each cost at least their name's least cost.
Only greedy search uses it: A* keeps the lifted sum, which under a cost bound is also the
bound's own test (``--anytime``), and the step was measured for greedy search alone.  And
only where the problem is a task network alone: with a goal, greedy search's estimate
counts what the goal still needs (§7.4), and a cost added holds back the nodes that move
towards it (Monroe-Partially-Observable's 10th problem: 2,484 expansions without it, none
found in 200,000 with it).
"""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence

from htnagent.model.domain import Domain
from htnagent.model.preconditions import LazyDecomposer
from htnagent.model.state import FactBase, State
from htnagent.model.terms import Atom

_INF = float("inf")

MOST_ACTIONS = 16
"""The most actions looked through before the first compound task: past them, nothing is
added (a long run of actions is rare, and each is applied for every list estimated)."""

Ways = Callable[[str], Sequence[tuple[str, LazyDecomposer]]]
"""A task name's methods as the search decomposes by them, in the domain's order: each
method's name and its lazy decomposer."""


class OneStepAhead:
    """What a task list's next decomposition costs above the least costs of its names."""

    def __init__(
        self,
        domain: Domain,
        static: FactBase,
        dynamic_predicates: frozenset[str],
        costs: Mapping[str, float],
        ways: Ways,
    ) -> None:
        self._domain = domain
        self._static = static
        self._dyn = dynamic_predicates
        self._costs = costs
        self._ways = ways
        # Each task name's methods, the cheapest first: the first that applies gives the least.
        self._by_cost: dict[str, list[tuple[float, LazyDecomposer]]] = {}
        self._cache: dict[tuple[frozenset[Atom], Atom], float] = {}

    def extra(self, tasks: Sequence[Atom], dynamic: frozenset[Atom]) -> float:
        """How much the list's first compound task costs at least above its name's least
        cost, in the state its actions before it lead to from the state whose changing
        facts are ``dynamic``; ``inf`` where one of those actions cannot be done, or no
        method of the task applies there.  0 where an action is not a ground one of one
        operator (what it leads to is not one state), or past :data:`MOST_ACTIONS`."""
        operators = self._domain.operators
        actions = self._domain.actions
        static_facts = self._static.facts
        for i, task in enumerate(tasks):
            if task.name not in operators:
                return self._first(task, dynamic)
            if i == MOST_ACTIONS or len(operators[task.name]) != 1 or not task.is_ground:
                return 0.0
            action = actions.known(task) or actions.compiled_or_none(task)
            if action is None or action.checks is None:
                return 0.0
            after = action.after(dynamic, static_facts, self._dyn)
            if after is None:
                return _INF
            dynamic = after
        return 0.0

    def let_go(self) -> dict[tuple[frozenset[Atom], Atom], float]:
        """What it has worked out so far, handed over to be freed (it starts again empty)."""
        cache, self._cache = self._cache, {}
        return cache

    def _first(self, task: Atom, dynamic: frozenset[Atom]) -> float:
        key = (dynamic, task)
        found = self._cache.get(key)
        if found is None:
            state = State(self._static, dynamic, self._dyn)
            applies = (
                cost for cost, run in self._methods(task.name) if next(run(task, state), None) is not None
            )
            least = next(applies, _INF)
            found = self._cache[key] = _INF if least == _INF else least - self._costs.get(task.name, 0.0)
        return found

    def _methods(self, name: str) -> list[tuple[float, LazyDecomposer]]:
        listed = self._by_cost.get(name)
        if listed is None:
            costs = self._costs
            # The ways come in the domain's order of its methods (one name may stand for several).
            pairs = zip(self._domain.methods.get(name, ()), self._ways(name), strict=True)
            least = [(sum(costs.get(t.name, 0.0) for t in me.subtasks), run) for me, (_, run) in pairs]
            listed = self._by_cost[name] = sorted(least, key=lambda pair: pair[0])
        return listed


__all__ = ["MOST_ACTIONS", "OneStepAhead"]
