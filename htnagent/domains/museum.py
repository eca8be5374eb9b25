"""The museum guide's two domains (docs/design.md §6), for any map in the map format.

``museum.areas`` (the parent, "guide") plans over areas: ``goto(N)`` becomes
``move_area(A,B)`` steps and a final ``goto_node(N)``; both are executed by the
next agent.  ``museum.nodes`` (the child, "navigator") plans over nodes:
``goto_node(N)`` by the shortest route, ``move_area(A,B)`` to B's entry node
staying in A until the door; its action is ``move(From,To,Arc)``, whose cost is
the arc length.

Facts.  Parent: ``at(Area)``, ``moving(A,B)`` while a suspended ``move_area`` waits,
``visiting(N)`` while a suspended ``goto_node`` waits, ``in_area(N,Area)``,
``door(A,B,Arc)``, ``closed(Arc)``.  Child: ``at(N)``, ``on_arc(Arc,From,To)``
while a suspended ``move`` waits, ``arc(X,Y,Arc)`` (both ways), ``in_area(N,Area)``,
``closed(Arc)``.

A suspended ``move`` leaves the robot on the arc (a fact about the world, which
clearing the suspension does not change); ``resume`` and ``rollback`` are each
costed at half the arc (the planner does not know how far the robot got, and a
symmetric guess keeps their order right).  The parent's coarse belief does
not change when its action is suspended — the robot is still in area A — it only
notes ``moving(A,B)`` so that ``resume(move_area(A,B))`` can be planned; that
note is dropped when the suspension is cleared.
"""

from __future__ import annotations

import math

from htnagent.domains.info import DomainInfo
from htnagent.domains.landmarks import Landmarks
from htnagent.domains.maps import WorldMap
from htnagent.model.domain import Domain, Effect, State, Suspension
from htnagent.model.terms import Atom


def _position(state: State, name: str = "at") -> str | None:
    for f in state.dynamic:
        if f.name == name and len(f.args) == 1 and isinstance(f.args[0], str):
            return f.args[0]
    return None


def areas_domain(world: WorldMap) -> Domain:
    """The parent's domain over the areas of ``world``."""
    d = Domain("museum.areas")
    centre = world.centroids

    def hop(a: str, b: str) -> float:
        (xa, ya), (xb, yb) = centre[a], centre[b]
        return math.hypot(xa - xb, ya - yb)

    def move_cost(action: Atom) -> float:
        a, b = action.args
        return hop(str(a), str(b))

    def half_move(action: Atom) -> float:
        return move_cost(action) / 2

    d.operator(
        "move_area(?a,?b)",
        pre=["at(?a)", "door(?a,?b,?arc)", "not closed(?arc)"],
        add=["at(?b)"],
        delete=["at(?a)", "moving(?a,?b)"],
        cost=move_cost,
        suspend=Suspension(
            add=("moving(?a,?b)",),
            cleared=("moving(?a,?b)",),
            # The rest of the way still needs an open door (docs/design.md §5: a parent must
            # not resume into a shut door).
            resume=Effect(
                pre=("moving(?a,?b)", "at(?a)", "door(?a,?b,?arc)", "not closed(?arc)"),
                add=("at(?b)",),
                delete=("at(?a)", "moving(?a,?b)"),
                cost=half_move,
            ),
        ),
        undo="move_area(?b,?a)",
    )
    nodes = world.nodes

    def walk_in(action: Atom) -> float:
        # The guide does not know where in the area the robot stands: it counts the
        # way from the area's centre, as move_area counts centre to centre.  A free
        # goto_node would make finishing another goal's suspended one look free too.
        node = nodes[str(action.args[0])]
        x, y = centre[node.area]
        return math.hypot(node.x - x, node.y - y)

    d.operator(
        "goto_node(?n)",
        pre=["at(?a)", "in_area(?n,?a)"],
        delete=["visiting(?n)"],
        cost=walk_in,
        suspend=Suspension(
            add=("visiting(?n)",),
            cleared=("visiting(?n)",),
            resume=Effect(
                pre=("visiting(?n)", "at(?a)", "in_area(?n,?a)"),
                delete=("visiting(?n)",),
                cost=lambda action: walk_in(action) / 2,
            ),
        ),
    )
    d.method("goto(?n)", "in_its_area", when=["at(?a)", "in_area(?n,?a)"], do=["goto_node(?n)"])
    d.method(
        "goto(?n)",
        "through_a_door",
        when=["at(?a)", "not in_area(?n,?a)", "door(?a,?b,?arc)", "not closed(?arc)"],
        do=["move_area(?a,?b)", "goto(?n)"],
    )
    area_of = {n.name: n.area for n in world.nodes.values()}

    # Routes between areas follow doors: routes on the door graph are far tighter
    # than the straight line between centres (both are lower bounds).
    routes = Landmarks((a, b, hop(a, b)) for a, b, _ in world.doors)

    def estimate_goto(task: Atom, state: State) -> float:
        here = _position(state)
        node = str(task.args[0])
        target = area_of.get(node)
        if here is None or target is None or here not in centre:
            return 0.0
        # The target area as its own landmark: the exact route over the doors (a lower
        # bound while doors are shut); and every way ends with goto_node(N), whose cost
        # is known.  A* then has next to nothing to explore besides the route.
        return max(hop(here, target), routes.exact(here, target)) + walk_in(Atom("goto_node", (node,)))

    d.estimate("goto", estimate_goto)
    d.world_facts = lambda start: areas_facts(world, start)
    return d


