"""Scenario agents on HDDL domains: ``agents[].domain: {hddl: DOMAIN.hddl, problem: PROBLEM.hddl}``.

The domain and problem files are read and checked by :mod:`htnagent.hddl` (any
fault is its one line ``FILE:LINE:COL: reason``, an
:class:`~htnagent.errors.HddlError`) and translated by
:mod:`htnagent.hddl_domain`: the agent plans with the translation's domain, its
start belief is the problem's ``:init`` with the translation's static type and
equality facts (docs/design.md §7.1).  Its goals name the HDDL domain's tasks
(or actions) and the problem's objects; the actions in ``agents[].suspendable``
can be stopped half way.  What goes wrong in the scenario's own values is a
:class:`~htnagent.errors.ScenarioError` at the key path.
"""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING

from htnagent.domains import DomainInfo
from htnagent.errors import ScenarioError
from htnagent.maps import WorldMap
from htnagent.scenario.schema import HddlDomainSpec
from htnagent.terms import Atom
from htnagent.user_domains import ResolvedDomain

if TYPE_CHECKING:
    from htnagent.hddl import model as m
    from htnagent.hddl_domain import HddlPlanning

# htnagent.hddl reads its files with htnagent.scenario.reading: this module imports the
# HDDL modules when it uses them, so that importing either package first works.

DEFAULT_DURATION = 1.0
"""Simulated seconds an HDDL action takes when ``robot.durations`` does not name it."""
RESERVED = "__"
"""The prefix of the names the HDDL translation adds (htnagent.hddl_domain.RESERVED)."""

__all__ = ["DEFAULT_DURATION", "RESERVED", "check_fact", "check_hddl_task", "load_hddl_agent", "no_map"]


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
    from htnagent.hddl.reader import read_domain, read_problem
    from htnagent.hddl_domain import translate, unsuspendable

    domain = read_domain(base_dir / spec.hddl, max_file_bytes)
    problem = read_problem(base_dir / spec.problem, domain, max_file_bytes)
    for i, name in enumerate(suspendable):
        why = unsuspendable(domain, name)
        if why is not None:
            raise ScenarioError(file, f"{where}.suspendable[{i}]", why)
    planning = translate(domain, problem, suspendable)
    built = planning.domain
    # Nothing of an HDDL domain names the map, and the robot travels on none of its actions.
    info = DomainInfo(lambda _world: built, robot_moves=frozenset())
    return ResolvedDomain(built, info), planning


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


def check_fact(planning: HddlPlanning, fact: Atom, file: str, where: str) -> None:
    """Raise ScenarioError at ``where`` unless ``fact`` is a ground fact of one of the HDDL
    domain's predicates, naming objects of the problem (an event's ``add``/``delete``)."""
    hddl = planning.hddl
    predicate = hddl.predicates.get(fact.name)
    if predicate is None:
        known = ", ".join(hddl.predicates) or "none"
        raise ScenarioError(
            file, where, f"{fact}: domain {hddl.name} has no predicate {fact.name} (its predicates: {known})"
        )
    _check_arguments(planning, fact, len(predicate.params), f"predicate {fact.name} takes", file, where)


def _check_arguments(
    planning: HddlPlanning, term: Atom, arity: int, what: str, file: str, where: str
) -> None:
    if len(term.args) != arity:
        noun = "argument" if arity == 1 else "arguments"
        found = len(term.args)
        raise ScenarioError(file, where, f"{what} {arity} {noun} in {planning.hddl.name}, not {found}")
    if not term.is_ground:
        raise ScenarioError(file, where, f"{term} has variables; name objects of the problem")
    objects = {o.name for o in (*planning.hddl.constants, *planning.problem.objects)}
    for arg in term.args:
        if not isinstance(arg, str) or arg not in objects:
            raise ScenarioError(
                file,
                where,
                f"{term}: {str(arg)!r} is not an object of problem {planning.problem.name} "
                "nor a constant of its domain",
            )
