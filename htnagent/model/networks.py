"""A task network as one goal: an ordered list of tasks planned as one whole.

docs/design.md §4 ("A goal may be a task network"): a network is one goal in everything
the agent does -- one entry on the waiting list or the stack, one set of kept plans.
So that the agent, plan upkeep and the planner need nothing new, a network is the
compound task ``tasks(t1,...,tn)`` whose one method does ``t1 … tn`` in order.  Its
text form names it by its tasks (docs/contracts.md), and its decomposition record
has the network at the top, so repair (docs/design.md §2.4) walks up to one of its tasks and
re-plans that task plus what follows it -- the rest of the network included -- and
re-plans the whole network only when no task below can be decomposed again.
"""

from __future__ import annotations

from collections.abc import Sequence

from htnagent.errors import DomainError
from htnagent.model.domain import Domain
from htnagent.model.terms import Atom

__all__ = ["NETWORK", "NETWORK_METHOD", "is_network", "network_task"]

NETWORK = "tasks"
"""The name of a network's compound task: ``tasks(t1,...,tn)``."""
NETWORK_METHOD = "network"
"""The name of its one method (what a decomposition record shows under it)."""


def is_network(task: Atom) -> bool:
    """Whether ``task`` is a task network made by :func:`network_task`."""
    return task.name == NETWORK and bool(task.args) and all(isinstance(a, Atom) for a in task.args)


def network_task(domain: Domain, tasks: Sequence[Atom]) -> Atom:
    """The compound task ``tasks(t1,...,tn)`` of ``domain`` that does ``tasks`` in order.

    Its method is added to ``domain`` the first time (later calls with the same tasks give
    the same task).  Each task must be one the domain knows; DomainError for an empty
    network, an unknown task, or a domain that has a task of its own named ``tasks``.
    """
    if not tasks:
        raise DomainError(f"domain {domain.name}: a task network needs at least one task")
    for t in tasks:
        if not domain.knows(t):
            raise DomainError(f"domain {domain.name} has no operator or method for {t}")
    head = Atom(NETWORK, tuple(tasks))
    if NETWORK in domain.operators or any(m.name != NETWORK_METHOD for m in domain.methods.get(NETWORK, ())):
        raise DomainError(
            f"domain {domain.name} has a task of its own named {NETWORK}: a task network cannot be named"
        )
    if not any(m.head == head for m in domain.methods.get(NETWORK, ())):
        # Atoms, not text: a task without arguments (``__goal``) reads back as a constant.
        domain.method(head, NETWORK_METHOD, do=tasks)
    return head
