"""Scenario agents on HDDL domains: ``agents[].domain: {hddl: DOMAIN.hddl, problem: PROBLEM.hddl}``.

The domain and problem files are read and checked by :mod:`htnagent.hddl` (any
fault is its one line ``FILE:LINE:COL: reason``, an
:class:`~htnagent.errors.HddlError`) and translated by
:mod:`htnagent.planning.hddl_translation`: the agent plans with the translation's domain, its
start belief is the problem's ``:init`` with the translation's static type and
equality facts (docs/design.md §7.1).  Its goals name the HDDL domain's tasks
(or actions) and the problem's objects; the actions in ``agents[].suspendable``
can be stopped half way.  What goes wrong in the scenario's own values is a
:class:`~htnagent.errors.ScenarioError` at the key path.
"""

from __future__ import annotations

from collections.abc import Mapping
from pathlib import Path
from typing import Annotated

from pydantic import Field, ValidationError

from htnagent.domains import DomainInfo
from htnagent.domains.maps import WorldMap
from htnagent.domains.user import ResolvedDomain
from htnagent.errors import ScenarioError
from htnagent.hddl import model as m
from htnagent.hddl.reader import read_domain, read_problem
from htnagent.model.terms import Atom
from htnagent.planning.hddl_translation import (
    RESERVED,
    HddlPlanning,
    Started,
    StartedError,
    translate,
    unsuspendable,
)
from htnagent.reading import read_yaml
from htnagent.scenario.specs import Name, Spec, TextForm
from htnagent.scenario.wording import kind_of, scenario_error

DEFAULT_DURATION = 1.0
"""Simulated seconds an HDDL action takes when ``robot.durations`` does not name it."""

__all__ = [
    "DEFAULT_DURATION",
    "RESERVED",
    "HddlDomainSpec",
    "check_fact",
    "check_hddl_task",
    "load_hddl_agent",
    "no_map",
    "read_started",
]


class HddlDomainSpec(Spec):
    """An agent's domain written in HDDL: the domain file and a problem file (its ``:init``)."""

    hddl: Name
    """The HDDL domain file, relative to the scenario file."""
    problem: Name
    """The HDDL problem file, relative to the scenario file: the agent's start belief is its
    ``:init`` (its objects are what the goals may name; its task network is not used)."""
    started: Name | None = None
    """Optional: a YAML file, relative to the scenario file, of the effects that hold as soon
    as a suspendable action starts (``ACTION: {add: [fact], delete: [fact]}``, the facts over
    the action's parameters): what a half-done one has changed (docs/design.md §7.1)."""


def load_hddl_agent(
    spec: HddlDomainSpec,
    suspendable: tuple[str, ...],
    base_dir: Path,
    file: str,
    where: str,
    max_file_bytes: int | None = None,
) -> tuple[ResolvedDomain, HddlPlanning]:
    """The agent's planning domain (with its info) and the HDDL translation it came from.

    ``where`` is the agent's key path (``agents[0]``).  Raises HddlError for the HDDL
    files, ScenarioError for an action of ``suspendable`` the domain cannot suspend.
    """
    domain = read_domain(base_dir / spec.hddl, max_file_bytes)
    problem = read_problem(base_dir / spec.problem, domain, max_file_bytes)
    for i, name in enumerate(suspendable):
        why = unsuspendable(domain, name)
        if why is not None:
            raise ScenarioError(file, f"{where}.suspendable[{i}]", why)
    started = None
    if spec.started is not None:
        started = read_started(base_dir / spec.started, domain, problem, suspendable, where, max_file_bytes)
    try:
        planning = translate(domain, problem, suspendable, started)
    except StartedError as e:
        raise ScenarioError(str(base_dir / str(spec.started)), f"{e.action}.{e.key}", str(e)) from None
    built = planning.domain
    # Nothing of an HDDL domain names the map, and the robot travels on none of its actions.
    info = DomainInfo(lambda _world: built, robot_moves=frozenset())
    return ResolvedDomain(built, info), planning


class _StartedSpec(Spec):
    """One action's entry in a started-effects file."""

    add: Annotated[tuple[TextForm, ...], Field(fail_fast=True)] = ()
    delete: Annotated[tuple[TextForm, ...], Field(fail_fast=True)] = ()


