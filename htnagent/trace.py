"""Trace events (CONTRACTS.md "Trace events") and the observers that receive them.

An event is a plain dict with ``t`` (simulated seconds), ``agent`` and
``event``, plus the fields of its kind.  The runtime publishes events to every
observer in order; observers must not block (the CLI's printers, a collector
for the summary, the embedding API's event stream).
"""

from __future__ import annotations

import logging
from collections.abc import Callable
from typing import Any

from htnagent.clock import Clock

Event = dict[str, Any]
Observer = Callable[[Event], None]

log = logging.getLogger("htnagent")

WALL_CLOCK_FIELDS = frozenset({"replan_ms", "planning_ms", "ms"})
"""Fields measured on the wall clock: they differ from run to run."""


class Trace:
    """Publishes events, stamped with the clock's time, to the observers."""

    def __init__(self, clock: Clock) -> None:
        self.clock = clock
        self.observers: list[Observer] = []

    def subscribe(self, observer: Observer) -> Callable[[], None]:
        """Add an observer; returns a function that removes it."""
        self.observers.append(observer)
        return lambda: self.observers.remove(observer) if observer in self.observers else None

    def emit(self, agent: str, event: str, **fields: Any) -> Event:
        """Publish an event now."""
        record: Event = {"t": round(self.clock.now(), 6), "agent": agent, "event": event, **fields}
        log.debug("%s", record)
        for observer in list(self.observers):
            try:
                observer(record)
            except (Exception, SystemExit) as exc:  # a broken observer must not stop the agents
                log.warning("dropping trace observer %r: %r", observer, exc)
                if observer in self.observers:
                    self.observers.remove(observer)
        return record
