"""Built-in domains, by the names scenario files use, and the mark a user's domain factory carries."""

from __future__ import annotations

import types
from collections.abc import Callable
from typing import Any, TypeVar

from htnagent.domain import Domain
from htnagent.domains.museum import areas_domain, nodes_domain
from htnagent.maps import WorldMap

BUILTIN: dict[str, Callable[[WorldMap], Domain]] = {
    "museum.areas": areas_domain,
    "museum.nodes": nodes_domain,
}
"""Factories of the built-in domains: each takes the scenario's map."""

F = TypeVar("F", bound=Callable[[WorldMap], Domain])

_MARK = "__htnagent_domain_factory__"


def domain_factory(function: F) -> F:
    """Mark ``function`` (map → :class:`~htnagent.domain.Domain`) as one a scenario may name.

    A scenario names a user's domain as ``package.module:attribute``; the
    attribute must be a ``Domain`` or a function marked with this decorator.
    Anything else is refused before it is called, so that a scenario file
    cannot call arbitrary functions (``os:system``, ``code:interact``)::

        from htnagent.domains import domain_factory

        @domain_factory
        def greeter(world):
            d = Domain("greeter")
            ...
            return d
    """
    setattr(function, _MARK, True)
    return function


def is_domain_factory(obj: Any) -> bool:
    """Whether ``obj`` is a plain Python function marked with :func:`domain_factory`.

    Looks at the function's own ``__dict__`` only: asking an arbitrary object for
    an attribute could run its code.
    """
    return type(obj) is types.FunctionType and vars(obj).get(_MARK) is True


__all__ = ["BUILTIN", "areas_domain", "domain_factory", "is_domain_factory", "nodes_domain"]