def areas_facts(world: WorldMap, start: str) -> list[Atom]:
    """The parent's belief with the robot at node ``start``."""
    facts = [Atom("at", (world.nodes[start].area,))]
    facts += [Atom("in_area", (n.name, n.area)) for n in world.nodes.values()]
    facts += [Atom("door", (a, b, arc.name)) for a, b, arc in world.doors]
    return facts


def nodes_domain(world: WorldMap) -> Domain:
    """The child's domain over the nodes and arcs of ``world``."""
    d = Domain("museum.nodes")
    length = {a.name: a.length for a in world.arcs.values()}

    def arc_cost(action: Atom) -> float:
        return length[str(action.args[2])]

    def half_arc(action: Atom) -> float:
        return arc_cost(action) / 2

    d.operator(
        "move(?f,?t,?a)",
        pre=["at(?f)", "arc(?f,?t,?a)", "not closed(?a)"],
        add=["at(?t)"],
        delete=["at(?f)"],
        cost=arc_cost,
        suspend=Suspension(
            add=("on_arc(?a,?f,?t)",),
            delete=("at(?f)",),
            resume=Effect(
                pre=("on_arc(?a,?f,?t)", "not closed(?a)"),
                add=("at(?t)",),
                delete=("on_arc(?a,?f,?t)",),
                cost=half_arc,
            ),
            rollback=Effect(
                pre=("on_arc(?a,?f,?t)",), add=("at(?f)",), delete=("on_arc(?a,?f,?t)",), cost=half_arc
            ),
        ),
        undo="move(?t,?f,?a)",
    )
    d.method("goto_node(?n)", "arrived", when=["at(?n)"], do=[])
    d.method(
        "goto_node(?n)",
        "step",
        when=["not at(?n)", "at(?x)", "arc(?x,?y,?a)", "not closed(?a)"],
        do=["move(?x,?y,?a)", "goto_node(?n)"],
    )
    d.method("move_area(?a,?b)", "entered", when=["at(?x)", "in_area(?x,?b)"], do=[])
    d.method(
        "move_area(?a,?b)",
        "cross_the_door",
        when=["at(?x)", "in_area(?x,?a)", "arc(?x,?y,?arc)", "in_area(?y,?b)", "not closed(?arc)"],
        do=["move(?x,?y,?arc)"],
    )
    d.method(
        "move_area(?a,?b)",
        "walk_to_the_door",
        when=["at(?x)", "in_area(?x,?a)", "arc(?x,?y,?arc)", "in_area(?y,?a)", "not closed(?arc)"],
        do=["move(?x,?y,?arc)", "move_area(?a,?b)"],
    )
    nodes = world.nodes
    # The straight line is a lower bound on a route only while no arc is shorter than the
    # line between its ends; a map may give an arc its own length, so shrink the estimate
    # until it is one again (an over-estimate would cost goto_node its shortest route).
    lines = ((arc.length, world.distance(arc.a, arc.b)) for arc in world.arcs.values())
    scale = min([1.0] + [length / line for length, line in lines if line > 0])

    routes = Landmarks((arc.a, arc.b, arc.length) for arc in world.arcs.values())
    # A* asks for an estimate at every new place (docs/design.md §1): positions at hand.
    where = {n.name: (n.x, n.y) for n in nodes.values()}
    bound = routes.bound

    def lower_bound(a: str, b: str) -> float:
        (xa, ya), (xb, yb) = where[a], where[b]
        return max(scale * math.hypot(xa - xb, ya - yb), bound(a, b))  # world.distance(a, b), inlined

    def estimate_goto_node(task: Atom, state: State) -> float:
        here = _position(state)
        target = str(task.args[0])
        if here is None or target not in nodes:
            return 0.0
        return lower_bound(here, target)

    # The cheapest way into B from A: walk to a door's near end, then cross it.
    door_ends: dict[tuple[str, str], list[tuple[str, float]]] = {}
    for a, b, arc in world.doors:
        near = arc.a if nodes[arc.a].area == a else arc.b
        door_ends.setdefault((a, b), []).append((near, arc.length))

    def estimate_move_area(task: Atom, state: State) -> float:
        here = _position(state)
        if here is None or here not in nodes:
            return 0.0
        a, b = str(task.args[0]), str(task.args[1])
        if nodes[here].area == b:
            return 0.0
        ends = door_ends.get((a, b))
        if not ends:
            return 0.0
        return min(lower_bound(here, near) + crossing for near, crossing in ends)

    d.estimate("goto_node", estimate_goto_node)
    d.estimate("move_area", estimate_move_area)
    d.world_facts = lambda start: nodes_facts(world, start)
    return d


def nodes_facts(world: WorldMap, start: str) -> list[Atom]:
    """The child's belief with the robot at node ``start``."""
    facts: list[Atom] = [Atom("at", (start,))]
    facts += [Atom("in_area", (n.name, n.area)) for n in world.nodes.values()]
    for arc in world.arcs.values():
        facts.append(Atom("arc", (arc.a, arc.b, arc.name)))
        facts.append(Atom("arc", (arc.b, arc.a, arc.name)))
    return facts


AREAS = DomainInfo(
    areas_domain,
    argument_kinds={"goto": ("node",), "goto_node": ("node",), "move_area": ("area", "area")},
    robot_moves=frozenset(),
)
"""``museum.areas``: its tasks and actions name nodes and areas; the robot does none of its actions."""

NODES = DomainInfo(
    nodes_domain,
    argument_kinds={"goto_node": ("node",), "move_area": ("area", "area")},
    robot_moves=frozenset({"move"}),
)
"""``museum.nodes``: ``move(From,To,Arc)`` is the robot's; its tasks name nodes and areas."""
