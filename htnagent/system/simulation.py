"""Running a scenario file on the simulated robot, to the end (``htnagent run``).

:func:`run_scenario` builds the agent chain of the scenario over the simulated
robot, gives the goals at their triggers, applies the world events, waits
until every goal has ended (or nothing more can happen) and returns the
summary of docs/contracts.md.

An agent of the scenario marked ``remote`` is served by another process
(``python -m htnagent serve``): the chain here ends above it, with the stand-in
of :mod:`htnagent.remote` (imported only then) as the last agent's executor;
the run keeps wall-clock time, and the robot's part of the summary is what the
serving process last told.
"""

from __future__ import annotations

import os
from collections.abc import Callable, Collection, Iterable
from dataclasses import dataclass, field
from typing import TYPE_CHECKING

import anyio

from htnagent.agent import AgentConfig, GoalStatus
from htnagent.errors import RemoteError
from htnagent.executors.hddl_robot import FactWorld, HddlRobot
from htnagent.executors.robot import Robot, RobotWorld
from htnagent.model.terms import Atom
from htnagent.planning.hddl_translation import MARKERS
from htnagent.runtime.clock import Clock, TimerHandle
from htnagent.runtime.events import (
    ArcClosed,
    ArcOpened,
    FactsChanged,
    GoalRow,
    RunStarted,
    Summary,
    TraceEvent,
)
from htnagent.runtime.executor import Executor, ExecutorActor
from htnagent.runtime.messages import BeliefUpdate
from htnagent.runtime.progress import Phase, Progress
from htnagent.runtime.trace import Observer, Trace
from htnagent.scenario import ROBOT, GoalSpec, Scenario, Trigger
from htnagent.scenario.hddl_agent import DEFAULT_DURATION
from htnagent.system.goal_times import GoalClock, Resumption
from htnagent.system.heap import long_lived
from htnagent.system.runtime import Runtime
from htnagent.upkeep import Replanning
from htnagent.version import VERSION

if TYPE_CHECKING:
    from htnagent.remote.link import Keys, Security

NEVER_TRIGGERED = "never given: its trigger did not happen"
STALLED = "stalled: nothing more could happen"
INTERRUPTED = "interrupted before it ended"
_QUIET_WITHIN = 5.0
"""Real seconds the messages in flight at the end of a run may take to be handled."""
_SAME_INSTANT = 1e-6
"""Simulated seconds within which a trigger's moment and a suspension count as one instant
(the robot's trace gives durations to the microsecond)."""


@dataclass
class RunReport:
    """The end of a run: the summary event and whether every goal succeeded."""

    summary: Summary
    events: list[TraceEvent] = field(default_factory=list)
    interrupted: bool = False
    """The run was stopped (``stop`` was set) before every goal ended."""
    goal_times: GoalClock | None = None
    """Each goal's times and resumptions, as measured (:mod:`htnagent.system.goal_times`)."""

    def resumptions(self, agent: str | None = None) -> list[Resumption]:
        """Every resumption of a scenario goal (by ``agent`` only, if given), in time order,
        with each agent's share of the replanning."""
        return [] if self.goal_times is None else self.goal_times.resumptions(agent)

    @property
    def succeeded(self) -> bool:
        """Every goal of the scenario succeeded."""
        return self.summary.succeeded


