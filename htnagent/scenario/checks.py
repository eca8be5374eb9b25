"""Cross-references of a scenario: what its values name must exist, and fit together.

The schema (:mod:`htnagent.scenario.schema`) checks each value by itself; here,
once the map is read and the agents' domains are built, everything a run would
otherwise trip over later is checked: the robot's start node, the chain of
agents, each goal's task (known to the agent's domain, with the right number of
arguments, naming places of the map), each trigger's action (some agent's,
reachable at its ``progress``), each event's arc, the robot's timed actions and
the action timeout.  Every failure is one :class:`~htnagent.errors.ScenarioError`
at the key path of the value at fault.

Nothing here knows a particular domain: what an argument names on the map and
which actions are the robot's moves, each domain declares
(:class:`~htnagent.domains.DomainInfo`).
"""

from __future__ import annotations

from collections.abc import Collection
from pathlib import Path

from htnagent.domains import ROBOT_TRAVEL, DomainInfo
from htnagent.domains.maps import WorldMap
from htnagent.domains.user import resolve_domain
from htnagent.errors import DomainError, ScenarioError
from htnagent.model.actions import RECOVERY
from htnagent.model.domain import Domain
from htnagent.model.networks import network_task
from htnagent.model.terms import Atom
from htnagent.planning.hddl_translation import initial_network
from htnagent.scenario.hddl_agent import (
    DEFAULT_DURATION,
    RESERVED,
    HddlDomainSpec,
    check_fact,
    check_hddl_task,
    load_hddl_agent,
)
from htnagent.scenario.schema import PROBLEM_NETWORK, ROBOT, Scenario, Trigger, no_agent

__all__ = ["check_task", "cross_check"]

_PLANNER_ACTIONS = RECOVERY
"""Actions every domain has for suspended actions: never a goal's task, never timed by name."""


def cross_check(s: Scenario, base_dir: Path, max_file_bytes: int | None = None) -> None:
    """Check every reference of ``s`` against its map and build its agents' domains (in ``s``)."""
    file, world = s.file, s.world
    _check_chain(s)
    s._base = base_dir
    _check_link_files(s, base_dir)
    for i, a in enumerate(s.agents):
        if isinstance(a.domain, HddlDomainSpec):
            if a.executor != ROBOT:
                raise ScenarioError(
                    file,
                    f"agents[{i}].domain",
                    "an HDDL domain is for the agent on the robot (executor: robot), the last of the chain",
                )
            if a.remote is not None:
                raise ScenarioError(
                    file, f"agents[{i}].remote", "an agent on an HDDL domain runs in this process, not remote"
                )
            resolved, planning = load_hddl_agent(
                a.domain, a.suspendable, base_dir, file, f"agents[{i}]", max_file_bytes
            )
            s._domains[a.name] = resolved
            s._hddl[a.name] = planning
            continue
        if a.suspendable:
            raise ScenarioError(
                file,
                f"agents[{i}].suspendable",
                "suspendable is for an HDDL domain; a Python domain declares its own (Suspension)",
            )
        s._domains[a.name] = resolve_domain(a.domain, world, base_dir, file, f"agents[{i}].domain")
    if s.hddl_robot is None:
        # A robot on a map (docs/design.md §6): the map and the start node are needed.
        if s.map is None:
            raise ScenarioError(
                file, "map", "missing: a scenario needs a map, unless the robot's agent has an HDDL domain"
            )
        if s.robot.start is None:
            raise ScenarioError(file, "robot.start", "required: the node the robot starts at")
        if s.robot.speed is None:
            raise ScenarioError(file, "robot.speed", "required: the robot's speed in metres per second")
        if s.robot.start not in world.nodes:
            raise ScenarioError(file, "robot.start", f"unknown node {s.robot.start!r}; it is not on the map")
    else:
        # A world of facts (§7.1): the robot stands on no node and travels no arc.
        for key in ("start", "speed"):
            if getattr(s.robot, key) is not None:
                raise ScenarioError(
                    file, f"robot.{key}", "the robot of an HDDL agent is on no map: leave it out"
                )
    _check_durations(s)
    _check_timeout(s)
    names = s.agent_names
    here = {a.name for a in s.chain_from()[0]}
    goal_tasks: list[Atom] = []
    for i, g in enumerate(s.goals):
        if g.agent not in names:
            raise ScenarioError(file, f"goals[{i}].agent", no_agent(g.agent, names))
        if g.agent not in here:
            raise ScenarioError(
                file,
                f"goals[{i}].agent",
                f"agent {g.agent!r} is served by another process (remote); give goals to "
                f"{', '.join(a.name for a in s.chain_from()[0])}",
            )
        goal_tasks.append(_goal_task(s, i))
        if g.when is not None:
            _check_trigger(s, g.when, f"goals[{i}].when")
    s._goal_tasks = tuple(goal_tasks)
    for i, ev in enumerate(s.events):
        _check_trigger(s, ev.when, f"events[{i}].when")
        if ev.changes_facts:
            _check_facts(s, i)
            continue
        key = "close" if ev.closes else "open"
        if ev.arc not in world.arcs:
            raise ScenarioError(file, f"events[{i}].{key}", f"unknown arc {ev.arc!r}; it is not on the map")


