"""Built-in domains, by the names scenario files use, and the mark a user's domain factory carries.

Each entry of :data:`BUILTIN` is a :class:`~htnagent.domains.info.DomainInfo`:
the domain's factory and what the scenario checks need to know of it (what its
arguments name on the map, which actions are the robot's moves).
"""

from __future__ import annotations

# info first: museum declares its domains with it.
from htnagent.domains.info import (
    ROBOT_TRAVEL,
    DomainFactory,
    DomainInfo,
    MapKind,
    declared_info,
    domain_factory,
    is_domain_factory,
)
from htnagent.domains.museum import AREAS, NODES, areas_domain, nodes_domain

BUILTIN: dict[str, DomainInfo] = {"museum.areas": AREAS, "museum.nodes": NODES}
"""The built-in domains by the names scenario files use."""

__all__ = [
    "BUILTIN",
    "ROBOT_TRAVEL",
    "DomainFactory",
    "DomainInfo",
    "MapKind",
    "areas_domain",
    "declared_info",
    "domain_factory",
    "is_domain_factory",
    "nodes_domain",
]
