"""The scenario file's schema: frozen pydantic models of what docs/contracts.md "Scenario file" allows.

Each model checks its own values (types, bounds, one form of a trigger);
whatever refers to something else -- a node of the map, an agent, a domain's
task -- is checked by :mod:`htnagent.scenario.checks` once the map and the
domains are built.  :class:`Scenario` is what :func:`~htnagent.scenario.load_scenario`
returns: the file's fields plus the parsed map and each agent's domain.
"""

from __future__ import annotations

import ipaddress
import re
from collections.abc import Mapping
from dataclasses import replace
from pathlib import Path
from typing import Annotated, Literal

from pydantic import (
    BeforeValidator,
    Discriminator,
    Field,
    PlainValidator,
    PrivateAttr,
    Strict,
    Tag,
    model_validator,
)

from htnagent.domains import DomainInfo
from htnagent.domains.maps import WorldMap
from htnagent.domains.user import ResolvedDomain
from htnagent.errors import ScenarioError, TextFormError, shown
from htnagent.limits import MAX_SECONDS, MAX_SPEED, MIN_SPEED
from htnagent.model.actions import RECOVERY
from htnagent.model.domain import Domain, State
from htnagent.model.terms import Atom
from htnagent.planning.composition import ground
from htnagent.planning.hddl_translation import HddlPlanning
from htnagent.planning.planner import PlannerSettings, Search
from htnagent.scenario.hddl_agent import HddlDomainSpec
from htnagent.scenario.specs import Name, Spec, TextForm, parse_text_form
from htnagent.scenario.wording import ENDPOINT_PATTERN, kind_of

__all__ = [
    "GROUNDED",
    "PROBLEM_NETWORK",
    "ROBOT",
    "AgentSpec",
    "GoalSpec",
    "HddlDomainSpec",
    "MapSource",
    "PlannerSpec",
    "RemoteLink",
    "RobotSpec",
    "Scenario",
    "TaskNetwork",
    "TextForm",
    "Trigger",
    "WorldEvent",
    "on_loopback",
]

ROBOT = "robot"
"""The executor name of the last agent of the chain: the robot itself."""


Endpoint = Annotated[str, Strict(), Field(pattern=ENDPOINT_PATTERN)]
"""A Zenoh endpoint: ``tcp/HOST:PORT`` or ``tls/HOST:PORT`` (an IPv6 address in brackets)."""
EnvName = Annotated[str, Strict(), Field(pattern=r"^[A-Za-z_][A-Za-z0-9_]{0,127}$")]
FileName = Annotated[str, Strict(), Field(min_length=1, max_length=4096)]


def on_loopback(endpoint: str) -> bool:
    """Whether ``endpoint`` (``PROTO/HOST:PORT``) names this host only: 127.0.0.0/8, ::1 or localhost.

    Anything else -- another address, a host name, ``0.0.0.0`` (every interface) -- may be
    reached from the network."""
    host = endpoint.split("/", 1)[-1].rsplit(":", 1)[0].strip("[]")
    if host.lower() == "localhost":
        return True
    try:
        return ipaddress.ip_address(host).is_loopback
    except ValueError:
        return False


class RemoteLink(Spec):
    """Where another process serves an agent, and how the link to it is secured.

    Written either as the endpoint alone (``remote: "tcp/127.0.0.1:7447"``) or as a
    mapping.  Paths are relative to the scenario file; a password is never written in
    the file, only where to find it (an environment variable or a file)."""

    endpoint: Endpoint
    root_ca: FileName | None = None
    """The root certificate the serving process's certificate must be signed by (TLS)."""
    certificate: FileName | None = None
    """This (the parent's) side's certificate, for mutual TLS."""
    key: FileName | None = None
    """The private key of ``certificate``."""
    user: Annotated[str, Strict(), Field(min_length=1, max_length=256)] | None = None
    """Zenoh's user/password authentication: the user name."""
    password_env: EnvName | None = None
    """The environment variable holding the password."""
    password_file: FileName | None = None
    """The file holding the password (its first line)."""
    insecure: Annotated[bool, Strict()] = False
    """Allow a plain ``tcp/`` endpoint off the loopback (anyone on the way reads and forges)."""

    @model_validator(mode="after")
    def _secured(self) -> RemoteLink:
        if (self.certificate is None) != (self.key is None):
            raise ValueError("certificate and key go together (mutual TLS)")
        if self.password_env is not None and self.password_file is not None:
            raise ValueError("give the password in password_env or password_file, not both")
        has_password = self.password_env is not None or self.password_file is not None
        if has_password != (self.user is not None):
            raise ValueError("user and a password (password_env or password_file) go together")
        tls = self.endpoint.startswith("tls/")
        if tls:
            if self.root_ca is None:
                raise ValueError(
                    "a tls/ endpoint needs root_ca, the root certificate the server's is checked by"
                )
            if self.certificate is None and self.user is None:
                raise ValueError(
                    "a tls/ endpoint needs certificate and key (mutual TLS) or user and a password"
                )
        elif self.root_ca is not None or self.certificate is not None:
            raise ValueError("certificates need a tls/ endpoint")
        elif not on_loopback(self.endpoint) and not self.insecure:
            raise ValueError(
                f"{self.endpoint} is off the loopback, where anyone who reaches it could order the "
                "robot: use a tls/ endpoint with root_ca and certificate and key (mutual TLS) or "
                "user and a password (or insecure: true to allow it anyway)"
            )
        return self

    @property
    def files(self) -> dict[str, str]:
        """The files the link names, by key (relative to the scenario file)."""
        named = {
            "root_ca": self.root_ca,
            "certificate": self.certificate,
            "key": self.key,
            "password_file": self.password_file,
        }
        return {k: v for k, v in named.items() if v is not None}