def build_runtime(
    scenario: Scenario,
    *,
    replanning: str | None = None,
    speed: float | None = None,
    first: str | None = None,
    look_ahead: bool = True,
    relayed: Collection[str] | None = None,
) -> tuple[Runtime, RobotWorld]:
    """The scenario's agents over a simulated robot, ready to enter (``async with``).

    Returns the runtime and, on a map, the simulated world (where the robot is:
    ``where()``; the nodes it reached: ``visited``).  The scenario's goals and events are
    not given: :func:`run_scenario` does that; a program embedding the agents gives its
    own with :meth:`~htnagent.system.runtime.Runtime.submit` (``examples/embed_asyncio.py``).

    ``first``: the agents from this one down (a process serving it); by default from
    the first.  The chain stops above an agent served elsewhere (``remote``).
    ``look_ahead``: the agents' :attr:`AgentConfig.look_ahead` (it changes no outcome).
    ``relayed``: the trace events (by name) a process serving the agents below relays to
    this runtime's trace (None: all of them).
    """
    mode = Replanning(replanning or scenario.replanning)
    world = RobotWorld(scenario.world, at=scenario.robot.start, keep_path=True)
    hddl = scenario.hddl_robot
    local, remote = scenario.chain_from(first)
    configs = [
        AgentConfig(
            name=spec.name,
            domain=scenario.domain_for(spec.name),
            belief=scenario.initial_state(spec.name),
            replanning=mode,
            settings=scenario.settings_for(spec.name),
            action_timeout=scenario.action_timeout,
            look_ahead=look_ahead,
        )
        for spec in local
    ]

    def robot(clock: Clock, trace: Trace) -> Executor:
        return Robot(
            world,
            scenario.robot.metres_per_second,
            scenario.robot.failure_rate,
            scenario.robot.seed,
            scenario.robot.durations,
            name=ROBOT,
        )

    def hddl_robot(clock: Clock, trace: Trace) -> Executor:
        # The simulated world is the robot's own copy of the facts, never a belief (§7.1).
        assert hddl is not None
        facts = FactWorld(hddl.domain, scenario.initial_state(scenario.agents[-1].name))
        return HddlRobot(
            facts,
            scenario.robot.durations,
            markers=MARKERS,
            default_duration=DEFAULT_DURATION,
            failure_rate=scenario.robot.failure_rate,
            seed=scenario.robot.seed,
            name=ROBOT,
        )

    bottom: Callable[[Clock, Trace], ExecutorActor | Executor] = robot if hddl is None else hddl_robot
    if remote is not None:
        from htnagent.remote.proxy import RemoteChild  # only now: zenoh is an optional extra

        served, link = remote, remote.remote
        assert link is not None
        security = link_security(scenario, served.name)

        def bottom(clock: Clock, trace: Trace) -> ExecutorActor | Executor:
            return RemoteChild(
                served.name,
                clock,
                trace,
                endpoint=link.endpoint,
                keys=remote_keys(scenario, served.name),
                security=security,
                domain=scenario.domain_for(served.name),
                wait=scenario.peer_wait,
                where=f"{scenario.file}: agents[{scenario.agent_names.index(served.name)}].remote",
                relay=None if relayed is None else frozenset(relayed),
            )

        # Another process acts meanwhile: time is the wall clock's.
        speed = 1.0 if speed is None else speed

    # The summary names every goal's outcome: keep them all (a scenario lists its goals).
    return Runtime(configs, bottom, speed=speed, keep_outcomes=None), world


def link_security(scenario: Scenario, agent: str) -> Security | None:
    """How the parent's side of the link to ``agent`` is secured, as the scenario's
    ``remote:`` says: the files found relative to the scenario, the password read now
    (from its environment variable or file).  None: a plain ``tcp/`` link.

    Raises RemoteError naming the scenario's key when the password is not there."""
    from htnagent.remote.link import Security

    index = scenario.agent_names.index(agent)
    link = scenario.agents[index].remote
    assert link is not None
    where = f"{scenario.file}: agents[{index}].remote"
    if not link.endpoint.startswith("tls/") and link.user is None:
        return None
    password = None
    if link.password_env is not None:
        password = os.environ.get(link.password_env)
        if not password:
            raise RemoteError(
                f"{where}.password_env: the environment variable {link.password_env} is not set"
            )
    elif link.password_file is not None:
        path = scenario.link_file(link.password_file)
        try:
            lines = path.read_text(encoding="utf-8").splitlines()
        except (OSError, UnicodeError) as e:
            raise RemoteError(f"{where}.password_file: {link.password_file}: cannot read it ({e})") from None
        password = lines[0].strip() if lines else ""
        if not password:
            raise RemoteError(f"{where}.password_file: {link.password_file} holds no password")

    folder = scenario.link_file("")  # the scenario's folder, looked up once

    def file(name: str | None) -> str | None:
        # Joined as text (Zenoh's settings are text): a pathlib join and a read of the
        # scenario's private folder for each file were most of this function's time, and a
        # fleet works it out twice a robot as it starts (its session, then its link).
        return None if name is None else os.path.join(folder, name)

    return Security(
        root_ca=file(link.root_ca),
        certificate=file(link.certificate),
        key=file(link.key),
        mutual=link.certificate is not None,
        user=link.user,
        password=password,
    )


