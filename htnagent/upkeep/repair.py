"""Plan repair (docs/design.md §2.4): re-plan only the lowest task above a failing step.

The rule (§2.4): "A plan whose action *i* fails is repaired, not thrown
away: walk up its decomposition record from action *i* to the lowest compound
task that can be decomposed again from the state at that point, and re-plan
only that task (plus what follows it)."

A plan that fails at action *i* when re-checked is not thrown away: the
:class:`Repairer` walks up its decomposition record from action *i* to the
lowest compound task that can be decomposed again from the state at that point,
and re-plans that task plus what follows it; only when no ancestor below the
goal can be, the goal itself is planned from the current belief.  The same
object makes the searches of the comparison with a plan made afresh
(:mod:`htnagent.upkeep.quality`), so the two share them.

One :class:`Repairer` serves one update of one plan set
(:class:`~htnagent.upkeep.online.OnlinePlanSet`); a :class:`SearchMemo` shares the
searches of one update between all the plan sets of an agent.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field, replace

from htnagent.model.actions import action_resumed_by
from htnagent.model.domain import Domain
from htnagent.model.plans import Decomposition, Done, Plan, span, tidy
from htnagent.model.state import State
from htnagent.model.terms import Atom
from htnagent.planning.planner import PlannerSettings, PlanStatus, TaskEntry, plan
from htnagent.upkeep.stats import PlanningStats


@dataclass
class SearchMemo:
    """Searches made during one update of an agent's plan sets, shared between them.

    The goals on a stack often repeat, and all of them are updated from the same
    belief: a search one plan set made (a goal from a state, or a task list found
    impossible) answers for the others.  Make one per update; never keep it.
    """

    results: dict[tuple[object, ...], Plan | None] = field(default_factory=dict)
    impossible: set[tuple[object, ...]] = field(default_factory=set)
    costs: dict[tuple[object, ...], float] = field(default_factory=dict)
    """The cost of the plan found for a task list from a state, whatever the tasks' records."""
    exhausted: dict[tuple[object, ...], int] = field(default_factory=dict)
    """Searches cut by their budget, with that budget: no answer, but none within it."""


def one_plan(settings: PlannerSettings) -> PlannerSettings:
    """The settings for one plan (repairs, fresh comparisons, naive mode)."""
    return replace(settings, alternatives=1)


_REPAIR_LEVELS = 3
"""How many of the lowest ancestors a repair tries before it re-plans the goal itself."""

_REDO = 2
"""How many of a method's subtasks already done a repair may do again (see :func:`done_subtasks`)."""

LOCAL_BUDGET = 2_000
"""Expansions all repairs below the goal may take in one update (the goal gets the full budget)."""

LOCAL_SHARE = 0.1
"""The share of what the goal's last plan from scratch took that repairs below the goal get
(the rest of :data:`LOCAL_BUDGET` waits until the goal is found to have no plan afresh).
A repair is worth making because it is cheaper than planning afresh (§2.4); one that has cost
a tenth as much and found nothing seldom is: local searches with the plan's later steps
fixed often cannot meet them, and spend their whole budget finding so (Depots: 725
expansions of local searches, then a plan afresh in 70).  Measured on the IPC interruption
bench (docs/benchmarks.md): a half or a quarter left on-line's whole-run planning 10-30%
above naive's in six domains, a tenth within 8% in all."""

_SAME = 1e-9
"""Costs closer than this are equal."""

LOCAL_MIN = 8
"""The least share (expansions) worth searching below the goal for, and what each search
there is charged at least: a search's own cost -- its set-up, the task list and the plan it
gives -- is a few expansions' worth, so a share smaller than this cannot pay for itself
(Snake: three local searches of a few expansions each, 0.4 ms, in a run whose planning was
4 ms)."""

LOCAL_GROWTH = 64
"""How much longer than the task list it was given a repair below the goal may let a list
grow.  A recursive method that puts its task back in front of more (Hiking's trips) grows
the list at every expansion, and each node costs as much as its list is long: past this,
the repair stops and the goal's re-plan, which comes next, takes over."""


