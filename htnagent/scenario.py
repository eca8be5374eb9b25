"""Scenario files: loading, checking and cross-referencing (CONTRACTS.md "Scenario file").

A scenario names a map, a robot, a chain of agents (parent first, the last one
executing on the robot), the goals they are given and the world events that
happen while the robot works.  :func:`load_scenario` reads the YAML file into
frozen pydantic models and checks everything a run would otherwise trip over
later: every reference (nodes, arcs, agents, domains, tasks, trigger actions)
is resolved against the map and the agents' domains.  Whatever is wrong is
reported as one :class:`~htnagent.errors.ScenarioError` naming the file and the
key path (``goals[1].when.progress``) or, for YAML syntax, the line.

Files are read by :mod:`htnagent.loading`, which trusts nothing in them (special
files, sizes, nesting, aliases; see :mod:`htnagent.limits`) and puts text forms
that YAML split at flow commas back together, so the contract's own example
``{action: move(n40,n35,arc59), progress: 0.5}`` reads as written.  A domain
named as ``package.module:attribute`` is the user's own code, and runs
(:mod:`htnagent.user_domains`).
"""

from __future__ import annotations

import os
from collections.abc import Collection, Mapping, Sequence
from pathlib import Path
from typing import Annotated, Any, Literal, get_args

from pydantic import (
    BaseModel,
    ConfigDict,
    Field,
    PlainSerializer,
    PlainValidator,
    PrivateAttr,
    Strict,
    ValidationError,
    field_validator,
    model_validator,
)

from htnagent.domain import Domain, State
from htnagent.errors import ScenarioError, shown
from htnagent.limits import MAX_SECONDS, MAX_SPEED, MIN_SPEED
from htnagent.loading import gc_paused, read_yaml
from htnagent.maps import WorldMap, parse_map
from htnagent.planner import PlannerSettings
from htnagent.terms import Atom, parse
from htnagent.user_domains import resolve_domain

__all__ = [
    "AgentSpec",
    "GoalSpec",
    "PlannerSpec",
    "RobotSpec",
    "Scenario",
    "Trigger",
    "WorldEvent",
    "load_scenario",
    "parse_scenario",
]

ROBOT = "robot"
"""The executor name of the last agent of the chain: the robot itself."""


def _parse_atom(value: Any) -> Atom:
    if isinstance(value, Atom):
        return value
    return parse(value)  # a TextFormError is a ValueError: pydantic reports it at the key


TextForm = Annotated[Atom, PlainValidator(_parse_atom), PlainSerializer(str)]
"""A task or action written ``name(arg,...)`` in the file, held as an :class:`Atom`."""

Name = Annotated[str, Field(min_length=1)]
PositiveSeconds = Annotated[float, Strict(), Field(gt=0, le=MAX_SECONDS, allow_inf_nan=False)]


class _Spec(BaseModel):
    model_config = ConfigDict(frozen=True, extra="forbid")


class RobotSpec(_Spec):
    """The simulated robot: where it starts, how fast it goes, how often an action fails."""

    start: Name
    speed: Annotated[float, Strict(), Field(ge=MIN_SPEED, le=MAX_SPEED, allow_inf_nan=False)]
    """Metres per simulated second."""
    failure_rate: Annotated[float, Strict(), Field(ge=0, le=1)] = 0.0
    """The chance that an action fails of itself (for failure experiments)."""
    seed: Annotated[int, Strict()] = 0
    """Seed of the robot's random failures, so runs repeat."""
    durations: dict[Name, PositiveSeconds] = {}
    """Seconds each of the robot's other actions takes, by action name (``explain: 60``).

    Moves take their arc's length at ``speed``; an action named here takes its
    time wherever the robot stands, and may be suspended half way and resumed.
    """


class AgentSpec(_Spec):
    """One planning agent: its name, its domain and who executes its actions."""

    name: Name
    domain: Name
    """A built-in domain name or ``package.module:attribute``."""
    executor: Name
    """The next agent's name, or ``robot`` for the last agent."""


class PlannerSpec(_Spec):
    """How hard every agent's planner tries (see :class:`~htnagent.planner.PlannerSettings`)."""

    alternatives: Annotated[int, Strict(), Field(ge=1)] = 2
    budget: Annotated[int, Strict(), Field(ge=1)] = 200_000


