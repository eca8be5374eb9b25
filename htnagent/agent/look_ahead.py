"""The look-ahead: work a resumption out while the action before it runs (§4, §5).

On-line mode only, and only with ``AgentConfig.look_ahead`` on (the default).  When
the running goal's last action is sent and a stacked goal will resume once it
succeeds, the look-ahead

1. updates a fork of the resuming goal's plans for that action's predicted success
   (:class:`PredictedSuccess`), and
2. works the resumption out on a fork of that (:func:`work_out_resumption`), kept on
   the goal (:attr:`GoalEntry.foreseen`);
3. tells a child agent the order the resumed plan will send first (``prepare``, a
   hint); the child plans that order — or readies its held goal for the parent's
   ``resume`` — once its own running goal has only its last action to go.

When the action's result comes and the belief is the predicted one, the agent takes
the forked plans, and then the worked-out resumption, over as they are: by identity,
with nothing compared or computed again.  Otherwise it works everything out then.

:class:`NoLookAhead` is the same interface doing nothing: naive mode, or the switch off.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import Protocol

from htnagent.agent.deferred import DeferredUpkeep
from htnagent.agent.goals import GoalEntry
from htnagent.agent.resumption import Foreseen, Resumption, work_out_resumption
from htnagent.model.actions import action_recovered_by, action_resumed_by
from htnagent.model.domain import Domain, State
from htnagent.model.plans import replay
from htnagent.model.terms import Atom
from htnagent.runtime.executor import ExecutorActor
from htnagent.runtime.messages import Order, Prepare
from htnagent.upkeep import PlanSet, SearchMemo

_ORDERS_AHEAD = 4
"""How many hinted orders' plans are kept at once (the oldest goes first)."""


class AgentView(Protocol):
    """What the look-ahead reads of its agent, and the one thing it does: send ``prepare``."""

    belief: State
    domain: Domain
    executor: ExecutorActor
    stack: list[GoalEntry]
    current: GoalEntry | None
    emergencies: list[GoalEntry]
    upkeep: DeferredUpkeep

    def order(self, below: ExecutorActor, message: Order) -> None: ...

    def held_goal(self, goal: Atom) -> GoalEntry | None: ...

    def new_plans(self, goal: Atom) -> PlanSet: ...


class NoLookAhead:
    """Nothing is worked out ahead: the agent works everything out when it is needed."""

    def has_work(self, action: Atom) -> bool:
        """Whether there is something to work out while ``action`` runs."""
        return False

    def foresee(self, action: Atom) -> bool:
        """Work out ahead what ``action``'s success leads to; whether a child was told (then
        it should be given a moment to get ready)."""
        return False

    def take_hint(self, action: Atom | None) -> None:
        """The parent hints that ``action`` is its likely next order (None: an order came)."""

    def plan_hinted_order(self) -> None:
        """Plan the hinted order ahead, if the moment has come."""

    def plans_for_order(self, action: Atom, belief: State) -> PlanSet | None:
        """The plans made ahead for the order ``action``, if made for this ``belief``."""
        return None

    def came_true(
        self, action: Atom, before: State, after: State, plans: Callable[[], list[PlanSet]]
    ) -> State | None:
        """``action`` succeeded: if as predicted, update the plan sets kept valid (``plans()``)
        taking over what was worked out ahead, and return the predicted belief (the agent's
        belief from now)."""
        return None

    def went_otherwise(self) -> None:
        """The belief went another way than predicted."""

    def foreseen_resumption(self, entry: GoalEntry, belief: State) -> Resumption | None:
        """``entry``'s resumption worked out ahead, taken over, if it holds for ``belief``."""
        return None


@dataclass
class PredictedSuccess:
    """The plan set of the goal that resumes, updated for an action's predicted success."""

    action: Atom
    before: State
    after: State
    plans: PlanSet
    fork: PlanSet
    """``plans`` updated ahead."""

    def fork_of(self, plans: PlanSet) -> PlanSet | None:
        # By identity: plan sets compare by value.
        return self.fork if plans is self.plans else None

    def came_true(self, action: Atom, before: State, after: State) -> bool:
        return (
            action == self.action
            and before is self.before
            and after.dynamic == self.after.dynamic
            and after.static is self.after.static
        )


