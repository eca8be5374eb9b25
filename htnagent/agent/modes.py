"""The two replanning modes as objects, chosen once from ``AgentConfig.replanning``.

The agent loop never asks which mode it is in: it asks its :class:`Mode` — for a goal's
plan set, for how a goal's kept plans are taken up again when it resumes, and for its
look-ahead.  This is the one module of the agent that reads :class:`Replanning`.

- **On-line** (§2, §4): a stacked goal's plans are kept valid while it waits and
  reused when it resumes; with ``look_ahead`` on, a resumption is worked out while the
  action before it runs (:mod:`htnagent.agent.look_ahead`).
- **Naive** (kept for comparison): a resumed goal's plans are dropped and it is
  planned afresh; nothing is worked out ahead.
"""

from __future__ import annotations

from abc import ABC, abstractmethod
from typing import ClassVar, Literal

from htnagent.agent.config import AgentConfig
from htnagent.agent.look_ahead import AgentView, LookAhead, NoLookAhead
from htnagent.model.domain import Domain
from htnagent.model.terms import Atom
from htnagent.planning.planner import PlannerSettings
from htnagent.upkeep import NaivePlanSet, OnlinePlanSet, PlanningStats, PlanSet, Replanning


class Mode(ABC):
    """How an agent keeps and takes up plans: on-line or naive."""

    name: ClassVar[Literal["online", "naive"]]
    """The mode's name, as the ``goal_resumed`` event gives it."""
    replanning: ClassVar[Replanning]
    plan_kind: ClassVar[type[PlanSet]]
    """The plan set that keeps a goal's plans in this mode."""

    def __init__(self, look_ahead: bool) -> None:
        self.wants_look_ahead = look_ahead

    def plan_set(
        self, domain: Domain, goal: Atom, settings: PlannerSettings, stats: PlanningStats
    ) -> PlanSet:
        """A new plan set for ``goal``, keeping plans as this mode does."""
        return self.plan_kind(domain, goal, settings, stats)

    @abstractmethod
    def take_up(self, plans: PlanSet) -> None:
        """A stacked goal resumes with ``plans``: make them what its resumption starts from."""

    def look_ahead(self, agent: AgentView) -> NoLookAhead:
        """The agent's look-ahead (one that does nothing where there is none)."""
        return NoLookAhead()


class OnLine(Mode):
    """Plans kept valid while the goal waits, reused when it resumes (§2, Algorithm 2)."""

    name = "online"
    replanning = Replanning.ONLINE
    plan_kind = OnlinePlanSet

    def take_up(self, plans: PlanSet) -> None:
        """The kept plans are reused as they are."""

    def look_ahead(self, agent: AgentView) -> NoLookAhead:
        return LookAhead(agent) if self.wants_look_ahead else NoLookAhead()


class Naive(Mode):
    """Plans dropped when the goal resumes, and made afresh."""

    name = "naive"
    replanning = Replanning.NAIVE
    plan_kind = NaivePlanSet

    def take_up(self, plans: PlanSet) -> None:
        """The kept plans are dropped: the goal is planned afresh."""
        plans.drop()


_MODES: dict[Replanning, type[Mode]] = {Replanning.ONLINE: OnLine, Replanning.NAIVE: Naive}


def mode_of(config: AgentConfig) -> Mode:
    """The mode ``config`` chooses."""
    return _MODES[config.replanning](config.look_ahead)
