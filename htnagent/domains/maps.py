"""Maps: areas, nodes with coordinates, and arcs, as values; and generated museums.

A :class:`WorldMap` is what the domains plan over and the robot travels; it
is built checked, from a map file (:mod:`htnagent.scenario.map_file`, whose
:func:`~htnagent.scenario.map_file.parse_map` is also reachable here) or by
:func:`generate_map`.  Arc lengths are in metres.
"""

from __future__ import annotations

import math
import random
from collections.abc import Mapping
from dataclasses import dataclass, field
from functools import cached_property
from typing import Any


@dataclass(frozen=True, slots=True)
class Node:
    """A place the robot can stand at."""

    name: str
    area: str
    x: float
    y: float


@dataclass(frozen=True, slots=True)
class Arc:
    """A two-way passage between two nodes."""

    name: str
    a: str
    b: str
    length: float


@dataclass(frozen=True)
class WorldMap:
    """A checked map: every arc joins two known nodes, every node is in a known area."""

    areas: tuple[str, ...]
    nodes: Mapping[str, Node]
    arcs: Mapping[str, Arc]
    area_grid: Mapping[str, tuple[int, int]] = field(default_factory=dict)

    @cached_property
    def area_nodes(self) -> dict[str, list[str]]:
        """The nodes of each area."""
        out: dict[str, list[str]] = {a: [] for a in self.areas}
        for n in self.nodes.values():
            out[n.area].append(n.name)
        return out

    @cached_property
    def centroids(self) -> dict[str, tuple[float, float]]:
        """The mean position of each area's nodes."""
        out: dict[str, tuple[float, float]] = {}
        for a, names in self.area_nodes.items():
            if names:
                out[a] = (
                    sum(self.nodes[n].x for n in names) / len(names),
                    sum(self.nodes[n].y for n in names) / len(names),
                )
            else:
                out[a] = (0.0, 0.0)
        return out

    @cached_property
    def doors(self) -> list[tuple[str, str, Arc]]:
        """Arcs joining two areas, each as ``(from area, to area, arc)``, both ways."""
        out: list[tuple[str, str, Arc]] = []
        for arc in self.arcs.values():
            aa, ab = self.nodes[arc.a].area, self.nodes[arc.b].area
            if aa != ab:
                out.append((aa, ab, arc))
                out.append((ab, aa, arc))
        return out

    def distance(self, a: str, b: str) -> float:
        """The straight-line distance between two nodes."""
        na, nb = self.nodes[a], self.nodes[b]
        return math.hypot(na.x - nb.x, na.y - nb.y)

    def arc_between(self, a: str, b: str) -> Arc | None:
        """An arc joining the two nodes, if there is one."""
        for arc in self.arcs.values():
            if {arc.a, arc.b} == {a, b}:
                return arc
        return None


def generate_map(cols: int, rows: int, side: int, seed: int = 0) -> WorldMap:
    """A museum of ``cols × rows`` areas, each a ``side × side`` grid of nodes.

    Nodes are jittered, some inner arcs dropped and diagonals added at random,
    so routes differ; neighbouring areas are joined by one to two doors.  Every
    node stays reachable.
    """
    rng = random.Random(seed)
    spacing = 4.0
    area_size = side * spacing + 2.0
    areas: list[str] = []
    grid: dict[str, tuple[int, int]] = {}
    nodes: dict[str, Node] = {}
    arcs: dict[str, Arc] = {}
    cell: dict[tuple[int, int, int, int], str] = {}

    def add_arc(a: str, b: str) -> None:
        name = f"arc{len(arcs) + 1}"
        arcs[name] = Arc(name, a, b, math.hypot(nodes[a].x - nodes[b].x, nodes[a].y - nodes[b].y))

    for r in range(rows):
        for c in range(cols):
            area = f"area{r * cols + c + 1}"
            areas.append(area)
            grid[area] = (c, r)
            for j in range(side):
                for i in range(side):
                    name = f"n{len(nodes) + 1}"
                    x = c * area_size + 1 + i * spacing + rng.uniform(-1.0, 1.0)
                    y = r * area_size + 1 + j * spacing + rng.uniform(-1.0, 1.0)
                    nodes[name] = Node(name, area, round(x, 2), round(y, 2))
                    cell[(c, r, i, j)] = name
            # Row 0 and every column form a comb that connects the area; extra arcs make cycles.
            for j in range(side):
                for i in range(side):
                    here = cell[(c, r, i, j)]
                    if i + 1 < side and (j == 0 or rng.random() < 0.7):
                        add_arc(here, cell[(c, r, i + 1, j)])
                    if j + 1 < side:
                        add_arc(here, cell[(c, r, i, j + 1)])
                    if i + 1 < side and j + 1 < side and rng.random() < 0.15:
                        add_arc(here, cell[(c, r, i + 1, j + 1)])
    for r in range(rows):
        for c in range(cols):
            if c + 1 < cols:
                for _ in range(rng.randint(1, 2)):
                    j = rng.randrange(side)
                    add_arc(cell[(c, r, side - 1, j)], cell[(c + 1, r, 0, j)])
            if r + 1 < rows:
                for _ in range(rng.randint(1, 2)):
                    i = rng.randrange(side)
                    add_arc(cell[(c, r, i, side - 1)], cell[(c, r + 1, i, 0)])
    # Duplicate doors (same two nodes) collapse to one.
    unique: dict[frozenset[str], Arc] = {}
    for arc in arcs.values():
        unique.setdefault(frozenset((arc.a, arc.b)), arc)
    return WorldMap(tuple(areas), nodes, {a.name: a for a in unique.values()}, grid)


def map_to_yaml_data(world: WorldMap) -> dict[str, Any]:
    """The map as plain data in the file format (for writing generated maps)."""
    return {
        "areas": {
            a: (
                {"col": world.area_grid[a][0], "row": world.area_grid[a][1]} if a in world.area_grid else None
            )
            for a in world.areas
        },
        "nodes": {n.name: {"area": n.area, "x": n.x, "y": n.y} for n in world.nodes.values()},
        "arcs": {a.name: [a.a, a.b] for a in world.arcs.values()},
    }
