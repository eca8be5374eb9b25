"""What must hold in every run on the simulated museum robot, checked from outside.

:class:`RunChecker` is a trace observer that also looks at the simulated
robot's physical state and the bottom agent's belief at the moment of each
event.  It knows nothing of how the agents work inside; it checks:

- every submitted goal ends exactly once;
- whenever the bottom agent (the one on the robot) has an action result, its
  belief about where the robot is matches the robot;
- no robot action starts while the simulated world forbids it;
- a ``goto(N)`` or ``goto_node(N)`` that succeeds has the robot standing at N,
  and a ``move_area(A,B)`` that succeeds has it in area B (docs/design.md §2.8:
  a goal succeeds only when it is achieved now);
- an agent that receives an emergency (or its parent's ``suspend``) while
  pursuing a goal suspends (or finishes) that goal in the same simulated
  instant, unless the robot refused to stop its running action, and no robot
  action starts in between (docs/design.md §4, Algorithm 3; §5);
- no agent crashes, and every stack is empty at the end.
"""

from __future__ import annotations

from dataclasses import dataclass, field

from htnagent.executors.hddl_robot import HddlRobot
from htnagent.executors.robot import Robot
from htnagent.model.actions import action_recovered_by, action_resumed_by
from htnagent.model.terms import Atom, parse
from htnagent.planning.hddl_translation import RESERVED
from htnagent.runtime.events import (
    ActionFinished,
    ActionStarted,
    AgentCrashed,
    GoalFinished,
    GoalReceived,
    GoalResumed,
    GoalSuspended,
    MessageSent,
    PlanSelected,
    RobotActing,
    RobotMoving,
    TraceEvent,
)
from htnagent.system.runtime import Runtime

_INSTANT = 1e-9


@dataclass
class _Pending:
    """An agent was asked to stop its goal at ``t``; it must do so at once."""

    t: float
    goal: str
    why: str
    refused: bool = False


