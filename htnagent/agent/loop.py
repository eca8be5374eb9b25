"""A planning agent: the published Algorithms 2–5 as one coroutine loop.

The agent has a belief, a domain, the running goal (:attr:`Agent.current`), a
stack of suspended goals, a LIFO list of emergencies that have arrived, a FIFO
list of waiting normal goals and, as its parent's executor, a queue of the
parent's orders.  :meth:`Agent.run` loops; each turn it reads every message that
has arrived, then either starts the next goal or takes one step of the running one:

- **Algorithm 2** (:meth:`Agent._step`): make sure the goal has plans, select
  the cheapest, send its first action to the executor, wait for the result,
  update the belief and *all* plan sets (the running goal's and every stacked
  goal's, through :class:`~htnagent.upkeep.PlanSet`).  A resumed goal's plans
  are worked out by :func:`~htnagent.agent.resumption.work_out_resumption`.
- **Algorithm 3**: an emergency that arrives while an action runs asks the
  executor to suspend it (if the domain can follow that); when the action's
  result is in, the running goal is pushed on the stack with its plans and its
  suspended action, and the emergency runs.  When nothing is left above it, the
  stacked goal is popped and resumed.  Emergencies nest on the explicit stack
  (no recursion), up to :attr:`AgentConfig.max_depth`.
- **Algorithm 4** (:meth:`Agent._start_next`): a normal goal starts when it is
  first in the waiting list, nothing runs and the stack is empty.
- **Algorithm 5**: as its parent's executor the agent treats ``execute`` as a
  goal; on ``suspend`` it stops that goal after the running action (suspending
  the action if it can) and reports ``suspended`` — it never refuses; the goal
  then waits on the stack, *held* for the parent's ``resume`` or ``clear``,
  while the agent carries out whatever else the parent sends.

The mode (:mod:`~htnagent.agent.modes`) is an object chosen once; the stacked goals'
upkeep waits off the critical path (:mod:`~htnagent.agent.deferred`); the
look-ahead (:mod:`~htnagent.agent.look_ahead`) works resumptions out early.
"""

from __future__ import annotations

import functools
import itertools
import time
from collections import deque
from collections.abc import Callable
from dataclasses import replace

import anyio
import anyio.lowlevel
from anyio.abc import TaskStatus

from htnagent.agent.config import AgentConfig
from htnagent.agent.deferred import DeferredUpkeep
from htnagent.agent.goals import GoalEntry, GoalStatus, Running
from htnagent.agent.modes import mode_of
from htnagent.agent.resumption import Resumption, work_out_resumption
from htnagent.model.actions import ROLLBACK, action_recovered_by, action_resumed_by
from htnagent.model.domain import State
from htnagent.model.plans import Plan
from htnagent.model.terms import Atom
from htnagent.runtime.clock import Clock
from htnagent.runtime.events import (
    ActionFinished,
    ActionStarted,
    GoalCleared,
    GoalFinished,
    GoalReceived,
    GoalResumed,
    GoalSuspended,
    PlanSelected,
    SuspendRefused,
)
from htnagent.runtime.executor import ExecutorActor
from htnagent.runtime.messages import (
    BeliefUpdate,
    Clear,
    Execute,
    Failure,
    Message,
    ParentLost,
    Prepare,
    Refused,
    Resume,
    Submit,
    Success,
    Suspend,
    Suspended,
    Timeout,
)
from htnagent.runtime.progress import Phase, Progress
from htnagent.runtime.trace import Trace
from htnagent.upkeep import PlanningStats, PlanSet, SearchMemo

OutcomeCallback = Callable[[int, GoalStatus, str], None]
Result = Success | Failure | Suspended


