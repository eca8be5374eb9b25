"""Callbacks the runtime calls as things happen: a user's code, which must not stop the agents.

A callback that raises is dropped, with a warning in the log, and the others are
still called: the actors' progress (:mod:`htnagent.runtime.progress`) and goals' ends
(:meth:`htnagent.system.runtime.Runtime.on_goal_end`).  Trace observers follow the same
rule in :meth:`htnagent.runtime.trace.Trace.emit`, written out there: it is called for
every event.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Generic, TypeVar

from htnagent.log import library_log

log = library_log()

T = TypeVar("T")


class Listeners(Generic[T]):
    """Callbacks of one kind (``what``, as the log names them); none may block."""

    def __init__(self, what: str) -> None:
        self.what = what
        self._listeners: list[Callable[[T], None]] = []

    def add(self, listener: Callable[[T], None]) -> Callable[[], None]:
        """Call ``listener`` with every report; returns a function that removes it."""
        self._listeners.append(listener)
        return lambda: self._listeners.remove(listener) if listener in self._listeners else None

    def report(self, value: T) -> None:
        """Tell every listener (one that raises is dropped, the actors go on)."""
        for listener in list(self._listeners):
            try:
                listener(value)
            except Exception as exc:
                log.warning("dropping %s %r: %r", self.what, listener, exc)
                if listener in self._listeners:
                    self._listeners.remove(listener)