class Repairer:
    """The searches of one update of one plan set: repairs (§2.4) and fresh comparisons.

    A repair re-decomposes the lowest ancestor task of a failing step that can
    be decomposed again.  Searches are shared — through ``memo``, with the other
    plan sets updated from the same belief — so a goal re-planned for one broken
    plan answers for all.  Repairs below the goal share ``local_budget``
    expansions; the goal itself gets the planner's full budget; where it has no
    plan, or its plan afresh found none within ``fresh_budget``, repairs below it
    get ``reserve`` expansions more.  Make one per
    update; ``unsolvable`` is then the belief the goal was found impossible
    from, if it was.
    """

    __slots__ = (
        "_avoided",
        "_costs",
        "_domain",
        "_exhausted",
        "_goal",
        "_impossible",
        "_results",
        "_settings",
        "_stats",
        "fresh_budget",
        "local_left",
        "reserve",
        "unsolvable",
    )

    def __init__(
        self,
        domain: Domain,
        goal: Atom,
        settings: PlannerSettings,
        stats: PlanningStats,
        avoided: Callable[[State], frozenset[Atom]],
        memo: SearchMemo | None = None,
        local_budget: int = 0,
        reserve: int = 0,
        fresh_budget: int | None = None,
    ) -> None:
        memo = memo if memo is not None else SearchMemo()
        self._domain = domain
        self._goal = goal
        self._settings = settings
        self._stats = stats
        self._avoided = avoided
        self._results = memo.results
        self._impossible = memo.impossible
        self._costs = memo.costs
        self._exhausted = memo.exhausted
        self.local_left = local_budget
        """Expansions left for repairs below the goal in this update."""
        self.reserve = reserve
        """Expansions more for repairs below the goal, once the goal itself has no plan."""
        self.fresh_budget = fresh_budget
        """Expansions the goal's plan afresh gets before repairs below it are tried (None:
        the planner's budget)."""
        self.unsolvable: tuple[object, ...] | None = None
        """The key of a belief from which the goal itself has no plan, once a repair found so."""

    def repair(
        self, p: Plan, index: int, states: list[State], done: Done | None = None, *, alone: bool = True
    ) -> Plan | None:
        """Re-decompose the lowest ancestor task of step ``index`` that can be (§2.4).

        ``states`` are the beliefs before each of the plan's first ``index + 1``
        steps.  The last ancestor is the goal itself; steps inserted by maintenance
        (undo, rollback) belong to no task, so for them the goal is the only
        ancestor.  The goal is re-decomposed from the current belief, once per
        update, and the result is shared by every plan that needs it.  It comes first;
        repairs below the goal follow, within ``local_left`` and a share of what the plan
        afresh took, where the steps they keep do not already cost as much as it.

        ``alone``: no other plan of the goal is kept.  Only then does the repair make
        searches of its own: an alternative kept beside a valid plan is repaired only
        from the searches this update made for the goal's other plans (a goal re-planned
        for the best answers for it) -- one that does not follow the actions taken breaks
        again at every action, and is not worth a search at every action (IPC domains,
        with no undo to put in front of it).  And only then, when an ancestor cannot be
        decomposed again, are the last of its subtasks already done done again before
        what is left of it (docs/design.md §2.4: an emergency may have undone what they
        achieved, a truck driven away with the parcel still on it): such a search is the
        costliest part of a repair (the steps kept after the subtasks are fixed, so one
        that cannot meet them runs until the budget is spent); and if the goal has no
        plan afresh, the repairs below it get ``reserve`` more.
        """
        record = p.steps[index].record
        chain = record.chain() if record is not None else []
        # The goal itself first, from the current belief: one search shared by all plans.
        # §2.4 keeps a repair only if no plan made afresh from the same belief is cheaper,
        # so that plan is needed whatever the repair finds.  Made first, it tells what the
        # repairs below the goal may spend -- a share of what it took (the goal's first plan
        # from scratch planned the whole network: Satellite p19's took 11,264 expansions,
        # the rest of it 1,682, and a tenth of the first cost the repair as much as the
        # plan afresh) -- and where they cannot be cheaper.
        # It gets what the goal's last plan from scratch took (``fresh_budget``): a network
        # that cannot be planned afresh is not searched through the planner's whole budget
        # before a repair below the goal is tried; only once that finds none.
        goal: list[TaskEntry] = [(self._goal, None)]
        whole = one_plan(self._settings)
        first = whole if self.fresh_budget is None else replace(whole, budget=self.fresh_budget)
        spent = self._stats.expansions
        fresh = self.search(states[0], goal, first, made_only=not alone)
        if fresh is not None and self._stats.expansions > spent:
            share = math.ceil(LOCAL_SHARE * (self._stats.expansions - spent))
            self.local_left = share if share >= LOCAL_MIN else 0
        elif fresh is None and alone and self.reserve > 0 and self.fresh_budget is not None:
            # No plan afresh within what planning the goal is known to cost: the repairs
            # below it get their whole budget before the goal gets the planner's.  A network
            # whose done tasks cannot start again is searched through to the end of that
            # budget (Entertainment: a million expansions of depth-first search, minutes),
            # where doing a task again below the goal mends it in a few hundred.
            self.local_left, self.reserve = max(self.local_left, 0) + self.reserve, 0
        found = self._below_goal(p, index, states, chain, done, alone, within=fresh)
        if found is not None:
            return found
        found = fresh if fresh is not None else self.search(states[0], goal, whole, made_only=not alone)
        if found is None and alone:
            self.unsolvable = states[0].key()
            if self.reserve > 0:
                # No plan afresh (the goal's methods may not start again from part of it
                # done): only a repair below the goal can keep it, and it gets the rest of
                # its budget (test_repair_redo: doing a subtask again takes 700 expansions).
                self.local_left, self.reserve = max(self.local_left, 0) + self.reserve, 0
                found = self._below_goal(p, index, states, chain, done, alone)
        return found

    def _below_goal(
        self,
        p: Plan,
        index: int,
        states: list[State],
        chain: list[Decomposition],
        done: Done | None,
        alone: bool,
        within: Plan | None = None,
    ) -> Plan | None:
        """§2.4's walk up from step ``index``: re-decompose the lowest of its ancestors
        below the goal that can be, within ``local_left`` (``alone``: see :meth:`repair`);
        with ``within`` (the goal's plan afresh), not where the steps a repair keeps
        already cost more than it (a repair no cheaper is not kept, §2.4)."""
        # A recursive method makes the record as long as the plan; past a few levels a
        # re-decomposition costs as much as planning the goal, so go straight to it.
        for record in chain[:_REPAIR_LEVELS]:
            start, end = span(p.steps, record)
            if start > index:
                continue
            # Repairs below the goal are local fixes: together, in one update, they get
            # a small budget; what they cannot fix the goal's re-decomposition will.
            if self.local_left < LOCAL_MIN:
                break
            # What the steps a repair from here keeps cost: one that cannot be cheaper than
            # the plan afresh is not searched for (§2.4 would not keep it).
            before = sum(s.cost for s in p.steps[:start])
            if within is not None and before > within.cost + _SAME:
                break  # the steps before already cost more than the plan afresh
            if record.parent is not None:
                tasks: list[TaskEntry] = [(record.task, record.parent)]
                tasks += [(s.action, s.record) for s in p.steps[end + 1 :]]
                if start == 0 and within is not None and [t for t, _ in tasks] == [self._goal]:
                    return within  # a recursive method's task equal to the goal: that very search
                after = sum(s.cost for s in p.steps[end + 1 :])
                if within is None or before + after <= within.cost + _SAME:
                    result = self._local(states[start], tasks, made_only=not alone)
                    if result is not None:
                        return Plan(tidy(self._domain, (*p.steps[:start], *result.steps)))
            # §2.4 (our choice): do again the subtasks of this task's method already done,
            # the last one first, then the plan's steps from there as they are.
            rest: list[TaskEntry] = [(s.action, s.record) for s in p.steps[start:]]
            again = done_subtasks(done, record, _REDO) if alone else []
            if within is not None and before + sum(s.cost for s in p.steps[start:]) > within.cost + _SAME:
                again = []
            for k in range(1, len(again) + 1):
                if self.local_left < LOCAL_MIN:
                    break
                result = self._local(states[start], [*again[-k:], *rest])
                if result is not None:
                    return Plan(tidy(self._domain, (*p.steps[:start], *result.steps)))
            if record.parent is None:
                break  # the goal's own decomposition: below, shared
        return None

    def _local(self, state: State, tasks: Sequence[TaskEntry], *, made_only: bool = False) -> Plan | None:
        """A search below the goal, within what is left of the local budget."""
        if self.known_cost(state, tasks) is not None:
            # These very tasks were planned from this belief in this update (a recursive
            # method's task equal to the goal): under other records, the same plan.
            return None
        spent = self._stats.expansions
        local = replace(
            self._settings, alternatives=1, budget=self.local_left, max_tasks=len(tasks) + LOCAL_GROWTH
        )
        result = self.search(state, tasks, local, made_only=made_only)
        # Each search is charged its own cost too (:data:`LOCAL_MIN`): a search that ends at
        # once still set up, and the share is what the repairs may cost, not only expand
        # (Depots: three searches of 1, 3 and 10 expansions cost 1 ms beside the plan
        # afresh's 3.7 ms of 136).
        self.local_left -= max(self._stats.expansions - spent, LOCAL_MIN)
        return result

    def known_cost(self, state: State, tasks: Sequence[TaskEntry]) -> float | None:
        """The cost of the plan a search this update found for the task list from the state,
        under any records (a recursive method's repair re-plans a task equal to the goal:
        that search answers what a search for the goal would find), if one did."""
        return self._costs.get((state.dynamic, self._avoided(state), *(t for t, _ in tasks)))

    def _impossible_key(
        self, state: State, tasks: Sequence[TaskEntry], settings: PlannerSettings
    ) -> tuple[object, ...]:
        # Records do not change whether tasks can be done: a search that found the task
        # list impossible from a state answers for every plan that asks again -- under
        # the same cost bound (none cheaper than a bound is not none at all).
        key: tuple[object, ...] = (state.dynamic, self._avoided(state), *(t for t, _ in tasks))
        return key if settings.cost_bound is None else (*key, ("cost_bound", settings.cost_bound))

    def search(
        self, state: State, tasks: Sequence[TaskEntry], settings: PlannerSettings, *, made_only: bool = False
    ) -> Plan | None:
        """The best plan for the task list from the state, searched once per update
        (with ``made_only``, only if this update already searched it: else None)."""
        impossible = self._impossible_key(state, tasks, settings)
        if impossible in self._impossible:
            return None
        # Records compare by identity; the key holds them, so none can be mistaken for another.
        key: tuple[object, ...] = (*impossible, *(r for _, r in tasks))
        if key in self._results:
            return self._results[key]
        if made_only or self._exhausted.get(key, -1) >= settings.budget:
            return None  # not searched, or cut by a budget as large already
        result = plan(self._domain, state, tasks, settings, avoid=self._avoided(state))
        self._stats.expansions += result.expansions
        found = result.best
        if result.status is PlanStatus.BUDGET_EXHAUSTED:
            # Not an answer: a larger budget (a repair's reserve) may find one.
            self._exhausted[key] = settings.budget
            return None
        self._results[key] = found
        if result.status is PlanStatus.UNSOLVABLE:
            self._impossible.add(impossible)
        elif found is not None and settings.cost_bound is None:
            # The search is deterministic and stops at its first plan: a larger budget
            # would have found the same one.
            self._costs[impossible] = found.cost
        return found


