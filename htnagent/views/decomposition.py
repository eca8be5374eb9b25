"""A plan's decomposition tree, as SHOP and GTPyhop users read it (``plan --tree``).

Each compound task is shown with the method that decomposed it and, indented under it,
its subtasks in order; the actions are the leaves, numbered as in the plan.  The tree is
read off the plan's decomposition records (:class:`~htnagent.model.plans.Decomposition`,
docs/design.md §1) or, for an HDDL problem, off its plan in the IPC format's terms
(:class:`~htnagent.hddl.plan_file.IpcPlan`).  Only what produced an action is there: a
subtask whose method had no subtasks leaves no trace in the plan's records.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Any

from htnagent.hddl.plan_file import IpcDecomposition, IpcPlan, IpcStep
from htnagent.model.plans import Decomposition, Plan

__all__ = ["Action", "Decomposed", "hddl_tree", "plan_tree", "tree_json", "tree_lines"]


@dataclass(frozen=True, slots=True)
class Action:
    """A leaf: the plan's ``number``-th action (from 1)."""

    number: int
    action: str


@dataclass(frozen=True, slots=True)
class Decomposed:
    """A compound ``task`` decomposed by ``method`` into ``subtasks``, in order."""

    task: str
    method: str
    subtasks: tuple[Decomposed | Action, ...]


Tree = tuple[Decomposed | Action, ...]
"""The tasks given (or an HDDL problem's initial task network), each as its subtree."""


def plan_tree(plan: Plan) -> Tree:
    """The decomposition tree of a plan made by :func:`~htnagent.planning.planner.plan`.

    A step with no record (a ``resume`` or ``rollback`` put in front by plan upkeep)
    is a leaf at the top.
    """
    children: dict[int, list[Decomposition | Action]] = {}
    top: list[Decomposition | Action] = []
    for number, step in enumerate(plan.steps, start=1):
        node: Decomposition | Action = Action(number, str(step))
        record = step.record
        while record is not None:
            known = id(record) in children
            kids = children.setdefault(id(record), [])
            if not kids or kids[-1] is not node:
                kids.append(node)
            if known:
                break
            node, record = record, record.parent
        else:
            if not top or top[-1] is not node:
                top.append(node)

    def built(node: Decomposition | Action) -> Decomposed | Action:
        if isinstance(node, Action):
            return node
        return Decomposed(str(node.task), node.method, tuple(built(n) for n in children[id(node)]))

    return tuple(built(n) for n in top)


def hddl_tree(plan: IpcPlan, spell: Callable[[str, Sequence[object]], str]) -> Tree:
    """The decomposition tree of an HDDL plan; ``spell(name, args)`` writes a task or action
    as the HDDL files do."""
    steps: dict[int, tuple[int, IpcStep]] = {s.id: (n, s) for n, s in enumerate(plan.steps, start=1)}
    decomposed: dict[int, IpcDecomposition] = {d.id: d for d in plan.decompositions}

    def built(ids: Sequence[int]) -> Tree:
        out: list[Decomposed | Action] = []
        for i in ids:
            if i in steps:
                number, step = steps[i]
                out.append(Action(number, spell(step.action.name, step.action.args)))
            elif i in decomposed:
                d = decomposed[i]
                out.append(
                    Decomposed(spell(d.task.name, d.task.args), spell(d.method, ()), built(d.subtasks))
                )
        return tuple(out)

    return built(plan.root)


def tree_lines(tree: Tree, indent: str = "  ") -> list[str]:
    """The tree as text: ``task -> method``, its subtasks indented under it; actions numbered."""
    width = len(str(max(_numbers(tree), default=1)))
    lines: list[str] = []

    def add(nodes: Tree, depth: int) -> None:
        for node in nodes:
            if isinstance(node, Action):
                lines.append(f"{indent * depth}{node.number:>{width}}. {node.action}")
            else:
                lines.append(f"{indent * depth}{node.task} -> {node.method}")
                add(node.subtasks, depth + 1)

    add(tree, 0)
    return lines


def tree_json(tree: Tree) -> list[Any]:
    """The tree as JSON: an action is its text, a decomposed task
    ``{"task", "method", "subtasks"}``."""

    def one(node: Decomposed | Action) -> Any:
        if isinstance(node, Action):
            return node.action
        return {"task": node.task, "method": node.method, "subtasks": [one(n) for n in node.subtasks]}

    return [one(n) for n in tree]


def _numbers(tree: Tree) -> list[int]:
    out: list[int] = []
    for node in tree:
        out += [node.number] if isinstance(node, Action) else _numbers(node.subtasks)
    return out
