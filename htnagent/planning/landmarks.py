"""The goal's fact landmarks: what greedy search counts on the way to a state goal.

An HDDL ``:goal`` is checked once the whole network is done, and the lifted estimate
(each task's least number of actions, whatever the state) counts a false goal fact as
one action more -- nothing about what it takes to make it true.  Where the goal is a
fact only one particular action adds, and that action needs another particular fact
first, and so on (Monroe-Partially-Observable: the goal ``l7`` is added only by the
sixth observed action, which needs ``l6``, which only the fifth adds...), greedy search
sees a plateau until the very end.

This module backchains from the goal facts (docs/design.md §7.4): a fact's *necessary
preconditions* are the ground facts in the precondition of every action that may add
it (its add effect unified with the fact; a precondition some variable of the action
alone leaves open is no one fact).  A fact that is false must be added again before
the goal holds, and every action that may add it needs each of its necessary
preconditions true at that moment: so a false goal fact, and a false necessary
precondition of a fact still needed, are still needed.  :meth:`GoalLandmarks.count`
is how many facts are still needed in a state -- the goal facts that are false, and
the landmarks behind them -- which greedy search adds to its estimate in place of the
false goal facts alone.  One action may add two of them, so the count is a guide, not
a bound: only greedy search reads it (A* keeps its own estimate).  The facts needed
(:meth:`GoalLandmarks.needed`, and after an action :meth:`GoalLandmarks.needed_after`)
also tell the dead-end test of :mod:`~htnagent.planning.goal_support` which marks to
watch (design §7.3).
"""

from __future__ import annotations

from collections.abc import Iterable, Sequence

from htnagent.model.domain import Domain
from htnagent.model.terms import Atom, substitute, unify
from htnagent.planning.per_domain import PerDomain


def necessary_preconditions(
    domain: Domain, goals: Sequence[Atom], dynamic: frozenset[str]
) -> dict[Atom, frozenset[Atom]]:
    """Each goal fact and each landmark found behind it, with its necessary preconditions:
    the ground facts on changing predicates (``dynamic``) that every action that may add it
    needs.  A fact no action adds has none (it is true at the start or never)."""
    adders = [(op, x) for ops in domain.operators.values() for op in ops for x in op.add]
    found: dict[Atom, frozenset[Atom]] = {}
    todo = list(dict.fromkeys(goals))
    while todo:
        fact = todo.pop()
        if fact in found:
            continue
        common: set[Atom] | None = None
        for op, added in adders:
            b = unify(added, fact, {})
            if b is None:
                continue
            needs = {
                atom
                for lit in op.pre
                if lit.positive and lit.atom.name in dynamic
                if (atom := substitute(lit.atom, b)).is_ground
            }
            common = needs if common is None else common & needs
            if not common:
                break
        found[fact] = frozenset(common or ())
        todo.extend(f for f in found[fact] if f not in found)
    return found


class GoalLandmarks:
    """The goal facts and the landmarks behind them, for greedy search's estimate
    (:meth:`count`) and the dead-end test's marks (:meth:`needed`, :meth:`needed_after`).
    Made once for a domain and its goal (:meth:`of`)."""

    @classmethod
    def of(cls, domain: Domain, dynamic: frozenset[str]) -> GoalLandmarks:
        """The landmarks of ``domain``'s goal facts, made once for the last few domains seen
        (the key holds the domain's size and goal too, as :meth:`GoalSupport.of`'s does)."""
        key = (id(domain), domain.goal_facts, len(domain.operators), dynamic)
        goals = domain.goal_facts
        return _MADE.get(domain, key, lambda: cls(goals, necessary_preconditions(domain, goals, dynamic)))

    def __init__(self, goals: Sequence[Atom], needs: dict[Atom, frozenset[Atom]]) -> None:
        self.goals = tuple(dict.fromkeys(goals))
        self.needs = {fact: pre for fact, pre in needs.items() if pre}
        """The facts with necessary preconditions, and those preconditions."""
        self.facts = frozenset(self.goals).union(*self.needs.values())
        """Every fact that may be needed: the goal facts and the landmarks behind them."""
        self._goal_set = frozenset(self.goals)
        self._above: dict[Atom, list[Atom]] = {}  # a fact: the facts it is behind
        for fact, pre in self.needs.items():
            for p in pre:
                self._above.setdefault(p, []).append(fact)
        self._needed: dict[frozenset[Atom], frozenset[Atom]] = {}

    @property
    def beyond_goals(self) -> bool:
        """Whether any goal fact has a landmark behind it (otherwise :meth:`count` is the
        number of false goal facts)."""
        return bool(self.needs)

    def needed(self, dynamic: frozenset[Atom]) -> frozenset[Atom]:
        """The facts that must still be made true in a state of changing facts ``dynamic``:
        each false goal fact, and each false necessary precondition of a fact needed."""
        known = self._needed.get(dynamic)
        if known is not None:
            return known
        needed = {g for g in self.goals if g not in dynamic}
        behind = self.needs
        frontier: Iterable[Atom] = needed
        while behind and frontier:  # a level at a time: what is behind the facts just found
            more: set[Atom] = set()
            for fact in frontier:
                pre = behind.get(fact)
                if pre:
                    more.update(pre)
            more.difference_update(dynamic)
            more.difference_update(needed)
            needed |= more
            frontier = more
        if len(self._needed) >= _KEEP_NEEDED:
            self._needed.clear()
        found = self._needed[dynamic] = frozenset(needed)
        return found

    def count(self, dynamic: frozenset[Atom]) -> int:
        """How many facts must still be made true in a state (:meth:`needed`)."""
        return len(self.needed(dynamic))

    def needed_after(self, before: frozenset[Atom], after: frozenset[Atom]) -> frozenset[Atom]:
        """:meth:`needed` in the state ``after`` an action, worked out from the state before it
        where that is known: only what the facts it changed are behind, or behind them, is
        looked at again (a search applies thousands of actions, most touching a few facts)."""
        known = self._needed.get(after)
        if known is not None:
            return known
        was = self._needed.get(before)
        if was is None or not self.needs:
            return self.needed(after)
        facts = self.facts
        made = [f for f in after.difference(before) if f in facts]
        lost = [f for f in before.difference(after) if f in facts]
        if not made and not lost:
            found = was
        else:
            need = set(was)
            # A fact made true is needed no more, nor, perhaps, what is behind it: take out all
            # that is behind it, then put back what a fact still needed is behind.
            gone: set[Atom] = set()
            todo = [f for f in made if f in need]
            while todo:
                fact = todo.pop()
                if fact in need:
                    need.discard(fact)
                    gone.add(fact)
                    todo.extend(self.needs.get(fact, ()))
            back = [
                f
                for f in gone
                if f not in after and (f in self._goal_set or any(p in need for p in self._above.get(f, ())))
            ]
            # A fact made false is needed if it is a goal fact or behind a fact needed.
            back += [f for f in lost if f in self._goal_set or any(p in need for p in self._above.get(f, ()))]
            while back:  # and so is what is false behind a fact needed
                fact = back.pop()
                if fact in need or fact in after:
                    continue
                need.add(fact)
                back.extend(self.needs.get(fact, ()))
            found = frozenset(need)
        if len(self._needed) >= _KEEP_NEEDED:
            self._needed.clear()
        self._needed[after] = found
        return found


_KEEP_NEEDED = 256
"""The states whose needed facts :meth:`GoalLandmarks.needed` keeps: a search asks again for
a state it has just made (greedy search's estimate, then the dead-end test), or for the
state before an action; a miss is a walk again, never a wrong answer."""

_MADE: PerDomain[GoalLandmarks] = PerDomain()
