"""The tour host: a third planning agent above the guide (``scenarios/four_emergencies.yaml``).

The host plans visits: ``visit(N)`` is the guide's ``goto(N)``, which the guide
carries out through the navigator and the robot.  ``goto(N)`` can be suspended
half way (the host notes ``going(N)``) and resumed, so that emergencies given to
the host nest down the whole chain: host → guide → navigator → robot.
"""

from __future__ import annotations

from htnagent.domains import domain_factory
from htnagent.domains.maps import WorldMap
from htnagent.model.domain import Domain, Effect, Suspension
from htnagent.model.terms import Atom


@domain_factory(argument_kinds={"visit": ("node",), "goto": ("node",)})
def host_domain(world: WorldMap) -> Domain:
    """Visits of the nodes of ``world``, each one order to the guide."""
    d = Domain("tour.host")
    d.operator(
        "goto(?n)",
        add=["visited(?n)"],
        cost=1.0,
        suspend=Suspension(
            add=("going(?n)",),
            cleared=("going(?n)",),
            resume=Effect(pre=("going(?n)",), add=("visited(?n)",), delete=("going(?n)",), cost=0.5),
        ),
    )
    d.method("visit(?n)", "go", do=["goto(?n)"])
    # The tour starts where the robot stands: that node counts as visited.
    d.world_facts = lambda start: [Atom("visited", (start,))]
    return d