def _goal_task(s: Scenario, i: int) -> Atom:
    """What ``goals[i]``'s agent plans: its task, or its network (every task of it checked
    as a goal's task) as one compound task (docs/design.md §4)."""
    g = s.goals[i]
    if g.task is not None:
        check_task(s, g.agent, g.task, f"goals[{i}].task")
        return g.task
    where = f"goals[{i}].tasks"
    if g.tasks == PROBLEM_NETWORK:
        planning = s.hddl_for(g.agent)
        if planning is None:
            raise ScenarioError(
                s.file,
                where,
                f"{PROBLEM_NETWORK!r} is an HDDL problem's own network, and agent {g.agent}'s domain "
                "is not HDDL; list the tasks: [t1, t2, ...]",
            )
        tasks = initial_network(planning)
    else:
        assert isinstance(g.tasks, tuple)  # the schema allows a list of tasks or PROBLEM_NETWORK
        tasks = g.tasks
        for j, task in enumerate(tasks):
            check_task(s, g.agent, task, f"{where}[{j}]")
    try:
        return network_task(s.domain_for(g.agent), tasks)
    except DomainError as e:
        raise ScenarioError(s.file, where, str(e)) from None


def _check_facts(s: Scenario, i: int) -> None:
    """An event's ``add``/``delete`` facts: of the predicates of the robot's HDDL world."""
    ev = s.events[i]
    planning = s.hddl_robot
    if planning is None:
        key = "add" if ev.add else "delete"
        raise ScenarioError(
            s.file,
            f"events[{i}].{key}",
            "facts are added and deleted in an HDDL agent's world; on a map, close or open an arc",
        )
    for key, facts in (("add", ev.add), ("delete", ev.delete)):
        for j, fact in enumerate(facts):
            check_fact(planning, fact, s.file, f"events[{i}].{key}[{j}]")


def check_task(s: Scenario, agent_name: str, task: Atom, where: str) -> None:
    """Raise ScenarioError at ``where`` unless ``task`` is a task the agent can plan for.

    The task must be ground, named by an operator or method of the agent's
    domain with the same number of arguments, and name nodes, arcs and
    areas of the map where the domain says its arguments do (for an HDDL
    domain: one of its tasks or actions, naming objects of the problem).
    """
    planning = s.hddl_for(agent_name)
    if planning is not None:
        check_hddl_task(planning, agent_name, task, s.file, where)
        return
    domain = s.domain_for(agent_name)
    if not task.is_ground:
        raise ScenarioError(s.file, where, f"{task} has variables; a goal must be ground")
    if not domain.knows(task):
        known = ", ".join(_task_names(domain)) or "none"
        raise ScenarioError(
            s.file,
            where,
            f"agent {agent_name}'s domain {domain.name} has no task {task.name} (its tasks: {known})",
        )
    _check_arity(domain, task, s.file, where)
    _check_map_names(s.info_for(agent_name), task, s.world, s.file, where)