def read_started(
    path: Path,
    domain: m.Domain,
    problem: m.Problem,
    suspendable: tuple[str, ...],
    where: str,
    max_file_bytes: int | None = None,
) -> dict[str, Started]:
    """The effects that hold as soon as each named action starts, from the YAML file at
    ``path`` (``agents[].domain.started``; docs/design.md §7.1).

    Each key is a suspendable action of the domain; each fact is one of its predicates,
    over the action's parameters and the problem's objects.  Anything else is a
    ScenarioError naming the file and the key.
    """
    file = str(path)
    data = read_yaml(path, "list of started effects", max_file_bytes)
    if not isinstance(data, Mapping):
        raise ScenarioError(
            file,
            "",
            f"a started-effects file maps actions to {{add: [fact], delete: [fact]}}, not {kind_of(data)}",
        )
    out: dict[str, Started] = {}
    for key, value in data.items():
        name = str(key)
        action = domain.actions.get(name)
        if action is None:
            known = ", ".join(domain.actions) or "none"
            raise ScenarioError(
                file, name, f"domain {domain.name} has no action {name} (its actions: {known})"
            )
        if name not in suspendable:
            raise ScenarioError(
                file,
                name,
                f"{name} is not in {where}.suspendable: its start matters only if it can be stopped",
            )
        _refuse_cut_facts(value, file, name)
        try:
            entry = _StartedSpec.model_validate(value if value is not None else {})
        except ValidationError as e:
            raise scenario_error(e, file, _StartedSpec, name) from None
        if not entry.add and not entry.delete:
            raise ScenarioError(file, name, "no add nor delete: give what its start changes, or leave it out")
        params = {p.name: p.types for p in action.params}
        for kind, facts in (("add", entry.add), ("delete", entry.delete)):
            for i, fact in enumerate(facts):
                _check_started_fact(domain, problem, fact, params, file, f"{name}.{kind}[{i}]")
        both = set(entry.add) & set(entry.delete)
        if both:
            raise ScenarioError(file, name, f"{min(map(str, both))} is both added and deleted")
        out[name] = Started(tuple(map(str, entry.add)), tuple(map(str, entry.delete)))
    return out


def _refuse_cut_facts(value: object, file: str, name: str) -> None:
    """A fact with variables in a YAML flow list (``[at(?r,?from)]``) is cut at ``,?``,
    which YAML reads as a key: say so, rather than that a parenthesis is missing."""
    if not isinstance(value, Mapping):
        return
    for kind in ("add", "delete"):
        items = value.get(kind)
        if not isinstance(items, list):
            continue
        for i, item in enumerate(items):
            if not isinstance(item, str) or item.count("(") == item.count(")"):
                continue
            raise ScenarioError(
                file,
                f"{name}.{kind}[{i}]",
                f"{item!r} is a fact cut at a comma: in a YAML list written [...], ',?' starts a key; "
                'quote each fact ("at(?r,?from)") or write one per line (- at(?r,?from))',
            )


def _check_started_fact(
    domain: m.Domain,
    problem: m.Problem,
    fact: Atom,
    params: dict[str, tuple[str, ...]],
    file: str,
    where: str,
) -> None:
    """A started fact is one of the domain's predicates, over the action's parameters and
    the problem's objects, each of a type the predicate takes there."""
    predicate = _declared_predicate(domain, fact, file, where)
    objects = {o.name: o.types for o in (*domain.constants, *problem.objects)}
    for arg, slot in zip(fact.args, predicate.params, strict=True):
        types = params.get(arg) if isinstance(arg, str) else None
        if types is None and isinstance(arg, str):
            types = objects.get(arg)
        if types is None:
            raise ScenarioError(
                file,
                where,
                f"{fact}: {str(arg)!r} is neither a parameter of the action ({', '.join(params)}) "
                "nor an object of the problem",
            )
        if not any(domain.supertypes(t) & set(slot.types) for t in types):
            raise ScenarioError(
                file,
                where,
                f"{fact}: {arg} is a {' or '.join(types)}, but {fact.name} takes a "
                f"{' or '.join(slot.types)} there",
            )


def no_map() -> WorldMap:
    """The map of a scenario whose robot serves an HDDL agent: empty (its world is facts)."""
    return WorldMap(areas=(), nodes={}, arcs={})


