"""What several test files share: trace events in their JSON form (``run --json``'s objects).

Tests compare events as the dicts users script against; the library hands out typed
events (:mod:`htnagent.events`).
"""

from __future__ import annotations

from collections.abc import Callable, Iterable
from typing import Any

from htnagent.events import TraceEvent
from htnagent.simulation import RunReport

Event = dict[str, Any]
"""A trace event's JSON object."""


def as_dicts(events: Iterable[TraceEvent]) -> list[Event]:
    """The events' JSON objects."""
    return [e.as_dict() for e in events]


def record(into: list[Event]) -> Callable[[TraceEvent], None]:
    """An observer that appends each event's JSON object to ``into``."""
    return lambda event: into.append(event.as_dict())


def events_of(report: RunReport) -> list[Event]:
    """A run's events (kept with ``keep_events=True``) as JSON objects."""
    return as_dicts(report.events)


def summary_of(report: RunReport) -> Event:
    """A run's summary event as its JSON object."""
    return report.summary.as_dict()
