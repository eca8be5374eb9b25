"""A planning agent: the published Algorithms 2–5 as one coroutine loop.

The agent has a belief, a domain, the running goal (:attr:`Agent.current`), a
stack of suspended goals, a LIFO list of emergencies that have arrived, a FIFO
list of waiting normal goals and, as its parent's executor, a queue of the
parent's orders.  :meth:`Agent.run` loops; each turn it either starts the next
goal or takes one step of the running one:

- **Algorithm 2** (:meth:`Agent._step`): make sure the goal has plans, select
  the cheapest, send its first action to the executor, wait for the result,
  update the belief and *all* plan sets (the running goal's and every stacked
  goal's, through :class:`~htnagent.upkeep.PlanSet`).
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

Every message that has arrived is taken into account before the next action is
sent (:meth:`Agent._drain`).
"""

from __future__ import annotations

import functools
import itertools
import math
import time
from collections import deque
from collections.abc import Callable
from dataclasses import dataclass, field, replace
from enum import Enum

import anyio
import anyio.lowlevel
from anyio.abc import TaskStatus

from htnagent.errors import SettingsError
from htnagent.model.actions import ROLLBACK, half_done, resumed
from htnagent.model.domain import Domain, State
from htnagent.model.plans import replay
from htnagent.model.terms import Atom
from htnagent.planning.planner import PlannerSettings
from htnagent.runtime.clock import Clock, TimerHandle
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
from htnagent.upkeep import PlanningStats, PlanSet, Replanning, SearchMemo, new_plan_set

OutcomeCallback = Callable[[int, "GoalStatus", str], None]


class GoalStatus(Enum):
    """How a goal ended."""

    SUCCESS = "success"
    """The goal was achieved: a plan for it ran to its end while it was the running goal, or
    a plan made for it from the belief has nothing left to do (it holds now, §2.8)."""
    FAILURE = "failure"
    """No plan was left for the goal, an action kept failing, or the agent could not go on."""


@dataclass(eq=False)
class GoalEntry:
    """A goal with its plans; on the stack it also keeps its suspended action.

    Entries compare by identity: the same goal may be on the stack twice.
    """

    goal: Atom
    plans: PlanSet
    emergency: bool = False
    ticket: int | None = None
    order_seq: int | None = None
    """The parent's order this goal carries out (Algorithm 5), if any."""
    suspended: list[Atom] = field(default_factory=list)
    """Actions of this goal stopped half way and kept for ``resume(A)`` (oldest first).

    Usually one; more when a resumed goal walks back to finish an action later and
    is suspended again on the way."""
    held: bool = False
    """On the stack by the parent's ``suspend``: it waits for the parent's resume or clear."""
    stop_requested: bool = False
    """The parent asked to suspend this goal; it stops after the running action."""
    failures: dict[Atom, tuple[tuple[object, ...], int]] = field(default_factory=dict)
    """Failures in a row per action, from one belief: (that belief, count)."""
    arrival: int = 0
    """When the goal arrived, as a count: only a later emergency suspends it."""
    ready: _Ready | None = None
    """How it resumes, worked out ahead while the action before that ran (§4)."""


@dataclass
class _Running:
    seq: int
    action: Atom
    ordered: Atom  # what the executor was told: A for resume(A), else the action itself
    timer: TimerHandle | None = None
    suspend_sent: bool = False


