"""One process coordinating several robots: a scenario run per robot, side by side.

A fleet server runs, for every robot, the agents at the top of its chain (a
guide, say) while each robot's navigator and robot are usually served by a
process of their own (``remote:``, ``python -m htnagent serve``).  Each robot is
one scenario file, so a robot is described exactly as when it runs alone;
:func:`run_fleet` runs their :func:`~htnagent.system.simulation.run_scenario` side by
side in one task group of the caller's event loop and returns each run's report.

The runs share nothing but the event loop and the process's Zenoh session (one
for every robot whose links are secured alike, held open for the whole fleet):
each has its own runtime, clock and link (its keys, its liveliness tokens), so
a robot whose serving process dies or freezes fails only its own goals (``peer
lost``) while the others go on, and the fleet ends once every run has ended.
Two robots that would talk on the same keys of the same endpoint (the same
namespace and served agent) would read each other's messages; :func:`check_fleet`
refuses that before anything starts.
"""

from __future__ import annotations

import contextlib
import functools
from collections.abc import Callable, Collection, Iterable, Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING

import anyio

from htnagent.errors import HtnAgentError, ScenarioError
from htnagent.runtime.trace import Observer
from htnagent.scenario import Scenario
from htnagent.system.heap import long_lived
from htnagent.system.simulation import RunReport, link_security, run_scenario

if TYPE_CHECKING:
    from htnagent.remote.link import Security


@dataclass(frozen=True, slots=True)
class FleetReport:
    """The end of a fleet's run: one report per robot, in the order the scenarios were given."""

    runs: tuple[RunReport, ...]

    @property
    def succeeded(self) -> bool:
        """Every goal of every robot succeeded."""
        return all(run.succeeded for run in self.runs)

    @property
    def interrupted(self) -> bool:
        """Some robot's run was stopped before its goals ended."""
        return any(run.interrupted for run in self.runs)


def share_domains(scenarios: Sequence[Scenario]) -> None:
    """Let robots on one map plan with one domain per built-in domain
    (:meth:`~htnagent.scenario.Scenario.share_domains`): each scenario takes them from the
    first one before it on an equal map."""
    firsts: list[Scenario] = []
    for scenario in scenarios:
        for first in firsts:
            if first is scenario or scenario.share_domains(first):
                break
        else:
            firsts.append(scenario)


def check_fleet(scenarios: Sequence[Scenario]) -> None:
    """Raise ScenarioError unless every robot's served agent has keys of its own.

    Processes are told apart by endpoint, agents by namespace and name
    (``htnagent/<namespace>/<agent>/…``): two robots reaching the same agent of
    the same namespace at the same endpoint would share its orders and results.
    """
    seen: dict[tuple[str, str, str], str] = {}
    for scenario in scenarios:
        _, served = scenario.chain_from()
        if served is None or served.endpoint is None:
            continue  # this robot runs in this process: nothing on the network to share
        key = (served.endpoint, scenario.key_space, served.name)
        if key in seen:
            index = scenario.agent_names.index(served.name)
            raise ScenarioError(
                scenario.file,
                f"agents[{index}].remote",
                f"{served.name} at {served.endpoint} in namespace {scenario.key_space} is another robot's "
                f"too ({seen[key]}); give each robot's scenario a namespace of its own",
            )
        seen[key] = scenario.file


async def run_fleet(
    scenarios: Sequence[Scenario],
    *,
    replanning: str | None = None,
    speed: float | None = None,
    observers: Callable[[int], Iterable[Observer]] | None = None,
    stop: anyio.Event | None = None,
    relayed: Collection[str] | None = None,
) -> FleetReport:
    """Run every scenario (one robot each) to its end, side by side; their reports.

    ``observers(i)`` gives the observers of the ``i``-th robot's run.  Setting
    ``stop`` stops every run as :func:`~htnagent.system.simulation.run_scenario` does;
    ``relayed`` too (the serving processes' trace events the observers look at).
    An error at start-up (a serving process not reached within the scenario's
    ``peer_wait``: :class:`~htnagent.errors.RemoteError`) ends the whole fleet and
    is raised as it is (the first, if several robots could not start): a fleet
    is started whole or not at all.
    """
    check_fleet(scenarios)
    share_domains(scenarios)
    reports: list[RunReport | None] = [None] * len(scenarios)

    async def one(index: int) -> None:
        run = functools.partial(
            run_scenario,
            scenarios[index],
            replanning=replanning,
            speed=speed,
            observers=() if observers is None else observers(index),
            stop=stop,
            relayed=relayed,
        )
        reports[index] = await run()

    try:
        async with contextlib.AsyncExitStack() as stack:
            stack.enter_context(long_lived())
            await _share_sessions(stack, scenarios)
            async with anyio.create_task_group() as tg:
                for index in range(len(scenarios)):
                    tg.start_soon(one, index)
    except BaseExceptionGroup as group:
        # A robot that could not start (its serving process not reached): raised as
        # run_scenario raises it, not wrapped in this task group's group.  Anything else
        # (a bug, a KeyboardInterrupt) stays the group it is.
        errors, rest = group.split(HtnAgentError)
        if errors is None or rest is not None:
            raise
        raise _first(errors) from None
    # Every task ended without raising (else the group would have): every report is in.
    return FleetReport(runs=tuple(r for r in reports if r is not None))


async def _share_sessions(stack: contextlib.AsyncExitStack, scenarios: Sequence[Scenario]) -> None:
    """Hold one Zenoh session open, for the whole fleet, per way its links are secured,
    connecting to every endpoint of the robots secured that way: the robots' links then
    share it (one session for the process, not one per robot)."""
    groups: dict[Security | None, list[str]] = {}
    for scenario in scenarios:
        _, served = scenario.chain_from()
        if served is None or served.endpoint is None:
            continue
        security = link_security(scenario, served.name)
        endpoints = groups.setdefault(security, [])
        if served.endpoint not in endpoints:
            endpoints.append(served.endpoint)
    if not groups:
        return  # no robot is served elsewhere: zenoh (an optional extra) is not needed
    from htnagent.remote.link import SESSIONS

    for security, endpoints in groups.items():
        await stack.enter_async_context(SESSIONS.hold(connect=endpoints, security=security))


def _first(group: BaseExceptionGroup[HtnAgentError]) -> HtnAgentError:
    first: HtnAgentError | BaseExceptionGroup[HtnAgentError] = group.exceptions[0]
    while isinstance(first, BaseExceptionGroup):
        first = first.exceptions[0]
    return first


__all__ = ["FleetReport", "check_fleet", "run_fleet", "share_domains"]
