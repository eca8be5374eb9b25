"""An action finished with success (docs/design.md §2.1).

The rule: "In each plan whose first action is the executed action, that action
is removed.  A plan whose first action is some other action is kept only if it
stays valid: if the executed action has an undo operator, the undo is put in
front of it; otherwise it is re-checked."

:func:`moved_on` is that rewrite of one plan (also applied to the plans waiting
for revival, and to a waiting goal's plans, whose re-check is deferred);
:func:`kept_after_success` rewrites every kept plan and says which are known
valid without a walk (the re-check itself is :mod:`htnagent.upkeep.recheck`'s).
"""

from __future__ import annotations

from collections.abc import Callable, Sequence

from htnagent.model.actions import RESUME, action_recovered_by
from htnagent.model.domain import Domain
from htnagent.model.plans import Plan, Step, tidy
from htnagent.model.state import State
from htnagent.model.terms import Atom
from htnagent.upkeep.validity import Kept, leads_back


def ran(plans: Sequence[Plan], action: Atom) -> Step | None:
    """The step that did ``action``, if a kept plan made it (the cheapest such plan: the
    one selected)."""
    return next((p.steps[0] for p in plans if p.steps and p.steps[0].action == action), None)


def behind(domain: Domain, undo: Atom, steps: tuple[Step, ...]) -> tuple[Step, ...]:
    """The steps behind the undo of an action another goal made (§2.1), tidied.

    A ``resume(A)`` among them no longer continues from where A was stopped —
    the executor has since done other things — so it is costed as the whole A:
    how much of A is left is not known.
    """
    cost = domain.actions.cost
    # The name test first: this runs on every step of every kept plan.
    rest = tuple(
        Step(s.action, cost(inner), s.record)
        if s.action.name == RESUME and (inner := action_recovered_by(s.action)) is not None
        else s
        for s in steps
    )
    return tidy(domain, (Step(undo, cost(undo), None), *rest), front=True)


def moved_on(domain: Domain, action: Atom, undo: Atom | None) -> Callable[[Plan], Plan | None]:
    """§2.1's rewrite of a plan once ``action`` succeeded: the plan that ran it moves
    on; another goes behind the action's ``undo``; None: the plan stays as it is."""

    def rewrite(p: Plan) -> Plan | None:
        if p.steps and p.steps[0].action == action:
            return p.rest()
        if undo is not None:
            return Plan(behind(domain, undo, p.steps))
        return None

    return rewrite


def kept_after_success(
    domain: Domain,
    plans: Sequence[Plan],
    action: Atom,
    undo: Atom | None,
    before: State,
    after: State,
    *,
    trusted: bool,
    untouched: Callable[[Plan], bool],
) -> list[Kept]:
    """Every kept plan rewritten as §2.1 says, with whether it is known valid from ``after``.

    A plan valid from ``before`` (``trusted``: all were) that ran the action is valid
    from ``after``; so is one behind the undo, when the undo really leads back to
    ``before``; so is any other that reads no fact the action changed (``untouched``).
    """
    restores: bool | None = None  # whether the undo leads back: worked out when needed
    kept: list[Kept] = []
    for p in plans:
        if p.steps and p.steps[0].action == action:
            # §2.1: the plan that ran the action moves on.
            kept.append(Kept(p.rest(), trusted))
        elif undo is not None:
            # §2.1: another plan stays valid by undoing the action first.
            if restores is None:
                restores = trusted and leads_back(domain, undo, before, after)
            kept.append(Kept(Plan(behind(domain, undo, p.steps)), restores))
        else:
            kept.append(Kept(p, untouched(p)))
    return kept


__all__ = ["behind", "kept_after_success", "moved_on", "ran"]