class Trigger(_Spec):
    """When something happens: at a simulated ``time``, or once ``action`` reaches ``progress``."""

    action: TextForm | None = None
    progress: Annotated[float, Strict(), Field(gt=0, le=1)] | None = None
    """The fraction of the action's duration covered, in (0, 1].

    Below 1 only for an action the robot performs itself (a move, or an action of
    ``robot.durations``), followed through suspensions and resumptions; any
    agent's action may trigger with 1, when it (or its ``resume``) succeeds.
    """
    time: Annotated[float, Strict(), Field(ge=0, le=MAX_SECONDS, allow_inf_nan=False)] | None = None
    """Simulated seconds from the start."""

    @model_validator(mode="after")
    def _one_form(self) -> Trigger:
        if self.time is not None:
            if self.action is not None or self.progress is not None:
                raise ValueError("give either {time: T} or {action: A, progress: P}, not both")
        elif self.action is None:
            raise ValueError("expected {time: T} or {action: A, progress: P}")
        elif self.progress is None:
            raise ValueError("an action trigger needs progress, the fraction in (0, 1] it fires at")
        return self


class GoalSpec(_Spec):
    """A task given to an agent: at the start, or when its trigger fires."""

    agent: Name
    task: TextForm
    emergency: Annotated[bool, Strict()] = False
    """Whether the goal interrupts (suspends) what the agent is doing."""
    when: Trigger | None = None
    """None: given at time 0, in file order."""


class WorldEvent(_Spec):
    """A change of the world: an arc is closed (a door shut) or opened again."""

    when: Trigger
    close: Name | None = None
    open: Name | None = None

    @model_validator(mode="after")
    def _one_change(self) -> WorldEvent:
        if (self.close is None) == (self.open is None):
            raise ValueError("an event either closes or opens one arc: give exactly one of close, open")
        return self

    @property
    def arc(self) -> str:
        """The arc the event closes or opens."""
        arc = self.close if self.close is not None else self.open
        assert arc is not None  # guaranteed by the validator
        return arc

    @property
    def closes(self) -> bool:
        """True when the event closes the arc, False when it opens it."""
        return self.close is not None


class Scenario(_Spec):
    """A checked scenario; build it with :func:`load_scenario` (or :func:`parse_scenario`).

    Besides the fields of the file it holds the parsed map (:attr:`world`) and
    each agent's domain, built once from that map.
    """

    name: Name
    map: Any
    """The map file name (relative to the scenario file) or the map inline, as written."""
    robot: RobotSpec
    agents: Annotated[tuple[AgentSpec, ...], Field(min_length=1)]
    """Parent first; each agent's executor is the next agent, the last one's the robot."""
    replanning: Literal["online", "naive"] = "online"
    planner: PlannerSpec = PlannerSpec()
    action_timeout: PositiveSeconds | None = None
    """Simulated seconds after which a running action is given up; None: never."""
    goals: Annotated[tuple[GoalSpec, ...], Field(min_length=1)]
    events: tuple[WorldEvent, ...] = ()

    _file: str = PrivateAttr(default="")
    _world: WorldMap | None = PrivateAttr(default=None)
    _domains: dict[str, Domain] = PrivateAttr(default_factory=dict)

    @field_validator("map", mode="before")
    @classmethod
    def _map_form(cls, value: Any) -> Any:
        if isinstance(value, str) and value.strip():
            return value
        if isinstance(value, Mapping):
            return value
        raise ValueError(f"expected a map file name or the map inline (a mapping), got {_kind(value)}")

    @property
    def file(self) -> str:
        """The scenario file, as it was named when loaded."""
        return self._file

    @property
    def world(self) -> WorldMap:
        """The scenario's map."""
        if self._world is None:
            raise RuntimeError("this Scenario was not built by load_scenario or parse_scenario")
        return self._world

    @property
    def settings(self) -> PlannerSettings:
        """The planner settings every agent uses."""
        return PlannerSettings(alternatives=self.planner.alternatives, budget=self.planner.budget)

    @property
    def agent_names(self) -> tuple[str, ...]:
        """The agents' names, parent first."""
        return tuple(a.name for a in self.agents)

    def agent(self, name: str) -> AgentSpec:
        """The agent called ``name``; ScenarioError if there is none."""
        for a in self.agents:
            if a.name == name:
                return a
        raise ScenarioError(self._file, "agents", _no_agent(name, self.agent_names))

    def domain_for(self, agent_name: str) -> Domain:
        """The agent's domain, built from the map (once; later calls return the same object)."""
        self.agent(agent_name)
        return self._domains[agent_name]

    def initial_state(self, agent_name: str) -> State:
        """The agent's belief at the start, with the robot at ``robot.start``."""
        return self.domain_for(agent_name).initial_state(self.robot.start)

    def robot_does(self, action: Atom) -> bool:
        """Whether the robot itself performs ``action``: a move or an action of ``robot.durations``.

        Such an action's duration is known when the robot starts it, so a trigger
        may fire part way through it; any other action is a planning agent's,
        achieved by the agents below it in however long that takes.
        """
        last = self.agents[-1].name
        if not self.domain_for(last).is_primitive(action):
            return False
        return action.name == "move" or action.name in self.robot.durations

    def check_task(self, agent_name: str, task: Atom, where: str) -> None:
        """Raise ScenarioError at ``where`` unless ``task`` is a task the agent can plan for.

        The task must be ground, named by an operator or method of the agent's
        domain with the same number of arguments, and (for the built-in museum
        domains) name nodes, arcs and areas of the map.
        """
        domain = self.domain_for(agent_name)
        if not task.is_ground:
            raise ScenarioError(self._file, where, f"{task} has variables; a goal must be ground")
        if not domain.knows(task):
            known = ", ".join(_task_names(domain)) or "none"
            raise ScenarioError(
                self._file,
                where,
                f"agent {agent_name}'s domain {domain.name} has no task {task.name} (its tasks: {known})",
            )
        _check_arity(domain, task, self._file, where)
        _check_map_names(self.agent(agent_name).domain, task, self.world, self._file, where)


