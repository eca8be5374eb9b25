"""The garbage collector kept off what a run builds before it starts (``gc.freeze``).

A run's process holds many long-lived objects -- the scenario, its map and domains, the
methods compiled for them, the runtime -- and makes many short-lived ones, which
reference counting frees.  Python's full collections walk the long-lived ones all the
same: one pause of the event loop each time (about 0.1 s in a 100-robot fleet's parent;
7 ms in an IPC agent's run, often inside the agent's plan upkeep).  :func:`long_lived`
takes what exists when a run starts out of the collector's passes until it ends, the
advice in Python's ``gc`` documentation for long-running servers.
"""

from __future__ import annotations

import contextlib
import gc
from collections.abc import Iterator

_frozen = 0
"""How many :func:`long_lived` are open now (only the outermost freezes)."""

YOUNG = 20_000
"""Allocations between two collections of the youngest generation while a run goes on
(:func:`long_lived`; Python's default is 700)."""


@contextlib.contextmanager
def long_lived() -> Iterator[None]:
    """What exists now (the scenarios, their maps and domains, the runtime) out of the
    garbage collector's passes until the end, and the youngest generation collected every
    :data:`YOUNG` allocations, not 700; both as they were after, unless someone has frozen
    the heap already (then left alone: a fleet's run of each robot's scenario).

    The young collections walk the messages and events of the moment, alive for a few
    steps more (a hundred in a 100-robot museum run, 0.05 s).  Only garbage in cycles
    waits longer (for the next pass, or the thaw: what is frozen was alive then)."""
    global _frozen
    # Our own count first: ``gc.get_freeze_count`` walks every frozen object (CPython
    # counts its list), and a fleet's parent asked it once per robot with the whole
    # fleet frozen -- 100 walks of its heap, a third of its CPU, most of it at start-up.
    if _frozen or gc.get_freeze_count():
        yield  # frozen by the caller, who thaws it
        return
    gc.freeze()
    thresholds = gc.get_threshold()
    gc.set_threshold(YOUNG, *thresholds[1:])
    _frozen += 1
    try:
        yield
    finally:
        _frozen -= 1
        gc.set_threshold(*thresholds)
        gc.unfreeze()


__all__ = ["YOUNG", "long_lived"]
