"""Plans as values: the steps, their cost, and the decomposition record.

Every step of a plan remembers which compound task (and which of its methods)
produced it, through a chain of :class:`Decomposition` records up to the goal.
Plan repair (docs/design.md §2.4) walks that chain.  Steps inserted by plan
maintenance — ``resume``/``rollback``/undo actions — belong to no compound task
and have no record.  :func:`replay` checks a plan against a belief; :func:`tidy`
is the tidy-up of docs/design.md §2.6.
"""

from __future__ import annotations

from collections.abc import Iterable, Sequence
from dataclasses import dataclass, field
from typing import NamedTuple

from htnagent.model.actions import ROLLBACK, action_rolled_back_by
from htnagent.model.domain import Domain
from htnagent.model.state import State
from htnagent.model.terms import Atom


@dataclass(frozen=True, slots=True, eq=False)
class Decomposition:
    """One link of a decomposition record: ``task`` was decomposed by ``method``.

    Records compare by identity: two equal tasks decomposed at two places are two
    records.
    """

    task: Atom
    method: str
    parent: Decomposition | None

    def chain(self) -> list[Decomposition]:
        """This record and its ancestors, lowest first."""
        out: list[Decomposition] = []
        node: Decomposition | None = self
        while node is not None:
            out.append(node)
            node = node.parent
        return out


@dataclass(frozen=True, slots=True)
class Step:
    """One action of a plan, its cost, and the record of the task that produced it."""

    action: Atom
    cost: float
    record: Decomposition | None = None
    _text: str | None = field(default=None, init=False, repr=False, compare=False)

    def __str__(self) -> str:
        # Kept: the steps of a plan are shared by the plans that follow it, and a plan is
        # shown (plan_selected) each time it changes.
        if self._text is None:
            object.__setattr__(self, "_text", str(self.action))
        assert self._text is not None
        return self._text


@dataclass(frozen=True, slots=True)
class Plan:
    """A totally ordered sequence of steps and their total cost."""

    steps: tuple[Step, ...]
    _cost: float | None = field(default=None, init=False, repr=False, compare=False)
    _actions: tuple[Atom, ...] | None = field(default=None, init=False, repr=False, compare=False)
    _shown: tuple[str, ...] | None = field(default=None, init=False, repr=False, compare=False)
    _later: tuple[Atom, ...] | None = field(default=None, init=False, repr=False, compare=False)

    @property
    def cost(self) -> float:
        """The sum of the step costs (worked out once: plans are sorted by it often)."""
        if self._cost is None:
            object.__setattr__(self, "_cost", sum(s.cost for s in self.steps))
        assert self._cost is not None
        return self._cost

    @property
    def actions(self) -> tuple[Atom, ...]:
        """The actions, in order (worked out once)."""
        if self._actions is None:
            object.__setattr__(self, "_actions", tuple(s.action for s in self.steps))
        assert self._actions is not None
        return self._actions

    @property
    def later_actions(self) -> tuple[Atom, ...]:
        """The actions after the first (worked out once, and the very actions of :meth:`rest`:
        what is left to do is then known unchanged by identity)."""
        if self._later is None:
            object.__setattr__(self, "_later", self.actions[1:])
        assert self._later is not None
        return self._later

    def rest(self) -> Plan:
        """The plan without its first step (once that step is done), keeping what was
        worked out of it: its actions and text, sliced, are not walked again."""
        rest = Plan(self.steps[1:])
        if self._actions is not None:
            object.__setattr__(rest, "_actions", self.later_actions)
        if self._shown is not None:
            object.__setattr__(rest, "_shown", self._shown[1:])
        return rest

    def text(self) -> list[str]:
        """The actions in the text form of docs/contracts.md."""
        return list(self.shown)

    @property
    def shown(self) -> tuple[str, ...]:
        """:meth:`text` as a tuple, worked out once (a plan is shown when it is selected;
        a resumption made ready ahead shows its plan without walking it again)."""
        if self._shown is None:
            object.__setattr__(self, "_shown", tuple(str(s) for s in self.steps))
        assert self._shown is not None
        return self._shown

    def __len__(self) -> int:
        return len(self.steps)

    def __bool__(self) -> bool:
        return True

    def __str__(self) -> str:
        return "[" + ", ".join(self.shown) + f"] cost {self.cost:g}"


class Done(NamedTuple):
    """The steps a goal has carried out, newest first, as a linked list.

    A link per step, so that adding one is O(1) and a plan set's forks share what
    came before.  Repair reads it to find the subtasks of a method already done
    (:func:`htnagent.upkeep.repair.done_subtasks`).  A named tuple: one is made at
    every action a goal's plan takes.
    """

    step: Step
    before: Done | None


def span(steps: Sequence[Step], record: Decomposition) -> tuple[int, int]:
    """The first and last index of the steps that ``record``'s task produced (-1, -1 if none)."""
    start = end = -1
    for i, s in enumerate(steps):
        node = s.record
        while node is not None:
            if node is record:
                if start < 0:
                    start = i
                end = i
                break
            node = node.parent
    return start, end


def replay(domain: Domain, state: State, actions: Iterable[Atom]) -> State | None:
    """The state after all the actions, or None if one of them is not applicable."""
    current: State | None = state
    apply = domain.actions.apply
    for a in actions:
        assert current is not None
        current = apply(current, a)
        if current is None:
            return None
    return current


def tidy(domain: Domain, steps: Sequence[Step], *, front: bool = False) -> tuple[Step, ...]:
    """Apply the tidy-up rules of docs/design.md §2.6 until none applies.

    - an action directly followed by its own undo: both go;
    - ``rollback(A)`` directly followed by ``A``: they become ``resume(A)``.

    With ``front`` only the first step is new and the rest is known tidy: the
    rules are applied where they meet, in constant time.
    """
    if front:
        # The new first step meets the tidy rest once: a cancelled pair leaves a rest that
        # was already tidy, and resume(A) takes part in neither rule.
        if len(steps) < 2:
            return tuple(steps)
        return (*tidy(domain, steps[:2]), *steps[2:])
    actions = domain.actions
    undo_of = actions.undo_of
    rollback = ROLLBACK
    out: list[Step] = []
    for step in steps:
        if out:
            prev = out[-1].action
            # §2.6: an action directly followed by its own undo vanishes with it.
            if undo_of(prev) == step.action:
                out.pop()
                continue
            # §2.6: rollback(A) directly followed by A is resume(A).
            if prev.name == rollback and action_rolled_back_by(prev) == step.action:
                resume = actions.resume_of(step.action)
                if resume is not None:
                    out[-1] = Step(resume, actions.cost(resume), step.record)
                    continue
        out.append(step)
    return tuple(out)
