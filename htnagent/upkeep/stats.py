"""What plan upkeep counts: searches, re-checks, repairs, revivals, and the time it takes.

One :class:`PlanningStats` per agent, shared by all its plan sets; :class:`Timed`
adds the wall-clock time of each update to it.
"""

from __future__ import annotations

import time
from dataclasses import dataclass


@dataclass(slots=True)
class PlanningStats:
    """Counters and wall-clock time of one agent's planning and plan maintenance."""

    rechecks: int = 0
    repairs: int = 0
    failed_repairs: int = 0
    revivals: int = 0
    from_scratch: int = 0
    shortcuts: int = 0
    fresher: int = 0
    removed: int = 0
    expansions: int = 0
    seconds: float = 0.0
    cpu_seconds: float = 0.0
    """The agent's thread's CPU time in the same blocks as :attr:`seconds`: what other
    processes on a shared machine do not add to (benchmarks compare modes by it)."""

    def as_dict(self) -> dict[str, float]:
        """The figures, for traces and benchmarks."""
        return {
            "rechecks": self.rechecks,
            "repairs": self.repairs,
            "failed_repairs": self.failed_repairs,
            "revivals": self.revivals,
            "from_scratch": self.from_scratch,
            "shortcuts": self.shortcuts,
            "fresher": self.fresher,
            "removed": self.removed,
            "expansions": self.expansions,
            "ms": round(self.seconds * 1000, 3),
        }


class Timed:
    """Adds the wall-clock and CPU time of a ``with`` block to the statistics (a plain
    class: it wraps every plan-set update, so it should cost next to nothing)."""

    __slots__ = ("_cpu", "_started", "_stats")

    def __init__(self, stats: PlanningStats) -> None:
        self._stats = stats
        self._started = 0.0
        self._cpu = 0.0

    def __enter__(self) -> None:
        self._cpu = time.thread_time()
        self._started = time.perf_counter()

    def __exit__(self, *exc: object) -> None:
        self._stats.seconds += time.perf_counter() - self._started
        self._stats.cpu_seconds += time.thread_time() - self._cpu


__all__ = ["PlanningStats", "Timed"]
