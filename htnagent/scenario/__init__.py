"""Scenario and map files (docs/contracts.md "Scenario file"): read, checked, cross-referenced.

A scenario names a map, a robot, a chain of agents (parent first, the last one
executing on the robot), the goals they are given and the world events that
happen while the robot works.  :func:`load_scenario` reads the YAML file into
frozen pydantic models and checks everything a run would otherwise trip over
later; whatever is wrong is one :class:`~htnagent.errors.ScenarioError` naming
the file and the key path (``goals[1].when.progress``) or, for YAML syntax,
the line.

One module per job:

- :mod:`~htnagent.reading` -- files and YAML, trusting nothing in them;
- :mod:`~htnagent.scenario.specs` -- what the models are built from: the frozen base, names, tasks as text;
- :mod:`~htnagent.scenario.schema` -- the scenario file's pydantic models, :class:`Scenario`;
- :mod:`~htnagent.scenario.map_file` -- the map file's models and :func:`parse_map`;
- :mod:`~htnagent.scenario.hddl_agent` -- agents on HDDL domains: the files read and translated;
- :mod:`~htnagent.scenario.checks` -- cross-references against the map and the domains;
- :mod:`~htnagent.scenario.wording` -- the one translator of validation errors to ScenarioError;
- :mod:`~htnagent.scenario.loader` -- :func:`load_scenario` and :func:`parse_scenario`, tying them together.
"""

from __future__ import annotations

from htnagent.reading import load_yaml_text, read_text, read_yaml
from htnagent.scenario.loader import load_scenario, parse_scenario
from htnagent.scenario.map_file import MapFile, load_map, parse_map
from htnagent.scenario.schema import (
    ROBOT,
    AgentSpec,
    GoalSpec,
    PlannerSpec,
    RobotSpec,
    Scenario,
    TextForm,
    Trigger,
    WorldEvent,
)

__all__ = [
    "ROBOT",
    "AgentSpec",
    "GoalSpec",
    "MapFile",
    "PlannerSpec",
    "RobotSpec",
    "Scenario",
    "TextForm",
    "Trigger",
    "WorldEvent",
    "load_map",
    "load_scenario",
    "load_yaml_text",
    "parse_map",
    "parse_scenario",
    "read_text",
    "read_yaml",
]
