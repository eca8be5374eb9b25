"""The map file: its schema, and the checked :class:`~htnagent.domains.maps.WorldMap` it becomes.

The format is that of ``scenarios/museum_map.yaml`` (docs/contracts.md): ``areas``
(name → nothing or ``{col, row}``), ``nodes`` (name → ``{area, x, y}``) and
``arcs`` (id → ``[a, b]`` or ``{ends: [a, b], length: L}``).  An arc's length
defaults to the Euclidean distance of its ends, in metres.  A scenario names
its map file or writes the map inline under ``map:``.

:class:`MapFile` checks the shape and every value (names usable in text forms,
coordinates and lengths finite and bounded; see :mod:`htnagent.limits`);
:func:`parse_map` then checks what refers to what (a node's area, an arc's
ends) while building the map.  Errors of both are worded like the scenario's
(:mod:`htnagent.scenario.wording`): ``FILE: nodes.n1.x: reason``.

Maps may be large (generated museums of 100,000 nodes, checked in about a
second): the entries are ``TypedDict``s, validated by pydantic's compiled core
without a model object or a Python call per node.
"""

from __future__ import annotations

import math
import os
from collections.abc import Mapping
from pathlib import Path
from typing import (
    Annotated,
    NotRequired,  # pydantic reads TypedDicts from here before 3.12
)

from pydantic import (
    BaseModel,
    ConfigDict,
    Discriminator,
    Field,
    Strict,
    StringConstraints,
    Tag,
    ValidationError,
)
from typing_extensions import TypedDict

from htnagent.domains.maps import Arc, Node, WorldMap
from htnagent.errors import ScenarioError, shown
from htnagent.limits import MAX_ARC_LENGTH, MAX_COORDINATE
from htnagent.reading import read_text, yaml_document
from htnagent.scenario.wording import NAME_PATTERN, kind_of, scenario_error

__all__ = ["ArcEntry", "ArcForm", "AreaEntry", "MapFile", "NodeEntry", "load_map", "parse_map"]

MAX_GRID = 1_000_000
"""The largest ``col`` or ``row`` of an area, either way."""

# A node written `12:` is node '12' (YAML reads the key as a number), and so is an arc's end `12`.
_CONFIG = ConfigDict(extra="forbid", coerce_numbers_to_str=True)

MapName = Annotated[str, StringConstraints(min_length=1, pattern=NAME_PATTERN)]
"""The name of an area, node or arc: one constant of a text form."""
Coordinate = Annotated[float, Strict(), Field(ge=-MAX_COORDINATE, le=MAX_COORDINATE, allow_inf_nan=False)]
GridIndex = Annotated[int, Strict(), Field(ge=-MAX_GRID, le=MAX_GRID)]
ArcLength = Annotated[float, Strict(), Field(gt=0, le=MAX_ARC_LENGTH, allow_inf_nan=False)]


class AreaEntry(TypedDict):
    """Where an area is drawn on a grid of areas (used by plots); both or neither."""

    __pydantic_config__ = _CONFIG  # type: ignore[misc]
    col: NotRequired[GridIndex]
    row: NotRequired[GridIndex]


class NodeEntry(TypedDict):
    """A node: the area it is in and its position in metres."""

    __pydantic_config__ = _CONFIG  # type: ignore[misc]
    area: Annotated[str, Strict()]
    x: Coordinate
    y: Coordinate


class ArcEntry(TypedDict):
    """An arc: the two nodes it joins and, if not their distance, its length in metres."""

    __pydantic_config__ = _CONFIG  # type: ignore[misc]
    ends: tuple[str, str]
    length: NotRequired[ArcLength]


def _arc_form(value: object) -> str | None:
    """Which form an arc is written in: ``[a, b]``, ``{ends: [a, b], length: L}``, or neither."""
    kind = type(value)
    if kind is list:
        return _SHORT
    return _LONG if kind is dict or isinstance(value, Mapping) else None


# The tags name the two forms; the translator leaves them out of key paths (no map name looks so).
_SHORT, _LONG = "[a, b]", "{ends, length}"

ArcForm = Annotated[
    Annotated[tuple[str, str], Tag(_SHORT)] | Annotated[ArcEntry, Tag(_LONG)],
    Discriminator(
        _arc_form,
        custom_error_type="arc_form",
        custom_error_message="expected [node, node] or {ends: [node, node], length: L}",
    ),
]
"""An arc in either form: ``id: [a, b]`` is short for ``id: {ends: [a, b]}``."""


class MapFile(BaseModel):
    """A map file's content, each value checked; what refers to what is checked by :func:`parse_map`."""

    model_config = ConfigDict(frozen=True, extra="forbid", coerce_numbers_to_str=True)

    # fail_fast: only the first error is told, so a map of a million bad nodes stops at the first.
    areas: Annotated[dict[MapName, AreaEntry | None], Field(min_length=1, fail_fast=True)]
    nodes: Annotated[dict[MapName, NodeEntry], Field(min_length=1, fail_fast=True)]
    arcs: Annotated[dict[MapName, ArcForm], Field(min_length=1, fail_fast=True)]


