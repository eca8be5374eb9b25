"""No worse than planning afresh (docs/design.md §2.4, last paragraph).

The rule: "A repair must not be worse than planning afresh: a repaired plan is
kept only if no plan made from scratch from the same belief would be cheaper
(the domain's admissible estimate tells when the repair is already optimal;
otherwise compare).  On-line re-planning never settles for a longer route than
naive."

:func:`fresher_kept` applies it whenever the best plan took the place of a
broken one (or a change from outside opened a way); :func:`rival_from` gives a
plan a rival made by re-decomposing the lowest task above one of its steps, as
a repair would — the shorter way past a resumed goal's undo detour.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import replace

from htnagent.model.plans import Plan, span
from htnagent.model.state import State
from htnagent.planning.planner import TaskEntry, heuristic
from htnagent.upkeep.base import PlanSet
from htnagent.upkeep.repair import Repairer, one_plan


def proven_optimal(ps: PlanSet, p: Plan, state: State) -> bool:
    """Whether the admissible estimate proves no plan for ``ps``'s goal from ``state`` is cheaper."""
    return p.cost <= heuristic(ps.domain, [ps.goal], state) + 1e-9


def fresher_kept(ps: PlanSet, state: State, repairer: Callable[[], Repairer]) -> bool:
    """Make ``ps``'s best plan no worse than a plan made afresh from ``state``: proven by
    the estimate, or compared (and replaced by the fresh plan if that is cheaper).
    Returns whether it is known to be now (False: no plan is kept, or the search for a
    plan afresh found none within its budget -- whether one exists is then not known).

    The search is shared (``repairer``) with a repair that reached the goal itself.
    """
    if not ps.plans or proven_optimal(ps, ps.plans[0], state):
        return bool(ps.plans)
    goal: list[TaskEntry] = [(ps.goal, None)]
    searches = repairer()
    known = searches.known_cost(state, goal)
    if known is not None and known >= ps.plans[0].cost - 1e-9:
        return True  # a search this update made for the goal's very task found nothing cheaper
    # Compared as naive would plan the goal here: the same search, to its first plan (a
    # search under the kept plan's cost would find that plan no later, if it is cheaper,
    # but where none is cheaper it looks on until its budget is spent -- a depth-first
    # search many times what naive's takes).  Given a few times what the goal's last plan
    # from scratch took: a network that cannot be done again from scratch is not searched
    # through to the end of the planner's budget.  None found says nothing of whether
    # a plan afresh exists: not known (the caller may then re-decompose the lowest task
    # instead, as where none exists).
    fresh = searches.search(state, goal, replace(one_plan(ps.settings), budget=comparison_budget(ps)))
    if fresh is None:
        return False
    if fresh.cost >= ps.plans[0].cost - 1e-9:
        return True
    ps.stats.fresher += 1
    # The plan it beat goes: a plan worse than one made afresh from the same belief is
    # no alternative worth keeping valid at every action (alternatives come when an
    # action fails, §2.2).
    others = [p for p in ps.plans[1:] if p.actions != fresh.actions]
    ps.plans = [fresh, *others][: max(ps.settings.alternatives, 1)]
    return True


COMPARISON_FACTOR = 2
"""§2.4's comparison searches at most this many times what the goal's last plan from scratch
took (and at least :data:`COMPARISON_FLOOR`).  Not once: the rest of a recursive network,
planned afresh from the middle, can take as many expansions as the whole did from the start
(Towers p07: 395 both), and a search cut just short of its plan is made again with the
planner's whole budget -- on-line planned the goal afresh twice, 1.32 times naive's
whole-run planning."""
COMPARISON_FLOOR = 100


def comparison_budget(ps: PlanSet) -> int:
    """The expansions §2.4's search for a plan afresh may take: a few times what planning
    ``ps``'s goal from scratch is known to cost.  A search that runs far past that is
    looking through a space where the goal cannot be planned afresh (an IPC network whose
    done tasks cannot start again), and is not worth more than naive's whole search."""
    known = ps.scratch_expansions
    if known is None:
        return ps.settings.budget
    return min(ps.settings.budget, max(COMPARISON_FLOOR, COMPARISON_FACTOR * known))


def first_own_step(p: Plan) -> int:
    """The index of the plan's first step of the goal's own (one with a record), or its
    length: the steps before are plan maintenance's (undo steps, a rollback of another
    goal's action) — not a ``resume(A)``, which took its own A's place."""
    return next((i for i, s in enumerate(p.steps) if s.record is not None), len(p.steps))


def rival_from(ps: PlanSet, state: State, best: Plan, first: int, repairer: Callable[[], Repairer]) -> bool:
    """Re-decompose the lowest compound task above ``best``'s step ``first`` (the goal, if
    none is left) from ``state``, followed by the rest of ``best``; select the rival if
    it is cheaper (a repair as in §2.4).  Returns whether it was."""
    rival = cheaper_rival(ps, state, best, first, repairer)
    if rival is None:
        return False
    take_rival(ps, rival)
    return True


def cheaper_rival(
    ps: PlanSet, state: State, best: Plan, first: int, repairer: Callable[[], Repairer]
) -> Plan | None:
    """:func:`rival_from`'s rival, if it is cheaper than ``best`` (not selected)."""
    tasks: list[TaskEntry]
    if first == len(best.steps):
        # Nothing of the goal's own is left, only the way back to where an
        # emergency achieved it (§2.8): the rival is the goal itself.
        tasks, head, fixed = [(ps.goal, None)], ps.goal, 0.0
    else:
        record = best.steps[first].record
        assert record is not None
        _, end = span(best.steps, record)
        tasks = [(record.task, record.parent)]
        tasks += [(s.action, s.record) for s in best.steps[end + 1 :]]
        head, fixed = record.task, sum(s.cost for s in best.steps[end + 1 :])
    # With admissible estimates nothing can beat a plan that costs no more than
    # the estimate of the rival's tasks: then the search is not worth making.
    if best.cost <= heuristic(ps.domain, [head], state) + fixed + 1e-9:
        return None
    rival = repairer().search(state, tasks, one_plan(ps.settings))
    if rival is None or rival.cost >= best.cost - 1e-9:
        return None
    return rival


def take_rival(ps: PlanSet, rival: Plan) -> None:
    """Select ``rival``, which beat the best plan (:func:`cheaper_rival`)."""
    # The plan it beat is not kept as an alternative: a detour walks back over the
    # emergency's route only to go the way the rival goes, and keeping it valid would
    # cost an undo step more at every action (a goal's plan comes alone, §1, §4;
    # alternatives are looked for when an action fails: see widen).
    others = [p for p in ps.plans[1:] if p.actions != rival.actions]
    ps.plans = sorted([rival, *others], key=lambda q: q.cost)[: ps.settings.alternatives]
    ps.stats.shortcuts += 1


__all__ = [
    "COMPARISON_FACTOR",
    "COMPARISON_FLOOR",
    "cheaper_rival",
    "comparison_budget",
    "first_own_step",
    "fresher_kept",
    "proven_optimal",
    "rival_from",
    "take_rival",
]