def load_scenario(path: str | Path, *, max_file_bytes: int | None = None) -> Scenario:
    """Read and check a scenario file; raise ScenarioError naming what is wrong and where.

    Only regular files of at most ``max_file_bytes`` bytes are read, the
    scenario and its map file alike (default: the environment variable
    ``HTNAGENT_MAX_FILE_BYTES``, else 64 MiB; see :mod:`htnagent.limits`).
    A domain named as ``package.module:attribute`` is imported from the
    scenario file's folder or the installed packages, and runs.
    """
    file = str(path)
    data = read_yaml(path, "scenario", max_file_bytes)
    return parse_scenario(data, file, Path(file).parent, max_file_bytes=max_file_bytes)


def parse_scenario(
    data: Any, file: str, base_dir: str | Path = ".", *, max_file_bytes: int | None = None
) -> Scenario:
    """Check a scenario given as parsed YAML.

    ``base_dir`` is where a map file name and a user's domain module are looked up.
    """
    if not isinstance(data, Mapping):
        raise ScenarioError(
            file,
            "",
            f"a scenario must be a mapping (name, map, robot, agents, goals, ...), not {_kind(data)}",
        )
    if "nodes" in data and "arcs" in data and "agents" not in data:
        raise ScenarioError(file, "", "this is a map, not a scenario; a scenario names its map under map:")
    try:
        scenario = Scenario.model_validate(data)
    except ValidationError as e:
        where, reason = _first_error(e)
        raise ScenarioError(file, where, reason) from None
    scenario._file = file
    # Big maps make millions of objects (the map, the domains' tables); collecting garbage
    # meanwhile would walk them again and again for nothing, so it waits until the end.
    with gc_paused():
        scenario._world = _load_map(scenario.map, file, Path(base_dir), max_file_bytes)
        _cross_check(scenario, Path(base_dir))
    return scenario


# -- cross references -------------------------------------------------------------


