"""A plan of a translated HDDL problem in the IPC's terms: its HDDL actions, and the
decompositions the IPC plan format lists, without what the translation added
(:mod:`htnagent.planning.hddl_translation`: the ``__top``, ``__goal`` and ``__partK``
tasks, the ``__done`` marker).
"""

from __future__ import annotations

import itertools

from htnagent.hddl.plan_file import IpcDecomposition, IpcPlan, IpcStep
from htnagent.model.plans import Decomposition, Plan
from htnagent.model.terms import Atom
from htnagent.planning.hddl_translation import GOAL, MARKERS, PART, TOP


def actions_of(plan: Plan) -> list[Atom]:
    """The plan's HDDL actions, in order (the translation's markers left out)."""
    return [s.action for s in plan.steps if s.action.name not in MARKERS]


def ipc_plan(plan: Plan) -> IpcPlan:
    """The plan in the IPC format's terms: its actions, the initial task network's tasks
    (``root``) and each decomposed task with its method and subtasks, in order.

    The plan's steps carry their decomposition records (docs/design.md §1): the tree is
    read off them.  A record's subtasks are, in order, the steps and records whose parent
    it is, as they first appear along the plan (HDDL's methods are totally ordered).
    """
    ids: dict[int, int] = {}  # id(record) -> plan id
    records: list[Decomposition] = []
    children: dict[int, list[int]] = {}
    steps: list[IpcStep] = []
    top: Decomposition | None = None
    next_id = itertools.count()
    for s in plan.steps:
        if s.action.name not in MARKERS:
            steps.append(IpcStep(next(next_id), s.action))
    # Records get ids after the actions; walk each step's chain of records up to the top.
    n = 0
    for s in plan.steps:
        own: int | None = None
        if s.action.name not in MARKERS:
            own = steps[n].id
            n += 1
        record = s.record
        child = own
        while record is not None:
            if record.task.name == TOP:
                top = record
            known = id(record) in ids
            if not known:
                # The translation's own tasks are not in the plan: they take no ID.
                hidden = _hidden(record.task)
                ids[id(record)] = -1 - len(ids) if hidden else next(next_id)
                records.append(record)
                children[id(record)] = []
            if child is not None and child not in children[id(record)]:
                children[id(record)].append(child)
            if known:
                break
            child = ids[id(record)]
            record = record.parent
    # A part of the network (a stretch binding its open parameters) is its tasks in the root.
    inner = {ids[id(r)]: children[id(r)] for r in records if r.task.name.startswith(PART)}

    def shown(kids: list[int]) -> tuple[int, ...]:
        return tuple(k for kid in kids for k in (shown(inner[kid]) if kid in inner else (kid,)))

    root: tuple[int, ...] = shown(children[id(top)]) if top is not None else ()
    decompositions = tuple(
        IpcDecomposition(ids[id(r)], r.task, r.method, tuple(children[id(r)]))
        for r in records
        if not _hidden(r.task)
    )
    return IpcPlan("<plan>", tuple(steps), root, decompositions)


def _hidden(task: Atom) -> bool:
    """Whether ``task`` is one the translation added (no HDDL task: not in an IPC plan)."""
    return task.name in (TOP, GOAL) or task.name.startswith(PART)


__all__ = ["actions_of", "ipc_plan"]
