"""Working out how a suspended goal resumes, from a belief (Algorithm 2, §2.7, §2.8, §4).

One function, :func:`work_out_resumption`, does it.  The agent calls it at the moment
a goal comes off the stack, or — in on-line mode with the look-ahead on — ahead, on a
copy of the goal's plans, while the last action before the resumption runs
(:mod:`htnagent.agent.look_ahead`).  Either way the agent then carries the result out
the same way: it takes the plans and clears the suspended actions the selected plan
does not need.
"""

from __future__ import annotations

from dataclasses import dataclass

from htnagent.model.actions import action_recovered_by
from htnagent.model.domain import Domain, State
from htnagent.model.terms import Atom
from htnagent.runtime.messages import Clear
from htnagent.upkeep import PlanSet, SearchMemo


@dataclass
class Resumption:
    """How a goal resumes: its plans, and the suspended actions to clear."""

    plans: PlanSet
    """The goal's plans, made good from the belief after the clears."""
    clears: list[tuple[Clear, State]]
    """The orders clearing the suspended actions the selected plan does not need, each
    with the belief once that action is cleared (oldest first)."""


def work_out_resumption(
    domain: Domain, plans: PlanSet, belief: State, suspended: list[Atom], memo: SearchMemo | None = None
) -> Resumption:
    """Make a resumed goal's ``plans`` good from ``belief`` and say which of its
    ``suspended`` actions to clear.  ``plans`` is updated in place (the goal's own, or a
    fork of them when worked out ahead); the belief and ``suspended`` are not touched.
    ``memo``: the searches an update of the plans from ``belief`` made just before (the
    look-ahead's), to share.

    Algorithm 2 for a resumed goal, with §2.7 and §2.8::

        confirm that an emptied plan achieves the goal now (§2.8), else plan it (§2.7)
        weigh a way opened while it waited; shorten detours plan upkeep put in front
        select the cheapest plan P
        for each suspended action A that P does not resume or roll back:
            clear A (the belief forgets its half-done facts; the plans follow, §3)
        if anything was cleared: make sure of a plan, shorten detours, from the new belief
    """
    # One update from one belief: its steps share their searches (the re-check of plans
    # left unchecked while the goal waited may plan the goal afresh; shortening a detour
    # would search for that very plan again).
    memo = memo if memo is not None else SearchMemo()
    plans.confirm_achieved(belief, memo)
    plans.ensure(belief, memo)
    plans.reconsider(belief, memo)  # a way opened while it waited: as good as a plan made afresh
    plans.shorten_detours(belief, memo)  # and its lowest task done again, which can be cheaper still
    best = plans.best
    # A plan that rolls an action back, or finishes it later (after walking back to where
    # it was stopped), still needs what was kept for it.
    needed = {a for s in best.steps if (a := action_recovered_by(s.action)) is not None} if best else set()
    unused = [a for a in suspended if a not in needed]
    clears: list[tuple[Clear, State]] = []
    state = belief
    for action in unused:
        after = domain.clear(state, action)
        plans.suspension_cleared(action, state, after)
        clears.append((Clear(action=action), after))
        state = after
    if unused:
        # A clear can open a cheaper way (a precondition asking the half-done action gone).
        memo = SearchMemo()
        plans.ensure(state, memo)
        plans.shorten_detours(state, memo)
    return Resumption(plans, clears)


@dataclass
class Foreseen:
    """A resumption worked out ahead, with what it was worked out for."""

    belief: tuple[object, ...]
    """The key of the belief it was worked out from."""
    suspended: tuple[Atom, ...]
    """The goal's suspended actions it was worked out with."""
    resumption: Resumption

    def holds_for(self, belief: State, suspended: list[Atom]) -> bool:
        """Whether things went as predicted: the belief and the goal's suspended actions."""
        return self.belief == belief.key() and self.suspended == tuple(suspended)
