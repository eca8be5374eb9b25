"""A planning agent: the published Algorithms 2–5 (docs/design.md §4, §5).

- :mod:`~htnagent.agent.loop` — :class:`Agent`: the loop, one function per step;
- :mod:`~htnagent.agent.goals` — :class:`GoalEntry`, :class:`GoalStatus`;
- :mod:`~htnagent.agent.config` — :class:`AgentConfig`;
- :mod:`~htnagent.agent.modes` — on-line and naive, chosen once;
- :mod:`~htnagent.agent.resumption` — working a resumption out from a belief;
- :mod:`~htnagent.agent.look_ahead` — working it out early (on-line mode);
- :mod:`~htnagent.agent.deferred` — upkeep kept off the critical path.
"""

from htnagent.agent.config import AgentConfig
from htnagent.agent.goals import GoalEntry, GoalStatus
from htnagent.agent.loop import Agent, OutcomeCallback

__all__ = ["Agent", "AgentConfig", "GoalEntry", "GoalStatus", "OutcomeCallback"]