class OnDemand:
    """A :class:`Repairer` made when first asked for: most updates re-check nothing or
    find every plan valid, and need none."""

    __slots__ = ("_make", "made")

    def __init__(self, make: Callable[[], Repairer]) -> None:
        self._make = make
        self.made: Repairer | None = None
        """The repairer, once made."""

    def __call__(self) -> Repairer:
        if self.made is None:
            self.made = self._make()
        return self.made


def done_subtasks(done: Done | None, record: Decomposition, limit: int) -> list[TaskEntry]:
    """The last ``limit`` subtasks of ``record``'s method that are done, in their order.

    Each is a task entry to plan again under ``record``: a compound subtask as its
    task, a primitive one as its action (a ``resume(A)`` as A).  Steps inserted by
    maintenance (no record) are passed over; the walk stops at the first step that
    ``record`` did not produce.  Consecutive steps under the same compound task are
    one subtask (two equal tasks one after the other are taken as one).
    """
    found: list[TaskEntry] = []
    last: object = None
    link = done
    while link is not None:
        step, link = link.step, link.before
        node = step.record
        if node is None:
            continue
        key: object
        if node is record:
            key, entry = step, (action_resumed_by(step.action) or step.action, record)
        else:
            while node is not None and node.parent is not record:
                node = node.parent
            if node is None:
                break
            # A subtask re-decomposed part way by an earlier repair has two records for
            # one task: its steps before and after the repair are still one subtask.
            key, entry = node.task, (node.task, record)
        if key != last:
            if len(found) == limit:
                break
            found.append(entry)
            last = key
    found.reverse()
    return found


__all__ = [
    "LOCAL_BUDGET",
    "LOCAL_GROWTH",
    "LOCAL_MIN",
    "LOCAL_SHARE",
    "OnDemand",
    "Repairer",
    "SearchMemo",
    "done_subtasks",
    "one_plan",
]
