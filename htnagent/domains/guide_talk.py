"""The guide robot talks: it explains exhibits, answers guests, greets visitors.

The published paper's other museum situations, beside the walk of §6: the
guide explaining an exhibit is interrupted by a guest's question, answers it
and then finishes the explanation where it stopped; a visitor who arrives must
be greeted at once, whatever the guide is doing.

Use it in a scenario as ``domain: htnagent.domains.guide_talk:talk_domain``,
for one agent executing on the robot, and give the robot the time each spoken
action takes (``robot.durations``; see ``scenarios/explain_question.yaml`` and
``scenarios/greeting.yaml``).  The domain is the navigator's
(:func:`~htnagent.domains.museum.nodes_domain`: ``goto_node(N)``, suspendable
``move``) plus:

- ``explain(E)`` — the action of explaining exhibit E, standing at its node.
  Suspendable: stopped half way it leaves ``explaining(E)``, and
  ``resume(explain(E))`` says the rest (costed at half), standing at the exhibit
  again — the robot walks back first if it was taken away.  While that half is
  kept, ``explain(E)`` cannot start again: a suspended explanation is never
  restarted; once the half is cleared (``explaining(E)`` only records that it
  can be resumed), it can.
- ``present(E)`` — walk to E's node, then explain E (nothing, once E is explained).
- ``answer(G)`` — answer guest G's question (typically an emergency goal).
- ``greet(V)`` — greet visitor V (an emergency goal); not suspendable: a
  greeting is never stopped half way.

Exhibits stand at nodes of the museum map (:data:`EXHIBITS`); those whose node
is not on the scenario's map are left out.
"""

from __future__ import annotations

from htnagent.domains import domain_factory
from htnagent.domains.maps import WorldMap
from htnagent.domains.museum import NODES, nodes_domain
from htnagent.model.domain import Domain, Effect, Suspension
from htnagent.model.terms import Atom

EXHIBITS: dict[str, str] = {
    "statue": "n4",
    "fresco": "n12",
    "mosaic": "n28",
    "vase": "n38",
}
"""Exhibit → the node it stands at, on ``scenarios/museum_map.yaml``."""

EXPLAIN_COST = 10.0
"""The planner's cost of a whole explanation (resuming one costs half)."""


# Walking is the navigator's: the same arguments name the map, and move is the robot's.
@domain_factory(argument_kinds=NODES.argument_kinds, robot_moves=NODES.robot_moves)
def talk_domain(world: WorldMap) -> Domain:
    """The guide robot's domain: walking over the nodes of ``world``, and talking."""
    d = nodes_domain(world)
    d.name = "guide_talk"
    d.facts = tuple(Atom("exhibit", (e, n)) for e, n in EXHIBITS.items() if n in world.nodes)
    d.operator(
        "explain(?e)",
        pre=["at(?n)", "exhibit(?e,?n)", "not explaining(?e)"],
        add=["explained(?e)"],
        cost=EXPLAIN_COST,
        suspend=Suspension(
            add=("explaining(?e)",),
            cleared=("explaining(?e)",),
            # The rest of an explanation is said at the exhibit, nowhere else.
            resume=Effect(
                pre=("explaining(?e)", "at(?n)", "exhibit(?e,?n)"),
                add=("explained(?e)",),
                delete=("explaining(?e)",),
                cost=EXPLAIN_COST / 2,
            ),
        ),
    )
    d.operator("answer(?g)", add=["answered(?g)"], cost=1.0)
    d.operator("greet(?v)", add=["greeted(?v)"], cost=1.0)
    # "Already explained" lets a plan made from scratch after resume(explain(E)) end there.
    d.method("present(?e)", "already_explained", when=["explained(?e)"], do=[])
    # An explanation stopped half way is finished where it was stopped: walk back to the
    # exhibit (nothing to walk when the robot is still there), then say the rest.
    d.method(
        "present(?e)",
        "finish_explaining",
        when=["explaining(?e)", "exhibit(?e,?n)"],
        do=["goto_node(?n)", "resume(explain(?e))"],
    )
    d.method(
        "present(?e)",
        "walk_and_explain",
        when=["exhibit(?e,?n)", "not explained(?e)"],
        do=["goto_node(?n)", "explain(?e)"],
    )
    return d