@dataclass
class AgentConfig:
    """What an agent needs besides its executor."""

    name: str
    domain: Domain
    belief: State
    replanning: Replanning = Replanning.ONLINE
    settings: PlannerSettings = field(default_factory=PlannerSettings)
    action_timeout: float | None = None
    """Simulated seconds after which an action that got no answer counts as failed.

    It applies to an agent whose executor is not an agent (the robot, or a user's
    executor): an order to a child agent is a whole goal and takes as long as it takes.
    """
    max_failures: int = 3
    """How often in a row (from the same belief) the same action may fail before the goal fails."""
    max_depth: int = 10_000
    """How many goals the stack may hold; an emergency beyond that fails at once."""
    maintained_depth: int = 32
    """How many of the stack's top goals keep their plans valid after every event.

    Keeping a stacked goal's plans valid costs work at every action (§2); a storm of
    emergencies nested hundreds deep would make each action cost as much as the
    stack is deep.  Goals deeper than this let their plans go and are planned afresh
    if they come back to the top (as in naive replanning).  No real use nests so deep.
    """

    def __post_init__(self) -> None:
        timeout = self.action_timeout
        if timeout is not None and not (
            isinstance(timeout, int | float) and timeout > 0 and math.isfinite(timeout)
        ):
            raise SettingsError(
                f"agent {self.name}: action_timeout must be a positive number of seconds, not {timeout!r}"
            )
        for name, least in (("max_failures", 1), ("max_depth", 1), ("maintained_depth", 0)):
            value = getattr(self, name)
            if not isinstance(value, int) or isinstance(value, bool) or value < least:
                raise SettingsError(
                    f"agent {self.name}: {name} must be a whole number of at least {least}, not {value!r}"
                )


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
        self.agent_domain = config.domain
        self.config = config
        self.domain = config.domain
        self.belief = config.belief
        self.mode = config.replanning
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
        self.running: _Running | None = None
        self._seq = itertools.count(1)
        self._arrivals = itertools.count(1)
        self._later: deque[Callable[[], None]] = deque()
        self._spent: list[object] = []
        """Plans a resumption replaced, goals that ended and held goals the parent cleared:
        let go of once the next order is on its way (§4: freeing what was kept for long is
        work like any other)."""
        self._prepared: _Prepared | None = None
        self._orphaned = False
        self._hint: Atom | None = None
        self._ready: dict[Atom, tuple[tuple[object, ...], PlanSet]] = {}
        self._shown: tuple[Atom, ...] | None = None
        self._done: Atom | None = None  # the running goal's last action, when it succeeded

    # -- the loop ------------------------------------------------------------------------

    async def run(self, *, task_status: TaskStatus[None] = anyio.TASK_STATUS_IGNORED) -> None:
        task_status.started()
        while True:
            self._drain()
            entry = self.current
            if entry is not None:
                await self._step(entry)
            elif not self._start_next():
                self._spent.clear()
                self._flush()  # nothing to do but wait: keep the stacked plans up to date now
                self._on_message(await self.inbox.receive())

    def _drain(self) -> None:
        """§4: every message that has arrived is seen before the next decision."""
        while (message := self.inbox.receive_nowait()) is not None:
            self._on_message(message)

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
        self.current = entry
        entry.plans.lazy = False  # the running goal's plans are repaired at once
        self._shown = None
        self._done = None

    def _take_order(self, order: Execute | Resume | Clear) -> bool:
        """Algorithm 5: the parent's orders while this agent is its executor."""
        if isinstance(order, Execute):
            self.trace.emit(GoalReceived(agent=self.name, goal=str(order.action), emergency=False))
            if not self.domain.knows(order.action):
                reason = f"{self.name} cannot do {order.action}"
                self.reply(Failure(action=order.action, seq=order.seq, reason=reason))
                return False
            entry = GoalEntry(order.action, self._ready_plans(order.action), order_seq=order.seq)
            entry.arrival = next(self._arrivals)
            self._begin(entry)
            return True
        held = self._held(order.action)
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
            self._spent.append(held)
            self.trace.emit(GoalCleared(agent=self.name, goal=str(held.goal)))
        return False

    def _held(self, goal: Atom) -> GoalEntry | None:
        for entry in reversed(self.stack):
            if entry.held and entry.goal == goal:
                return entry
        return None

    # -- Algorithm 2: one step of the running goal ----------------------------------------------

    async def _step(self, entry: GoalEntry) -> None:
        ps = entry.plans
        if ps.finished:
            # A plan ran to its end while this goal was running: achieved (§2.8), even if
            # an emergency or a suspension came with the last result.
            self._end(entry, GoalStatus.SUCCESS)
            return
        if entry.stop_requested or (
            self.emergencies and any(e.arrival > entry.arrival for e in self.emergencies)
        ):
            # Algorithm 3: an emergency that arrived after this goal suspends it (one that
            # arrived with it, in the same instant, waits until it has ended).
            if not ps.plans and ps.ensure(self.belief) and _achieved(ps):
                # Its plans were lost while the last action ran (a door shut on the robot's
                # arc), but that action achieved it (§2.8): it ended, it is not suspended.
                self._end(entry, GoalStatus.SUCCESS)
                return
            self._suspend_current(entry)
            return
        # §2.4: a way opened from outside since its plan was made (a door, while the action
        # ran) is weighed now, before the next action — where naive, had its plan broken
        # meanwhile, would plan afresh with the door open.
        ps.reconsider(self.belief)
        if not ps.ensure(self.belief):
            status = ps.last_status.value if ps.last_status else "none"
            # No plan from here: the parent should not ask the same again from its belief.
            self._end(entry, GoalStatus.FAILURE, f"no plan for {entry.goal} ({status})", permanent=True)
            return
        if _achieved(ps):  # a plan made just now has nothing left to do
            self._end(entry, GoalStatus.SUCCESS)
            return
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
        action = best.steps[0].action
        self._shown = best.later_actions
        result, asked = await self._act(action)
        self._done = action if isinstance(result, Success) and self.current is entry else None
        if isinstance(result, Success) or (isinstance(result, Suspended) and asked):
            entry.failures.pop(action, None)
            return
        # A failure, or an executor that stopped the action without being asked (its
        # belief follows, but the action did not get done): count it, so that an
        # executor that keeps doing so ends the goal instead of looping.
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

    def _resume(self, entry: GoalEntry) -> None:
        """Algorithm 2 for a resumed goal: reuse (online) or remake (naive) its plans."""
        started = time.perf_counter()
        self._flush()  # whatever maintenance still waits, before the kept plans are used
        self._begin(entry)
        ready, entry.ready = entry.ready, None
        if self.mode is Replanning.ONLINE and ready is not None and ready.holds_for(self.belief, entry):
            # Made ready while the last action before this moment ran (_get_ready): the
            # plans, and which suspended actions to clear, are already worked out.
            self._spent.append(entry.plans.adopt(ready.plans))
            for clear, after in ready.cleared:
                action = clear.action
                entry.suspended.remove(action)
                self.order(self.executor, clear)
                before, self.belief = self.belief, after  # worked out ahead, from this belief
                update = functools.partial(_cleared, action, before, after)
                self._maintain(update, skip=entry.plans)
            entry.plans.rebase(self.belief)
        else:
            ps = entry.plans
            if self.mode is Replanning.NAIVE:
                ps.drop()
            unused = _make_ready(ps, self.belief, entry.suspended)
            if unused:
                # Algorithm 2: the selected plan will not resume these: clear them below.
                self._clear_suspended(entry, unused)
                ps.ensure(self.belief)
                ps.shorten_detours(self.belief)
        # docs/contracts.md: wall-clock time spent making the resumed goal's plan.
        replan_ms = (time.perf_counter() - started) * 1000
        self.trace.emit(
            GoalResumed(
                agent=self.name,
                goal=str(entry.goal),
                replanning="online" if self.mode is Replanning.ONLINE else "naive",
                replan_ms=round(replan_ms, 4),
            )
        )

    def _get_ready(self, entry: GoalEntry, plans: PlanSet, belief: State, done: tuple[Atom, ...]) -> None:
        """Work out, ahead, how ``entry`` resumes from ``belief`` with ``plans`` (a fork
        updated up to that belief, once the actions ``done`` have succeeded): what
        :meth:`_resume` would do, kept in ``entry.ready``."""
        plans.lazy = False
        # A resume or rollback among the actions done settles what it finished or undid.
        settled = {a for step in done if (a := half_done(step)) is not None}
        suspended = [a for a in entry.suspended if a not in settled]
        unused = _make_ready(plans, belief, suspended)
        final = belief
        cleared: list[tuple[Clear, State]] = []
        for action in unused:
            after = self.domain.clear(final, action)
            plans.suspension_cleared(action, final, after)
            cleared.append((Clear(action=action), after))  # the order too: sent as it is
            final = after
        if unused:
            plans.ensure(final)
            plans.shorten_detours(final)
        if plans.best is not None:
            # Worked out now: showing the plan at resumption, and following it, are then free.
            _ = plans.best.shown, plans.best.later_actions
        entry.ready = _Ready(belief.key(), tuple(suspended), plans, cleared)

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

    # -- acting -----------------------------------------------------------------------------

    async def _act(self, action: Atom) -> tuple[Success | Failure | Suspended, bool]:
        """Carry out the action; its result, and whether a suspension of it was asked for."""
        seq = next(self._seq)
        inner = resumed(action)
        ordered = inner if inner is not None else action
        if inner is not None:
            self.order(self.executor, Resume(action=inner, seq=seq))
        else:
            self.order(self.executor, Execute(action=action, seq=seq))
        running = _Running(seq, action, ordered)
        if self.config.action_timeout is not None and self.executor.agent_domain is None:
            running.timer = self.clock.call_later(
                self.config.action_timeout, lambda: self.inbox.send(Timeout(seq=seq))
            )
        self.running = running
        self.trace.emit(ActionStarted(agent=self.name, action=str(action)))
        try:
            if self._later or self._spent or self._hint is not None or self._will_resume_after(action):
                # The order is on its way: let it reach the robot — one round of the event
                # loop for each level below — then let go of what is spent, do the plan
                # maintenance that waited for this moment (§4, Algorithm 3), and get ready
                # for what comes after this action while it runs.
                for _ in range(self.executor.levels_below()):
                    await anyio.lowlevel.checkpoint()
                self._spent.clear()
                # §4: an emergency that came meanwhile (given as this very order reached
                # the robot) is seen first; the upkeep waits for the next order.
                if not any(isinstance(m, Submit) and m.emergency for m in self.inbox.waiting()):
                    self._flush()
                    if self._prepare_resumption(action):
                        await anyio.lowlevel.checkpoint()  # the child agent gets ready meanwhile
            result = await self._await_result(running)
            if isinstance(result, Suspended) and not self.domain.can_suspend(action):
                # The executor stopped half way an action the domain says cannot be: the
                # belief cannot follow, and nothing will resume it.  It failed.
                self.order(self.executor, Clear(action=ordered))
                reason = f"the executor stopped {action} half way, which cannot be suspended"
                result = Failure(action=action, seq=seq, reason=reason)
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

    async def _await_result(self, running: _Running) -> Success | Failure | Suspended:
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

    def _update(self, action: Atom, result: Success | Failure | Suspended, asked: bool) -> None:
        """Update the belief and every plan set, active and stacked (§2, §3).

        ``asked``: a suspension of the action was asked for (the running goal will be
        stacked).
        """
        before = self.belief
        inner = half_done(action)
        if isinstance(result, Success):
            after = self.domain.progress(before, action)
            self.belief = after
            prepared = self._prepared
            if prepared is not None and prepared.came_true(action, before, after):
                # The goal that resumes was updated (and made ready) for this very
                # result while the action ran: take that over; the others are updated now.
                # The predicted belief is this one: kept, its plans and readiness are known
                # to hold for it by identity, without comparing the facts again.
                after = self.belief = prepared.after
                self._prepared = None
                for ps in self._plansets():
                    fork = prepared.fork_of(ps)
                    if fork is not None:
                        self._spent.append(ps.adopt(fork))
                        ps.rebase(after)
                    else:
                        ps.action_succeeded(action, before, after)
            else:
                self._maintain(lambda ps, memo: ps.action_succeeded(action, before, after, memo))
            if inner is not None:
                # The half-done action was finished or undone: nothing is left to clear.
                holder = self._holder(inner)
                if holder is not None:
                    holder.suspended.remove(inner)
        elif isinstance(result, Suspended):
            if inner is not None:
                # Algorithm 3: stopping resume(A) or rollback(A) leaves A suspended, as the
                # belief and every plan already say; whoever held A still holds it.
                if self._holder(inner) is None and self.current is not None:
                    self.current.suspended.append(inner)
                return
            # Algorithm 1, step 1: the belief takes the suspension effect.
            after = self.domain.suspend(before, action)
            self.belief = after
            # The running goal is being suspended: its own update (Algorithm 1) can wait
            # until the emergency's first action is on its way (§4, Algorithm 3).
            self._maintain(lambda ps, memo: ps.action_suspended(action, before, after, memo), eager=not asked)
            if self.current is not None:
                self.current.suspended.append(action)
        else:
            self._maintain(lambda ps, memo: ps.action_failed(action, before, before, memo))
            if resumed(action) is not None and inner is not None:
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
        chosen from them.  The stacked goals' updates wait in a queue that is worked
        off once the next action is on its way (:meth:`_flush`) — keeping them valid
        must not delay the agent's reaction (§4, Algorithm 3).  The stacked goals
        often repeat: one memo lets their searches be shared.
        """
        self._prepared = None  # the belief went another way than predicted
        memo = SearchMemo()
        now = self.current.plans if eager and self.current is not None else None
        for ps in self._plansets():
            if ps is skip:
                continue
            if ps is now:
                update(ps, memo)
            else:
                self._later.append(functools.partial(update, ps, memo))

    def _flush(self) -> None:
        """Do the plan maintenance that waited (see :meth:`_maintain`), oldest first."""
        while self._later:
            self._later.popleft()()
        if self._hint is not None and self._prepare_order(self._hint):
            self._hint = None

    # -- getting ready for what comes next, while an action runs (§4) -----------------------------

    def levels_below(self) -> int:
        return 1 + self.executor.levels_below()

    def _will_resume_after(self, action: Atom) -> bool:
        """Whether the running goal ends with this action and a stacked goal resumes then."""
        current = self.current
        if self.mode is not Replanning.ONLINE or current is None or not self.stack:
            return False
        best = current.plans.best
        top = self.stack[-1]
        return (
            best is not None
            and best.actions == (action,)
            and not top.held
            and not self.emergencies
            and not current.stop_requested
        )

    def _prepare_resumption(self, action: Atom) -> bool:
        """Update the goal that resumes after the action for its predicted success, and
        make it ready (its plans re-checked, repaired, shortened) — so that resuming
        costs nothing when the prediction comes true.  A child agent is told the first
        order of the resumed plan (:class:`~htnagent.runtime.messages.Prepare`); returns whether
        it was."""
        if not self._will_resume_after(action):
            return False
        before = self.belief
        after = self.domain.progress(before, action)
        top = self.stack[-1]
        # Only the goal that resumes is worked on ahead: the other stacked goals' plans
        # are only rewritten (``lazy``), which costs no more when the result comes than
        # a copy made now would (with a thousand nested emergencies, 32 copies each).
        fork = top.plans.fork()
        fork.lazy = False
        fork.action_succeeded(action, before, after, SearchMemo())
        self._prepared = _Prepared(action, before, after, top.plans, fork)
        self._get_ready(top, fork.fork(), after, (action,))
        assert top.ready is not None
        best = top.ready.plans.best
        if self.executor.agent_domain is not None and best is not None and best.steps:
            # The child agent gets ready for this order too (or for resuming its goal).
            self.order(self.executor, Prepare(action=best.steps[0].action))
            return True
        return False

    def _prepare_order(self, action: Atom) -> bool:
        """Get ready for a likely next order of the parent's (Prepare), from the belief this
        agent will have when its running goal's plan is done: plan a new goal, or make a
        held goal ready to resume.  Returns False to be asked again later: the running
        goal has more than its last action to do (ready then, the prediction rests on one
        action, and nothing made ready is updated action by action meanwhile)."""
        if self.mode is not Replanning.ONLINE:
            return True
        current = self.current
        steps = current.plans.best.actions if current is not None and current.plans.best is not None else ()
        if len(steps) > 1:
            return False
        predicted = replay(self.domain, self.belief, steps)
        if predicted is None:
            return True
        inner = resumed(action)
        if inner is not None:
            held = self._held(inner)
            if held is not None:
                plans = held.plans.fork()
                state = self.belief
                for step in steps:  # the updates the held goal's plans will get meanwhile
                    after = self.domain.progress(state, step)
                    plans.action_succeeded(step, state, after)
                    state = after
                self._get_ready(held, plans, state, steps)
            return True
        if not self.domain.knows(action):
            return True
        ps = self._planset(action)
        if ps.ensure(predicted) and ps.best is not None:
            _ = ps.best.shown, ps.best.later_actions  # worked out now: free when the order comes
        if len(self._ready) >= 4:
            self._ready.pop(next(iter(self._ready)))
        self._ready[action] = (predicted.key(), ps)
        return True

    def _ready_plans(self, action: Atom) -> PlanSet:
        """The plans prepared for this order, if the belief is the one they were made for."""
        ready = self._ready.pop(action, None)
        if ready is not None and ready[0] == self.belief.key():
            ready[1].rebase(self.belief)
            return ready[1]
        return self._planset(action)

    def _holder(self, action: Atom) -> GoalEntry | None:
        """The goal whose suspended action ``action`` is: the running one's, else the latest."""
        running = [self.current] if self.current is not None else []
        for entry in [*running, *reversed(self.stack)]:
            if action in entry.suspended:
                return entry
        return None

    def _push(self, entry: GoalEntry) -> None:
        self.stack.append(entry)
        entry.plans.lazy = True  # see PlanSet.lazy: made good when it is about to run again
        sunk = len(self.stack) - 1 - self.config.maintained_depth
        if sunk >= 0:
            # Too deep to keep up (see AgentConfig.maintained_depth): planned afresh if it
            # comes back to the top.
            self.stack[sunk].plans.drop()

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
        if isinstance(message, Submit):
            self._submitted(message)
        elif isinstance(message, Execute | Resume | Clear):
            if isinstance(message, Execute):
                self._orphaned = False  # a parent orders again (one in another process came back)
            self.orders.append(message)
            self._hint = None  # the order the hint foretold (or another) has come
        elif isinstance(message, Suspend):
            self._parent_suspends(message)
        elif isinstance(message, Prepare):
            self._hint = message.action  # planned when there is time (see _flush)
        elif isinstance(message, ParentLost):
            self._parent_lost()
        elif isinstance(message, BeliefUpdate):
            before = self.belief
            after = self.belief = before.updated(message.add, message.delete)
            self._maintain(lambda ps, memo: ps.belief_changed(before, after, memo))
        # Anything else is a late answer to an abandoned order: ignored.

    def _submitted(self, message: Submit) -> None:
        entry = GoalEntry(message.goal, self._planset(message.goal), message.emergency, message.ticket)
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
                entry = GoalEntry(order.action, self._planset(order.action), order_seq=order.seq, held=True)
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

    def _planset(self, goal: Atom) -> PlanSet:
        return new_plan_set(self.domain, goal, self.mode, self.settings, self.stats)

    def _end(
        self, entry: GoalEntry, status: GoalStatus, reason: str = "", *, permanent: bool = False
    ) -> None:
        """The goal has ended: report it (once) to whoever is waiting for it.

        ``permanent``: it failed because there is no plan for it from the belief.
        """
        if self.current is entry:
            self.current = None
        if len(self._spent) >= 64:  # goals ending one after another with no action between
            self._spent.clear()
        self._spent.append(entry)
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


