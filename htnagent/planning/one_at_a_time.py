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

import time
from dataclasses import dataclass
from typing import NamedTuple

from htnagent.model.domain import Domain
from htnagent.model.plans import Decomposition, Plan, Step, replay
from htnagent.model.state import State
from htnagent.model.terms import Atom
from htnagent.planning.goal_support import checks_goal
from htnagent.planning.planner import PlannerSettings, Progress, Search, plan, searches_stopped


class Cheaper(NamedTuple):
    """What :func:`cheaper_one_at_a_time` found: a cheaper plan, if any, and the expansions
    of its searches."""

    plan: Plan | None
    expansions: int


Later = tuple[tuple[Atom, Decomposition | None], ...]
"""The tasks after a part, with their records: they follow it in its search, not planned."""


@dataclass(frozen=True, slots=True)
class Part:
    """One task of the network and the steps of the plan that do it."""

    task: Atom
    parent: Decomposition | None
    """The record the task was decomposed under (None: a task of the list planned)."""
    steps: tuple[Step, ...]
    record: Decomposition | None
    """The task's own record (None: the task is an action, the one step)."""

    @property
    def cost(self) -> float:
        return sum(s.cost for s in self.steps)


def parts_of(plan: Plan, top: str) -> list[Part]:
    """The plan cut into its network's tasks, in order: the tasks decomposed by the record
    of the task named ``top`` (an HDDL problem's ``__top``), and the tasks of the list
    planned that are not below it.  Where only one of them costs anything, its own subtasks
    in its place, and so on down: a network of one task is cut as that task's method."""
    under = next((r for s in plan.steps if s.record for r in s.record.chain() if r.task.name == top), None)
    parts = _cut(plan, under)
    while True:
        costly = [p for p in parts if p.cost > 0]
        if len(costly) != 1 or costly[0].record is None:
            return parts
        parts = _cut(plan, costly[0].record)


def _cut(plan: Plan, under: Decomposition | None) -> list[Part]:
    """The plan cut at the tasks decomposed by the record ``under``; a step outside it, at
    the highest record of its own (or alone, with none)."""
    cut: list[tuple[Atom, Decomposition | None, list[Step], Decomposition | None]] = []
    for s in plan.steps:
        task: Atom = s.action
        parent: Decomposition | None = None
        own: Decomposition | None = None  # the part's record
        if s.record is not None and s.record is under:
            parent = under  # an action of the method itself
        else:
            record = s.record
            while record is not None:
                own = record
                if record.parent is under and under is not None:
                    break
                record = record.parent
            if own is not None:
                task, parent = own.task, own.parent
        if cut and own is not None and cut[-1][3] is own:
            cut[-1][2].append(s)
        else:
            cut.append((task, parent, [s], own))
    return [Part(task, parent, tuple(steps), own) for task, parent, steps, own in cut]


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
    each task with an equal share of what is left when its turn comes; each search within
    ``budget`` expansions.  With ``grounded`` (a grounded search's settings, design §7.2),
    the searches decompose by its ground methods, with its estimate and dead-end test.
    ``progress`` hears the expansions of all the searches so far (see
    :func:`~htnagent.planning.planner.plan`)."""
    parts = parts_of(given, top)
    if sum(p.cost > 0 for p in parts) < 2:
        return Cheaper(None, 0)  # one task that costs anything: the whole problem, which A* plans next
    deadline = None if time_limit is None else time.perf_counter() + time_limit
    turns = _Turns(domain, parts, deadline, budget, grounded, progress)
    steps = turns.run(state)
    cheaper = None if steps is None else Plan(steps)
    return Cheaper(cheaper if cheaper is not None and cheaper.cost < given.cost else None, turns.spent)


class _Turns:
    """The parts planned in turn (design §7.6, steps 2 and 3)."""

    def __init__(
        self,
        domain: Domain,
        parts: list[Part],
        deadline: float | None,
        budget: int,
        grounded: PlannerSettings | None,
        progress: Progress | None,
    ) -> None:
        self.domain = domain
        self.parts = parts
        self.deadline = deadline
        self.budget = budget
        self.grounded = grounded
        self.progress = progress
        # Step 3: where the goal is checked at the end, the parts after each follow it.
        self.follow = checks_goal(domain, [p.task for p in parts])
        self.spent = 0

    def run(self, state: State) -> tuple[Step, ...] | None:
        """Each part's steps in turn, from ``state``; None where a part has no plan found
        (or the searches were told to stop)."""
        steps: list[Step] = []
        unchanged = True  # the state is still the one the given plan had reached here
        for i, part in enumerate(self.parts):
            if searches_stopped():
                return None  # a signal: the command ends with the plans it has told
            done = self._turn(i, part, state, unchanged)
            if done is None:
                return None
            unchanged = unchanged and done is part.steps
            after = replay(self.domain, state, [s.action for s in done])
            if after is None:  # (a plan of the search: it applies)
                return None
            state = after
            steps.extend(done)
        return tuple(steps)

    def _turn(self, i: int, part: Part, state: State, unchanged: bool) -> tuple[Step, ...] | None:
        """Step 2: the part's cheapest plan from ``state``, else its old one where the state
        is unchanged, else greedy search's; None if there is none of these."""
        later = tuple((p.task, p.parent) for p in self.parts[i + 1 :]) if self.follow else ()
        share = None
        if self.deadline is not None:
            share = max((self.deadline - time.perf_counter()) / (len(self.parts) - i), 1e-3)
        if unchanged:
            # The old plan is still good here: only a cheaper one is wanted.
            costs = self.domain.task_costs or {}
            at_most = part.cost + sum(costs.get(t.name, 0.0) for t, _ in later)
            cheapest = self._search(part, state, later, Search.ASTAR, share, at_most) if at_most > 0 else None
            return part.steps if cheapest is None else cheapest
        cheapest = self._search(part, state, later, Search.ASTAR, share, None)
        if cheapest is not None:
            return cheapest
        return self._search(part, state, later, Search.GBFS, share, None)

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
            budget=self.budget,
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
        return None if found.best is None else found.best.steps


__all__ = ["Cheaper", "Part", "cheaper_one_at_a_time", "parts_of"]
