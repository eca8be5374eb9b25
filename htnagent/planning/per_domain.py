"""What the planner works out once for a domain and keeps: :class:`PerDomain`, the store
behind :meth:`~htnagent.planning.goal_support.GoalSupport.of` and
:meth:`~htnagent.planning.landmarks.GoalLandmarks.of`."""

from __future__ import annotations

from collections.abc import Callable
from typing import Generic, TypeVar

from htnagent.model.domain import Domain

_T = TypeVar("_T")


class PerDomain(Generic[_T]):
    """What is worked out once for a domain (:meth:`~htnagent.planning.goal_support.GoalSupport.of`,
    :meth:`~htnagent.planning.landmarks.GoalLandmarks.of`), kept for the last ``keep``
    domains seen; each domain is held, so that its id is not reused while its entry lives."""

    def __init__(self, keep: int = 8) -> None:
        self._keep = keep
        self._made: dict[tuple[object, ...], tuple[Domain, _T]] = {}

    def get(self, domain: Domain, key: tuple[object, ...], make: Callable[[], _T]) -> _T:
        """The value for ``domain`` under ``key`` (which holds ``id(domain)``), made by
        ``make()`` the first time."""
        known = self._made.get(key)
        if known is not None and known[0] is domain:
            return known[1]
        made = make()
        self._made[key] = (domain, made)
        while len(self._made) > self._keep:
            del self._made[next(iter(self._made))]  # the oldest
        return made

    def clear(self) -> None:
        self._made.clear()


__all__ = ["PerDomain"]
