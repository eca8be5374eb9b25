"""A unified-planning ``HierarchicalPlan`` in the IPC plan format, so that a bench verifies a
peer planner's plan as it verifies ours (``bench/ipc_peer.py`` runs Aries through
unified-planning and writes its plan with :func:`ipc_plan`).

Nothing here imports unified-planning: its objects are read by the attributes they have
(``action_plan``, ``decomposition.subtasks``, a method's ``achieved_task`` and
``total_order()``), so that the writer is tested without the ``peers`` extra.  The text
is :func:`htnagent.hddl.plan_file.format_plan`'s, as ``plan --format ipc`` writes ours.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

from htnagent.hddl.plan_file import IpcDecomposition, IpcPlan, IpcStep, format_plan
from htnagent.model.terms import Atom

__all__ = ["flat_actions", "ipc_plan"]


def flat_actions(plan: Any) -> list[Any]:
    """The plan's primitive actions in execution order (Aries returns an empty plan as a
    ``TimeTriggeredPlan``, the others as a ``SequentialPlan``)."""
    flat = getattr(plan, "action_plan", plan)
    if hasattr(flat, "timed_actions"):
        return [a for _, a, _ in sorted(flat.timed_actions, key=lambda timed: timed[0])]
    return list(flat.actions)


def _arg(node: Any) -> str:
    return str(node.object().name if node.is_object_exp() else node)


def _order(network: Any) -> list[str]:
    total = network.total_order()
    return list(total) if total is not None else [s.identifier for s in network.subtasks]


def ipc_plan(problem: Any, plan: Any, spelling: Mapping[str, str]) -> str:
    """The ``HierarchicalPlan`` of ``problem`` in the IPC 2020 plan format: its flat plan
    for the actions and their order, its decomposition for the rest; ``spelling`` gives the
    names as the HDDL files write them (unified-planning lower-cases what it reads)."""
    actions = flat_actions(plan)
    ids = {id(a): i for i, a in enumerate(actions)}
    steps = tuple(
        IpcStep(i, Atom(a.action.name, tuple(map(_arg, a.actual_parameters)))) for i, a in enumerate(actions)
    )
    decompositions: list[IpcDecomposition] = []
    next_id = len(actions)

    def number(node: Any) -> int:
        nonlocal next_id
        if id(node) in ids:  # an action of the flat plan
            return ids[id(node)]
        method = node.method
        binding = {p.name: v for p, v in zip(method.parameters, node.parameters, strict=True)}
        task = method.achieved_task
        me = next_id
        next_id += 1
        subtasks = node.decomposition.subtasks
        children = tuple(number(subtasks[ident]) for ident in _order(method) if ident in subtasks)
        atom = Atom(task.task.name, tuple(_arg(binding[p.name]) for p in task.parameters))
        decompositions.append(IpcDecomposition(me, atom, method.name, children))
        return me

    top = plan.decomposition.subtasks
    root = tuple(number(top[ident]) for ident in _order(problem.task_network) if ident in top)
    decompositions.sort(key=lambda d: d.id)
    return format_plan(IpcPlan("<plan>", steps, root, tuple(decompositions)), spelling)