def _remote_link(value: object) -> object:
    # The short form, the endpoint alone, is the mapping with nothing but it.
    return {"endpoint": value} if isinstance(value, str) else value


Namespace = Annotated[str, Strict(), Field(pattern=r"^[A-Za-z0-9_.-]+(/[A-Za-z0-9_.-]+)*$", max_length=200)]
PositiveSeconds = Annotated[float, Strict(), Field(gt=0, le=MAX_SECONDS, allow_inf_nan=False)]


def _map_source(value: object) -> str | Mapping[object, object]:
    if isinstance(value, str) and value.strip():
        return value
    if isinstance(value, Mapping):
        return value
    raise ValueError(f"expected a map file name or the map inline (a mapping), got {kind_of(value)}")


MapSource = Annotated[str | Mapping[object, object], PlainValidator(_map_source)]
"""A map file name (relative to the scenario file) or the map inline, as written."""


class RobotSpec(Spec):
    """The simulated robot: where it starts, how fast it goes, how often an action fails."""

    start: Name | None = None
    """The node it starts at: needed on a map (not for an HDDL agent's robot, docs/design.md §7.1)."""
    speed: Annotated[float, Strict(), Field(ge=MIN_SPEED, le=MAX_SPEED, allow_inf_nan=False)] | None = None
    """Metres per simulated second: needed on a map (not for an HDDL agent's robot)."""
    failure_rate: Annotated[float, Strict(), Field(ge=0, le=1)] = 0.0
    """The chance that an action fails of itself (for failure experiments)."""
    seed: Annotated[int, Strict()] = 0
    """Seed of the robot's random failures, so runs repeat."""
    durations: Annotated[dict[Name, PositiveSeconds], Field(fail_fast=True)] = {}  # noqa: RUF012 (a pydantic field: copied per model)
    """Seconds each of the robot's other actions takes, by action name (``explain: 60``).

    Moves take their arc's length at ``speed``; an action named here takes its
    time wherever the robot stands, and may be suspended half way and resumed.
    For an HDDL agent's robot, every action not named here takes 1 s.
    """

    @property
    def metres_per_second(self) -> float:
        """:attr:`speed`, checked present for a robot on a map (1 for an HDDL agent's, unused)."""
        return 1.0 if self.speed is None else self.speed


def _domain_form(value: object) -> str | None:
    """Which form a domain is written in: a name, ``{hddl: D, problem: P}``, or neither."""
    if isinstance(value, str):
        return _NAMED
    return _HDDL if isinstance(value, Mapping) else None


# The tags name the two forms; the translator leaves them out of key paths.
_NAMED, _HDDL = "name", "{hddl, problem}"

DomainForm = Annotated[
    Annotated[Name, Tag(_NAMED)] | Annotated[HddlDomainSpec, Tag(_HDDL)],
    Discriminator(
        _domain_form,
        custom_error_type="domain_form",
        custom_error_message=(
            "expected a domain name (museum.nodes, package.module:attribute) "
            "or {hddl: DOMAIN.hddl, problem: PROBLEM.hddl}"
        ),
    ),
]
"""An agent's domain: a built-in or user's domain by name, or HDDL files."""