def remote_keys(scenario: Scenario, agent: str) -> Keys:
    """The key space of the link to ``agent``, served by another process."""
    from htnagent.remote.link import Keys

    return Keys(scenario.key_space, agent)


async def run_scenario(
    scenario: Scenario,
    *,
    replanning: str | None = None,
    speed: float | None = None,
    observers: Iterable[Observer] = (),
    keep_events: bool = False,
    on_start: Callable[[Runtime], None] | None = None,
    stop: anyio.Event | None = None,
    look_ahead: bool = True,
    relayed: Collection[str] | None = None,
) -> RunReport:
    """Run the scenario to the end and return its summary (the last event published).

    ``on_start`` is called with the runtime before anything runs (for measurements).
    Setting ``stop`` ends the run early: goals not yet ended fail as interrupted,
    and the summary of what was done is still published.
    ``look_ahead``: the agents' :attr:`AgentConfig.look_ahead` (it changes no outcome).
    ``relayed``: with agents served by another process, the trace events of theirs (by
    name, ``event``) the observers look at; by default all of them.  The summary's own
    (:attr:`GoalClock.EVENTS`) always are; the others are not even sent.
    """
    interrupted = False
    if relayed is not None:
        relayed = frozenset(relayed) | GoalClock.EVENTS
    runtime, world = build_runtime(
        scenario, replanning=replanning, speed=speed, look_ahead=look_ahead, relayed=relayed
    )
    # The goal clock reads the wall clock before the other observers (an interval ends at
    # the event) and after them (one starts once the event is seen): printing is not timed.
    goal_clock = GoalClock.of(scenario)
    runtime.subscribe(goal_clock)
    if on_start is not None:
        on_start(runtime)
    events: list[TraceEvent] = []
    if keep_events:
        runtime.subscribe(events.append)
    for observer in observers:
        runtime.subscribe(observer)
    runtime.subscribe(goal_clock.seen)
    tickets: list[int | None] = [None] * len(scenario.goals)
    settled = anyio.Event()

    # What the run was built from is out of the collector's passes while it runs
    # (htnagent.system.heap: a full collection in an agent's plan upkeep took 7 ms).
    with long_lived():
        async with runtime:
            clock = runtime.clock
            mode = replanning or scenario.replanning
            header = RunStarted(agent="runtime", scenario=scenario.name, mode=mode, version=VERSION)
            runtime.trace.emit(header)

            def give(index: int, goal: GoalSpec) -> None:
                ticket = tickets[index] = runtime.submit(
                    goal.agent, scenario.goal_task(index), emergency=goal.emergency
                )
                goal_clock.given(index, ticket)

            def change_facts(add: tuple[Atom, ...], delete: tuple[Atom, ...]) -> None:
                # The generic world event (docs/design.md §7.1): the simulated world changes, and
                # every agent learns it at once, as a shut door is known (§6).
                bottom = runtime.bottom_executor
                assert isinstance(bottom, HddlRobot)  # checked: add/delete only in an HDDL world
                bottom.world.change(add, delete)
                runtime.trace.emit(
                    FactsChanged(agent="world", add=tuple(map(str, add)), delete=tuple(map(str, delete)))
                )
                for agent in runtime.agents.values():
                    agent.inbox.send(BeliefUpdate(add=add, delete=delete))

            def apply_event(close: bool, arc: str) -> None:
                fact = Atom("closed", (arc,))
                if close:
                    world.closed.add(arc)
                else:
                    world.closed.discard(arc)
                runtime.trace.emit(
                    ArcClosed(agent="world", arc=arc) if close else ArcOpened(agent="world", arc=arc)
                )
                for agent in runtime.agents.values():
                    agent.inbox.send(BeliefUpdate(add=(fact,)) if close else BeliefUpdate(delete=(fact,)))
                world_changed(runtime, arc, close)

            watchers: list[_Watcher] = []

            def schedule(trigger: Trigger | None, fire: Callable[[], None]) -> None:
                if trigger is None:
                    fire()
                elif trigger.time is not None:
                    clock.call_at(trigger.time, fire)
                else:
                    assert trigger.action is not None  # guaranteed by Trigger's validator
                    watchers.append(_Watcher(trigger, fire, timed=scenario.robot_does(trigger.action)))

            runtime.on_progress(lambda progress: _watch(progress, watchers, clock))
            for i, goal in enumerate(scenario.goals):
                schedule(goal.when, lambda i=i, goal=goal: give(i, goal))  # type: ignore[misc]
            for ev in scenario.events:
                if ev.changes_facts:
                    schedule(ev.when, lambda ev=ev: change_facts(ev.add, ev.delete))  # type: ignore[misc]
                else:
                    schedule(ev.when, lambda ev=ev: apply_event(ev.closes, ev.arc))  # type: ignore[misc]

            first_open = 0  # tickets before it are given and ended: each is looked at once

            def check_done() -> None:
                nonlocal first_open
                while first_open < len(tickets):
                    t = tickets[first_open]
                    if t is None or not runtime.outcomes[t].done:
                        return
                    first_open += 1
                settled.set()

            def on_idle() -> None:
                # Nothing is in flight and no timer is left: nothing more can happen.
                settled.set()

            clock.on_idle(on_idle)
            runtime.on_goal_end(lambda _: check_done())
            check_done()

            async def interrupt(stop: anyio.Event) -> None:
                nonlocal interrupted
                await stop.wait()
                interrupted = not settled.is_set()
                settled.set()

            async with anyio.create_task_group() as waiting:
                if stop is not None:
                    waiting.start_soon(interrupt, stop)
                await settled.wait()
                waiting.cancel_scope.cancel()
            if not interrupted:
                # What is already on its way is handled before the run is summed up.
                with anyio.move_on_after(_QUIET_WITHIN):
                    await clock.stop()
            runtime.fail_unfinished(INTERRUPTED if interrupted else STALLED)
            goal_clock.close(clock.now())
            summary = _summary(scenario, runtime, world, tickets, goal_clock)
            runtime.trace.emit(summary)
            runtime.trace.close()  # the summary is the run's last event, whatever stopping it does
    return RunReport(summary=summary, events=events, interrupted=interrupted, goal_times=goal_clock)


