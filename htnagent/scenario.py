"""Scenario files: loading, checking and cross-referencing (CONTRACTS.md "Scenario file").

A scenario names a map, a robot, a chain of agents (parent first, the last one
executing on the robot), the goals they are given and the world events that
happen while the robot works.  :func:`load_scenario` reads the YAML file into
frozen pydantic models and checks everything a run would otherwise trip over
later: every reference (nodes, arcs, agents, domains, tasks, trigger actions)
is resolved against the map and the agents' domains.  Whatever is wrong is
reported as one :class:`~htnagent.errors.ScenarioError` naming the file and the
key path (``goals[1].when.progress``) or, for YAML syntax, the line.

Text forms inside YAML flow mappings need care: in ``{action: move(n40,n35,arc59),
progress: 0.5}`` YAML itself splits the action at its commas.  The loader puts
such a text form back together from the source, so the contract's own example
reads as written.
"""

from __future__ import annotations

import importlib
import types
from collections.abc import Collection, Mapping, Sequence
from pathlib import Path
from typing import Annotated, Any, Literal, get_args

import yaml
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
from yaml.constructor import ConstructorError

from htnagent.domain import Domain, State
from htnagent.domains import BUILTIN
from htnagent.errors import ScenarioError
from htnagent.maps import WorldMap, parse_map
from htnagent.planner import PlannerSettings
from htnagent.terms import Atom, parse

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
PositiveSeconds = Annotated[float, Strict(), Field(gt=0, allow_inf_nan=False)]


class _Spec(BaseModel):
    model_config = ConfigDict(frozen=True, extra="forbid")


class RobotSpec(_Spec):
    """The simulated robot: where it starts, how fast it goes, how often an action fails."""

    start: Name
    speed: Annotated[float, Strict(), Field(gt=0, allow_inf_nan=False)]
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
    time: Annotated[float, Strict(), Field(ge=0, allow_inf_nan=False)] | None = None
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


def load_scenario(path: str | Path) -> Scenario:
    """Read and check a scenario file; raise ScenarioError naming what is wrong and where."""
    file = str(path)
    p = Path(path)
    data = _read_yaml(p, file, "scenario")
    return parse_scenario(data, file, p.parent)


def parse_scenario(data: Any, file: str, base_dir: str | Path = ".") -> Scenario:
    """Check a scenario given as parsed YAML; ``base_dir`` is where a map file name is looked up."""
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
    scenario._world = _load_map(scenario.map, file, Path(base_dir))
    _cross_check(scenario)
    return scenario


# -- cross references -------------------------------------------------------------


def _cross_check(s: Scenario) -> None:
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
        s._domains[a.name] = _resolve_domain(a.domain, world, file, f"agents[{i}].domain")
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


# -- domains ------------------------------------------------------------------------


def _resolve_domain(spec: str, world: WorldMap, file: str, where: str) -> Domain:
    """A built-in domain by name, or a user's ``package.module:attribute``."""
    factory = BUILTIN.get(spec)
    if factory is not None:
        return factory(world)
    if ":" not in spec:
        raise ScenarioError(
            file,
            where,
            f"unknown domain {spec!r}; built-in domains are {', '.join(sorted(BUILTIN))}, "
            "or name your own as package.module:attribute",
        )
    module_name, _, attr_path = spec.partition(":")
    if not module_name or not attr_path:
        raise ScenarioError(file, where, f"{spec!r}: expected package.module:attribute")
    try:
        module = importlib.import_module(module_name)
    except ModuleNotFoundError as e:
        raise ScenarioError(file, where, f"cannot import module {module_name!r}: {e}") from None
    except Exception as e:  # a user's module may fail to import in any way
        raise ScenarioError(file, where, f"importing {module_name!r} failed: {_one_line(e)}") from None
    target: Any = module
    for part in attr_path.split("."):
        if not hasattr(target, part):
            raise ScenarioError(file, where, f"module {module_name!r} has no attribute {attr_path!r}")
        target = getattr(target, part)
    if isinstance(target, Domain):
        return target
    if not callable(target) or isinstance(target, types.ModuleType):
        raise ScenarioError(
            file,
            where,
            f"{spec} is a {type(target).__name__}, not a Domain nor a function of the map returning one",
        )
    try:
        built = target(world)
    except Exception as e:  # the user's factory
        raise ScenarioError(file, where, f"calling {spec}(map) failed: {_one_line(e)}") from None
    if not isinstance(built, Domain):
        raise ScenarioError(file, where, f"{spec}(map) returned a {type(built).__name__}, not a Domain")
    return built


# -- maps ---------------------------------------------------------------------------


def _load_map(spec: Any, file: str, base_dir: Path) -> WorldMap:
    if isinstance(spec, Mapping):
        return parse_map(spec, file, "map")
    map_path = base_dir / str(spec)
    if not map_path.exists():
        raise ScenarioError(file, "map", f"map file {str(map_path)!r} not found")
    map_file = str(map_path)
    data = _read_yaml(map_path, map_file, "map")
    # An error inside the map file names that file and the key path in it.
    return parse_map(data, map_file, "")


# -- YAML ---------------------------------------------------------------------------