def _make_ready(plans: PlanSet, belief: State, suspended: list[Atom]) -> list[Atom]:
    """Make a resumed goal's plans good from ``belief``; the suspended actions the selected
    plan does not need (they are to be cleared).  Algorithm 2, §2.7, §2.8."""
    plans.confirm_achieved(belief)
    plans.ensure(belief)
    plans.reconsider(belief)  # a way opened while it waited: as good as a plan made afresh
    plans.shorten_detours(belief)  # and its lowest task done again, which can be cheaper still
    best = plans.best
    # A plan that rolls an action back, or finishes it later (after walking back to where
    # it was stopped), still needs what was kept for it.
    needed = {a for s in best.steps if (a := half_done(s.action)) is not None} if best else set()
    return [a for a in suspended if a not in needed]


@dataclass
class _Ready:
    """How a stacked goal resumes, worked out ahead for one belief."""

    belief: tuple[object, ...]
    suspended: tuple[Atom, ...]
    plans: PlanSet
    cleared: list[tuple[Clear, State]]
    """The orders clearing the suspended actions, each with the belief once it is cleared."""

    def holds_for(self, belief: State, entry: GoalEntry) -> bool:
        """Whether things went as predicted: the belief and the goal's suspended actions."""
        return self.belief == belief.key() and self.suspended == tuple(entry.suspended)


@dataclass
class _Prepared:
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
