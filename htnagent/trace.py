"""Trace events (CONTRACTS.md "Trace events") and the observers that receive them.

An event is a plain dict with ``t`` (simulated seconds), ``agent`` and
``event``, plus the fields of its kind.  The runtime publishes events to every
observer in order; observers must not block (the CLI's printers, a collector
for the summary, the embedding API's event stream).
"""

from __future__ import annotations

import logging
from collections import deque
from collections.abc import Callable
from typing import Any

import anyio

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
        self.closed = False
        """Set by :meth:`close`: nothing more is published (a run's summary is its last event)."""

    def close(self) -> None:
        """Publish nothing more (what the agents do while they are being stopped is not told)."""
        self.closed = True

    def subscribe(self, observer: Observer) -> Callable[[], None]:
        """Add an observer; returns a function that removes it."""
        self.observers.append(observer)
        return lambda: self.observers.remove(observer) if observer in self.observers else None

    def emit(self, agent: str, event: str, **fields: Any) -> Event:
        """Publish an event now."""
        record: Event = {"t": round(self.clock.now(), 6), "agent": agent, "event": event, **fields}
        if self.closed:
            return record
        log.debug("%s", record)
        for observer in list(self.observers):
            try:
                observer(record)
            except (Exception, SystemExit) as exc:  # a broken observer must not stop the agents
                log.warning("dropping trace observer %r: %r", observer, exc)
                if observer in self.observers:
                    self.observers.remove(observer)
        return record


class EventStream:
    """A reader's own stream of trace events, with a bounded buffer (drop oldest).

    The agents never wait for a reader: emitting an event must not block them.  So
    when a reader falls behind by more than ``limit`` events, the oldest unread
    ones are dropped, and the reader is told how many before the next event it
    gets, by an ``events_dropped`` event (``{"event": "events_dropped", "count":
    n, ...}``).  The stream ends (``EndOfStream``; ``async for`` stops) when the
    runtime closes or the reader calls :meth:`aclose`.
    """

    def __init__(self, trace: Trace, limit: int = 10_000) -> None:
        if limit < 1:
            raise ValueError("an event stream needs room for at least one event")
        self.limit = limit
        self.dropped = 0
        """Events dropped so far (the reader was told of them with ``events_dropped``)."""
        self._trace = trace
        self._buffer: deque[Event] = deque()
        self._untold = 0
        self._closed = False
        self._wakeup = anyio.Event()
        self._unsubscribe = trace.subscribe(self._push)

    def _push(self, event: Event) -> None:
        if self._closed:
            return
        if len(self._buffer) >= self.limit:
            self._buffer.popleft()
            self._untold += 1
            self.dropped += 1
        self._buffer.append(event)
        self._wakeup.set()

    def close(self) -> None:
        """No more events: the reader gets what is buffered, then the end."""
        if not self._closed:
            self._closed = True
            self._unsubscribe()
            self._wakeup.set()

    async def aclose(self) -> None:
        """Stop reading: nothing more is buffered for this reader."""
        self.close()
        self._buffer.clear()

    def receive_nowait(self) -> Event:
        """The next event; ``WouldBlock`` if none is buffered, ``EndOfStream`` at the end."""
        if self._untold:
            told = {"t": self._buffer[0]["t"] if self._buffer else 0.0, "agent": "runtime"}
            event: Event = {**told, "event": "events_dropped", "count": self._untold}
            self._untold = 0
            return event
        if self._buffer:
            return self._buffer.popleft()
        if self._closed:
            raise anyio.EndOfStream
        raise anyio.WouldBlock

    async def receive(self) -> Event:
        """The next event, waiting for one."""
        while True:
            try:
                return self.receive_nowait()
            except anyio.WouldBlock:
                self._wakeup = anyio.Event()
                await self._wakeup.wait()

    def __aiter__(self) -> EventStream:
        return self

    async def __anext__(self) -> Event:
        try:
            return await self.receive()
        except anyio.EndOfStream:
            raise StopAsyncIteration from None

    async def __aenter__(self) -> EventStream:
        return self

    async def __aexit__(self, *exc: object) -> None:
        await self.aclose()