def _check_link_files(s: Scenario, base_dir: Path) -> None:
    """Each file a ``remote:`` link names (certificates, key, password) is a regular file."""
    for i, a in enumerate(s.agents):
        if a.remote is None:
            continue
        for key, name in a.remote.files.items():
            path = base_dir / name
            if not path.is_file():
                why = "is not a regular file" if path.exists() else "does not exist"
                raise ScenarioError(
                    s.file, f"agents[{i}].remote.{key}", f"{name} {why} (paths are relative to the scenario)"
                )


def _check_chain(s: Scenario) -> None:
    """Agents form a chain, parent first: unique names, each executed by the next, the last by the robot."""
    names = s.agent_names
    for i, a in enumerate(s.agents):
        if a.name == ROBOT:
            raise ScenarioError(
                s.file, f"agents[{i}].name", f"{ROBOT!r} names the robot; call the agent something else"
            )
        if a.name in names[:i]:
            raise ScenarioError(s.file, f"agents[{i}].name", f"duplicate agent name {a.name!r}")
    if s.agents[0].remote is not None:
        raise ScenarioError(
            s.file,
            "agents[0].remote",
            "the first agent runs where the goals are given; only an agent below it can be remote",
        )
    for i, a in enumerate(s.agents):
        expected = names[i + 1] if i + 1 < len(names) else ROBOT
        if a.executor != expected:
            what = (
                f"the next agent, {expected!r}" if expected != ROBOT else f"{ROBOT!r} (it is the last agent)"
            )
            raise ScenarioError(
                s.file,
                f"agents[{i}].executor",
                f"expected {what}, got {a.executor!r}; agents form a chain, parent first",
            )


def _check_durations(s: Scenario) -> None:
    """Each timed robot action must be an action of the agent the robot serves, and not a move."""
    last = s.agents[-1]
    domain = s.domain_for(last.name)
    # The simulated robot travels on its moves whatever the domain declares: never timed by name.
    # On an HDDL world it travels nowhere: every action of the domain is timed (docs/design.md §7.1).
    hddl = s.hddl_robot is not None
    untimed = {*_PLANNER_ACTIONS}
    if not hddl:
        untimed |= {*ROBOT_TRAVEL, *s.info_for(last.name).robot_moves}
    for name in s.robot.durations:
        where = f"robot.durations.{name}"
        if hddl and (name in untimed or name.startswith(RESERVED)):
            raise ScenarioError(s.file, where, f"{name} is not an action of the HDDL domain; it is not timed")
        if name in untimed:
            raise ScenarioError(
                s.file, where, f"{name} is not timed here: moves take their arc's length at the robot's speed"
            )
        if name not in domain.operators:
            raise ScenarioError(
                s.file,
                where,
                f"agent {last.name}'s domain {domain.name} has no action {name}, so the robot never does it",
            )


def _check_timeout(s: Scenario) -> None:
    """A timeout must leave the robot time for its longest action, or a normal action times out."""
    if s.action_timeout is None:
        return
    longest: list[tuple[float, str]] = []
    speed = s.robot.metres_per_second
    if s.info_for(s.agents[-1].name).robot_moves:
        longest += [
            (arc.length / speed, f"a move over {arc.name} ({arc.length:g} m at {speed:g} m/s)")
            for arc in s.world.arcs.values()
        ]
    longest += [(seconds, f"{name} (robot.durations)") for name, seconds in s.robot.durations.items()]
    if s.hddl_robot is not None:
        longest.append((DEFAULT_DURATION, f"an action not in robot.durations ({DEFAULT_DURATION:g} s)"))
    if not longest:
        return
    need, what = max(longest)
    if s.action_timeout <= need:
        raise ScenarioError(
            s.file,
            "action_timeout",
            f"{s.action_timeout:g} s is too short: {what} takes {need:.6g} s; give more than {need:.6g} s, "
            "or a normal action times out while the robot is still doing it",
        )


