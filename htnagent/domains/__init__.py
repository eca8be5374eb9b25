"""Built-in domains, by the names scenario files use."""

from __future__ import annotations

from collections.abc import Callable

from htnagent.domain import Domain
from htnagent.domains.museum import areas_domain, nodes_domain
from htnagent.maps import WorldMap

BUILTIN: dict[str, Callable[[WorldMap], Domain]] = {
    "museum.areas": areas_domain,
    "museum.nodes": nodes_domain,
}
"""Factories of the built-in domains: each takes the scenario's map."""

__all__ = ["BUILTIN", "areas_domain", "nodes_domain"]