def check_hddl_task(planning: HddlPlanning, agent: str, task: Atom, file: str, where: str) -> None:
    """Raise ScenarioError at ``where`` unless ``task`` is one of the HDDL domain's tasks or
    actions, with its number of arguments, naming objects of the problem."""
    hddl = planning.hddl
    declared: m.Task | m.Action | None = hddl.tasks.get(task.name) or hddl.actions.get(task.name)
    if declared is None or task.name.startswith(RESERVED):
        known = ", ".join([*hddl.tasks, *hddl.actions]) or "none"
        raise ScenarioError(
            file, where, f"agent {agent}'s domain {hddl.name} has no task {task.name} (its tasks: {known})"
        )
    _check_arguments(planning, task, len(declared.params), f"{task.name} takes", file, where)
    _check_types(planning, task, declared.params, file, where)


def check_fact(planning: HddlPlanning, fact: Atom, file: str, where: str) -> None:
    """Raise ScenarioError at ``where`` unless ``fact`` is a ground fact of one of the HDDL
    domain's predicates, naming objects of the problem (an event's ``add``/``delete``)."""
    predicate = _declared_predicate(planning.hddl, fact, file, where)
    _check_ground(planning, fact, file, where)
    _check_types(planning, fact, predicate.params, file, where)


def _declared_predicate(domain: m.Domain, fact: Atom, file: str, where: str) -> m.Predicate:
    """The domain's predicate of ``fact``, which it has with its number of arguments."""
    predicate = domain.predicates.get(fact.name)
    if predicate is None:
        known = ", ".join(domain.predicates) or "none"
        reason = f"{fact}: domain {domain.name} has no predicate {fact.name} (its predicates: {known})"
        raise ScenarioError(file, where, reason)
    _check_arity(domain, fact, len(predicate.params), f"predicate {fact.name} takes", file, where)
    return predicate


def _check_arity(domain: m.Domain, term: Atom, arity: int, what: str, file: str, where: str) -> None:
    if len(term.args) != arity:
        noun = "argument" if arity == 1 else "arguments"
        raise ScenarioError(file, where, f"{what} {arity} {noun} in {domain.name}, not {len(term.args)}")


def _check_arguments(
    planning: HddlPlanning, term: Atom, arity: int, what: str, file: str, where: str
) -> None:
    _check_arity(planning.hddl, term, arity, what, file, where)
    _check_ground(planning, term, file, where)


def _check_types(
    planning: HddlPlanning, term: Atom, params: tuple[m.Typed, ...], file: str, where: str
) -> None:
    """Each argument (an object or constant, checked before) is of its parameter's type."""
    hddl = planning.hddl
    kinds = _object_kinds(planning)
    for i, (arg, param) in enumerate(zip(term.args, params, strict=True), start=1):
        have = kinds[str(arg)]
        if not any(set(param.types) & hddl.supertypes(kind) for kind in have):
            wanted = " or ".join(param.types)
            kind = " or ".join(have)
            raise ScenarioError(
                file, where, f"{term}: argument {i}, {arg}, is a {kind}; {term.name} wants a {wanted} there"
            )


_KINDS: list[tuple[HddlPlanning, dict[str, tuple[str, ...]]]] = []
"""The last problem's objects and constants with their types (a scenario's goals and events
are checked one after another against the same problem)."""


def _object_kinds(planning: HddlPlanning) -> dict[str, tuple[str, ...]]:
    """Each object of the problem and constant of its domain, with its types."""
    if not _KINDS or _KINDS[0][0] is not planning:
        kinds = {o.name: o.types for o in (*planning.hddl.constants, *planning.problem.objects)}
        _KINDS[:] = [(planning, kinds)]
    return _KINDS[0][1]


def _check_ground(planning: HddlPlanning, term: Atom, file: str, where: str) -> None:
    if not term.is_ground:
        raise ScenarioError(file, where, f"{term} has variables; name objects of the problem")
    objects = _object_kinds(planning)
    for arg in term.args:
        if not isinstance(arg, str) or arg not in objects:
            raise ScenarioError(
                file,
                where,
                f"{term}: {str(arg)!r} is not an object of problem {planning.problem.name} "
                "nor a constant of its domain",
            )