def _check_trigger(s: Scenario, trigger: Trigger, where: str) -> None:
    """The trigger's action must be one some agent does, and ``progress`` one it can reach.

    Only the robot's own actions (moves, ``robot.durations``) have a duration
    known when they start, so only they may fire part way (``progress`` below
    1); any agent's action may fire when it finishes (``progress: 1``).
    """
    action = trigger.action
    if action is None:
        return
    place = f"{where}.action"
    if not action.is_ground:
        raise ScenarioError(s.file, place, f"{action} has variables; a trigger names one ground action")
    if action.name in _PLANNER_ACTIONS:
        inner = action.args[0] if len(action.args) == 1 and isinstance(action.args[0], Atom) else None
        named = f" ({inner})" if inner is not None else ""
        raise ScenarioError(
            s.file,
            place,
            f"{action}: a trigger names the action itself{named}, not its {action.name}; "
            "its progress counts the part done after a resume too",
        )
    owners = [a for a in s.agents if s.domain_for(a.name).is_primitive(action)]
    if not owners:
        raise ScenarioError(
            s.file, place, f"no agent has an action named {action.name}, so the trigger would never fire"
        )
    owner = owners[0]
    _check_arity(s.domain_for(owner.name), action, s.file, place)
    _check_map_names(s.info_for(owner.name), action, s.world, s.file, place)
    if s.robot_does(action):
        return
    if [a.name for a in owners] == [s.agents[-1].name]:
        raise ScenarioError(
            s.file,
            place,
            f"the robot cannot do {action} (it is not a move and {action.name} is not in robot.durations), "
            "so it never succeeds and the trigger would never fire",
        )
    if trigger.progress is not None and trigger.progress < 1:
        raise ScenarioError(
            s.file,
            f"{where}.progress",
            f"{action} is agent {owner.name}'s action, not the robot's: its duration is not known "
            "in advance, so it can only trigger when it has finished (progress: 1), "
            f"not at {trigger.progress:g}",
        )


def _check_arity(domain: Domain, task: Atom, file: str, where: str) -> None:
    arities = {len(op.head.args) for op in domain.operators.get(task.name, ())}
    arities |= {len(m.head.args) for m in domain.methods.get(task.name, ())}
    if len(task.args) not in arities:
        expected = " or ".join(str(n) for n in sorted(arities))
        noun = "argument" if expected == "1" else "arguments"
        raise ScenarioError(
            file, where, f"{task.name} takes {expected} {noun} in {domain.name}, not {len(task.args)}"
        )


def _check_map_names(info: DomainInfo, task: Atom, world: WorldMap, file: str, where: str) -> None:
    """The arguments the domain says name the map must be on it; a robot move's arc must join its ends."""
    kinds = info.kinds_of(task.name)
    if kinds is None or len(kinds) != len(task.args):
        return
    known: dict[str, Collection[str]] = {"node": world.nodes, "arc": world.arcs, "area": world.areas}
    for kind, arg in zip(kinds, task.args, strict=True):
        if not isinstance(arg, str) or arg not in known[kind]:
            raise ScenarioError(file, where, f"{task}: unknown {kind} {str(arg)!r}; it is not on the map")
    if task.name in info.robot_moves:
        f, t, arc = (str(a) for a in task.args)
        ends = world.arcs[arc]
        if {ends.a, ends.b} != {f, t}:
            raise ScenarioError(file, where, f"{task}: {arc} joins {ends.a} and {ends.b}, not {f} and {t}")


def _task_names(domain: Domain) -> list[str]:
    return sorted(n for n in (*domain.methods, *domain.operators) if n not in _PLANNER_ACTIONS)
