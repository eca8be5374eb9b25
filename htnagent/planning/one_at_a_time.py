"""A plan made cheaper one task of its network at a time (docs/design.md §7.6).

A plan for a network of tasks done in order is a plan for each of them in turn, each from
where the ones before it left the world.  A search of the whole network weighs every task's
choices against every other's; its first plan, from a greedy search, is often far from the
cheapest (Logistics' 18-1: 4,277 actions, where the cheapest has 242).  Each task alone is a
small search: A* finds its cheapest plan at once (Logistics: a few thousand nodes a package).

:func:`cheaper_one_at_a_time` takes the network's tasks in order.  For each, from the state
the new plan has reached, A* plans that task alone; where A* runs out of its share of the
time, the task keeps its old plan if the state is still the one it was planned from, else
greedy search plans it.  The tasks after it are passed to the search as tasks that follow
(:func:`~htnagent.planning.planner.plan`'s ``then``): they are not planned, but the goal's
check (§7.3) sees them, so that a task's cheapest plan does not undo a goal fact that no
later task can bring back.  The new plan is the old one's only if cheaper in all.

Each task's cheapest plan is not always the cheapest for the ones after it (Barman: a shaker
left dirty costs the next cocktail more), so the result can be dearer than the plan given:
then it is not taken.
"""

from __future__ import annotations

import dataclasses
import itertools
from collections.abc import Sequence
from dataclasses import dataclass
from enum import Enum
from time import perf_counter
from typing import NamedTuple

from htnagent.model.domain import Domain
from htnagent.model.plans import Decomposition, Plan, Step
from htnagent.model.state import State
from htnagent.model.terms import Atom
from htnagent.planning.goal_support import checks_goal
from htnagent.planning.planner import PlannerSettings, Progress, Search, plan, searches_stopped


class Outcome(Enum):
    """How :func:`cheaper_one_at_a_time` ended."""

    CHEAPER = "cheaper"
    """Every part was planned, and the plan costs less than the one given."""
    NOT_CHEAPER = "not cheaper"
    """Every part was planned, and the plan costs no less than the one given."""
    ONE_PART = "one part"
    """Only one part costs anything: it is the whole problem, which A* plans next."""
    NO_PLAN = "no plan"
    """From where the parts before it had changed the world, a part had no plan found."""
    STOPPED = "stopped"
    """The searches were told to stop (a signal) or ran out of their budget."""
    OUT_OF_TIME = "out of time"
    """The time ran out where the parts before had changed the world, and so did the time
    as long again that greedy search had to finish: the rest has no plan.  (Where they had
    not, the whole is the old plan: :attr:`NOT_CHEAPER`.)"""


class Cheaper(NamedTuple):
    """What :func:`cheaper_one_at_a_time` found: how it ended, the cheaper plan (with
    :attr:`Outcome.CHEAPER`), and the expansions of its searches."""

    outcome: Outcome
    plan: Plan | None
    expansions: int


Later = tuple[tuple[Atom, Decomposition | None], ...]
"""The tasks after a part, with their records: they follow it in its search, not planned."""


@dataclass(frozen=True, slots=True)
class Part:
    """One task of the network and the steps of the plan that do it."""

    task: Atom
    parent: Decomposition | None
    """The record the task was decomposed under (None: a task of the list the plan was
    made for, as the problem's ``__goal``, or a step with no record)."""
    steps: tuple[Step, ...]
    record: Decomposition | None
    """The task's own record (None: the task is an action, the one step)."""

    @property
    def cost(self) -> float:
        return sum(s.cost for s in self.steps)


def parts_of(plan: Plan, top: str) -> list[Part]:
    """The plan cut into its network's tasks, in order: the tasks decomposed by the record
    of the task named ``top`` (an HDDL problem's ``__top``), and the tasks of the list
    planned that are not below it.  Where only one of them costs anything, its own
    subtasks take its place, and so on down: a network of one task is cut as that task's
    method."""
    under = next((r for s in plan.steps if s.record for r in s.record.chain() if r.task.name == top), None)
    parts = _cut(plan.steps, under)
    while True:
        costly = [i for i, p in enumerate(parts) if p.cost > 0]
        if len(costly) != 1 or parts[costly[0]].record is None:
            return parts
        alone = parts[costly[0]]
        parts[costly[0] : costly[0] + 1] = _cut(alone.steps, alone.record)


