"""Re-checking every kept plan, and repairing the broken ones (docs/design.md §2.4).

The rule: "Re-checking a plan means progressing the belief through the plan and
testing each action's precondition.  A plan whose action *i* fails is repaired,
not thrown away [...]  Only if no ancestor up to the goal can be re-decomposed
is the plan removed."

:func:`recheck_all` re-checks the plans an update leaves (tidied first, §2.6)
and the plans it revives (§2.5), cheapest first, without repeats;
:func:`recheck` does one plan: the walk (:func:`~htnagent.upkeep.validity.first_failure`),
then the repair (:class:`~htnagent.upkeep.repair.Repairer`), and keeps the plan
as it was for revival.  Whether what is left is as good as planning afresh is
:mod:`htnagent.upkeep.quality`'s question.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence

from htnagent.model.plans import Plan, tidy
from htnagent.model.state import State
from htnagent.model.terms import Atom
from htnagent.upkeep.base import PlanSet
from htnagent.upkeep.repair import Repairer
from htnagent.upkeep.revival import Revival
from htnagent.upkeep.validity import Kept, by_cost, first_failure, states_before


def recheck_all(
    ps: PlanSet,
    revival: Revival,
    candidates: Sequence[Kept],
    revived_from: int,
    after: State,
    repairer: Callable[[], Repairer],
) -> tuple[list[Plan], bool]:
    """The plans of ``candidates`` valid from ``after`` (repaired where broken), cheapest
    first, at most K; and whether the first candidate (the best plan) broke.

    The candidates from ``revived_from`` on come back from revival: they are
    counted so, and neither repaired nor kept for revival again if broken.
    """
    out: list[Plan] = []
    seen: set[tuple[Atom, ...]] = set()
    best_broke = False
    best: Plan | None = None  # what the first candidate (the best plan) became
    came_back: list[Plan] = []
    for n, (p, valid) in enumerate(candidates):
        revived = n >= revived_from
        if valid:
            checked: Plan | None = p
        else:
            p = Plan(tidy(ps.domain, p.steps))  # §2.6
            # The costliest repairs only while no valid plan is kept: see Repairer.repair.
            checked = recheck(
                ps, revival, p, after, repairer, allow_repair=not revived, remember=not revived, alone=not out
            )
            if n == 0 and checked is not p:
                best_broke = True
        if checked is None:
            continue
        if n == 0 and not revived:
            best = checked
        if revived and out and checked.cost >= min(q.cost for q in out) - 1e-9:
            # §2.5: a plan comes back when its fact holds again "and it is then the
            # cheaper one"; kept beside a cheaper valid plan it would only be re-checked
            # (and, as it does not follow the actions taken, repaired) at every action.
            continue
        if revived:
            ps.stats.revivals += 1
            came_back.append(checked)
        key = checked.actions
        if key not in seen:
            seen.add(key)
            out.append(checked)
    out.sort(key=by_cost)
    if best is not None and any(out[0] is q for q in came_back) and best in out:
        # The best plan gave way to a plan that came back cheaper (§2.5: the first route,
        # once the door is open again): it goes, as a plan a cheaper one made afresh beats
        # does (§2.4) -- kept as an alternative it would be re-checked at every action for
        # nothing (Barman: 0.26 ms an action).  Alternatives come when an action fails (§2.2).
        out.remove(best)
    return out[: max(ps.settings.alternatives, 1)], best_broke


def recheck(
    ps: PlanSet,
    revival: Revival,
    p: Plan,
    state: State,
    repairer: Callable[[], Repairer],
    *,
    allow_repair: bool,
    remember: bool,
    alone: bool = True,
) -> Plan | None:
    """The plan if valid from ``state``, else its repair, else None (and it is kept for revival)."""
    ps.stats.rechecks += 1
    failure = first_failure(ps.domain, p, state)
    if failure is None:
        return p
    index, at_failure = failure
    culprit = p.steps[index].action
    if not allow_repair:
        if remember:
            ps.stats.removed += 1
            revival.keep(p, culprit, at_failure)
        return None
    repaired = repairer().repair(p, index, states_before(ps.domain, p, state, index), ps.done, alone=alone)
    # §2.5: a removed plan, and the plan as it was before a repair, come back if the fact does.
    revival.keep(p, culprit, at_failure)
    if repaired is not None:
        ps.stats.repairs += 1
        return repaired
    ps.stats.failed_repairs += 1
    ps.stats.removed += 1
    return None


__all__ = ["recheck", "recheck_all"]
