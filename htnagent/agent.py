"""A planning agent: the published Algorithms 2–5 as coroutines of one task.

- :meth:`Agent.run` is Algorithm 4's loop: it takes the next goal — a pending
  emergency first, then an order from the parent agent, then the first
  waiting normal goal once nothing runs and the stack is empty.
- :meth:`Agent._pursue` is Algorithm 2 (plan, select, execute, update all plans)
  with Algorithm 3 inside: when an emergency arrives the running action is
  suspended if it can be, the goal is pushed on the stack with its plans and
  suspended action, the emergency runs (recursively, so emergencies nest), and
  the goal is popped and resumed.
- As its parent's executor (Algorithm 5) the agent treats ``execute`` as a
  goal, and on ``suspend`` stacks that goal and answers ``suspended``; it then
  waits for the parent's ``resume`` or ``clear`` while carrying out whatever
  else the parent sends.

Every executor result updates the belief and *all* plan sets — the running
goal's and every stacked goal's — through :class:`~htnagent.planset.PlanSet`.
"""

from __future__ import annotations

import itertools
import time
from collections import deque
from collections.abc import Callable
from dataclasses import dataclass, field
from enum import Enum
from typing import Any

import anyio
from anyio.abc import TaskStatus

from htnagent.clock import Clock, TimerHandle
from htnagent.domain import Domain, State
from htnagent.executor import ExecutorActor
from htnagent.messages import (
    BeliefUpdate,
    Clear,
    Execute,
    Failure,
    Refused,
    Resume,
    Submit,
    Success,
    Suspend,
    Suspended,
    Timeout,
)
from htnagent.planner import PlannerSettings
from htnagent.planset import PlanningStats, PlanSet, Replanning
from htnagent.terms import Atom
from htnagent.trace import Trace

OutcomeCallback = Callable[[int, "GoalStatus", str], None]


class GoalStatus(Enum):
    """How a goal ended."""

    SUCCESS = "success"
    """A plan for the goal ran to its end."""
    FAILURE = "failure"
    """No plan was left for the goal, or an action kept failing."""


class _Stop(Enum):
    DONE = "done"
    STACKED = "stacked"  # suspended by the parent: waits on the stack for resume/clear


@dataclass
class GoalEntry:
    """A goal with its plans; on the stack it also keeps its suspended action."""

    goal: Atom
    plans: PlanSet
    emergency: bool = False
    ticket: int | None = None
    order_seq: int | None = None  # set when the goal is the parent's order
    suspended_action: Atom | None = None
    parent_suspend: int | None = None  # seq of a parent's suspend request being served
    failures: dict[Atom, int] = field(default_factory=dict)  # failures in a row, per action
    reason: str = ""