def _cut(steps: Sequence[Step], under: Decomposition | None) -> list[Part]:
    """The steps cut at the tasks decomposed by the record ``under``; a step outside it, at
    the highest record of its own (or alone, with none)."""
    parts: list[Part] = []
    gathered: list[Step] = []  # the steps of the last part, which may go on
    for s in steps:
        own = _part_record(s, under)
        if parts and own is not None and parts[-1].record is own:
            gathered.append(s)
            continue
        if parts:
            parts[-1] = dataclasses.replace(parts[-1], steps=tuple(gathered))
        gathered = [s]
        if own is None:
            parts.append(Part(s.action, s.record, (), None))  # an action of the method itself
        else:
            parts.append(Part(own.task, own.parent, (), own))
    if parts:
        parts[-1] = dataclasses.replace(parts[-1], steps=tuple(gathered))
    return parts


def _part_record(step: Step, under: Decomposition | None) -> Decomposition | None:
    """The record of the part ``step`` belongs to when the steps are cut under ``under``:
    the one just below ``under`` in its chain (the highest, where ``under`` is not in it);
    None where the step is an action of ``under``'s method itself, or has no record."""
    if step.record is under:
        return None
    record = step.record
    own = None
    while record is not None:
        own = record
        if under is not None and record.parent is under:
            break
        record = record.parent
    return own


def cheaper_one_at_a_time(
    domain: Domain,
    state: State,
    given: Plan,
    top: str,
    *,
    time_limit: float | None,
    budget: int,
    grounded: PlannerSettings | None = None,
    progress: Progress | None = None,
) -> Cheaper:
    """A plan cheaper than ``given``, found by planning each of its network's tasks
    (:func:`parts_of`) alone in turn, if there is one.  Within about ``time_limit`` seconds,
    each task with an equal share of what is left when its turn comes, and ``budget``
    expansions in all.  With ``grounded`` (a grounded search's settings, design §7.2), the
    searches decompose by its ground methods, with its estimate and dead-end test.
    ``progress`` hears the expansions of all the searches so far (see
    :func:`~htnagent.planning.planner.plan`)."""
    parts = parts_of(given, top)
    if sum(p.cost > 0 for p in parts) < 2:
        return Cheaper(Outcome.ONE_PART, None, 0)
    now = perf_counter()
    # Past its time with the world changed, the step may take as long again, by greedy
    # search alone, to finish the plan it has begun: the parts searched so far are not lost
    # for the last few.
    deadlines = None if time_limit is None else (now + time_limit, now + 2 * time_limit)
    turns = _Turns(domain, parts, deadlines, budget, grounded, progress)
    outcome, steps = turns.run(state)
    if outcome is Outcome.CHEAPER:
        found = Plan(steps)
        if found.cost < given.cost:
            return Cheaper(Outcome.CHEAPER, found, turns.spent)
        outcome = Outcome.NOT_CHEAPER
    return Cheaper(outcome, None, turns.spent)