class LookAhead(NoLookAhead):
    """On-line mode's look-ahead (see the module docstring)."""

    def __init__(self, agent: AgentView) -> None:
        self.agent = agent
        self.prediction: PredictedSuccess | None = None
        self.hint: Atom | None = None
        """The parent's likely next order, to plan when there is time (§5)."""
        self.orders_ahead: dict[Atom, tuple[tuple[object, ...], PlanSet]] = {}
        """Plans made ahead for hinted orders, each with the key of the belief they are for."""

    def has_work(self, action: Atom) -> bool:
        return self.hint is not None or self._resumes_after(action)

    def _resumes_after(self, action: Atom) -> bool:
        """Whether the running goal ends with ``action`` and a stacked goal resumes then."""
        agent = self.agent
        current = agent.current
        if current is None or not agent.stack:
            return False
        best = current.plans.best
        top = agent.stack[-1]
        return (
            best is not None
            and best.actions == (action,)
            and not top.held
            and not agent.emergencies
            and not current.stop_requested
        )

    def foresee(self, action: Atom) -> bool:
        """§4: the goal that resumes after ``action`` is updated for its predicted success
        and its resumption worked out; a child agent is told the resumed plan's first
        order (``prepare``)."""
        if not self._resumes_after(action):
            return False
        agent = self.agent
        before = agent.belief
        after = agent.domain.progress(before, action)
        top = agent.stack[-1]
        # Only the goal that resumes is worked on ahead: the other stacked goals' plans
        # are only rewritten (``lazy``), which costs no more when the result comes than
        # a copy made now would (with a thousand nested emergencies, 32 copies each).
        fork = top.plans.fork()
        fork.lazy = False
        memo = SearchMemo()  # one belief, ``after``: the update and the resumption share their searches
        fork.action_succeeded(action, before, after, memo)
        self.prediction = PredictedSuccess(action, before, after, top.plans, fork)
        best = self._foresee_resumption(top, fork.fork(), after, (action,), memo).plans.best
        if agent.executor.agent_domain is not None and best is not None and best.steps:
            # The child agent gets ready for this order too (or for resuming its goal).
            agent.order(agent.executor, Prepare(action=best.steps[0].action))
            return True
        return False

    def _foresee_resumption(
        self,
        entry: GoalEntry,
        plans: PlanSet,
        belief: State,
        done: tuple[Atom, ...],
        memo: SearchMemo | None = None,
    ) -> Resumption:
        """Work out ahead how ``entry`` resumes from ``belief`` with ``plans`` (a fork
        updated up to that belief, once the actions ``done`` have succeeded; ``memo``, the
        searches of that update)."""
        plans.lazy = False
        # A resume or rollback among the actions done settles what it finished or undid.
        settled = {a for step in done if (a := action_recovered_by(step)) is not None}
        suspended = [a for a in entry.suspended if a not in settled]
        resumption = work_out_resumption(self.agent.domain, plans, belief, suspended, memo)
        if plans.best is not None:
            # Worked out now: showing the plan at resumption, and following it, are then free.
            _ = plans.best.shown, plans.best.later_actions
        entry.foreseen = Foreseen(belief.key(), tuple(suspended), resumption)
        return resumption

    def foreseen_resumption(self, entry: GoalEntry, belief: State) -> Resumption | None:
        foreseen, entry.foreseen = entry.foreseen, None
        if foreseen is None or not foreseen.holds_for(belief, entry.suspended):
            return None
        worked_out = foreseen.resumption
        self.agent.upkeep.keep_until_sent(entry.plans.adopt(worked_out.plans))
        # The plans were checked from the belief after the clears, worked out then: take
        # that very belief as theirs (the agent takes it as its own as it clears).
        entry.plans.rebase(worked_out.clears[-1][1] if worked_out.clears else belief)
        worked_out.plans = entry.plans
        return worked_out

    def came_true(
        self, action: Atom, before: State, after: State, plans: Callable[[], list[PlanSet]]
    ) -> State | None:
        prediction = self.prediction
        if prediction is None or not prediction.came_true(action, before, after):
            return None
        # The goal that resumes was updated for this very result while the action ran:
        # take that over; the others are updated now.  The predicted belief is kept: its
        # plans and resumption are known to hold for it by identity.
        after = prediction.after
        self.prediction = None
        for ps in plans():
            fork = prediction.fork_of(ps)
            if fork is not None:
                self.agent.upkeep.keep_until_sent(ps.adopt(fork))
                ps.rebase(after)
            else:
                ps.action_succeeded(action, before, after)
        return after

    def went_otherwise(self) -> None:
        self.prediction = None

    # -- a child agent: the parent's likely next order (§5) -------------------------------

    def take_hint(self, action: Atom | None) -> None:
        self.hint = action

    def plan_hinted_order(self) -> None:
        if self.hint is not None and self._plan_order(self.hint):
            self.hint = None

    def _plan_order(self, action: Atom) -> bool:
        """Get ready for the parent's likely next order, from the belief this agent will
        have when its running goal's plan is done: plan a new goal, or work out how a
        held goal resumes.  Returns False to be asked again later: the running goal has
        more than its last action to do (ready then, the prediction rests on one action,
        and nothing worked out ahead is updated action by action meanwhile)."""
        agent = self.agent
        current = agent.current
        steps = current.plans.best.actions if current is not None and current.plans.best is not None else ()
        if len(steps) > 1:
            return False
        predicted = replay(agent.domain, agent.belief, steps)
        if predicted is None:
            return True
        inner = action_resumed_by(action)
        if inner is not None:
            held = agent.held_goal(inner)
            if held is not None:
                plans = held.plans.fork()
                state = agent.belief
                for step in steps:  # the updates the held goal's plans will get meanwhile
                    after = agent.domain.progress(state, step)
                    plans.action_succeeded(step, state, after)
                    state = after
                self._foresee_resumption(held, plans, state, steps)
            return True
        if not agent.domain.knows(action):
            return True
        ps = agent.new_plans(action)
        if ps.ensure(predicted) and ps.best is not None:
            _ = ps.best.shown, ps.best.later_actions  # worked out now: free when the order comes
        if len(self.orders_ahead) >= _ORDERS_AHEAD:
            self.orders_ahead.pop(next(iter(self.orders_ahead)))
        self.orders_ahead[action] = (predicted.key(), ps)
        return True

    def plans_for_order(self, action: Atom, belief: State) -> PlanSet | None:
        ahead = self.orders_ahead.pop(action, None)
        if ahead is not None and ahead[0] == belief.key():
            ahead[1].rebase(belief)
            return ahead[1]
        return None
