"""What a scenario loader knows of a domain besides the domain itself.

A :class:`~htnagent.model.domain.Domain` says what an agent can plan; a scenario file
also names places of the map in its goals and triggers (``goto(n1)``,
``move(n40,n35,arc59)``), and some actions are the robot's own.  A domain
declares both here, next to its factory, so that the generic scenario checks
(:mod:`htnagent.scenario.checks`) ask the domain instead of knowing the museum:

- :attr:`DomainInfo.argument_kinds` -- what each argument of a task or action
  names on the map (a node, an arc, an area), checked against the scenario's map;
- :attr:`DomainInfo.robot_moves` -- the actions the robot performs itself by
  travelling an arc, written ``name(From,To,Arc)``: they take the arc's length
  at the robot's speed, so a trigger may fire part way through one.

Built-in domains declare theirs in :mod:`htnagent.domains.museum`; a user's
factory declares its own with ``@domain_factory(argument_kinds=...,
robot_moves=...)``, or nothing: then no argument is checked against the map,
and the robot's moves are :data:`ROBOT_TRAVEL`, the action the simulated robot
travels on whatever the domain (its other actions are those given times in
``robot.durations``).
"""

from __future__ import annotations

import types
from collections.abc import Callable, Iterable, Mapping
from dataclasses import dataclass, field
from typing import Literal, TypeVar, get_args, overload

from htnagent.domains.maps import WorldMap
from htnagent.errors import DomainError
from htnagent.model.domain import Domain

MapKind = Literal["node", "arc", "area"]
"""What an argument names on the map."""

MAP_KINDS: tuple[MapKind, ...] = get_args(MapKind)

DomainFactory = Callable[[WorldMap], Domain]
"""Builds a domain for the scenario's map."""

MOVE_KINDS: tuple[MapKind, MapKind, MapKind] = ("node", "node", "arc")
"""The arguments of a robot move: ``name(From,To,Arc)``."""

ROBOT_TRAVEL: frozenset[str] = frozenset({"move"})
"""The robot moves of a domain that declares none: the simulated robot (:mod:`executors.robot`)
travels on ``move(From,To,Arc)``, whichever domain plans it."""


@dataclass(frozen=True, slots=True)
class DomainInfo:
    """A domain's factory and what its tasks' arguments and the robot's actions are.

    Raises :class:`~htnagent.errors.DomainError` when built with an unknown
    argument kind or a robot move that also has other declared kinds.
    """

    factory: DomainFactory
    argument_kinds: Mapping[str, tuple[MapKind, ...]] = field(default_factory=dict)
    """Task or action name → what each of its arguments names on the map.

    Names not listed are not checked against the map; robot moves need not be
    listed (their arguments are always :data:`MOVE_KINDS`).
    """
    robot_moves: frozenset[str] = ROBOT_TRAVEL
    """Actions the robot performs itself by travelling an arc, written ``name(From,To,Arc)``.

    The simulated robot (:mod:`executors.robot`) travels on ``move``; an action
    named here must be that one for the robot to carry it out.  A domain whose
    actions the robot never does itself (one planning for another agent)
    declares none.
    """

    def __post_init__(self) -> None:
        kinds = {name: tuple(k) for name, k in self.argument_kinds.items()}
        for name, arg_kinds in kinds.items():
            unknown = [k for k in arg_kinds if k not in MAP_KINDS]
            if unknown:
                raise DomainError(
                    f"argument kinds of {name}: {unknown[0]!r} is not one of {', '.join(MAP_KINDS)}"
                )
        for name in self.robot_moves:
            if kinds.get(name, MOVE_KINDS) != MOVE_KINDS:
                raise DomainError(f"robot move {name} takes (From,To,Arc): its kinds are {MOVE_KINDS}")
        object.__setattr__(self, "argument_kinds", types.MappingProxyType(kinds))
        object.__setattr__(self, "robot_moves", frozenset(self.robot_moves))

    def kinds_of(self, name: str) -> tuple[MapKind, ...] | None:
        """What the arguments of task or action ``name`` name on the map; None: not checked."""
        if name in self.robot_moves:
            return MOVE_KINDS
        return self.argument_kinds.get(name)


F = TypeVar("F", bound=DomainFactory)

_MARK = "__htnagent_domain_factory__"


@overload
def domain_factory(function: F, /) -> F: ...


@overload
def domain_factory(
    *,
    argument_kinds: Mapping[str, Iterable[MapKind]] | None = None,
    robot_moves: Iterable[str] = ROBOT_TRAVEL,
) -> Callable[[F], F]: ...


def domain_factory(
    function: F | None = None,
    /,
    *,
    argument_kinds: Mapping[str, Iterable[MapKind]] | None = None,
    robot_moves: Iterable[str] = ROBOT_TRAVEL,
) -> F | Callable[[F], F]:
    """Mark ``function`` (map → :class:`~htnagent.model.domain.Domain`) as one a scenario may name.

    A scenario names a user's domain as ``package.module:attribute``; the
    attribute must be a ``Domain`` or a function marked with this decorator.
    Anything else is refused before it is called, so that a scenario file
    cannot call arbitrary functions (``os:system``, ``code:interact``)::

        from htnagent.domains import domain_factory

        @domain_factory
        def greeter(world):
            d = Domain("greeter")
            ...
            return d

    Given keyword arguments, it also declares what the domain's arguments name
    on the map and which of its actions are the robot's moves (see
    :class:`DomainInfo`; by default none is checked, and the moves are
    :data:`ROBOT_TRAVEL`)::

        @domain_factory(argument_kinds={"goto_node": ["node"]}, robot_moves={"move"})
        def walker(world): ...
    """
    kinds = {name: tuple(k) for name, k in (argument_kinds or {}).items()}
    moves = frozenset(robot_moves)

    def mark(f: F) -> F:
        setattr(f, _MARK, DomainInfo(f, kinds, moves))
        return f

    return mark if function is None else mark(function)


def declared_info(obj: object) -> DomainInfo | None:
    """The :class:`DomainInfo` of a plain Python function marked with :func:`domain_factory`, else None.

    Looks at the function's own ``__dict__`` only: asking an arbitrary object for
    an attribute could run its code.
    """
    if type(obj) is not types.FunctionType:
        return None
    info = vars(obj).get(_MARK)
    return info if isinstance(info, DomainInfo) else None


def is_domain_factory(obj: object) -> bool:
    """Whether ``obj`` is a plain Python function marked with :func:`domain_factory`."""
    return declared_info(obj) is not None
