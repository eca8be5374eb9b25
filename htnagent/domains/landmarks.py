"""Landmark lower bounds on route lengths (ALT), for the museum domains' A* estimates.

For a few landmark places L, the shortest route length d(L, x) to every place
x is computed once (Dijkstra).  By the triangle inequality, for any two places
``|d(L, a) - d(L, b)| <= d(a, b)``, so the largest of these over the landmarks
is a lower bound on the route from a to b: an admissible A* estimate, usually
much tighter than the straight line.  Shut doors only make routes longer, so
bounds computed on the whole map stay admissible while doors close.
"""

from __future__ import annotations

import heapq
import math
import operator
from collections.abc import Iterable

_TARGETS = 16
"""How many targets' exact route tables :meth:`Landmarks.exact` keeps (the oldest goes)."""


class Landmarks:
    """Lower bounds on the shortest route between two places of a weighted graph."""

    def __init__(self, edges: Iterable[tuple[str, str, float]], count: int = 8) -> None:
        self._adjacent: dict[str, list[tuple[str, float]]] = {}
        for a, b, w in edges:
            self._adjacent.setdefault(a, []).append((b, w))
            self._adjacent.setdefault(b, []).append((a, w))
        self._count = count
        self._tables: list[dict[str, float]] | None = None
        self._rows: dict[str, tuple[float, ...]] | None = None
        self._targets: dict[str, dict[str, float]] = {}

    def exact(self, a: str, b: str) -> float:
        """The shortest route from ``a`` to ``b`` on the whole graph (0 when there is none).

        The target itself is the landmark: one Dijkstra from ``b``, kept for the next
        questions about the same target (a search asks about one target thousands of
        times).  A lower bound on the route while some edges are shut.  Worth it where
        searches are long next to the graph's size (a parent's few places).
        """
        table = self._targets.get(b)
        if table is None:
            if len(self._targets) >= _TARGETS:
                self._targets.pop(next(iter(self._targets)))
            table = self._targets[b] = self._dijkstra(b)
        return table.get(a, 0.0)

    def bound(self, a: str, b: str) -> float:
        """A lower bound on the route from ``a`` to ``b`` (0 when nothing is known)."""
        rows = self._rows if self._rows is not None else self._make_rows()
        ra, rb = rows.get(a), rows.get(b)
        if ra is not None and rb is not None:
            # Both places measured from every landmark: the same largest gap, worked out in C.
            return max(map(abs, map(operator.sub, ra, rb)), default=0.0)
        tables = self._tables if self._tables is not None else self._build()
        best = 0.0
        for table in tables:
            da, db = table.get(a), table.get(b)
            if da is not None and db is not None:
                gap = abs(da - db)
                if gap > best:
                    best = gap
        return best

    def _make_rows(self) -> dict[str, tuple[float, ...]]:
        """Each place's distances from the landmarks in order, for the places every
        landmark reaches (a search asks for thousands of bounds)."""
        tables = self._tables if self._tables is not None else self._build()
        rows: dict[str, tuple[float, ...]] = {}
        for place in self._adjacent:
            if all(place in table for table in tables):
                rows[place] = tuple(table[place] for table in tables)
        self._rows = rows
        return rows

    def _build(self) -> list[dict[str, float]]:
        """Pick landmarks far apart (farthest-point) and measure every place from each."""
        places = sorted(self._adjacent)
        tables: list[dict[str, float]] = []
        if places:
            # Start from the place farthest from an arbitrary one, then always the place
            # farthest from every landmark chosen so far.
            seed = self._dijkstra(places[0])
            nearest = dict.fromkeys(seed, math.inf)
            landmark = max(seed, key=lambda p: (seed[p], p))
            for _ in range(min(self._count, len(places))):
                table = self._dijkstra(landmark)
                tables.append(table)
                for p, dist in table.items():
                    if dist < nearest.get(p, math.inf):
                        nearest[p] = dist
                landmark = max(nearest, key=lambda p: (nearest[p], p))
                if nearest[landmark] == 0:
                    break
        self._tables = tables
        return tables

    def _dijkstra(self, source: str) -> dict[str, float]:
        dist = {source: 0.0}
        queue = [(0.0, source)]
        while queue:
            d, here = heapq.heappop(queue)
            if d > dist[here]:
                continue
            for there, w in self._adjacent.get(here, ()):
                nd = d + w
                if nd < dist.get(there, math.inf):
                    dist[there] = nd
                    heapq.heappush(queue, (nd, there))
        return dist