@dataclass
class RunChecker:
    """Observe a run (``checker(event)``), then call :meth:`finish`; read :attr:`violations`."""

    runtime: Runtime | None = None
    violations: list[str] = field(default_factory=list)
    finished: dict[int, int] = field(default_factory=dict)
    max_depth: int = 0
    _busy: dict[str, str | None] = field(default_factory=dict)
    _pending: dict[str, _Pending] = field(default_factory=dict)

    def attach(self, runtime: Runtime) -> None:
        """Give the checker the runtime (``run_scenario``'s ``on_start``)."""
        self.runtime = runtime

    @property
    def robot(self) -> Robot:
        assert self.runtime is not None, "attach the runtime first"
        robot = self.runtime.bottom_executor
        assert isinstance(robot, Robot)
        return robot

    @property
    def bottom(self) -> str:
        assert self.runtime is not None
        return list(self.runtime.agents)[-1]

    def _violation(self, event: TraceEvent, text: str) -> None:
        self.violations.append(f"t={event.t}: {text}")

    def __call__(self, event: TraceEvent) -> None:
        agent = event.agent
        if isinstance(event, GoalFinished) and event.ticket is not None:
            self.finished[event.ticket] = self.finished.get(event.ticket, 0) + 1
        if isinstance(event, GoalSuspended):
            self.max_depth = max(self.max_depth, event.stack_depth)
        if isinstance(event, AgentCrashed):
            self._violation(event, f"{agent} crashed: {event.error}")
        self._watch_reaction(event)
        if isinstance(event, GoalFinished) and event.status == "success":
            self._check_achieved(event)
        if agent != self.bottom:
            return
        if isinstance(event, ActionStarted):
            problem = world_refuses(self.robot, parse(event.action))
            if problem:
                self._violation(event, f"{event.action} started but {problem}")
        elif isinstance(event, ActionFinished):
            assert self.runtime is not None
            believed = sorted(
                str(f) for f in self.runtime.agents[agent].belief.dynamic if f.name in ("at", "on_arc")
            )
            truth = robot_facts(self.robot)
            if believed != truth:
                self._violation(event, f"{agent} believes {believed}, the robot is {truth}")

    # -- §2.8: a goal succeeds only when achieved --------------------------------------

    def _check_achieved(self, event: GoalFinished) -> None:
        goal = parse(event.goal)
        state = self.robot.state
        if goal.name in ("goto", "goto_node") and len(goal.args) == 1:
            if state.on_arc is not None or state.at != str(goal.args[0]):
                where = f"on {state.on_arc[0]}" if state.on_arc else f"at {state.at}"
                self._violation(event, f"{event.agent}: {goal} succeeded with the robot {where}")
        elif goal.name == "move_area" and len(goal.args) == 2:
            world = state.world
            node = world.nodes.get(state.at or "")
            area = node.area if node is not None and state.on_arc is None else None
            if area != str(goal.args[1]):
                self._violation(event, f"{event.agent}: {goal} succeeded with the robot in {area}")

    # -- Algorithm 3 / 5: the reaction is immediate ------------------------------------------

    def _watch_reaction(self, event: TraceEvent) -> None:
        agent, t = event.agent, event.t
        match event:
            case PlanSelected() | GoalResumed():
                self._busy[agent] = event.goal
            case GoalSuspended() | GoalFinished():
                pending = self._pending.get(agent)
                if pending is not None and event.goal == pending.goal:
                    if not pending.refused and t - pending.t > _INSTANT:
                        self._violation(
                            event,
                            f"{agent} {event.event.removeprefix('goal_')} {pending.goal} at t={t}, "
                            f"{t - pending.t:.3f} s after {pending.why}",
                        )
                    del self._pending[agent]
                if self._busy.get(agent) == event.goal:
                    self._busy[agent] = None
            case GoalReceived(emergency=True):
                busy = self._busy.get(agent)
                if busy is not None and agent not in self._pending:
                    self._pending[agent] = _Pending(t, busy, f"the emergency {event.goal} arrived")
            case MessageSent(kind="suspend"):
                busy = self._busy.get(event.to)
                if busy is not None and event.to not in self._pending:
                    self._pending[event.to] = _Pending(t, busy, f"{agent} asked to suspend {event.action}")
            case MessageSent(kind="refused"):
                # The robot cannot stop its action: the agents above wait for it to end.
                for pending in self._pending.values():
                    pending.refused = True
            case RobotMoving() | RobotActing() if self._pending:
                waiting = ", ".join(f"{a} ({p.goal})" for a, p in self._pending.items())
                self._violation(event, f"the robot started {event.action} while {waiting} should stop")

    # -- the end of the run -------------------------------------------------------------------

    def finish(self) -> list[str]:
        """The end-of-run checks; returns every violation seen."""
        assert self.runtime is not None
        for ticket, outcome in self.runtime.outcomes.items():
            count = self.finished.get(ticket, 0)
            if outcome.status is None:
                self.violations.append(f"goal {outcome.goal} (ticket {ticket}) never ended")
            elif count > 1:
                self.violations.append(f"goal {outcome.goal} (ticket {ticket}) ended {count} times")
        for name, agent in self.runtime.agents.items():
            if agent.stack:
                goals = [str(e.goal) for e in agent.stack]
                self.violations.append(f"{name}'s stack is not empty at the end: {goals}")
        return self.violations


def robot_facts(robot: Robot) -> list[str]:
    """Where the robot is, as the navigator's facts would say it."""
    state = robot.state
    if state.on_arc is not None:
        arc, frm, to, _ = state.on_arc
        return [f"on_arc({arc},{frm},{to})"]
    return [f"at({state.at})"]


def world_refuses(robot: Robot, action: Atom) -> str | None:
    """Why the simulated world would not let the action start, if it would not."""
    state = robot.state
    if action.name == "move":
        frm, to, arc = (str(a) for a in action.args)
        if state.on_arc is not None:
            return f"the robot is on {state.on_arc[0]}"
        if state.at != frm:
            return f"the robot is at {state.at}"
        if arc in state.closed:
            return f"{arc} is closed"
        return None
    inner = action_recovered_by(action)
    if inner is not None and inner.name == "move":
        frm, to, arc = (str(a) for a in inner.args)
        if state.on_arc is None or state.on_arc[:3] != (arc, frm, to):
            return f"the robot is not half way along {arc} from {frm} to {to}"
        if action_resumed_by(action) is not None and arc in state.closed:
            return f"{arc} is closed"
    return None


def hddl_belief_differences(runtime: Runtime) -> list[str]:
    """For a run on the simulated HDDL robot: each agent whose belief, without the
    translation's own facts (``__…``), differs from the robot's world, with the facts that
    differ (sorted); nothing when every belief matches, or the robot is not an HDDL one."""
    robot = runtime.bottom_executor
    if not isinstance(robot, HddlRobot):
        return []
    world = robot.world.facts()
    found = []
    for name, agent in runtime.agents.items():
        belief = frozenset(f for f in agent.belief.facts() if not f.name.startswith(RESERVED))
        if belief != world:
            found.append(f"{name}: {sorted(map(str, belief ^ world))}")
    return found
