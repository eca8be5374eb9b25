"""Maps: areas, nodes with coordinates, and arcs; loading, checking, generating.

The file format is that of ``scenarios/museum_map.yaml`` (CONTRACTS.md):
``areas`` (name → optional ``col``/``row``), ``nodes`` (name → ``area``, ``x``,
``y``) and ``arcs`` (id → ``[a, b]`` or ``{ends: [a, b], length: L}``).  An
arc's length defaults to the Euclidean distance of its ends, in metres.

Maps may be large (generated museums of 100,000 nodes), so :func:`parse_map`
checks each node and arc with a few cheap operations, and refuses what would
break text forms or arithmetic later: names with spaces, commas or
parentheses, coordinates beyond :data:`~htnagent.limits.MAX_COORDINATE`.
"""

from __future__ import annotations

import math
import random
import re
from collections.abc import Mapping
from dataclasses import dataclass, field
from functools import cached_property
from typing import Any

from htnagent.errors import ScenarioError, shown
from htnagent.limits import MAX_ARC_LENGTH, MAX_COORDINATE


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


def parse_map(data: Any, file: str, where: str = "map") -> WorldMap:
    """Check a map given as parsed YAML; raise ScenarioError naming the key path.

    Names of areas, nodes and arcs must be usable in text forms (no spaces,
    parentheses, commas, quotes or '?'); coordinates are finite numbers of at
    most :data:`~htnagent.limits.MAX_COORDINATE` metres, so every distance is
    finite too.  A map of 100,000 nodes is checked in about a second: the checks
    per node are kept to a few dictionary and set operations.
    """
    if not isinstance(data, Mapping):
        raise ScenarioError(
            file, where, f"a map must be a mapping with areas, nodes and arcs, not {_kind(data)}"
        )
    pre = f"{where}." if where else ""
    for key in data:
        if key not in ("areas", "nodes", "arcs"):
            raise ScenarioError(file, f"{pre}{key}", "unknown key; a map has areas, nodes and arcs")
    areas, grid = _parse_areas(data.get("areas"), file, pre)
    nodes = _parse_nodes(data.get("nodes"), areas, file, pre)
    arcs = _parse_arcs(data.get("arcs"), nodes, file, pre)
    return WorldMap(tuple(areas), nodes, arcs, grid)


def _parse_areas(raw: Any, file: str, pre: str) -> tuple[dict[str, None], dict[str, tuple[int, int]]]:
    if not isinstance(raw, Mapping) or not raw:
        raise ScenarioError(file, f"{pre}areas", "expected a non-empty mapping of area names")
    areas: dict[str, None] = {}
    grid: dict[str, tuple[int, int]] = {}
    for key, info in raw.items():
        name = _name(key, areas, "area", file, f"{pre}areas")
        path = f"{pre}areas.{name}"
        areas[name] = None
        if info is None:
            continue
        if not isinstance(info, Mapping) or not info.keys() <= {"col", "row"}:
            raise ScenarioError(file, path, "expected {col: int, row: int} or nothing")
        if "col" in info and "row" in info:
            col, row = info["col"], info["row"]
            if type(col) is not int or type(row) is not int or max(abs(col), abs(row)) > _MAX_GRID:
                raise ScenarioError(file, path, f"col and row must be whole numbers of at most {_MAX_GRID:,}")
            grid[name] = (col, row)
    return areas, grid


def _parse_nodes(raw: Any, areas: Mapping[str, None], file: str, pre: str) -> dict[str, Node]:
    if not isinstance(raw, Mapping) or not raw:
        raise ScenarioError(file, f"{pre}nodes", "expected a non-empty mapping of node names")
    nodes: dict[str, Node] = {}
    bad = _NOT_IN_NAMES.search
    for name, info in raw.items():
        if type(name) is not str or not name or name in nodes or bad(name):
            name = _name(name, nodes, "node", file, f"{pre}nodes")
        if type(info) is not dict and not isinstance(info, Mapping):
            raise ScenarioError(file, f"{pre}nodes.{name}", "expected {area: A, x: X, y: Y}")
        if not info.keys() <= _NODE_KEYS:
            extra = sorted(str(k) for k in info.keys() - _NODE_KEYS)[0]
            raise ScenarioError(file, f"{pre}nodes.{name}.{extra}", "unknown key; a node has area, x and y")
        area = info.get("area")
        if type(area) is not str or area not in areas:
            why = "expected an area name" if type(area) is not str else "unknown area"
            raise ScenarioError(file, f"{pre}nodes.{name}.area", f"{why}, got {shown(area)}")
        x: Any = info.get("x")
        y: Any = info.get("y")
        # Exact types first: a million isinstance checks against numbers would cost seconds.
        if (type(x) is not float and type(x) is not int) or not -MAX_COORDINATE <= x <= MAX_COORDINATE:
            _refuse_coordinate(x, file, f"{pre}nodes.{name}.x")
        if (type(y) is not float and type(y) is not int) or not -MAX_COORDINATE <= y <= MAX_COORDINATE:
            _refuse_coordinate(y, file, f"{pre}nodes.{name}.y")
        nodes[name] = Node(name, area, float(x), float(y))
    return nodes


