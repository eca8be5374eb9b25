"""The trace: publishing events (:mod:`htnagent.runtime.events`) to the observers that receive them.

The runtime publishes events to every observer in order, each stamped with the
simulated time; observers must not block (the CLI's printers, a collector for
the summary, the embedding API's event stream).  Observers watch: nothing the
agents do depends on them.
"""

from __future__ import annotations

import logging
from collections import deque
from collections.abc import Callable
from typing import Self

import anyio

from htnagent.errors import SettingsError
from htnagent.log import library_log
from htnagent.runtime.clock import Clock
from htnagent.runtime.events import EventsDropped, TraceEvent

Observer = Callable[[TraceEvent], None]

log = library_log()

WALL_CLOCK_FIELDS = frozenset({"replan_ms", "planning_ms", "window_ms", "ms"})
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

    def emit(self, event: TraceEvent) -> None:
        """Publish an event now (stamped with the time)."""
        if self.closed:
            return
        event.t = round(self.clock.now(), 6)
        if log.isEnabledFor(logging.DEBUG):
            log.debug("%s", event)
        for observer in list(self.observers):
            try:
                observer(event)
            except (Exception, SystemExit) as exc:  # a broken observer must not stop the agents
                log.warning("dropping trace observer %r: %r", observer, exc)
                if observer in self.observers:
                    self.observers.remove(observer)


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
            raise SettingsError("an event stream needs room for at least one event")
        self.limit = limit
        self.dropped = 0
        """Events dropped so far (the reader was told of them with ``events_dropped``)."""
        self._trace = trace
        self._buffer: deque[TraceEvent] = deque()
        self._untold = 0
        self._closed = False
        self._wakeup = anyio.Event()
        self._unsubscribe = trace.subscribe(self._push)

    def _push(self, event: TraceEvent) -> None:
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

    def receive_nowait(self) -> TraceEvent:
        """The next event; ``WouldBlock`` if none is buffered, ``EndOfStream`` at the end."""
        if self._untold:
            t = self._buffer[0].t if self._buffer else 0.0
            dropped = EventsDropped(agent="runtime", t=t, count=self._untold)
            self._untold = 0
            return dropped
        if self._buffer:
            return self._buffer.popleft()
        if self._closed:
            raise anyio.EndOfStream
        raise anyio.WouldBlock

    async def receive(self) -> TraceEvent:
        """The next event, waiting for one."""
        while True:
            try:
                return self.receive_nowait()
            except anyio.WouldBlock:
                self._wakeup = anyio.Event()
                await self._wakeup.wait()

    def __aiter__(self) -> Self:
        return self

    async def __anext__(self) -> TraceEvent:
        try:
            return await self.receive()
        except anyio.EndOfStream:
            raise StopAsyncIteration from None

    async def __aenter__(self) -> Self:
        return self

    async def __aexit__(self, *exc: object) -> None:
        await self.aclose()
