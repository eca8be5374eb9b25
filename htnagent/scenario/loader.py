"""Loading a scenario: the file read, its schema checked, its map and domains built, all cross-checked.

:func:`load_scenario` is what the command line and the benchmarks call; it
reads the file safely (:mod:`htnagent.reading`) and hands the data
to :func:`parse_scenario`, which validates it (:mod:`htnagent.scenario.schema`,
errors worded by :mod:`htnagent.scenario.wording`), reads the map
(:mod:`htnagent.scenario.map_file`) and checks every reference
(:mod:`htnagent.scenario.checks`).  A domain named as
``package.module:attribute`` is the user's own code, and runs
(:mod:`htnagent.domains.user`).
"""

from __future__ import annotations

from collections.abc import Mapping
from pathlib import Path

from pydantic import ValidationError

from htnagent.errors import ScenarioError
from htnagent.limits import MAX_EVENTS, MAX_GOALS
from htnagent.reading import gc_paused, read_yaml
from htnagent.scenario.checks import cross_check
from htnagent.scenario.hddl_agent import no_map
from htnagent.scenario.map_file import load_map
from htnagent.scenario.schema import Scenario
from htnagent.scenario.wording import kind_of, scenario_error

__all__ = ["load_scenario", "parse_scenario"]


def load_scenario(path: str | Path, *, max_file_bytes: int | None = None) -> Scenario:
    """Read and check a scenario file; raise ScenarioError naming what is wrong and where.

    Only regular files of at most ``max_file_bytes`` bytes are read, the
    scenario and its map file alike (default: the environment variable
    ``HTNAGENT_MAX_FILE_BYTES``, else 64 MiB; see :mod:`htnagent.limits`).
    A domain named as ``package.module:attribute`` is imported from the
    scenario file's folder or the installed packages, and runs.
    """
    file = str(path)
    data = read_yaml(path, "scenario", max_file_bytes)
    return parse_scenario(data, file, Path(file).parent, max_file_bytes=max_file_bytes)


def parse_scenario(
    data: object, file: str, base_dir: str | Path = ".", *, max_file_bytes: int | None = None
) -> Scenario:
    """Check a scenario given as parsed YAML; raise ScenarioError naming what is wrong and where.

    ``base_dir`` is where a map file name and a user's domain module are looked up.
    """
    if not isinstance(data, Mapping):
        raise ScenarioError(
            file,
            "",
            f"a scenario must be a mapping (name, map, robot, agents, goals, ...), not {kind_of(data)}",
        )
    if "nodes" in data and "arcs" in data and "agents" not in data:
        raise ScenarioError(file, "", "this is a map, not a scenario; a scenario names its map under map:")
    for key, bound in (("goals", MAX_GOALS), ("events", MAX_EVENTS)):
        items = data.get(key)
        if isinstance(items, list) and len(items) > bound:
            raise ScenarioError(file, key, f"{len(items):,} {key}; a scenario may give at most {bound:,}")
    try:
        scenario = Scenario.model_validate(data)
    except ValidationError as e:
        raise scenario_error(e, file, Scenario) from None
    scenario._file = file
    # Big maps make millions of objects (the map, the domains' tables); collecting garbage
    # meanwhile would walk them again and again for nothing, so it waits until the end.
    with gc_paused():
        if scenario.map is None:
            scenario._world = no_map()  # checked by cross_check: only an HDDL agent's robot has none
        else:
            scenario._world = load_map(scenario.map, file, Path(base_dir), max_file_bytes)
        cross_check(scenario, Path(base_dir), max_file_bytes)
    return scenario