@dataclass
class _Watcher:
    """An action trigger waiting to fire (once).

    ``timed``: the robot performs the action, so the trigger follows its motions
    (or timed activity) and fires when the fraction ``progress`` is covered;
    otherwise it fires when an agent's action finishes with success.
    """

    trigger: Trigger
    fire: Callable[[], None]
    timed: bool
    pending: TimerHandle | None = None
    due: float = 0.0
    fired: bool = False

    @property
    def action(self) -> str:
        return str(self.trigger.action)

    @property
    def progress(self) -> float:
        return self.trigger.progress if self.trigger.progress is not None else 1.0


def _watch(progress: Progress, watchers: list[_Watcher], clock: Clock) -> None:
    """Fire, arm or disarm the action triggers a progress report concerns."""
    action = str(progress.action)
    for w in watchers:
        if w.fired:
            continue
        if progress.phase is Phase.SUCCEEDED:
            # Any agent's action: fire when it (or the resume finishing it) succeeds.
            if not w.timed and action in (w.action, f"resume({w.action})"):
                _fire_in(w, 0.0, clock)
        elif not w.timed:
            continue
        elif progress.phase is Phase.STOPPED:
            # The robot stopped the action half way: disarm, unless the fraction was
            # reached at this very moment (then it fires now all the same).  A rollback
            # of the action always comes after this report, so it finds nothing armed.
            pending = w.pending if w.due > clock.now() + _SAME_INSTANT else None
            if action == w.action and pending is not None:
                pending.cancel()
                w.pending = None
        elif action == w.action:
            # A motion (or activity) of the action starts, fresh or resumed after
            # ``done`` of it: the fraction left to cover takes its share of ``duration``.
            if w.pending is not None:
                w.pending.cancel()
            done = progress.done
            left = 0.0 if w.progress <= done else (w.progress - done) / (1.0 - done)
            _fire_in(w, left * progress.duration, clock)


