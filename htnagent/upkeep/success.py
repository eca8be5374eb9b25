"""An action finished with success (docs/design.md §2.1).

The rule: "In each plan whose first action is the executed action, that action
is removed.  A plan whose first action is some other action is kept only if it
stays valid: if the executed action has an undo operator, the undo is put in
front of it; otherwise it is re-checked."

When the action was another goal's ``resume(A)`` or ``rollback(A)``, A is no longer
half done (§3): a plan that meant to resume or roll A back does the whole A, or no
rollback, instead; and after ``resume(A)``, A's undo goes in front, as it would after A.
Re-checked all the same, such a plan is most often valid, where it would need a repair.

:func:`moved_on` is that rewrite of one plan (also applied to the plans waiting
for revival, and to a waiting goal's plans, whose re-check is deferred);
:func:`kept_after_success` rewrites every kept plan and says which are known
valid without a walk (the re-check itself is :mod:`htnagent.upkeep.recheck`'s).
"""

from __future__ import annotations

from collections.abc import Callable, Sequence

from htnagent.model.actions import (
    RESUME,
    action_recovered_by,
    action_resumed_by,
    resume_action,
    rollback_action,
)
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
    rest = tuple(_whole(domain, s) for s in steps)
    return tidy(domain, (Step(undo, domain.actions.cost(undo), None), *rest), front=True)


class MovedOn:
    """§2.1's rewrite of a plan once ``action`` succeeded: the plan that ran it moves
    on; another goes behind the action's ``undo``; None: the plan stays as it is.

    ``settles``: A, when the action was ``resume(A)`` or ``rollback(A)`` -- in another plan,
    A is no longer half done (see :func:`settled`).

    A class, not a closure: a goal waiting on the stack logs these and takes them all
    at once when it is about to run again (:func:`followed`)."""

    __slots__ = ("action", "domain", "settles", "undo")

    def __init__(self, domain: Domain, action: Atom, undo: Atom | None, settles: Atom | None = None) -> None:
        self.domain = domain
        self.action = action
        self.undo = undo
        self.settles = settles

    def __call__(self, p: Plan) -> Plan | None:
        if p.steps and p.steps[0].action == self.action:
            return p.rest()
        steps = p.steps
        if self.settles is not None and (now := settled(self.domain, self.settles, steps)) is not None:
            steps = now
        if self.undo is not None:
            return Plan(behind(self.domain, self.undo, steps))
        return Plan(steps) if steps is not p.steps else None


def moved_on(domain: Domain, action: Atom) -> MovedOn:
    """§2.1's rewrite of a plan once ``action`` succeeded (see :class:`MovedOn`)."""
    half = action_recovered_by(action)
    if half is None:
        return MovedOn(domain, action, domain.actions.undo_of(action))
    # resume(A) finished A: A's undo leads back from there, as after A itself.  (Not to
    # where A was stopped: what was planned from there is re-checked.)  rollback(A) is back.
    undo = domain.actions.undo_of(half) if action_resumed_by(action) is not None else None
    return MovedOn(domain, action, undo, half)


def settled(domain: Domain, half: Atom, steps: tuple[Step, ...]) -> tuple[Step, ...] | None:
    """``steps`` once another goal's ``resume(half)`` or ``rollback(half)`` has ended ``half``'s
    suspension (§3): a ``resume(half)`` among them does the whole action (as when the
    suspension is cleared), a ``rollback(half)`` goes -- there is no half left to resume or
    to roll back; tidied (§2.6).  None when no step resumes or rolls ``half`` back."""
    resume, rollback = resume_action(half), rollback_action(half)
    if not any(s.action == resume or s.action == rollback for s in steps):
        return None
    cost = domain.actions.cost(half)
    rest = (Step(half, cost, s.record) if s.action == resume else s for s in steps if s.action != rollback)
    return tidy(domain, tuple(rest))