@dataclass
class _Running:
    seq: int
    action: Atom
    timer: TimerHandle | None = None


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
    """How often in a row the same action may fail before the goal fails."""


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
        self.belief = config.belief
        self.mode = config.replanning
        self.executor = executor
        executor.connect(self.inbox)
        self.on_outcome = on_outcome
        self.stats = PlanningStats()
        self.waiting: deque[GoalEntry] = deque()
        self.emergencies: deque[GoalEntry] = deque()
        self.orders: deque[Execute | Resume | Clear] = deque()
        self.stack: list[GoalEntry] = []
        self.current: GoalEntry | None = None
        self.running: _Running | None = None
        self._seq = itertools.count(1)
        self._shown: tuple[Atom, ...] | None = None

    # -- Algorithm 4: the agent's loop ------------------------------------------------

    async def run(self, *, task_status: TaskStatus[None] = anyio.TASK_STATUS_IGNORED) -> None:
        task_status.started()
        while True:
            entry, resumed = await self._next_goal()
            stop = await self._pursue(entry, resumed=resumed)
            if stop is _Stop.DONE:
                self._finished(entry)

    async def _next_goal(self) -> tuple[GoalEntry, bool]:
        while True:
            if self.emergencies:
                return self.emergencies.popleft(), False
            while self.orders:
                order = self.orders.popleft()
                picked = self._take_order(order)
                if picked is not None:
                    return picked
            # Algorithm 4: a normal goal starts when first, nothing runs and the stack is empty.
            if self.waiting and not self.stack:
                return self.waiting.popleft(), False
            self._on_message(await self.inbox.receive())

    def _take_order(self, order: Execute | Resume | Clear) -> tuple[GoalEntry, bool] | None:
        """Algorithm 5: the parent's orders while this agent is its executor."""
        if isinstance(order, Execute):
            if not self.domain.knows(order.action):
                self.reply(
                    Failure(
                        action=order.action, seq=order.seq, reason=f"{self.name} cannot do {order.action}"
                    )
                )
                return None
            entry = GoalEntry(order.action, self._planset(order.action), order_seq=order.seq)
            self.trace.emit(self.name, "goal_received", goal=str(order.action), emergency=False)
            return entry, False
        stacked = self._stacked(order.action)
        if isinstance(order, Resume):
            if stacked is None:
                self.reply(
                    Failure(
                        action=order.action, seq=order.seq, reason=f"nothing to resume for {order.action}"
                    )
                )
                return None
            # Algorithm 5: on resume, pop the goal and go on with it.
            self.stack.remove(stacked)
            stacked.order_seq = order.seq
            return stacked, True
        # Algorithm 5: on clear, drop the goal, its plans and its suspended action.
        if stacked is not None:
            self.stack.remove(stacked)
            self._clear_suspended(stacked)
            self.trace.emit(self.name, "goal_cleared", goal=str(stacked.goal))
        return None

    def _stacked(self, goal: Atom) -> GoalEntry | None:
        for entry in reversed(self.stack):
            if entry.goal == goal and entry.order_seq is not None:
                return entry
        return None

    # -- Algorithm 2 with Algorithm 3 inside -------------------------------------------

    async def _pursue(self, entry: GoalEntry, *, resumed: bool) -> _Stop:
        outer = self.current
        self.current = entry
        try:
            return await self._pursue_here(entry, resumed)
        finally:
            self.current = outer

    async def _pursue_here(self, entry: GoalEntry, resumed: bool) -> _Stop:
        ps = entry.plans
        if resumed:
            self._resume_plans(entry)
        else:
            ps.ensure(self.belief)
        self._shown = None
        while True:
            if ps.plans and ps.finished:
                # Done, even if an emergency or a suspension came with the last result.
                entry.reason = ""
                return _Stop.DONE
            if self.emergencies and entry.parent_suspend is None:
                # Algorithm 3: push the goal with its plans and suspended action, run the
                # emergency (emergencies that arrive meanwhile nest), pop and resume.
                self.stack.append(entry)
                self.trace.emit(
                    self.name, "goal_suspended", goal=str(entry.goal), stack_depth=len(self.stack)
                )
                while self.emergencies:
                    emergency = self.emergencies.popleft()
                    if await self._pursue(emergency, resumed=False) is _Stop.DONE:
                        self._finished(emergency)
                self.stack.remove(entry)
                self._resume_plans(entry)
                self._shown = None
                continue
            if entry.parent_suspend is not None:
                # Algorithm 5: stack the parent's goal and report it suspended.
                self.stack.append(entry)
                self.trace.emit(
                    self.name, "goal_suspended", goal=str(entry.goal), stack_depth=len(self.stack)
                )
                assert entry.order_seq is not None
                self.reply(Suspended(action=entry.goal, seq=entry.order_seq))
                entry.parent_suspend = None
                return _Stop.STACKED
            if not ps.ensure(self.belief):
                entry.reason = (
                    entry.reason
                    or f"no plan for {entry.goal} ({ps.last_status.value if ps.last_status else 'none'})"
                )
                ps.plans = []
                return _Stop.DONE
            if ps.finished:  # also when a plan made just now has nothing left to do
                entry.reason = ""
                return _Stop.DONE
            best = ps.best
            assert best is not None
            if self._shown is None or best.actions != self._shown:
                self.trace.emit(
                    self.name,
                    "plan_selected",
                    goal=str(entry.goal),
                    plan=best.text(),
                    cost=round(best.cost, 6),
                )
            action = best.steps[0].action
            self._shown = best.actions[1:]
            result = await self._act(action)
            if isinstance(result, Failure):
                failures = entry.failures[action] = entry.failures.get(action, 0) + 1
                entry.reason = result.reason
                self._shown = None
                if failures >= self.config.max_failures:
                    # The same action keeps failing although the belief says it can run.
                    ps.plans = []
                    times = "once" if failures == 1 else f"{failures} times"
                    entry.reason = f"{action} failed {times}: {result.reason}"
                    return _Stop.DONE
            else:
                entry.failures.pop(action, None)

    def _resume_plans(self, entry: GoalEntry) -> None:
        """Algorithm 2 for a resumed goal: reuse (online) or remake (naive) its plans."""
        ps = entry.plans
        started = time.perf_counter()
        if self.mode is Replanning.NAIVE:
            ps.drop()
        ps.ensure(self.belief)
        pending = entry.suspended_action
        if pending is not None:
            best = ps.best
            first = best.steps[0].action if best is not None and best.steps else None
            # A plan that starts by rolling the action back still needs what was kept
            # for it: the rollback itself settles the suspension.
            if first not in (Atom("resume", (pending,)), Atom("rollback", (pending,))):
                # Algorithm 2: the selected plan will not resume the action: clear it below.
                self._clear_suspended(entry)
                ps.ensure(self.belief)
        # After the clear, so that the detour check sees the plans that will be used.
        ps.shorten_detours(self.belief)
        # CONTRACTS.md: wall-clock time spent making the resumed goal's plan.
        replan_ms = (time.perf_counter() - started) * 1000
        self.trace.emit(
            self.name,
            "goal_resumed",
            goal=str(entry.goal),
            replanning=self.mode.value,
            replan_ms=round(replan_ms, 4),
        )

    def _clear_suspended(self, entry: GoalEntry) -> None:
        pending = entry.suspended_action
        if pending is None:
            return
        entry.suspended_action = None
        self.order(self.executor, Clear(action=pending))
        before = self.belief
        self.belief = self.domain.clear(before, pending)
        for ps in self._plansets():
            ps.suspension_cleared(pending, before, self.belief)

    # -- acting -----------------------------------------------------------------------------

    async def _act(self, action: Atom) -> Success | Failure | Suspended:
        seq = next(self._seq)
        inner = action.args[0] if action.name == "resume" and action.args else None
        if isinstance(inner, Atom):
            self.order(self.executor, Resume(action=inner, seq=seq))
        else:
            self.order(self.executor, Execute(action=action, seq=seq))
        running = _Running(seq, action)
        if self.config.action_timeout is not None and not isinstance(self.executor, Agent):
            running.timer = self.clock.call_later(
                self.config.action_timeout, lambda: self.inbox.send(Timeout(seq=seq))
            )
        self.running = running
        self.trace.emit(self.name, "action_started", action=str(action))
        try:
            result = await self._await_result(running)
        finally:
            if running.timer is not None:
                running.timer.cancel()
            self.running = None
        self._update(action, result)
        self.trace.emit(
            self.name,
            "action_finished",
            action=str(action),
            result=result.kind,
            **({"reason": result.reason} if isinstance(result, Failure) else {}),
        )
        return result

    async def _await_result(self, running: _Running) -> Success | Failure | Suspended:
        while True:
            message = await self.inbox.receive()
            if isinstance(message, Success | Failure | Suspended) and message.seq == running.seq:
                return message
            if isinstance(message, Refused) and message.seq == running.seq:
                self.trace.emit(self.name, "suspend_refused", action=str(running.action))
                self._refused()
                continue
            if isinstance(message, Timeout) and message.seq == running.seq:
                # A hung executor: the action counts as failed; a late answer is ignored.
                target = running.action.args[0] if running.action.name == "resume" else running.action
                if isinstance(target, Atom):
                    self.order(self.executor, Clear(action=target))
                return Failure(
                    action=running.action,
                    seq=running.seq,
                    reason=f"timeout: no answer within {self.config.action_timeout} s",
                )
            self._on_message(message)

    def _update(self, action: Atom, result: Success | Failure | Suspended) -> None:
        """Update the belief and every plan set, active and stacked (§2, §3)."""
        before = self.belief
        sets = self._plansets()
        if isinstance(result, Success):
            after = self.domain.progress(before, action)
            self.belief = after
            for ps in sets:
                ps.action_succeeded(action, before, after)
            if action.name in ("resume", "rollback"):
                # The half-done action was finished or undone: nothing is left to clear.  The
                # same action may be suspended at several depths; the latest one was resumed
                # (the running goal's own, or else the top of the stack's).
                running = [self.current] if self.current is not None else []
                for entry in [*running, *reversed(self.stack)]:
                    if entry.suspended_action is not None and action.args[0] == entry.suspended_action:
                        entry.suspended_action = None
                        break
        elif isinstance(result, Suspended):
            # Algorithm 1, step 1: the belief takes the suspension effect.
            after = self.domain.suspend(before, action)
            self.belief = after
            for ps in sets:
                ps.action_suspended(action, before, after)
            if self.current is not None:
                self.current.suspended_action = action
        else:
            for ps in sets:
                ps.action_failed(action, before, before)

    def _entries(self) -> list[GoalEntry]:
        entries = list(self.stack)
        if self.current is not None and self.current not in entries:
            entries.append(self.current)
        return entries

    def _plansets(self) -> list[PlanSet]:
        return [e.plans for e in self._entries()]

    # -- messages that arrive while waiting ---------------------------------------------------

    def _on_message(self, message: Any) -> None:
        if isinstance(message, Submit):
            self._submitted(message)
        elif isinstance(message, Execute | Resume | Clear):
            self.orders.append(message)
        elif isinstance(message, Suspend):
            self._parent_suspends(message)
        elif isinstance(message, BeliefUpdate):
            before = self.belief
            self.belief = before.updated(message.add, message.delete)
            for ps in self._plansets():
                ps.belief_changed(before, self.belief)
        # Anything else is a late answer to an abandoned order: ignored.

    def _submitted(self, message: Submit) -> None:
        known = self.domain.knows(message.goal)
        entry = GoalEntry(message.goal, self._planset(message.goal), message.emergency, message.ticket)
        self.trace.emit(
            self.name,
            "goal_received",
            goal=str(message.goal),
            emergency=message.emergency,
            ticket=message.ticket,
        )
        if not known:
            entry.reason = f"{self.name} has no method or operator for {message.goal}"
            self._finished(entry)
            return
        if message.emergency:
            self.emergencies.append(entry)
            if self.current is not None:
                # Algorithm 3: mark the running goal suspended; suspend its action if it can be.
                self._request_suspension()
        else:
            self.waiting.append(entry)

    def _parent_suspends(self, message: Suspend) -> None:
        current = self.current
        if current is None or current.order_seq != message.seq or current.goal != message.action:
            self.reply(Refused(action=message.action, seq=message.seq))
            return
        current.parent_suspend = message.seq
        self._request_suspension()

    def _request_suspension(self) -> None:
        running = self.running
        if running is None:
            return
        op, _ = self.domain.ground(running.action)
        if not op.suspendable:
            self._refused()
            return
        self.order(self.executor, Suspend(action=running.action, seq=running.seq))

    def _refused(self) -> None:
        """The running action goes on; a parent asking to suspend is told so."""
        current = self.current
        if current is not None and current.parent_suspend is not None and current.order_seq is not None:
            self.reply(Refused(action=current.goal, seq=current.order_seq))
            current.parent_suspend = None

    # -- outcomes --------------------------------------------------------------------------------

    def _planset(self, goal: Atom) -> PlanSet:
        return PlanSet(self.domain, goal, self.mode, self.config.settings, self.stats)

    def _finished(self, entry: GoalEntry) -> None:
        status = GoalStatus.SUCCESS if entry.plans.finished and not entry.reason else GoalStatus.FAILURE
        fields: dict[str, Any] = {"goal": str(entry.goal), "status": status.value}
        if entry.ticket is not None:
            fields["ticket"] = entry.ticket
        if status is GoalStatus.FAILURE:
            fields["reason"] = entry.reason or "failed"
        # The outcome is settled before the event, so observers see it settled.
        if entry.ticket is not None and self.on_outcome is not None:
            self.on_outcome(entry.ticket, status, fields.get("reason", ""))
        self.trace.emit(self.name, "goal_finished", **fields)
        if entry.order_seq is not None:
            if status is GoalStatus.SUCCESS:
                self.reply(Success(action=entry.goal, seq=entry.order_seq))
            else:
                self.reply(Failure(action=entry.goal, seq=entry.order_seq, reason=fields["reason"]))

    def submit(self, goal: Atom, ticket: int, emergency: bool = False) -> None:
        """Give the agent a goal (delivered through its mailbox)."""
        self.inbox.send(Submit(goal=goal, emergency=emergency, ticket=ticket))
