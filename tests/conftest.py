"""Shared fixtures: the museum map of the published experiment and its two domains.

Under CI (``CI`` set) hypothesis runs derandomized, so a run is reproducible;
locally it explores new examples each time.
"""

from __future__ import annotations

import os
import signal
import sys
from collections.abc import Callable
from pathlib import Path

# Bytecode caches on, for this run and the commands the tests start: a machine may turn them
# off (PYTHONDONTWRITEBYTECODE), and then each of the suite's hundred-odd commands compiles
# the package afresh -- about a second each on a loaded two-core machine.
os.environ.pop("PYTHONDONTWRITEBYTECODE", None)
sys.dont_write_bytecode = False

import pytest  # noqa: E402
import yaml  # noqa: E402
from hypothesis import settings  # noqa: E402

from htnagent.domains.maps import WorldMap  # noqa: E402
from htnagent.domains.museum import areas_domain, nodes_domain  # noqa: E402
from htnagent.model.domain import Domain, State  # noqa: E402
from htnagent.scenario import parse_map  # noqa: E402

settings.register_profile("ci", derandomize=True, database=None)
if os.environ.get("CI"):
    settings.load_profile("ci")

# A suite started in the background by a non-interactive shell (``pytest &``) inherits SIGINT
# ignored, and so would every command the tests start; a command keeps an ignored signal
# ignored (on purpose), so the tests that interrupt one would wait in vain.
if signal.getsignal(signal.SIGINT) is signal.SIG_IGN:
    signal.signal(signal.SIGINT, signal.default_int_handler)

REPO = Path(__file__).resolve().parents[1]
MUSEUM_MAP = REPO / "scenarios" / "museum_map.yaml"

StateAt = Callable[[Domain, str], State]


@pytest.fixture(scope="session")
def museum_map() -> WorldMap:
    """The 8-area, 40-node, 59-arc museum (docs/design.md §6)."""
    return parse_map(yaml.safe_load(MUSEUM_MAP.read_text()), str(MUSEUM_MAP))


@pytest.fixture
def areas(museum_map: WorldMap) -> Domain:
    """The parent's (guide's) domain over the museum's areas."""
    return areas_domain(museum_map)


@pytest.fixture
def nodes(museum_map: WorldMap) -> Domain:
    """The child's (navigator's) domain over the museum's nodes and arcs."""
    return nodes_domain(museum_map)


def robot_at(domain: Domain, node: str) -> State:
    """The domain's belief with the robot standing at ``node``."""
    return domain.initial_state(node)


@pytest.fixture
def state_at() -> StateAt:
    """``state_at(domain, "n40")``: the belief with the robot at a node."""
    return robot_at