def _cross_check(s: Scenario, base_dir: Path) -> None:
    file, world = s.file, s.world
    if s.robot.start not in world.nodes:
        raise ScenarioError(file, "robot.start", f"unknown node {s.robot.start!r}; it is not on the map")
    names = s.agent_names
    for i, a in enumerate(s.agents):
        if a.name == ROBOT:
            raise ScenarioError(
                file, f"agents[{i}].name", f"{ROBOT!r} names the robot; call the agent something else"
            )
        if a.name in names[:i]:
            raise ScenarioError(file, f"agents[{i}].name", f"duplicate agent name {a.name!r}")
    for i, a in enumerate(s.agents):
        expected = names[i + 1] if i + 1 < len(names) else ROBOT
        if a.executor != expected:
            what = (
                f"the next agent, {expected!r}" if expected != ROBOT else f"{ROBOT!r} (it is the last agent)"
            )
            raise ScenarioError(
                file,
                f"agents[{i}].executor",
                f"expected {what}, got {a.executor!r}; agents form a chain, parent first",
            )
    for i, a in enumerate(s.agents):
        s._domains[a.name] = resolve_domain(a.domain, world, base_dir, file, f"agents[{i}].domain")
    _check_durations(s)
    _check_timeout(s)
    for i, g in enumerate(s.goals):
        if g.agent not in names:
            raise ScenarioError(file, f"goals[{i}].agent", _no_agent(g.agent, names))
        s.check_task(g.agent, g.task, f"goals[{i}].task")
        if g.when is not None:
            _check_trigger(s, g.when, f"goals[{i}].when")
    for i, ev in enumerate(s.events):
        _check_trigger(s, ev.when, f"events[{i}].when")
        key = "close" if ev.closes else "open"
        if ev.arc not in world.arcs:
            raise ScenarioError(file, f"events[{i}].{key}", f"unknown arc {ev.arc!r}; it is not on the map")


def _check_durations(s: Scenario) -> None:
    """Each timed robot action must be an action of the agent the robot serves."""
    last = s.agents[-1]
    domain = s.domain_for(last.name)
    for name in s.robot.durations:
        where = f"robot.durations.{name}"
        if name in ("move", "resume", "rollback"):
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
    """A timeout must leave the robot time for its longest action, or a normal move times out."""
    if s.action_timeout is None:
        return
    longest: list[tuple[float, str]] = [
        (arc.length / s.robot.speed, f"a move over {arc.name} ({arc.length:g} m at {s.robot.speed:g} m/s)")
        for arc in s.world.arcs.values()
    ]
    longest += [(seconds, f"{name} (robot.durations)") for name, seconds in s.robot.durations.items()]
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
    if action.name in ("resume", "rollback"):
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
    domain = s.domain_for(owner.name)
    _check_arity(domain, action, s.file, place)
    _check_map_names(owner.domain, action, s.world, s.file, place)
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


# What the arguments of the built-in museum domains' tasks and actions name on the map.
_ARGUMENT_KINDS: dict[str, dict[str, tuple[str, ...]]] = {
    "museum.areas": {"goto": ("node",), "goto_node": ("node",), "move_area": ("area", "area")},
    "museum.nodes": {
        "goto_node": ("node",),
        "move_area": ("area", "area"),
        "move": ("node", "node", "arc"),
    },
}


def _check_map_names(domain_spec: str, task: Atom, world: WorldMap, file: str, where: str) -> None:
    kinds = _ARGUMENT_KINDS.get(domain_spec, {}).get(task.name)
    if kinds is None or len(kinds) != len(task.args):
        return
    known: dict[str, Collection[str]] = {"node": world.nodes, "arc": world.arcs, "area": world.areas}
    for kind, arg in zip(kinds, task.args, strict=True):
        if not isinstance(arg, str) or arg not in known[kind]:
            raise ScenarioError(file, where, f"{task}: unknown {kind} {str(arg)!r}; it is not on the map")
    if task.name == "move":
        f, t, arc = (str(a) for a in task.args)
        ends = world.arcs[arc]
        if {ends.a, ends.b} != {f, t}:
            raise ScenarioError(file, where, f"{task}: {arc} joins {ends.a} and {ends.b}, not {f} and {t}")


def _task_names(domain: Domain) -> list[str]:
    return sorted(n for n in (*domain.methods, *domain.operators) if n not in ("resume", "rollback"))


def _no_agent(name: str, names: Sequence[str]) -> str:
    return f"no agent named {name!r}; the agents are {', '.join(names)}"


# -- maps ---------------------------------------------------------------------------