class Agent(ExecutorActor):
    """One planning agent: a belief, a domain, goals, a stack, and an executor below."""

    def __init__(
        self,
        config: AgentConfig,
        clock: Clock,
        trace: Trace,
        executor: ExecutorActor,
        on_outcome: OutcomeCallback | None = None,
    ) -> None:
        super().__init__(config.name, clock, trace)
        self.config = config
        self.domain = config.domain
        # How a parent learns that its executor is an agent (ExecutorActor.agent_domain).
        self.agent_domain = self.domain
        self.belief = config.belief
        self.mode = mode_of(config)
        self.executor = executor
        executor.connect(self.inbox)
        self.on_outcome = on_outcome
        self.settings = config.settings
        child = executor.agent_domain
        if child is not None and ROLLBACK not in child.methods:
            # §5: a rollback(A) of an action a child agent carries out is offered only as a
            # task the child can plan.
            self.settings = replace(config.settings, rollbacks=False)
        self.stats = PlanningStats()
        self.waiting: deque[GoalEntry] = deque()
        self.emergencies: list[GoalEntry] = []
        self.orders: deque[Execute | Resume | Clear] = deque()
        self.stack: list[GoalEntry] = []
        self.current: GoalEntry | None = None
        self.running: Running | None = None
        self.upkeep = DeferredUpkeep()
        self.look_ahead = self.mode.look_ahead(self)
        self._seq = itertools.count(1)
        self._arrivals = itertools.count(1)
        self._orphaned = False
        self._shown: tuple[Atom, ...] | None = None
        self._done: Atom | None = None  # the running goal's last action, when it succeeded

    # -- the loop ------------------------------------------------------------------------

    async def run(self, *, task_status: TaskStatus[None] = anyio.TASK_STATUS_IGNORED) -> None:
        """Take the next goal, or one step of the running one; with nothing to do, catch
        up on the deferred upkeep and wait for a message."""
        task_status.started()
        while True:
            self._drain()
            entry = self.current
            if entry is not None:
                await self._step(entry)
            elif not self._start_next():
                self.upkeep.let_go()
                self._catch_up()  # nothing to do but wait: keep the stacked plans up to date now
                self._on_message(await self.inbox.receive())

    def _drain(self) -> None:
        """§4: every message that has arrived is seen before the next decision."""
        while (message := self.inbox.receive_nowait()) is not None:
            self._on_message(message)

    def _catch_up(self) -> None:
        """§4: run the upkeep that waited, then plan the parent's hinted order (§5)."""
        self.upkeep.run()
        self.look_ahead.plan_hinted_order()

    # -- Algorithm 4 (and 3, 5): which goal runs next --------------------------------------------

    def _start_next(self) -> bool:
        """Make the next goal the running one; False when there is none."""
        top = self.stack[-1] if self.stack and not self.stack[-1].held else None
        if self.emergencies and (top is None or self.emergencies[-1].arrival > top.arrival):
            # Algorithm 3: the latest emergency first (two in one instant: the later one).
            # One that came before the goal on top of the stack waits under it, as it
            # would have had that goal not been suspended (by a still later emergency).
            self._begin(self.emergencies.pop())
            return True
        if top is not None:
            # Algorithm 3: nothing is left above the suspended goal: pop and resume it.
            self._resume(self.stack.pop())
            return True
        while self.orders:
            if self._take_order(self.orders.popleft()):
                return True
        if self.waiting and not self.stack:
            # Algorithm 4: a normal goal starts when first, nothing runs and the stack is empty.
            self._begin(self.waiting.popleft())
            return True
        return False

    def _begin(self, entry: GoalEntry) -> None:
        """Algorithm 2: ``entry`` is the running goal from now."""
        self.current = entry
        entry.plans.lazy = False  # the running goal's plans are repaired at once
        self._shown = None
        self._done = None

    def _take_order(self, order: Execute | Resume | Clear) -> bool:
        """Algorithm 5: the parent's orders while this agent is its executor; whether a
        goal runs now."""
        if isinstance(order, Execute):
            return self._take_execute(order)
        held = self.held_goal(order.action)
        if isinstance(order, Resume):
            if held is None:
                reason = f"nothing to resume for {order.action}"
                self.reply(Failure(action=order.action, seq=order.seq, reason=reason))
                return False
            # Algorithm 5: on resume, pop the goal and go on with it.
            self.stack.remove(held)
            held.held = False
            held.order_seq = order.seq
            self._resume(held)
            return True
        # Algorithm 5: on clear, drop the goal, its plans and its suspended action.
        if held is not None:
            self.stack.remove(held)
            self._clear_suspended(held)
            self.upkeep.keep_until_sent(held)
            self.trace.emit(GoalCleared(agent=self.name, goal=str(held.goal)))
        return False

    def _take_execute(self, order: Execute) -> bool:
        """Algorithm 5: the parent's ``execute`` is a goal of this agent's."""
        self.trace.emit(GoalReceived(agent=self.name, goal=str(order.action), emergency=False))
        if not self.domain.knows(order.action):
            reason = f"{self.name} cannot do {order.action}"
            self.reply(Failure(action=order.action, seq=order.seq, reason=reason))
            return False
        plans = self.look_ahead.plans_for_order(order.action, self.belief)
        if plans is None:
            plans = self.new_plans(order.action)
        entry = GoalEntry(order.action, plans, order_seq=order.seq)
        entry.arrival = next(self._arrivals)
        self._begin(entry)
        return True

    def held_goal(self, goal: Atom) -> GoalEntry | None:
        """The stacked goal held for the parent's resume or clear of ``goal``, if any."""
        for entry in reversed(self.stack):
            if entry.held and entry.goal == goal:
                return entry
        return None

    # -- Algorithm 2: one step of the running goal ----------------------------------------------

    async def _step(self, entry: GoalEntry) -> None:
        """Algorithm 2, one turn of its loop for the running goal::

        if a plan has run to its end: the goal succeeded
        if a later emergency came (or the parent asked): suspend the goal (Algorithm 3)
        make sure of a plan (none: the goal failed); select the cheapest
        send its first action; wait for the result; update belief and all plans
        """
        ps = entry.plans
        if ps.finished:
            # A plan ran to its end while this goal was running: achieved (§2.8), even if
            # an emergency or a suspension came with the last result.
            self._end(entry, GoalStatus.SUCCESS)
            return
        if entry.stop_requested or (
            self.emergencies and any(e.arrival > entry.arrival for e in self.emergencies)
        ):
            self._on_emergency(entry)
            return
        best = self._select(entry)
        if best is None:
            return
        action = best.steps[0].action
        self._shown = best.later_actions
        result, asked = await self._act(action)
        self._done = action if isinstance(result, Success) and self.current is entry else None
        if isinstance(result, Success) or (isinstance(result, Suspended) and asked):
            entry.failures.pop(action, None)
            return
        self._count_failure(entry, action, result)

    def _select(self, entry: GoalEntry) -> Plan | None:
        """Algorithm 2: make sure the goal has a plan and select the cheapest (traced when
        it changed); None when the goal has ended here."""
        ps = entry.plans
        # §2.4: a way opened from outside since its plan was made (a door, while the action
        # ran) is weighed now, before the next action — where naive, had its plan broken
        # meanwhile, would plan afresh with the door open.
        ps.reconsider(self.belief)
        if not ps.ensure(self.belief):
            status = ps.last_status.value if ps.last_status else "none"
            # No plan from here: the parent should not ask the same again from its belief.
            self._end(entry, GoalStatus.FAILURE, f"no plan for {entry.goal} ({status})", permanent=True)
            return None
        if _achieved(ps):  # a plan made just now has nothing left to do
            self._end(entry, GoalStatus.SUCCESS)
            return None
        best = ps.best
        assert best is not None
        first = best.steps[0]
        if (
            self._done is not None
            and first.record is None  # a step plan upkeep put in front
            and first.action == self.domain.actions.undo_of(self._done)
            and ps.shorten_detours(self.belief)
        ):
            # §2.1 put the undo of the action just done in front of a plan made (repaired)
            # while it ran: from where the action ended, the goal's own way may be shorter
            # than walking back (§2.4: no worse than naive, which plans afresh here).
            best = ps.best
            assert best is not None
        # What was shown, less the actions done since: the same tuple while the plan just
        # moves on (Plan.later_actions), else compared.
        actions = best.actions
        if self._shown is None or (actions is not self._shown and actions != self._shown):
            self.trace.emit(
                PlanSelected(agent=self.name, goal=str(entry.goal), plan=best.shown, cost=round(best.cost, 6))
            )
        return best

    def _count_failure(self, entry: GoalEntry, action: Atom, result: Failure | Suspended) -> None:
        """Algorithm 2: the action failed (or the executor stopped it unasked: its belief
        follows, but the action did not get done); the goal fails when the same action
        keeps failing from the same belief."""
        self._shown = None
        if isinstance(result, Failure) and result.permanent:
            # §5: what the executor says it cannot do from here is not planned again from
            # the same belief (a child agent found no plan for it).
            entry.plans.cannot_do(action, self.belief)
        why = result.reason if isinstance(result, Failure) else "the executor stopped it unasked"
        # In a row means from the same belief: a failure long ago, from elsewhere, says
        # nothing about trying now.
        key = self.belief.key()
        last = entry.failures.get(action)
        failures = last[1] + 1 if last is not None and last[0] == key else 1
        entry.failures[action] = (key, failures)
        if failures >= self.config.max_failures:
            # The same action keeps failing although the belief says it can run.
            times = "once" if failures == 1 else f"{failures} times"
            self._end(entry, GoalStatus.FAILURE, f"{action} failed {times}: {why}")

    # -- Algorithm 3 (and 5): suspend and push; pop and resume ----------------------------------

    def _on_emergency(self, entry: GoalEntry) -> None:
        """Algorithm 3: an emergency that arrived after the running goal (or the parent's
        ``suspend``, Algorithm 5) suspends it; one that arrived with it, in the same
        instant, waits until it has ended."""
        ps = entry.plans
        if not ps.plans and ps.ensure(self.belief) and _achieved(ps):
            # Its plans were lost while the last action ran (a door shut on the robot's
            # arc), but that action achieved it (§2.8): it ended, it is not suspended.
            self._end(entry, GoalStatus.SUCCESS)
            return
        self._suspend_current(entry)

    def _suspend_current(self, entry: GoalEntry) -> None:
        """Algorithm 3 / 5: push the running goal with its plans and suspended action."""
        held = entry.stop_requested
        entry.stop_requested = False
        if held and self._orphaned:
            self.current = None
            self._drop_held(entry)  # its parent is gone: nobody will resume it
            return
        entry.held = held
        self._push(entry)
        self.current = None
        self.trace.emit(GoalSuspended(agent=self.name, goal=str(entry.goal), stack_depth=len(self.stack)))
        if held:
            assert entry.order_seq is not None
            self.reply(Suspended(action=entry.goal, seq=entry.order_seq))

    def _push(self, entry: GoalEntry) -> None:
        """Algorithm 3: push ``entry`` on the stack; its plans are kept valid while it waits."""
        self.stack.append(entry)
        entry.plans.lazy = True  # see PlanSet.lazy: made good when it is about to run again
        sunk = len(self.stack) - 1 - self.config.maintained_depth
        if sunk >= 0:
            # Too deep to keep up (see AgentConfig.maintained_depth): planned afresh if it
            # comes back to the top.
            self.stack[sunk].plans.drop()

    def _resume(self, entry: GoalEntry) -> None:
        """Algorithm 2 for a resumed goal: take its plans up as the mode does (on-line
        reuses them, naive plans afresh), or take over the resumption worked out ahead;
        then clear the suspended actions the selected plan does not need."""
        started = time.perf_counter()
        self._catch_up()  # whatever upkeep still waits, before the kept plans are used
        self._begin(entry)
        resumption = self.look_ahead.foreseen_resumption(entry, self.belief)
        if resumption is None:
            self.mode.take_up(entry.plans)
            resumption = work_out_resumption(self.domain, entry.plans, self.belief, entry.suspended)
        self._carry_out(entry, resumption)
        # docs/contracts.md: wall-clock time spent making the resumed goal's plan.
        replan_ms = (time.perf_counter() - started) * 1000
        self.trace.emit(
            GoalResumed(
                agent=self.name,
                goal=str(entry.goal),
                replanning=self.mode.name,
                replan_ms=round(replan_ms, 4),
            )
        )

    def _carry_out(self, entry: GoalEntry, resumption: Resumption) -> None:
        """Algorithm 2: the selected plan will not resume these actions: clear them below;
        the belief takes each clear as worked out, and the other goals' plans follow."""
        for clear, after in resumption.clears:
            action = clear.action
            entry.suspended.remove(action)
            self.order(self.executor, clear)
            before, self.belief = self.belief, after
            update = functools.partial(_cleared, action, before, after)
            self._maintain(update, skip=entry.plans)  # its own plans were worked out with it

    def _clear_suspended(self, entry: GoalEntry, actions: list[Atom] | None = None) -> None:
        """Tell the executor to forget the goal's suspended actions (all, by default)."""
        for action in list(entry.suspended if actions is None else actions):
            entry.suspended.remove(action)
            self.order(self.executor, Clear(action=action))
            self._forget_half(action)

    def _forget_half(self, action: Atom) -> None:
        """The half-done ``action`` will not be resumed: update the belief and all plans."""
        before = self.belief
        self.belief = self.domain.clear(before, action)
        self._maintain(functools.partial(_cleared, action, before, self.belief))

    def _holder(self, action: Atom) -> GoalEntry | None:
        """The goal whose suspended action ``action`` is: the running one's, else the latest."""
        running = [self.current] if self.current is not None else []
        for entry in [*running, *reversed(self.stack)]:
            if action in entry.suspended:
                return entry
        return None

    # -- Algorithm 2: acting ---------------------------------------------------------------

    async def _act(self, action: Atom) -> tuple[Result, bool]:
        """Carry out the action; its result, and whether a suspension of it was asked for."""
        running = self._send(action)
        try:
            if self.upkeep.pending or self.look_ahead.has_work(action):
                await self._while_it_runs(action)
            result = await self._await_result(running)
            if isinstance(result, Suspended) and not self.domain.can_suspend(action):
                # The executor stopped half way an action the domain says cannot be: the
                # belief cannot follow, and nothing will resume it.  It failed.
                self.order(self.executor, Clear(action=running.ordered))
                reason = f"the executor stopped {action} half way, which cannot be suspended"
                result = Failure(action=action, seq=running.seq, reason=reason)
        finally:
            if running.timer is not None:
                running.timer.cancel()
            self.running = None
        self._update(action, result, running.suspend_sent)
        reason = result.reason if isinstance(result, Failure) else ""
        self.trace.emit(
            ActionFinished(agent=self.name, action=str(action), result=result.kind, reason=reason)
        )
        if isinstance(result, Success):
            self.progress.report(Progress(self.name, action, Phase.SUCCEEDED))
        return result, running.suspend_sent

    def _send(self, action: Atom) -> Running:
        """Algorithm 2: order the action (``resume`` for ``resume(A)``) from the executor."""
        seq = next(self._seq)
        inner = action_resumed_by(action)
        ordered = inner if inner is not None else action
        if inner is not None:
            self.order(self.executor, Resume(action=inner, seq=seq))
        else:
            self.order(self.executor, Execute(action=action, seq=seq))
        running = Running(seq, action, ordered)
        if self.config.action_timeout is not None and self.executor.agent_domain is None:
            running.timer = self.clock.call_later(
                self.config.action_timeout, lambda: self.inbox.send(Timeout(seq=seq))
            )
        self.running = running
        self.trace.emit(ActionStarted(agent=self.name, action=str(action)))
        return running

    async def _while_it_runs(self, action: Atom) -> None:
        """§4: the order is on its way; the work kept off the critical path runs now
        (called when there is some: deferred upkeep, or something to work out ahead).

        The order passes one mailbox per level below on its way to the robot, and
        nothing answers its arrival: the agent lets the event loop run once per level
        (:meth:`levels_below`) so that the order reaches the robot before anything
        else is done.  Then it lets go of what is spent, runs the deferred upkeep and
        works out ahead what this action's success leads to — unless an emergency came
        meanwhile (given as the order reached the robot): that is seen first, and the
        upkeep waits for the next order.
        """
        for _ in range(self.executor.levels_below()):
            await anyio.lowlevel.checkpoint()
        self.upkeep.let_go()
        if any(isinstance(m, Submit) and m.emergency for m in self.inbox.waiting()):
            return
        self._catch_up()
        if self.look_ahead.foresee(action):
            await anyio.lowlevel.checkpoint()  # the child agent gets ready meanwhile

    def levels_below(self) -> int:
        return 1 + self.executor.levels_below()

    async def _await_result(self, running: Running) -> Result:
        """Algorithm 2: wait for ``success``, ``failure`` or ``suspended``; other messages
        are taken in meanwhile (an emergency asks for a suspension at once, Algorithm 3)."""
        while True:
            message = await self.inbox.receive()
            if isinstance(message, Success | Failure | Suspended) and message.seq == running.seq:
                return message
            if isinstance(message, Refused) and message.seq == running.seq:
                # The executor cannot stop the action: it runs to its end, and then
                # nothing further of the running goal starts (Algorithm 3).
                self.trace.emit(SuspendRefused(agent=self.name, action=str(running.action)))
                continue
            if isinstance(message, Timeout) and message.seq == running.seq:
                # A hung executor: the action counts as failed; a late answer is ignored.
                self.order(self.executor, Clear(action=running.ordered))
                return Failure(
                    action=running.action,
                    seq=running.seq,
                    reason=f"timeout: no answer within {self.config.action_timeout} s",
                )
            self._on_message(message)

    # -- on a result: keep the plans valid (§2, §3) ----------------------------------------------

    def _update(self, action: Atom, result: Result, asked: bool) -> None:
        """Update the belief and every plan set, active and stacked (§2, §3).

        ``asked``: a suspension of the action was asked for (the running goal will be
        stacked).
        """
        if isinstance(result, Success):
            self._succeeded(action)
        elif isinstance(result, Suspended):
            self._suspended(action, asked)
        else:
            self._failed(action)

    def _succeeded(self, action: Atom) -> None:
        """§2.1: the action succeeded."""
        before = self.belief
        after = self.belief = self.domain.progress(before, action)
        predicted = self.look_ahead.came_true(action, before, after, self._plansets)
        if predicted is not None:
            self.belief = predicted  # the plans worked out ahead hold for it by identity
        else:
            self._maintain(lambda ps, memo: ps.action_succeeded(action, before, after, memo))
        inner = action_recovered_by(action)
        if inner is not None:
            # The half-done action was finished or undone: nothing is left to clear.
            holder = self._holder(inner)
            if holder is not None:
                holder.suspended.remove(inner)

    def _suspended(self, action: Atom, asked: bool) -> None:
        """Algorithm 1: the action was stopped half way."""
        inner = action_recovered_by(action)
        if inner is not None:
            # Algorithm 3: stopping resume(A) or rollback(A) leaves A suspended, as the
            # belief and every plan already say; whoever held A still holds it.
            if self._holder(inner) is None and self.current is not None:
                self.current.suspended.append(inner)
            return
        # Algorithm 1, step 1: the belief takes the suspension effect.
        before = self.belief
        after = self.belief = self.domain.suspend(before, action)
        # The running goal is being suspended: its own update (Algorithm 1) can wait
        # until the emergency's first action is on its way (§4, Algorithm 3).
        self._maintain(lambda ps, memo: ps.action_suspended(action, before, after, memo), eager=not asked)
        if self.current is not None:
            self.current.suspended.append(action)

    def _failed(self, action: Atom) -> None:
        """§2.2: the action failed."""
        before = self.belief
        self._maintain(lambda ps, memo: ps.action_failed(action, before, before, memo))
        inner = action_resumed_by(action)
        if inner is not None:
            # The executor could not finish A: what was kept for it is no use, and the
            # same resume must not be planned again from the same belief (§5).
            holder = self._holder(inner)
            if holder is not None:
                holder.suspended.remove(inner)
            self.order(self.executor, Clear(action=inner))
            self._forget_half(inner)

    def _maintain(
        self,
        update: Callable[[PlanSet, SearchMemo], None],
        *,
        eager: bool = True,
        skip: PlanSet | None = None,
    ) -> None:
        """Apply a belief change to every plan set kept valid (§2), in event order.

        The running goal's plans are updated now (``eager``): its next action is
        chosen from them.  The stacked goals' updates are deferred
        (:class:`~htnagent.agent.deferred.DeferredUpkeep`) — keeping them valid must
        not delay the agent's reaction (§4, Algorithm 3).  The stacked goals often
        repeat: one memo lets their searches be shared.
        """
        self.look_ahead.went_otherwise()
        memo = SearchMemo()
        now = self.current.plans if eager and self.current is not None else None
        for ps in self._plansets():
            if ps is skip:
                continue
            if ps is now:
                update(ps, memo)
            else:
                self.upkeep.defer(functools.partial(update, ps, memo))

    def _plansets(self) -> list[PlanSet]:
        """The plan sets kept valid: the running goal's and the top stacked goals' (§2)."""
        deep = max(len(self.stack) - self.config.maintained_depth, 0)
        kept = self.stack[deep:]
        current = self.current
        if current is not None and current not in self.stack:  # by identity (eq=False)
            kept.append(current)
        return [e.plans for e in kept]

    # -- messages -------------------------------------------------------------------------------

    def _on_message(self, message: Message) -> None:
        """Take one message in: a goal, a parent's order or hint, or a change of the world."""
        if isinstance(message, Submit):
            self._submitted(message)
        elif isinstance(message, Execute | Resume | Clear):
            if isinstance(message, Execute):
                self._orphaned = False  # a parent orders again (one in another process came back)
            self.orders.append(message)
            self.look_ahead.take_hint(None)  # the order the hint foretold (or another) has come
        elif isinstance(message, Suspend):
            self._parent_suspends(message)
        elif isinstance(message, Prepare):
            self.look_ahead.take_hint(message.action)  # planned when there is time (_catch_up)
        elif isinstance(message, ParentLost):
            self._parent_lost()
        elif isinstance(message, BeliefUpdate):
            # §2.3: the belief changed from outside; every plan follows.
            before = self.belief
            after = self.belief = before.updated(message.add, message.delete)
            self._maintain(lambda ps, memo: ps.belief_changed(before, after, memo))
        # Anything else is a late answer to an abandoned order: ignored.

    def _submitted(self, message: Submit) -> None:
        """A goal arrives: a normal one waits its turn (Algorithm 4), an emergency
        suspends the running goal (Algorithm 3)."""
        entry = GoalEntry(message.goal, self.new_plans(message.goal), message.emergency, message.ticket)
        entry.arrival = next(self._arrivals)
        self.trace.emit(
            GoalReceived(
                agent=self.name, goal=str(message.goal), emergency=message.emergency, ticket=message.ticket
            )
        )
        if not self.domain.knows(message.goal):
            self._end(entry, GoalStatus.FAILURE, f"{self.name} has no method or operator for {message.goal}")
            return
        if not message.emergency:
            self.waiting.append(entry)
            return
        depth = len(self.stack) + len(self.emergencies) + (self.current is not None)
        if depth >= self.config.max_depth:
            limit = self.config.max_depth
            self._end(entry, GoalStatus.FAILURE, f"too many nested goals: {depth} (max_depth {limit})")
            return
        self.emergencies.append(entry)
        # Algorithm 3: mark the running goal suspended; suspend its action if it can be.
        self._request_suspension()

    def _parent_suspends(self, message: Suspend) -> None:
        """Algorithm 5: the parent wants its order stopped; the answer is never a refusal."""
        current = self.current
        if current is not None and current.order_seq == message.seq:
            current.stop_requested = True
            self._request_suspension()
            return
        for entry in self.stack:
            if entry.order_seq == message.seq:
                # Already stacked under an emergency of this agent's own: suspended at once.
                if not entry.held:
                    entry.held = True
                    self.reply(Suspended(action=entry.goal, seq=message.seq))
                return
        for order in self.orders:
            if isinstance(order, Execute) and order.seq == message.seq:
                # Not started yet: it waits on the stack without having done anything.
                self.orders.remove(order)
                entry = GoalEntry(order.action, self.new_plans(order.action), order_seq=order.seq, held=True)
                self.trace.emit(GoalReceived(agent=self.name, goal=str(order.action), emergency=False))
                self._push(entry)
                self.trace.emit(
                    GoalSuspended(agent=self.name, goal=str(entry.goal), stack_depth=len(self.stack))
                )
                self.reply(Suspended(action=entry.goal, seq=message.seq))
                return
        # The order has already ended: its result is on its way up.

    def _parent_lost(self) -> None:
        """Drop what the parent ordered: its held goals now, its running order after the
        running action (nothing of it starts again), its orders not yet taken."""
        self._orphaned = True
        self.orders.clear()
        for entry in [e for e in self.stack if e.held]:
            self._drop_held(entry)
        current = self.current
        if current is not None and current.order_seq is not None:
            current.stop_requested = True
            self._request_suspension()

    def _drop_held(self, entry: GoalEntry) -> None:
        if entry in self.stack:
            self.stack.remove(entry)
        self._clear_suspended(entry)
        self.trace.emit(GoalCleared(agent=self.name, goal=str(entry.goal)))

    def _request_suspension(self) -> None:
        """Ask the executor to stop the running action half way, if the belief can follow."""
        running = self.running
        if running is None or running.suspend_sent:
            return
        if not self.domain.can_suspend(running.action):
            return  # it runs to its end; nothing further of the goal starts
        running.suspend_sent = True
        self.order(self.executor, Suspend(action=running.ordered, seq=running.seq))

    # -- outcomes --------------------------------------------------------------------------------

    def new_plans(self, goal: Atom) -> PlanSet:
        """A plan set for ``goal``, keeping plans as the agent's mode does."""
        return self.mode.plan_set(self.domain, goal, self.settings, self.stats)

    def _end(
        self, entry: GoalEntry, status: GoalStatus, reason: str = "", *, permanent: bool = False
    ) -> None:
        """The goal has ended: report it (once) to whoever is waiting for it.

        ``permanent``: it failed because there is no plan for it from the belief.
        """
        if self.current is entry:
            self.current = None
        self.upkeep.keep_until_sent(entry)
        # What was kept below for resuming the goal's stopped actions is of no use now.
        self._clear_suspended(entry)
        if status is GoalStatus.FAILURE:
            reason = reason or "failed"
        # The outcome is settled before the event, so observers see it settled.
        if entry.ticket is not None and self.on_outcome is not None:
            self.on_outcome(entry.ticket, status, reason if status is GoalStatus.FAILURE else "")
        self.trace.emit(
            GoalFinished(
                agent=self.name,
                goal=str(entry.goal),
                status="success" if status is GoalStatus.SUCCESS else "failure",
                ticket=entry.ticket,
                reason=reason if status is GoalStatus.FAILURE else "",
            )
        )
        if entry.order_seq is not None:
            if status is GoalStatus.SUCCESS:
                self.reply(Success(action=entry.goal, seq=entry.order_seq))
            else:
                failure = Failure(action=entry.goal, seq=entry.order_seq, reason=reason, permanent=permanent)
                self.reply(failure)

    def executor_crashed(self, reason: str) -> None:
        """The executor below crashed: the action it was running has failed."""
        running = self.running
        if running is not None:
            self.inbox.send(Failure(action=running.action, seq=running.seq, reason=reason))

    def unfinished(self) -> list[GoalEntry]:
        """Every goal that has not ended: running, stacked, emergencies, waiting."""
        running = [self.current] if self.current is not None else []
        return [*running, *reversed(self.stack), *reversed(self.emergencies), *self.waiting]

    def fail_all(self, reason: str) -> None:
        """End every unfinished goal and order as a failure (the agent cannot go on)."""
        for entry in self.unfinished():
            self._end(entry, GoalStatus.FAILURE, reason)
        self.current = None
        self.stack.clear()
        self.emergencies.clear()
        self.waiting.clear()
        for order in self.orders:
            if isinstance(order, Execute | Resume):
                self.reply(Failure(action=order.action, seq=order.seq, reason=reason))
        self.orders.clear()

    def submit(self, goal: Atom, ticket: int, emergency: bool = False) -> None:
        """Give the agent a goal (delivered through its mailbox)."""
        self.inbox.send(Submit(goal=goal, emergency=emergency, ticket=ticket))


def _achieved(plans: PlanSet) -> bool:
    # A function, not the property inline: a type checker would take the second look at
    # ``plans.finished`` in one step as unreachable after the first.
    return plans.finished


def _cleared(action: Atom, before: State, after: State, plans: PlanSet, memo: SearchMemo) -> None:
    plans.suspension_cleared(action, before, after, memo)