class _Turns:
    """The parts planned in turn (design §7.6, steps 2 and 3)."""

    def __init__(
        self,
        domain: Domain,
        parts: list[Part],
        deadlines: tuple[float, float] | None,
        budget: int,
        grounded: PlannerSettings | None,
        progress: Progress | None,
    ) -> None:
        self.domain = domain
        self.parts = parts
        self.deadlines = deadlines  # (the step's time, the most it may take to finish)
        self.late = False  # past the step's time: greedy search only
        self.budget = budget
        self.grounded = grounded
        self.progress = progress
        # Step 3: where the goal is checked at the end, the parts after each follow it.
        self.follow = checks_goal(domain, [p.task for p in parts])
        self.tasks: Later = tuple((p.task, p.parent) for p in parts)
        # The least cost of the parts' tasks from each one on (a bound counts those after).
        costs = domain.task_costs or {}
        least = [costs.get(p.task.name, 0.0) for p in parts]
        self.least_from = [*reversed([0.0, *itertools.accumulate(reversed(least))])]
        self.spent = 0
        self.exhausted = False  # the last search saw every node under its bound

    def run(self, state: State) -> tuple[Outcome, tuple[Step, ...]]:
        """Each part's steps in turn, from ``state``: :attr:`Outcome.CHEAPER` with all the
        steps where every part has some (cheaper or not: :func:`cheaper_one_at_a_time`
        compares), else why not.  Once the time is up: the old plan where nothing has
        changed, else greedy search alone for the parts left, for as long again at most."""
        steps: list[Step] = []
        unchanged = True  # the state is still the one the given plan had reached here
        for i, part in enumerate(self.parts):
            if searches_stopped() or self.spent >= self.budget:
                return Outcome.STOPPED, ()  # a signal: the command ends with the plans told
            if self.deadlines is not None and perf_counter() >= self.deadlines[0]:
                if unchanged:
                    return Outcome.NOT_CHEAPER, ()  # (the rest is the old plan's: the whole is)
                if perf_counter() >= self.deadlines[1]:
                    return Outcome.OUT_OF_TIME, ()
                self.late = True
            done = self._turn(i, part, state, unchanged)
            if done is None:
                return Outcome.NO_PLAN, ()
            unchanged = unchanged and done is part.steps
            for s in done:
                # (Of an action's variants -- an HDDL `or`, a `when` -- the one that holds.)
                state = self.domain.actions.progress(state, s.action)
            steps.extend(done)
        return Outcome.CHEAPER, tuple(steps)

    def _turn(self, i: int, part: Part, state: State, unchanged: bool) -> tuple[Step, ...] | None:
        """Step 2: the part's cheapest plan from ``state``, else its old one where the state
        is unchanged, else greedy search's; None if there is none of these."""
        if unchanged and part.cost <= 0:
            return part.steps  # nothing costs less than nothing
        later = self.tasks[i + 1 :] if self.follow else ()
        if unchanged:
            # The old plan is still good here: only a cheaper one is wanted.
            at_most = part.cost + (self.least_from[i + 1] if self.follow else 0.0)
            cheapest = self._search(part, state, later, Search.ASTAR, self._share(i), at_most)
            return part.steps if cheapest is None else cheapest
        if not self.late:
            cheapest = self._search(part, state, later, Search.ASTAR, self._share(i), None)
            if cheapest is not None or self.exhausted:
                return cheapest  # (A* saw every node: no plan from here)
        return self._search(part, state, later, Search.GBFS, self._share(i), None)

    def _share(self, i: int) -> float | None:
        """The seconds for the search of part ``i``: what is left shared by the parts left."""
        if self.deadlines is None:
            return None
        until = self.deadlines[1] if self.late else self.deadlines[0]
        return max((until - perf_counter()) / (len(self.parts) - i), 1e-3)

    def _search(
        self,
        part: Part,
        state: State,
        later: Later,
        order: Search,
        seconds: float | None,
        at_most: float | None,
    ) -> tuple[Step, ...] | None:
        """The steps of a plan of the part's task by ``order`` (A*: the cheapest), under
        ``at_most`` if given; None if none is found in time."""
        grounded = self.grounded
        settings = PlannerSettings(
            alternatives=1,
            budget=max(self.budget - self.spent, 1),
            search=order,
            time_limit=seconds,
            cost_bound=at_most,
            guide=None if grounded is None else grounded.guide,
            decompositions=None if grounded is None else grounded.decompositions,
            prune=None if grounded is None else grounded.prune,
        )
        before, progress = self.spent, self.progress
        told = None if progress is None else (lambda n, t: progress(before + n, t))
        found = plan(
            self.domain, state, [(part.task, part.parent)], settings, recover=False, progress=told, then=later
        )
        self.spent += found.expansions
        self.exhausted = found.exhausted
        return None if found.best is None else found.best.steps


__all__ = ["Cheaper", "Outcome", "Part", "cheaper_one_at_a_time", "parts_of"]