_WHAT = {"areas": "area", "nodes": "node", "arcs": "arc"}


def parse_map(data: object, file: str, where: str = "map") -> WorldMap:
    """Check a map given as parsed YAML; raise ScenarioError naming ``file`` and the key path.

    ``where`` is the map's place in ``file``: ``map`` for a map inline in a
    scenario, ``""`` for a map file of its own.
    """
    if not isinstance(data, Mapping):
        raise ScenarioError(
            file, where, f"a map must be a mapping with areas, nodes and arcs, not {kind_of(data)}"
        )
    pre = f"{where}." if where else ""
    for section, what in _WHAT.items():
        _refuse_twice_named(data.get(section), what, file, f"{pre}{section}")
    try:
        spec = MapFile.model_validate(data)
    except ValidationError as e:
        raise scenario_error(e, file, MapFile, where) from None
    return _world(spec, file, pre)


def _refuse_twice_named(entries: object, what: str, file: str, where: str) -> None:
    """Two keys written differently (``1`` and ``'1'``) naming the same thing."""
    if not isinstance(entries, Mapping) or all(type(k) is str for k in entries):
        return
    seen: set[str] = set()
    for key in entries:
        name = str(key) if type(key) in (int, float) else key
        if isinstance(name, str):
            if name in seen:
                raise ScenarioError(file, f"{where}.{name}", f"a second {what} named {name}")
            seen.add(name)


def _world(spec: MapFile, file: str, pre: str) -> WorldMap:
    """The map, once each node's area and each arc's ends are known."""
    areas = spec.areas
    grid = {
        name: (entry["col"], entry["row"])
        for name, entry in areas.items()
        if entry is not None and "col" in entry and "row" in entry
    }
    nodes: dict[str, Node] = {}
    for name, n in spec.nodes.items():
        area = n["area"]
        if area not in areas:
            raise ScenarioError(
                file, f"{pre}nodes.{name}.area", f"unknown area {shown(area)}; it is not under areas"
            )
        nodes[name] = Node(name, area, n["x"], n["y"])  # pydantic gave floats
    arcs: dict[str, Arc] = {}
    hypot = math.hypot
    for name, arc in spec.arcs.items():
        if isinstance(arc, tuple):
            (a, b), length = arc, None
        else:
            (a, b), length = arc["ends"], arc.get("length")
        na, nb = nodes.get(a), nodes.get(b)
        if na is None or nb is None:
            unknown = b if na is not None else a
            raise ScenarioError(file, f"{pre}arcs.{name}", f"unknown node {shown(unknown)}")
        if a == b:
            raise ScenarioError(
                file, f"{pre}arcs.{name}", f"an arc must join two different nodes, not {a} to itself"
            )
        arcs[name] = Arc(name, a, b, length if length is not None else hypot(na.x - nb.x, na.y - nb.y))
    return WorldMap(tuple(areas), nodes, arcs, grid)


def load_map(
    spec: str | Mapping[object, object], file: str, base_dir: Path, max_file_bytes: int | None
) -> WorldMap:
    """A scenario's map: inline (``spec`` a mapping) or the file ``spec`` names, relative to ``base_dir``.

    ``file`` is the scenario file: a map file that is not there is its mistake;
    one that is there but bad is the map file's, and named so.
    """
    if isinstance(spec, Mapping):
        return parse_map(spec, file, "map")
    map_file = str(base_dir / spec)
    try:
        os.stat(map_file)
    except FileNotFoundError:
        raise ScenarioError(file, "map", f"map file {shown(map_file, 200)} not found") from None
    except (OSError, ValueError) as e:  # a name too long, a path through a file, a NUL in the name
        reason = e.strerror if isinstance(e, OSError) and e.strerror else str(e)
        raise ScenarioError(file, "map", f"cannot read map file {shown(map_file, 200)}: {reason}") from None
    text = read_text(map_file, "map", max_file_bytes)
    world = _MAPS_READ.get((map_file, text))
    if world is None:
        world = parse_map(yaml_document(text, map_file, "map"), map_file, "")
        if len(text) <= MAP_KEPT_CHARS:
            if len(_MAPS_READ) >= MAPS_KEPT:
                del _MAPS_READ[next(iter(_MAPS_READ))]
            _MAPS_READ[(map_file, text)] = world
    return world


MAPS_KEPT = 8
"""Map files kept read, by name and text (the oldest forgotten first)."""
MAP_KEPT_CHARS = 1 << 20
"""Only a map file of at most this many characters is kept (a huge one is not held on to)."""
_MAPS_READ: dict[tuple[str, str], WorldMap] = {}
"""Robots that each have a scenario file of their own on one map (a fleet) read the map
once: a map is a value, shared as it is; equal maps are then one object, which
:meth:`~htnagent.scenario.Scenario.share_domains` compares at once (comparing two equal
museum maps field by field took 0.23 ms, once a robot as a fleet starts)."""