def _parse_arcs(raw: Any, nodes: Mapping[str, Node], file: str, pre: str) -> dict[str, Arc]:
    if not isinstance(raw, Mapping) or not raw:
        raise ScenarioError(file, f"{pre}arcs", "expected a non-empty mapping of arc ids")
    arcs: dict[str, Arc] = {}
    hypot = math.hypot
    bad = _NOT_IN_NAMES.search
    for name, info in raw.items():
        if type(name) is not str or not name or name in arcs or bad(name):
            name = _name(name, arcs, "arc", file, f"{pre}arcs")
        length: Any = None
        ends: Any
        if type(info) is list:
            ends = info
        elif isinstance(info, Mapping):
            if not info.keys() <= _ARC_KEYS:
                extra = sorted(str(k) for k in info.keys() - _ARC_KEYS)[0]
                raise ScenarioError(
                    file, f"{pre}arcs.{name}.{extra}", "unknown key; an arc has ends and length"
                )
            ends = info.get("ends")
            length = info.get("length")
        else:
            ends = info
        if not isinstance(ends, list) or len(ends) != 2:
            raise ScenarioError(
                file, f"{pre}arcs.{name}", "expected [node, node] or {ends: [node, node], length: L}"
            )
        a, b = (e if type(e) is str else _number_name(e) for e in ends)
        na, nb = nodes.get(a), nodes.get(b)
        if na is None or nb is None:
            unknown = ends[1] if na is not None else ends[0]
            raise ScenarioError(file, f"{pre}arcs.{name}", f"unknown node {shown(unknown)}")
        if a == b:
            raise ScenarioError(
                file, f"{pre}arcs.{name}", f"an arc must join two different nodes, not {a} to itself"
            )
        if length is None:
            length = hypot(na.x - nb.x, na.y - nb.y)
        elif not _is_number(length) or not 0 < length <= MAX_ARC_LENGTH:
            raise ScenarioError(
                file,
                f"{pre}arcs.{name}.length",
                f"expected a positive number of at most {MAX_ARC_LENGTH:g}, got {shown(length)}",
            )
        arcs[name] = Arc(name, a, b, float(length))
    return arcs


_NODE_KEYS = frozenset({"area", "x", "y"})
_ARC_KEYS = frozenset({"ends", "length"})
_MAX_GRID = 1_000_000
# What a name may not hold: it must read as one constant of a text form, name(arg,...).
_NOT_IN_NAMES = re.compile(r"[(),\s\"'?]")


def _number_name(value: Any) -> str:
    """YAML reads a node named 12 as a number; as a name it means its text (but true or null do not)."""
    return str(value) if type(value) is int or type(value) is float else ""


def _name(raw: Any, seen: Mapping[str, Any], what: str, file: str, where: str) -> str:
    """The key as a name usable in text forms, or a ScenarioError."""
    key = raw if type(raw) is str else _number_name(raw)
    if type(raw) is not str and not key:
        raise ScenarioError(file, where, f"{shown(raw)} is not a valid {what} name")
    if not key or _NOT_IN_NAMES.search(key):
        raise ScenarioError(
            file,
            f"{where}.{key}",
            f"{shown(key)} is not a valid name (no spaces, parentheses, commas, quotes or '?')",
        )
    if key in seen:  # two keys written differently (1 and '1') naming the same thing
        raise ScenarioError(file, f"{where}.{key}", f"a second {what} named {key}")
    return key


def _refuse_coordinate(v: object, file: str, path: str) -> None:
    if _is_number(v):
        raise ScenarioError(
            file, path, f"expected a coordinate of at most {MAX_COORDINATE:g} m either way, got {v:g}"
        )
    raise ScenarioError(file, path, f"expected a number, got {shown(v)}")


def _is_number(v: object) -> bool:
    return isinstance(v, int | float) and not isinstance(v, bool) and math.isfinite(v)


def _kind(v: object) -> str:
    return "nothing" if v is None else type(v).__name__


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