def followed(
    domain: Domain, plans: Sequence[Plan], moves: Sequence[MovedOn]
) -> tuple[list[Plan], list[Step]]:
    """The plans once the actions of ``moves`` succeeded one after the other -- each
    move's rewrite in turn, a plan kept as it is where one gives None -- and the step
    each action was of the goal's own, if a plan ran it (:func:`ran`), in order.

    Made in one pass: a goal waiting through an emergency of n actions would otherwise
    copy each plan n times, a step longer each time (§2.1 puts an undo in front at
    every action).  Here the steps put in front of a plan are a stack, its own steps
    are sliced once at the end, and each new undo meets the step after it as in
    :func:`behind` (§2.6's rules, where they meet; a ``resume(A)`` behind an undo is
    costed as the whole A).
    """
    cost = domain.actions.cost
    plans = list(plans)
    fronts: list[list[Step]] = [[] for _ in plans]  # the steps put in front, the first last
    starts = [0] * len(plans)  # where each plan's own steps still left start
    behind_undo = [False] * len(plans)  # whether the plan went behind an undo
    ran_steps: list[Step] = []
    for move in moves:
        ran_step: Step | None = None
        for i, p in enumerate(plans):
            front, at = fronts[i], starts[i]
            first = front[-1] if front else p.steps[at] if at < len(p.steps) else None
            if first is not None and first.action == move.action:
                # §2.1: the plan ran the action: it moves on.
                if ran_step is None:
                    ran_step = _whole(domain, first) if behind_undo[i] else first
                if front:
                    front.pop()
                else:
                    starts[i] = at + 1
                continue
            if move.settles is not None:
                # Another goal ended a suspension this plan meant to resume or roll back
                # (rare: once a suspension): the plan is made as it stands, and settled.
                made = (*reversed(front), *p.steps[at:])
                if behind_undo[i]:
                    made = tuple(_whole(domain, s) for s in made)
                now = settled(domain, move.settles, made)
                if now is not None:
                    p = plans[i] = Plan(now)
                    front = fronts[i] = []
                    at = starts[i] = 0
                    # Costed as they stand, as one by one: a resume the settling's tidy-up
                    # makes is costed as the whole action only behind a later undo.
                    behind_undo[i] = False
                    first = p.steps[0] if p.steps else None
            if move.undo is not None:
                # §2.1: the undo goes in front and meets the step after it (§2.6).
                behind_undo[i] = True
                new = Step(move.undo, cost(move.undo), None)
                if first is None:
                    front.append(new)
                    continue
                if front:
                    front.pop()
                else:
                    starts[i] = at + 1
                front.extend(reversed(tidy(domain, (new, _whole(domain, first)))))
        if ran_step is not None:
            ran_steps.append(ran_step)
    out: list[Plan] = []
    for p, front, at, undone in zip(plans, fronts, starts, behind_undo, strict=True):
        if not undone:
            out.append(p if at == 0 else Plan(p.steps[at:]))
        else:
            out.append(Plan((*reversed(front), *(_whole(domain, s) for s in p.steps[at:]))))
    return out, ran_steps


def _whole(domain: Domain, step: Step) -> Step:
    """The step, or, if it is a ``resume(A)``, the step costed as the whole A (see :func:`behind`)."""
    # The name test first: this runs on every step of every kept plan.
    if step.action.name == RESUME and (inner := action_recovered_by(step.action)) is not None:
        return Step(step.action, domain.actions.cost(inner), step.record)
    return step


def kept_after_success(
    domain: Domain,
    plans: Sequence[Plan],
    move: MovedOn,
    before: State,
    after: State,
    *,
    trusted: bool,
    untouched: Callable[[Plan], bool],
) -> list[Kept]:
    """Every kept plan rewritten as §2.1 says (``move``), with whether it is known valid
    from ``after``.

    A plan valid from ``before`` (``trusted``: all were) that ran the action is valid
    from ``after``; so is one behind the undo, when the undo really leads back to
    ``before``; so is any other that reads no fact the action changed (``untouched``).
    A plan settled (:func:`settled`) is re-checked.
    """
    restores: bool | None = None  # whether the undo leads back: worked out when needed
    kept: list[Kept] = []
    for p in plans:
        if p.steps and p.steps[0].action == move.action:
            # §2.1: the plan that ran the action moves on.
            kept.append(Kept(p.rest(), trusted))
            continue
        settled_steps = settled(domain, move.settles, p.steps) if move.settles is not None else None
        if move.undo is not None:
            # §2.1: another plan stays valid by undoing the action first.
            if restores is None:
                restores = trusted and leads_back(domain, move.undo, before, after)
            q = Plan(behind(domain, move.undo, p.steps if settled_steps is None else settled_steps))
            kept.append(Kept(q, restores and settled_steps is None))
        elif settled_steps is not None:
            kept.append(Kept(Plan(settled_steps), False))
        else:
            kept.append(Kept(p, untouched(p)))
    return kept


__all__ = ["MovedOn", "behind", "followed", "kept_after_success", "moved_on", "ran", "settled"]
