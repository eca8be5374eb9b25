"""Suspending an action: the published Algorithm 1 (docs/design.md §3).

The rule, when the running action A is suspended:

1. update the belief with A's suspension effect (the caller does it);
2. add any new valid plans (§2.5);
3. for each kept plan P: if P starts with A, replace that A by ``resume(A)``;
   else, if A has a rollback operator, put ``rollback(A)`` in front of P;
   re-check P (§2.4).

:class:`Suspension` is step 3's rewrite, and knows which rewritten plans are
valid without a walk; steps 2 and 3's re-check are
:mod:`htnagent.upkeep.recheck`'s.  :func:`whole` is the rewrite for the other
end of a suspension: the half-done action will never be resumed.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence

from htnagent.model.actions import resume_action
from htnagent.model.domain import Domain
from htnagent.model.plans import Plan, Step
from htnagent.model.state import State
from htnagent.model.terms import Atom
from htnagent.upkeep.validity import Kept, leads_back


class Suspension:
    """Algorithm 1, step 3's rewrite of a kept plan, for the suspended ``action``.

    Called on a plan, it gives the rewritten plan, or None for a plan that started
    with the action when the action cannot be resumed.  Without ``rollbacks`` (a
    planner setting) no plan is put behind a rollback.
    """

    __slots__ = ("_domain", "action", "resume", "rollback")

    def __init__(self, domain: Domain, action: Atom, *, rollbacks: bool) -> None:
        actions = domain.actions
        self._domain = domain
        self.action = action
        self.resume = actions.resume_of(action)
        self.rollback = actions.rollback_of(action) if rollbacks else None

    def __call__(self, p: Plan) -> Plan | None:
        actions = self._domain.actions
        if p.steps and p.steps[0].action == self.action:
            if self.resume is None:
                return None
            # Algorithm 1, step 3: resume(A) takes A's place (and its record).
            first = Step(self.resume, actions.cost(self.resume), p.steps[0].record)
            return Plan((first, *p.steps[1:]))
        if self.rollback is not None:
            # Algorithm 1, step 3: undo the half-done A before the other plan.
            return Plan((Step(self.rollback, actions.cost(self.rollback), None), *p.steps))
        return p

    def kept(
        self,
        plans: Sequence[Plan],
        before: State,
        after: State,
        *,
        trusted: bool,
        untouched: Callable[[Plan], bool],
    ) -> list[Kept]:
        """Every kept plan rewritten, with whether it is known valid from ``after``.

        A plan valid from ``before`` (``trusted``: all were) stays valid when its new
        first step ends where the old one would have: ``resume(A)`` from ``after``
        where A from ``before`` ends, or ``rollback(A)`` back at ``before`` itself.
        A plan the rewrite leaves as it was is valid if it reads no fact that changed
        (``untouched``).
        """
        apply_dynamic = self._domain.actions.apply_dynamic
        action, resume = self.action, self.resume
        # Worked out once, when first needed.
        resumes_alike: bool | None = None
        rolls_back: bool | None = None
        kept: list[Kept] = []
        for p in plans:
            q = self(p)
            if q is None:
                continue
            if q is p:
                valid = untouched(p)
            elif q.steps[0].action == resume:
                if resumes_alike is None:
                    same_static = after.static is before.static
                    ended = apply_dynamic(before, action) if trusted and same_static else None
                    resumes_alike = ended is not None and apply_dynamic(after, resume) == ended
                valid = resumes_alike
            else:
                if rolls_back is None:
                    assert self.rollback is not None
                    rolls_back = trusted and leads_back(self._domain, self.rollback, before, after)
                valid = rolls_back
            kept.append(Kept(q, valid))
        return kept


def whole(domain: Domain, action: Atom) -> Callable[[Plan], Plan]:
    """The rewrite of a plan that meant to ``resume(action)`` into one doing the whole action.

    For a suspension cleared: the half-done action will never be resumed (the
    counterpart of §2.6's ``rollback(A), A`` → ``resume(A)``).
    """
    resume = resume_action(action)
    cost = domain.actions.cost(action)

    def rewrite(p: Plan) -> Plan:
        return Plan(tuple(Step(action, cost, s.record) if s.action == resume else s for s in p.steps))

    return rewrite


__all__ = ["Suspension", "whole"]