class AgentSpec(Spec):
    """One planning agent: its name, its domain and who executes its actions."""

    name: Name
    domain: DomainForm
    """A built-in domain name, ``package.module:attribute``, or ``{hddl: D, problem: P}``."""
    suspendable: Annotated[tuple[Name, ...], Field(fail_fast=True)] = ()
    """For an HDDL domain: the actions that may be suspended half way (docs/design.md §7.1)."""
    executor: Name
    """The next agent's name, or ``robot`` for the last agent."""
    remote: Annotated[RemoteLink, BeforeValidator(_remote_link)] | None = None
    """Where another process serves this agent and everything below it
    (``python -m htnagent serve``), e.g. ``tcp/127.0.0.1:7447``, and how the link is
    secured; None: in this process."""

    @property
    def endpoint(self) -> str | None:
        """The endpoint of :attr:`remote` (None: in this process)."""
        return None if self.remote is None else self.remote.endpoint


class PlannerSpec(Spec):
    """How hard every agent's planner tries (see :class:`~htnagent.planning.planner.PlannerSettings`)."""

    alternatives: Annotated[int, Strict(), Field(ge=1)] = 2
    budget: Annotated[int, Strict(), Field(ge=1)] = 200_000
    search: Literal["astar", "gbfs", "dfs", "grounded"] = "astar"
    """The search order (docs/design.md §1.1): cost-optimal A*, greedy best-first, or
    depth-first in method order; ``grounded``: greedy best-first guided, for an agent of an
    HDDL domain, by the problem grounded (§7.2, what ``plan --hddl`` may answer with)."""


class Trigger(Spec):
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


GROUNDED = "grounded"
"""The planner's ``search`` that guides greedy search by the grounded problem (§7.2)."""
PROBLEM_NETWORK = "problem"
"""``tasks: problem``: an HDDL agent's goal is its problem's own initial task network."""


def _task_network(value: object) -> tuple[Atom, ...] | str:
    """``tasks``: a non-empty list of tasks, each ``name(arg,...)``, or ``problem``."""
    if value == PROBLEM_NETWORK:
        return PROBLEM_NETWORK
    if isinstance(value, str):
        raise ValueError(
            f"expected a list of tasks [t1, t2, ...] or {PROBLEM_NETWORK!r} (an HDDL problem's own "
            f"network), got {shown(value)}"
        )
    if not isinstance(value, (list, tuple)):
        raise ValueError(f"expected a list of tasks [t1, t2, ...], got {kind_of(value)}")
    if not value:
        raise ValueError("an empty task network: give at least one task")
    tasks: list[Atom] = []
    for i, item in enumerate(value):
        try:
            tasks.append(parse_text_form(item))
        except TextFormError as e:
            raise ValueError(f"[{i}]: {e}") from None
    return tuple(tasks)


TaskNetwork = Annotated[tuple[Atom, ...] | str, PlainValidator(_task_network)]
"""A goal's task network as written: its tasks in order, or ``problem``."""


class GoalSpec(Spec):
    """A task, or a network of tasks, given to an agent: at the start, or when its trigger fires."""

    agent: Name
    task: TextForm | None = None
    """The goal's one task; exactly one of ``task`` and :attr:`tasks` is given."""
    tasks: TaskNetwork | None = None
    """A task network planned as one ordered whole (docs/design.md §4), or ``problem``: an
    HDDL agent's problem's own initial network, its ``:goal`` checked at the end."""
    emergency: Annotated[bool, Strict()] = False
    """Whether the goal interrupts (suspends) what the agent is doing."""
    when: Trigger | None = None
    """None: given at time 0, in file order."""

    @model_validator(mode="after")
    def _one_goal(self) -> GoalSpec:
        if (self.task is None) == (self.tasks is None):
            raise ValueError(
                "give exactly one of task (one task) and tasks (a task network), "
                + ("not both" if self.task is not None else "got neither")
            )
        return self


class WorldEvent(Spec):
    """A change of the world: an arc is closed (a door shut) or opened again, or, in the
    generic form for an HDDL agent's world, facts are added and deleted."""

    when: Trigger
    close: Name | None = None
    open: Name | None = None
    add: Annotated[tuple[TextForm, ...], Field(fail_fast=True)] = ()
    delete: Annotated[tuple[TextForm, ...], Field(fail_fast=True)] = ()

    @model_validator(mode="after")
    def _one_change(self) -> WorldEvent:
        facts = bool(self.add or self.delete)
        arcs = (self.close is not None) + (self.open is not None)
        if facts and arcs:
            raise ValueError("an event either closes or opens an arc, or adds and deletes facts: not both")
        if not facts and arcs != 1:
            raise ValueError(
                "an event either closes or opens one arc, or adds and deletes facts: "
                "give exactly one of close, open, or add/delete"
            )
        return self

    @property
    def changes_facts(self) -> bool:
        """True for the generic form (``add``/``delete``), False for an arc closed or opened."""
        return bool(self.add or self.delete)

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


