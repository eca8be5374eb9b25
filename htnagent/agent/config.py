"""What an agent needs besides its executor: :class:`AgentConfig`."""

from __future__ import annotations

import math
from dataclasses import dataclass, field

from htnagent.errors import SettingsError
from htnagent.model.domain import Domain, State
from htnagent.planning.planner import PlannerSettings
from htnagent.upkeep import Replanning


@dataclass
class AgentConfig:
    """What an agent needs besides its executor."""

    name: str
    domain: Domain
    belief: State
    replanning: Replanning = Replanning.ONLINE
    settings: PlannerSettings = field(default_factory=PlannerSettings)
    action_timeout: float | None = None
    """Simulated seconds after which an action that got no answer counts as failed.

    It applies to an agent whose executor is not an agent (the robot, or a user's
    executor): an order to a child agent is a whole goal and takes as long as it takes.
    """
    max_failures: int = 3
    """How often in a row (from the same belief) the same action may fail before the goal fails."""
    max_depth: int = 10_000
    """How many goals the stack may hold; an emergency beyond that fails at once."""
    maintained_depth: int = 32
    """How many of the stack's top goals keep their plans valid after every event.

    Keeping a stacked goal's plans valid costs work at every action (§2); a storm of
    emergencies nested hundreds deep would make each action cost as much as the
    stack is deep.  Goals deeper than this let their plans go and are planned afresh
    if they come back to the top (as in naive replanning).  No real use nests so deep.
    """
    look_ahead: bool = True
    """On-line mode: work a resumption (and a child's likely next order) out while the
    action before it runs, so that it costs nothing when it comes (§4).  Off, the agent
    works everything out at the moment it is needed; no outcome changes.  Naive mode
    has no look-ahead."""

    def __post_init__(self) -> None:
        timeout = self.action_timeout
        if timeout is not None and not (
            isinstance(timeout, int | float) and timeout > 0 and math.isfinite(timeout)
        ):
            raise SettingsError(
                f"agent {self.name}: action_timeout must be a positive number of seconds, not {timeout!r}"
            )
        for name, least in (("max_failures", 1), ("max_depth", 1), ("maintained_depth", 0)):
            value = getattr(self, name)
            if not isinstance(value, int) or isinstance(value, bool) or value < least:
                raise SettingsError(
                    f"agent {self.name}: {name} must be a whole number of at least {least}, not {value!r}"
                )
