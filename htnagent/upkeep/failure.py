"""An action failed (docs/design.md §2.2).

The rule: "Plans that start with the failed action are removed; the others are
re-checked against the new belief."

When that leaves no plan, the kept alternatives are searched for at once — those
that do not start with the failed action (:func:`new_alternatives`) — since a
goal's first plan comes alone.  An alternative that still means to do the failed
action later is no better than planning afresh (:func:`means_it_again`, then
:mod:`htnagent.upkeep.quality`).
"""

from __future__ import annotations

from collections.abc import Iterable, Sequence

from htnagent.model.plans import Plan
from htnagent.model.terms import Atom


def starts_with(p: Plan, action: Atom) -> bool:
    """Whether ``action`` is the plan's first step."""
    return bool(p.steps) and p.steps[0].action == action


def without_failed(plans: Sequence[Plan], action: Atom) -> list[Plan]:
    """§2.2: the plans that do not start with the failed ``action``."""
    return [p for p in plans if not starts_with(p, action)]


def new_alternatives(found: Iterable[Plan], kept: Sequence[Plan], failed: Atom | None) -> list[Plan]:
    """The plans of a search for alternatives worth adding to ``kept``: not kept already,
    and not starting with the action that just ``failed``."""
    seen = {p.actions for p in kept}
    return [
        p for p in found if p.actions not in seen and not (failed is not None and p.actions[:1] == (failed,))
    ]


def means_it_again(plans: Sequence[Plan], action: Atom) -> bool:
    """Whether the best plan left still does the failed ``action`` later on."""
    return bool(plans) and action in plans[0].actions


__all__ = ["means_it_again", "new_alternatives", "starts_with", "without_failed"]