def _read_yaml(path: Path, file: str, what: str) -> Any:
    if path.is_dir():
        raise ScenarioError(file, "", f"is a directory, not a {what} file")
    try:
        text = path.read_text(encoding="utf-8")
    except FileNotFoundError:
        raise ScenarioError(file, "", "no such file") from None
    except UnicodeDecodeError as e:
        raise ScenarioError(
            file, "", f"not UTF-8 text (byte {e.start}); expected a YAML {what} file"
        ) from None
    except OSError as e:
        raise ScenarioError(file, "", f"cannot read the file: {e.strerror or e}") from None
    try:
        data = yaml.load(text, Loader=_Loader)  # _Loader is a SafeLoader
    except yaml.MarkedYAMLError as e:
        mark = e.problem_mark or e.context_mark
        where = f"line {mark.line + 1}, column {mark.column + 1}" if mark is not None else ""
        reason = e.problem or e.context or "invalid YAML"
        if e.context and e.context_mark is not None and e.problem:
            reason += f" ({e.context} at line {e.context_mark.line + 1})"
        raise ScenarioError(file, where, f"invalid YAML: {reason}") from None
    except yaml.YAMLError as e:
        raise ScenarioError(file, "", f"invalid YAML: {_one_line(e)}") from None
    if data is None:
        raise ScenarioError(file, "", f"the file is empty; expected a {what}")
    return data


class _Loader(yaml.SafeLoader):
    """A safe loader that refuses duplicate keys and mends text forms split by flow commas."""

    def construct_mapping(self, node: yaml.MappingNode, deep: bool = False) -> dict[Any, Any]:
        if node.flow_style:
            node.value = _mend_pairs(node.value)
        seen: dict[Any, int] = {}
        for key_node, _ in node.value:
            if isinstance(key_node, yaml.ScalarNode):
                key = self.construct_object(key_node)
                if key in seen:
                    raise ConstructorError(
                        None,
                        None,
                        f"duplicate key {key!r} (first at line {seen[key]})",
                        key_node.start_mark,
                    )
                seen[key] = key_node.start_mark.line + 1
        return super().construct_mapping(node, deep)

    def construct_sequence(self, node: yaml.SequenceNode, deep: bool = False) -> list[Any]:
        if node.flow_style:
            node.value = _mend_items(node.value)
        return super().construct_sequence(node, deep)


def _text_form_end(node: yaml.Node) -> int | None:
    """Where the text form begun by ``node`` really ends, if a flow comma cut it short."""
    if not isinstance(node, yaml.ScalarNode) or node.style is not None:
        return None
    value = str(node.value)
    if value.count("(") <= value.count(")"):
        return None
    buf = node.start_mark.buffer
    if not isinstance(buf, str):
        return None
    depth = 0
    for i in range(node.start_mark.index, len(buf)):
        c = buf[i]
        if c == "(":
            depth += 1
        elif c == ")":
            depth -= 1
            if depth == 0:
                return i + 1
        elif c in "{}[]:\n\0":
            return None
    return None


def _mended(node: yaml.Node, end: int) -> yaml.ScalarNode:
    buf = str(node.start_mark.buffer)
    text = buf[node.start_mark.index : end]
    return yaml.ScalarNode("tag:yaml.org,2002:str", text, node.start_mark, node.end_mark)


def _mend_pairs(pairs: list[tuple[yaml.Node, yaml.Node]]) -> list[tuple[yaml.Node, yaml.Node]]:
    out: list[tuple[yaml.Node, yaml.Node]] = []
    end = -1
    for key, value in pairs:
        if key.start_mark.index < end:
            continue  # a piece of the text form mended into the previous value
        stop = _text_form_end(value)
        if stop is not None:
            end = stop
            value = _mended(value, stop)
        out.append((key, value))
    return out


def _mend_items(items: list[yaml.Node]) -> list[yaml.Node]:
    out: list[yaml.Node] = []
    end = -1
    for item in items:
        if item.start_mark.index < end:
            continue
        stop = _text_form_end(item)
        if stop is not None:
            end = stop
            item = _mended(item, stop)
        out.append(item)
    return out


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
        reason = f"expected text, got {_shown(got)}"
    elif kind == "string_too_short":
        reason = "must not be empty"
    elif kind in ("float_type", "float_parsing", "finite_number"):
        reason = f"expected a finite number, got {_shown(got)}"
    elif kind in ("int_type", "int_parsing", "int_from_float"):
        reason = f"expected a whole number, got {_shown(got)}"
    elif kind in ("bool_type", "bool_parsing"):
        reason = f"expected true or false, got {_shown(got)}"
    elif kind in ("greater_than", "greater_than_equal", "less_than", "less_than_equal"):
        sign = {"greater_than": "gt", "greater_than_equal": "ge", "less_than": "lt", "less_than_equal": "le"}
        words = {"gt": "greater than", "ge": "at least", "lt": "less than", "le": "at most"}
        bound = sign[kind]
        reason = f"must be {words[bound]} {_number(ctx.get(bound))}, got {_shown(got)}"
    elif kind == "too_short":
        reason = "must not be empty" if ctx.get("min_length") == 1 else str(err["msg"])
    elif kind == "literal_error":
        reason = f"expected {ctx.get('expected', 'one of the allowed values')}, got {_shown(got)}"
    elif kind in ("value_error", "assertion_error"):
        reason = str(err["msg"]).removeprefix("Value error, ").removeprefix("Assertion failed, ")
    else:
        reason = f"{err['msg']}, got {_shown(got)}"
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
        return f"text {_shown(value)}"
    return f"{type(value).__name__} {_shown(value)}"


def _shown(value: object) -> str:
    text = repr(value)
    return text if len(text) <= 60 else text[:57] + "..."


def _number(value: object) -> str:
    return f"{value:g}" if isinstance(value, float) else str(value)


def _one_line(e: BaseException) -> str:
    text = " ".join(str(e).split())
    return f"{type(e).__name__}: {text}" if text else type(e).__name__
