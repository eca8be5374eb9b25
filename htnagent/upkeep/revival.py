"""Revival of removed plans (docs/design.md §2.5): a plan broken by a fact comes back with it.

The rule (§2.5): "A plan removed earlier because a fact was false is
revived when that fact becomes true again (keep removed plans, indexed by the
fact that broke them, for a bounded while).  This covers repaired plans too."

A plan removed because a fact was false — or the plan as it was before a
repair — is kept in a :class:`Revival` store, indexed by the precondition
literal that broke it, and revived when that fact becomes true again (a door
shut and opened again gives back the first route).  The store is bounded in
time and in number.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

from htnagent.model.domain import Domain
from htnagent.model.plans import Plan
from htnagent.model.preconditions import satisfiers
from htnagent.model.state import State
from htnagent.model.terms import Atom, substitute


@dataclass(slots=True)
class _Removed:
    plan: Plan
    key: tuple[Atom, bool]
    update: int
    rewritten: int
    """How many of the store's rewrites ``plan`` has had (the later ones are still to come)."""


class Revival:
    """Plans removed because a fact was false, kept to come back when it is true again (§2.5).

    Each plan is indexed by the precondition literal that broke it — ``(fact,
    must be true)`` — and revived when that fact changes the right way.  The
    store is bounded twice: a plan waits at most ``window`` updates, and at most
    ``capacity`` plans are kept at once (the oldest goes first).  Kept plans
    follow the agent's actions (:meth:`rewrite`), so that a revived plan starts
    from where the robot is by then — lazily: the rewrites are logged, and a plan
    gets those it has not had yet when it is taken out (most plans expire unrevived).
    """

    __slots__ = ("_changes", "_domain", "_kept", "_updates", "capacity", "window")

    def __init__(self, domain: Domain, window: int = 64, capacity: int = 32) -> None:
        self._domain = domain
        self.window = window
        self.capacity = capacity
        self._kept: list[_Removed] = []
        self._updates = 0
        self._changes: list[Callable[[Plan], Plan | None]] = []  # the rewrites, in order

    def __len__(self) -> int:
        return len(self._kept)

    @property
    def plans(self) -> list[Plan]:
        """The plans kept, oldest first."""
        return [self._rewritten(r) for r in self._kept]

    def copy(self) -> Revival:
        """An independent copy (for a plan set's fork)."""
        other = Revival(self._domain, self.window, self.capacity)
        other._kept = [_Removed(r.plan, r.key, r.update, r.rewritten) for r in self._kept]
        other._updates = self._updates
        other._changes = list(self._changes)
        return other

    def clear(self) -> None:
        """Forget every kept plan."""
        self._kept.clear()
        self._changes.clear()

    def keep(self, p: Plan, action: Atom, state: State) -> None:
        """Keep the removed plan ``p``, whose ``action`` could not run in ``state``."""
        key = _broken_by(self._domain, action, state)
        if key is None:
            return
        self._kept.append(_Removed(p, key, self._updates, len(self._changes)))
        if len(self._kept) > self.capacity:
            del self._kept[0]

    def rewrite(self, change: Callable[[Plan], Plan | None]) -> None:
        """Replace each kept plan by ``change(plan)`` (unless that is None), when it is next
        read."""
        if self._kept:
            self._changes.append(change)
            if len(self._changes) > 4 * self.window:  # a long wait unchecked (lazy): catch up
                for r in self._kept:
                    self._rewritten(r)
                self._changes.clear()
                for r in self._kept:
                    r.rewritten = 0

    def _rewritten(self, r: _Removed) -> Plan:
        """``r``'s plan with every rewrite logged since it was kept."""
        for change in self._changes[r.rewritten :]:
            q = change(r.plan)
            if q is not None:
                r.plan = q
        r.rewritten = len(self._changes)
        return r.plan

    def tick(self) -> None:
        """An update of the plan set begins."""
        self._updates += 1

    def due(self, before: State, after: State) -> bool:
        """Whether :meth:`revive` would take a plan out for this change."""
        return bool(self._kept) and any(_came_back(r, before, after) for r in self._kept)

    def revive(self, before: State, after: State) -> list[Plan]:
        """Take out the plans whose breaking fact changed the right way between the states."""
        if not self._kept:
            return []
        out: list[Plan] = []
        keep: list[_Removed] = []
        for r in self._kept:
            if _came_back(r, before, after):
                out.append(self._rewritten(r))
            else:
                keep.append(r)
        self._kept = keep
        if not keep:
            self._changes.clear()
        return out

    def expire(self) -> None:
        """An update ended: forget the plans that waited more than ``window`` updates."""
        # Kept in the order they came (``update`` grows): the oldest are first.
        kept = self._kept
        while kept and self._updates - kept[0].update > self.window:
            del kept[0]
        if not kept:
            self._changes.clear()


def _came_back(r: _Removed, before: State, after: State) -> bool:
    """Whether ``r``'s breaking fact holds (is false) after, and did not (did) before: it
    became as the plan needs."""
    fact, positive = r.key
    return after.holds(fact) is positive and before.holds(fact) is not positive


def _broken_by(domain: Domain, action: Atom, state: State) -> tuple[Atom, bool] | None:
    """The precondition literal of the action that fails: ``(fact, must be true)``.

    SHOP binding makes later literals depend on earlier ones, so the culprit is
    the first literal with which the precondition's prefix has no satisfier;
    it is made ground with the first satisfier of the prefix before it.
    """
    op, bindings = domain.actions.ground(action)
    prefix_binding = bindings
    # The literals the action's own arguments make ground, up to the first that is not, are
    # plain look-ups (the prefix before each holds): only from there is a prefix searched
    # for a satisfier, again for each longer prefix.
    first = 0
    for lit in op.pre:
        if not lit.variables <= bindings.keys():
            break
        fact = substitute(lit.atom, bindings)
        if state.holds(fact) != lit.positive:
            return fact, lit.positive
        first += 1
    for i, lit in enumerate(op.pre[first:], start=first):
        extended = next(satisfiers(op.pre[: i + 1], state, bindings), None)
        if extended is None:
            fact = substitute(lit.atom, prefix_binding)
            return (fact, lit.positive) if fact.is_ground else None
        prefix_binding = extended
    return None


__all__ = ["Revival"]