def _fire_in(w: _Watcher, delay: float, clock: Clock) -> None:
    def fire() -> None:
        if not w.fired:
            w.fired = True
            w.pending = None
            w.fire()

    w.due = clock.now() + delay
    w.pending = clock.call_later(delay, fire)


def world_changed(runtime: Runtime, arc: str, close: bool) -> None:
    """Tell a process serving agents below this runtime's that a door shut or opened."""
    if runtime.bottom_executor is None:
        from htnagent.remote.proxy import RemoteChild

        bottom = runtime.executor
        if isinstance(bottom, RemoteChild):
            bottom.world_changed(arc, close)


def robot_status(runtime: Runtime, world: RobotWorld) -> tuple[dict[str, str], tuple[str, ...], float]:
    """Where the robot is, the nodes it reached, the metres travelled (counting the part of an
    arc it is on): from the robot here, or as the process serving the agents below last told."""
    robot = runtime.bottom_executor
    if isinstance(robot, Robot):
        return world.where(), tuple(world.visited), robot.travelled()
    if isinstance(robot, HddlRobot):
        return {}, (), 0.0  # a world of facts: the robot is at no node and travels no arc
    from htnagent.remote.proxy import RemoteChild

    bottom = runtime.executor
    if isinstance(bottom, RemoteChild) and bottom.status is not None:
        return bottom.status.robot, bottom.status.visited, bottom.status.distance
    return world.where(), tuple(world.visited), world.distance


def _summary(
    scenario: Scenario, runtime: Runtime, world: RobotWorld, tickets: list[int | None], times: GoalClock
) -> Summary:
    goals = []
    for index, (goal, ticket, noted) in enumerate(zip(scenario.goals, tickets, times.goals, strict=True)):
        status: GoalStatus = GoalStatus.FAILURE
        reason = NEVER_TRIGGERED
        if ticket is not None:
            outcome = runtime.outcomes[ticket]
            status = outcome.status or GoalStatus.FAILURE
            reason = outcome.reason
        success = status is GoalStatus.SUCCESS
        goals.append(
            GoalRow(
                agent=goal.agent,
                goal=str(scenario.goal_task(index)),
                status="success" if success else "failure",
                reason="" if success else reason,
                emergency=goal.emergency,
                given=_at(noted.given),
                started=_at(noted.started),
                ended=_at(noted.ended),
                waited_s=round(noted.waited_s, 6),
                resumes=tuple(r.row() for r in noted.resumes),
            )
        )
    robot, visited, distance = robot_status(runtime, world)
    return Summary(
        agent="runtime",
        goals=tuple(goals),
        robot=robot,
        visited=visited,
        distance=round(distance, 6),
        planning_ms={name: round(a.stats.seconds * 1000, 3) for name, a in runtime.agents.items()},
    )


def _at(t: float | None) -> float | None:
    return None if t is None else round(t, 6)