def _load_map(spec: Any, file: str, base_dir: Path, max_file_bytes: int | None) -> WorldMap:
    if isinstance(spec, Mapping):
        return parse_map(spec, file, "map")
    map_file = str(base_dir / str(spec))
    # A map file that is not there is the scenario's mistake; one that is there but bad, the map's.
    try:
        os.stat(map_file)
    except FileNotFoundError:
        raise ScenarioError(file, "map", f"map file {shown(map_file, 200)} not found") from None
    except (OSError, ValueError) as e:  # a name too long, a path through a file, a NUL in the name
        reason = e.strerror if isinstance(e, OSError) and e.strerror else str(e)
        raise ScenarioError(file, "map", f"cannot read map file {shown(map_file, 200)}: {reason}") from None
    data = read_yaml(map_file, "map", max_file_bytes)
    # An error inside the map file names that file and the key path in it.
    return parse_map(data, map_file, "")


# -- pydantic errors as key paths ----------------------------------------------------


def _first_error(e: ValidationError) -> tuple[str, str]:
    """The first validation error as ``(key path, reason)``, in the words of the file."""
    err = e.errors(include_url=False)[0]
    loc = tuple(err["loc"])
    kind = err["type"]
    got = err.get("input")
    ctx = err.get("ctx") or {}
    where = _key_path(loc)
    if kind == "missing":
        reason = "required, but missing"
    elif kind == "extra_forbidden":
        model = _model_at(loc[:-1])
        allowed = f"; expected one of {', '.join(model.model_fields)}" if model is not None else ""
        reason = f"unknown key{allowed}"
    elif kind in ("model_type", "dict_type", "model_attributes_type"):
        reason = f"expected a mapping, got {_kind(got)}"
    elif kind in ("tuple_type", "list_type"):
        reason = f"expected a list, got {_kind(got)}"
    elif kind == "string_type":
        reason = f"expected text, got {shown(got)}"
    elif kind == "string_too_short":
        reason = "must not be empty"
    elif kind in ("float_type", "float_parsing", "finite_number"):
        reason = f"expected a finite number, got {shown(got)}"
    elif kind in ("int_type", "int_parsing", "int_from_float"):
        reason = f"expected a whole number, got {shown(got)}"
    elif kind in ("bool_type", "bool_parsing"):
        reason = f"expected true or false, got {shown(got)}"
    elif kind in ("greater_than", "greater_than_equal", "less_than", "less_than_equal"):
        sign = {"greater_than": "gt", "greater_than_equal": "ge", "less_than": "lt", "less_than_equal": "le"}
        words = {"gt": "greater than", "ge": "at least", "lt": "less than", "le": "at most"}
        bound = sign[kind]
        reason = f"must be {words[bound]} {_number(ctx.get(bound))}, got {shown(got)}"
    elif kind == "too_short":
        reason = "must not be empty" if ctx.get("min_length") == 1 else str(err["msg"])
    elif kind == "literal_error":
        reason = f"expected {ctx.get('expected', 'one of the allowed values')}, got {shown(got)}"
    elif kind in ("value_error", "assertion_error"):
        reason = str(err["msg"]).removeprefix("Value error, ").removeprefix("Assertion failed, ")
    else:
        reason = f"{err['msg']}, got {shown(got)}"
    return where, reason


def _key_path(loc: Sequence[int | str]) -> str:
    out = ""
    for part in loc:
        if isinstance(part, int):
            out += f"[{part}]"
        else:
            out += f".{part}" if out else str(part)
    return out


def _model_at(loc: Sequence[int | str]) -> type[BaseModel] | None:
    """The model class validating the mapping at ``loc`` (to list its keys)."""
    model: type[BaseModel] = Scenario
    for part in loc:
        if isinstance(part, int):
            continue
        field = model.model_fields.get(part)
        if field is None:
            return None
        inner = _inner_model(field.annotation)
        if inner is None:
            return None
        model = inner
    return model


def _inner_model(annotation: Any) -> type[BaseModel] | None:
    if isinstance(annotation, type) and issubclass(annotation, BaseModel):
        return annotation
    for arg in get_args(annotation):
        found = _inner_model(arg)
        if found is not None:
            return found
    return None


def _kind(value: object) -> str:
    if value is None:
        return "nothing"
    if isinstance(value, Mapping):
        return "a mapping"
    if isinstance(value, list | tuple):
        return "a list"
    if isinstance(value, bool):
        return f"{value!r}".lower()
    if isinstance(value, str):
        return f"text {shown(value)}"
    return f"{type(value).__name__} {shown(value)}"


def _number(value: object) -> str:
    return f"{value:g}" if isinstance(value, float) else str(value)
