"""Whether a kept plan is still valid from a belief (docs/design.md §2.4, first step).

The rule (§2.4): "Re-checking a plan means progressing the belief through
the plan and testing each action's precondition."  :func:`first_failure` is that
walk; the other helpers tell when a plan is known valid without one (its first
step ends where the old one did, :func:`leads_back`; it reads no fact that
changed, :func:`changed_predicates`), and :class:`Kept` carries that knowledge
into a re-check.
"""

from __future__ import annotations

from collections.abc import Iterable
from typing import NamedTuple

from htnagent.model.domain import Domain
from htnagent.model.plans import Plan
from htnagent.model.state import State
from htnagent.model.terms import Atom


class Kept(NamedTuple):
    """A plan going into a re-check, and whether it is known valid from the new belief."""

    plan: Plan
    valid: bool


def first_failure(domain: Domain, p: Plan, state: State) -> tuple[int, State] | None:
    """Progress the belief through the plan: the first step that cannot run, and the state there."""
    current = state
    compiled = domain.actions.compiled
    for i, s in enumerate(p.steps):
        dynamic = compiled(s.action).apply_dynamic(current)
        if dynamic is None:
            return i, current
        if dynamic is not current.dynamic:
            current = current.with_dynamic(dynamic)
    return None


def states_before(domain: Domain, p: Plan, state: State, upto: int) -> list[State]:
    """The belief before each of the first ``upto + 1`` steps (all applicable)."""
    apply = domain.actions.apply
    states = [state]
    for s in p.steps[:upto]:
        nxt = apply(states[-1], s.action)
        assert nxt is not None
        states.append(nxt)
    return states


def leads_back(domain: Domain, undo: Atom, before: State, after: State) -> bool:
    """Whether doing ``undo`` in ``after`` gives back exactly the belief ``before``."""
    if after.static is not before.static:
        return False
    dynamic = domain.actions.apply_dynamic(after, undo)
    return dynamic is not None and dynamic == before.dynamic


def changed_predicates(before: State, after: State) -> frozenset[str]:
    """The names of the facts that differ between two beliefs."""
    names = {f.name for f in before.dynamic ^ after.dynamic}
    if after.static is not before.static:
        names |= {f.name for f in before.static.facts ^ after.static.facts}
    return frozenset(names)


def unique(plans: Iterable[Plan]) -> list[Plan]:
    """The plans without repeats (the first of equal action sequences), in order."""
    seen: set[tuple[Atom, ...]] = set()
    out: list[Plan] = []
    for p in plans:
        if p.actions not in seen:
            seen.add(p.actions)
            out.append(p)
    return out


def by_cost(p: Plan) -> float:
    """The sort key of plans, cheapest first."""
    return p.cost


__all__ = ["Kept", "by_cost", "changed_predicates", "first_failure", "leads_back", "states_before", "unique"]