class Scenario(Spec):
    """A checked scenario; build it with :func:`~htnagent.scenario.load_scenario` (or ``parse_scenario``).

    Besides the fields of the file it holds the parsed map (:attr:`world`) and
    each agent's domain, built once from that map.  A Scenario made any other
    way has neither, and its methods raise ScenarioError saying so.
    """

    name: Name
    map: MapSource | None = None
    """The map file name (relative to the scenario file) or the map inline, as written;
    None only when the agent on the robot has an HDDL domain (docs/design.md §7.1)."""
    robot: RobotSpec
    agents: Annotated[tuple[AgentSpec, ...], Field(min_length=1, fail_fast=True)]
    """Parent first; each agent's executor is the next agent, the last one's the robot."""
    replanning: Literal["online", "naive"] = "online"
    planner: PlannerSpec = PlannerSpec()
    action_timeout: PositiveSeconds | None = None
    """Simulated seconds after which a running action is given up; None: never."""
    goals: Annotated[tuple[GoalSpec, ...], Field(min_length=1, fail_fast=True)]
    events: Annotated[tuple[WorldEvent, ...], Field(fail_fast=True)] = ()
    namespace: Namespace | None = None
    """Where in Zenoh's key space the agents of this scenario talk (``a/b``); None: the
    scenario's name, with everything but letters, digits, ``_ . -`` made ``-``."""
    peer_wait: PositiveSeconds = 10.0
    """Wall-clock seconds a run waits at start-up for the processes serving its remote agents."""

    _file: str = PrivateAttr(default="")
    _base: Path = PrivateAttr(default=Path("."))
    _world: WorldMap | None = PrivateAttr(default=None)
    _domains: dict[str, ResolvedDomain] = PrivateAttr(default_factory=dict)
    _hddl: dict[str, HddlPlanning] = PrivateAttr(default_factory=dict)
    _goal_tasks: tuple[Atom, ...] = PrivateAttr(default=())
    _guided: dict[str, PlannerSettings] = PrivateAttr(default_factory=dict)

    @property
    def file(self) -> str:
        """The scenario file, as it was named when loaded."""
        return self._file

    @property
    def world(self) -> WorldMap:
        """The scenario's map."""
        if self._world is None:
            raise self._not_built()
        return self._world

    @property
    def settings(self) -> PlannerSettings:
        """The planner settings every agent uses (:meth:`settings_for` an agent's own)."""
        planner = self.planner
        search = Search.GBFS if planner.search == GROUNDED else Search(planner.search)
        return PlannerSettings(alternatives=planner.alternatives, budget=planner.budget, search=search)

    def settings_for(self, agent_name: str) -> PlannerSettings:
        """The agent's planner settings: :attr:`settings`, and with ``search: grounded`` for an
        agent of an HDDL domain, the grounded estimate of its goals' tasks from its start
        state as their guide (made once; none where the grounding is past its cap)."""
        if self.planner.search != GROUNDED or self.hddl_for(agent_name) is None:
            return self.settings
        known = self._guided.get(agent_name)
        if known is None:
            tasks = [self.goal_task(i) for i, g in enumerate(self.goals) if g.agent == agent_name]
            made = ground(self.domain_for(agent_name), self.initial_state(agent_name), tasks)
            guide = None if made is None else made.estimate
            known = self._guided[agent_name] = replace(self.settings, guide=guide)
        return known

    @property
    def key_space(self) -> str:
        """The namespace the scenario's agents talk in over Zenoh (see :attr:`namespace`)."""
        if self.namespace is not None:
            return self.namespace
        return re.sub(r"[^A-Za-z0-9_.-]+", "-", self.name).strip("-") or "scenario"

    def chain_from(self, first: str | None = None) -> tuple[tuple[AgentSpec, ...], AgentSpec | None]:
        """The agents one process runs, parent first, and the agent below them served elsewhere.

        From ``first`` (default: the first agent, whose process runs the goals) down to the
        next agent with a ``remote`` endpoint, which is returned apart (None: the chain
        ends at the robot, in this process).  ``first``'s own ``remote`` is where it is served.
        """
        start = 0 if first is None else self.agent_names.index(self.agent(first).name)
        local = [self.agents[start]]
        for spec in self.agents[start + 1 :]:
            if spec.remote is not None:
                return tuple(local), spec
            local.append(spec)
        return tuple(local), None

    def link_file(self, name: str) -> Path:
        """A file a ``remote:`` link names, found relative to the scenario file."""
        return self._base / name

    @property
    def remote(self) -> bool:
        """Whether some agent of the scenario is served by another process."""
        return any(a.remote is not None for a in self.agents)

    @property
    def agent_names(self) -> tuple[str, ...]:
        """The agents' names, parent first."""
        return tuple(a.name for a in self.agents)

    def agent(self, name: str) -> AgentSpec:
        """The agent called ``name``; ScenarioError if there is none."""
        for a in self.agents:
            if a.name == name:
                return a
        raise ScenarioError(self._file, "agents", no_agent(name, self.agent_names))

    def share_domains(self, other: Scenario) -> int:
        """Plan with ``other``'s domains where both build one of the built-in domains from
        equal maps; how many agents' domains are now ``other``'s.

        A built-in domain is a function of its name and the map alone, and one domain
        serves any number of runtimes (what a fleet of one scenario does): robots that a
        process runs from scenario files of their own (a namespace, an endpoint each)
        build its caches -- compiled methods, landmark rows -- once, not once a robot."""
        from htnagent.domains import BUILTIN

        if self._world is None or other._world is None or self._world != other._world:
            return 0
        theirs = {
            spec.domain: other._domains[spec.name]
            for spec in other.agents
            if isinstance(spec.domain, str) and spec.domain in BUILTIN and spec.name in other._domains
        }
        shared = 0
        for spec in self.agents:
            if isinstance(spec.domain, str) and spec.domain in theirs and spec.name in self._domains:
                self._domains[spec.name] = theirs[spec.domain]
                shared += 1
        return shared

    def goal_task(self, index: int) -> Atom:
        """What the agent plans for ``goals[index]``: its ``task``, or its network as the one
        compound task ``tasks(t1,...,tn)`` (:func:`~htnagent.model.networks.network_task`),
        which is also how traces and the summary name it."""
        if len(self._goal_tasks) != len(self.goals):
            raise self._not_built()
        return self._goal_tasks[index]

    def domain_for(self, agent_name: str) -> Domain:
        """The agent's domain, built from the map (once; later calls return the same object)."""
        return self._resolved(agent_name).domain

    def info_for(self, agent_name: str) -> DomainInfo:
        """What the agent's domain declares: its arguments' kinds on the map, the robot's moves."""
        return self._resolved(agent_name).info

    def hddl_for(self, agent_name: str) -> HddlPlanning | None:
        """The HDDL domain and problem the agent's domain was translated from; None for any
        other kind of domain."""
        self.agent(agent_name)
        return self._hddl.get(agent_name)

    @property
    def hddl_robot(self) -> HddlPlanning | None:
        """The HDDL domain of the agent on the robot, whose every action the simulated robot
        carries out on a world of facts (docs/design.md §7.1); None for a robot on a map."""
        return self._hddl.get(self.agents[-1].name)

    def initial_state(self, agent_name: str) -> State:
        """The agent's belief at the start, with the robot at ``robot.start``."""
        return self.domain_for(agent_name).initial_state(self.robot.start)

    def robot_does(self, action: Atom) -> bool:
        """Whether the robot itself performs ``action``: a move or an action of ``robot.durations``.

        Such an action's duration is known when the robot starts it, so a trigger
        may fire part way through it; any other action is a planning agent's,
        achieved by the agents below it in however long that takes.  Which
        actions are moves, the last agent's domain declares
        (:attr:`~htnagent.domains.DomainInfo.robot_moves`).
        """
        last = self.agents[-1].name
        if not self.domain_for(last).is_primitive(action):
            return False
        if self.hddl_robot is not None:
            # The robot carries out every HDDL action, in its time; the translation's own
            # (``__done``) succeed at once, so no trigger follows them.
            return action.name not in RECOVERY and not action.name.startswith("__")
        return action.name in self.info_for(last).robot_moves or action.name in self.robot.durations

    def _resolved(self, agent_name: str) -> ResolvedDomain:
        self.agent(agent_name)
        resolved = self._domains.get(agent_name)
        if resolved is None:
            raise self._not_built()
        return resolved

    def _not_built(self) -> ScenarioError:
        return ScenarioError(
            self._file or "<scenario>", "", "this Scenario was not built by load_scenario or parse_scenario"
        )


def no_agent(name: str, names: tuple[str, ...]) -> str:
    """The reason for naming an agent that is not in the scenario."""
    return f"no agent named {name!r}; the agents are {', '.join(names)}"
