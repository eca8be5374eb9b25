"""An emergency for an HDDL problem: where it strikes and which task it is, chosen from the problem.

``python -m bench ipc-interrupt`` gives every problem it runs one emergency, half way
through the plan of the problem's network, and needs no list written per domain: the
emergency is found here from the domain, the problem and the plan alone
(docs/benchmarks.md, "How the emergency is chosen").

- **Where.** The plan's actions (the translation's ``__done`` markers left out), and the
  one at index ``len // 2`` -- or the first after it that does not occur earlier in the
  plan, since a scenario trigger fires on the first occurrence of its action.  The
  emergency arrives half way through it: the action is suspended (it has had no effect,
  docs/design.md §7.1).
- **Which.** Candidates are the domain's compound tasks grounded with the problem's
  objects (and the domain's constants) of each parameter's type; the objects the rest of
  the plan names come first, so that the tasks most likely to touch what the rest needs
  are tried first.  At most :data:`MAX_CANDIDATES` are planned (when none of them changes
  a fact, up to as many again, the tasks taken in turn, until one does), each by the same search
  within :data:`CANDIDATE_BUDGET` expansions, from the belief at the emergency (the
  suspended action's record in it).  A candidate is taken when its plan
  1. changes some fact of the world,
  2. **breaks the rest of the suspended plan**: replayed after it (the suspended action
     first, whole), some action of the rest finds its precondition false -- the
     emergency undid a fact the rest needs (or made true one it needs false), so the
     suspended plan must be kept valid, not merely resumed -- and
  3. leaves the **rest still solvable**: the plan upkeep's own repair
     (:class:`~htnagent.upkeep.repair.Repairer`, docs/design.md §2.4) mends the rest
     from the belief after it, within :data:`REPAIR_BUDGET` expansions.
  The first candidate in that order that passes all three is the emergency.  When none
  does, the candidate whose plan changes the most facts (ties to the first) is taken
  instead, and :attr:`Interruption.breaks` says so.

Everything is bounded by counts (candidates, expansions): the choice is the same on every
machine -- unless a search hits :data:`SEARCH_SECONDS`, a backstop on the clock for the
searches that run long without counting expansions.
"""

from __future__ import annotations

import itertools
from collections.abc import Iterator, Sequence
from dataclasses import dataclass, replace

from htnagent.hddl import model as m
from htnagent.model.domain import Domain
from htnagent.model.plans import Done, Plan, Step
from htnagent.model.state import State
from htnagent.model.terms import Atom
from htnagent.planning.hddl_translation import MARKERS, RESERVED, suspended_fact
from htnagent.planning.planner import PlannerSettings, PlanStatus, plan
from htnagent.upkeep.repair import LOCAL_BUDGET, Repairer, SearchMemo
from htnagent.upkeep.stats import PlanningStats

__all__ = [
    "CANDIDATE_BUDGET",
    "MAX_CANDIDATES",
    "MAX_GROUNDINGS",
    "REPAIR_BUDGET",
    "Interruption",
    "choose_interruption",
    "half_way",
    "is_marker",
]

MAX_CANDIDATES = 40
"""The most candidate emergency tasks planned for one problem."""
MAX_GROUNDINGS = 2_000
"""The most groundings of one task looked at (the rest's objects first) before ranking."""
CANDIDATE_BUDGET = 20_000
"""Expansions a candidate's plan may take."""
REPAIR_BUDGET = 20_000
"""Expansions the check that the rest is still solvable may take (the repair's re-plan of
the whole goal, its last resort, included)."""
SEARCH_SECONDS = 2.0
"""A backstop on each search's time: a search can run long without counting expansions
(nodes it already expanded, ways of a method it skips), and the choice must end."""


@dataclass(frozen=True, slots=True)
class Interruption:
    """Where an emergency strikes a plan and which task it is."""

    trigger: Atom
    """The action the emergency arrives half way through."""
    index: int
    """Its index among the plan's actions (markers left out)."""
    actions: int
    """The plan's actions (markers left out)."""
    emergency: Atom | None
    """The emergency task; None when no candidate has a plan that changes anything."""
    breaks: bool
    """Whether its plan breaks the rest of the suspended plan, which stays solvable; False:
    no candidate did both, and this is the one whose plan changes the most facts."""
    changed: int
    """How many facts of the world its plan changes."""
    tried: int
    """How many candidates were planned."""
    solvable: bool
    """Whether the rest of the suspended plan is known solvable after it (mended, or left
    valid); False only for a fallback when every candidate broke the rest beyond repair."""


def is_marker(action: Atom) -> bool:
    """Whether ``action`` is one the translation adds (``__done``), not an HDDL action."""
    return action.name in MARKERS


def half_way(steps: Sequence[Step]) -> tuple[int, int, int]:
    """``(step index, action index, actions)``: where a plan is struck half way -- the action
    at index ``len // 2`` of its actions (markers left out), or the first after it that does
    not occur earlier; ``actions`` their number.  ValueError for a plan with no action."""
    actions = [(i, s.action) for i, s in enumerate(steps) if not is_marker(s.action)]
    if not actions:
        raise ValueError("the plan has no action to interrupt")
    half = len(actions) // 2
    seen = {a for _, a in actions[:half]}
    for k in range(half, len(actions)):
        i, action = actions[k]
        if action not in seen:
            return i, k, len(actions)
        seen.add(action)
    return actions[half][0], half, len(actions)


def choose_interruption(
    domain: Domain,
    state: State,
    goal: Atom,
    the_plan: Plan,
    hddl: m.Domain,
    problem: m.Problem,
    settings: PlannerSettings,
) -> Interruption:
    """Where the emergency strikes ``the_plan`` (the agent's plan for ``goal`` from ``state``)
    and which task of ``hddl`` it is (see the module's docstring); ``settings`` give the
    search (its order; budgets are this module's)."""
    steps = the_plan.steps
    at, index, count = half_way(steps)
    trigger = steps[at].action
    before = state
    for s in steps[:at]:
        after = domain.apply(before, s.action)
        if after is None:
            raise ValueError(f"the plan is not valid from the state: {s.action} at step {steps.index(s)}")
        before = after
    struck = domain.suspend(before, trigger) if domain.can_suspend(trigger) else before
    rest = steps[at:]
    done: Done | None = None
    for s in steps[:at]:
        done = Done(s, done)
    one = replace(settings, alternatives=1, budget=CANDIDATE_BUDGET, time_limit=SEARCH_SECONDS)
    fallback: tuple[tuple[bool, int], Atom] | None = None
    tried = 0
    ranked = list(candidates(hddl, problem, rest))
    # When none of the first MAX_CANDIDATES changes a fact (the best-ranked groundings of one
    # task can fill them all), as many again, each task's best untried in turn.
    order = ranked[:MAX_CANDIDATES]
    second = _round_robin(ranked[MAX_CANDIDATES:])
    for candidate in itertools.chain(order, second):
        if tried >= MAX_CANDIDATES and (fallback is not None or tried >= 2 * MAX_CANDIDATES):
            break
        tried += 1
        found = plan(domain, struck, [candidate], one)
        if found.status is not PlanStatus.SOLVED or found.best is None:
            continue
        end = struck
        for s in found.best.steps:
            end = domain.progress(end, s.action)
        changed = len(_world(end) ^ _world(struck))
        if changed == 0:
            continue
        breaks, mends = _breaks_but_mends(domain, goal, settings, end, trigger, rest, done)
        if breaks and mends:
            return Interruption(trigger, index, count, candidate, True, changed, tried, True)
        # The fallback leaves the rest as it is (so the network stays solvable), if any does.
        rank = (not breaks, changed)
        if fallback is None or rank > fallback[0]:
            fallback = (rank, candidate)
    if fallback is None:
        return Interruption(trigger, index, count, None, False, 0, tried, False)
    (keeps, changed), emergency = fallback
    return Interruption(trigger, index, count, emergency, False, changed, tried, keeps)


def candidates(hddl: m.Domain, problem: m.Problem, rest: Sequence[Step]) -> Iterator[Atom]:
    """The domain's compound tasks grounded with objects of their parameters' types: the
    groundings naming most objects of ``rest`` first, then the tasks' order, then each
    task's groundings in order (the rest's objects first, by first mention)."""
    mentioned: dict[str, int] = {}
    for s in rest:
        for arg in s.action.args:
            if isinstance(arg, str):
                mentioned.setdefault(arg, len(mentioned))
    objects = [*hddl.constants, *problem.objects]
    ranked: list[tuple[int, int, int, Atom]] = []
    for t, task in enumerate(hddl.tasks.values()):
        if task.name.startswith(RESERVED):
            continue
        choices: list[list[str]] = []
        for param in task.params:
            wanted = set(param.types)
            fit = sorted(
                {o.name for o in objects if any(hddl.supertypes(k) & wanted for k in o.types)},
                key=lambda name: (name not in mentioned, mentioned.get(name, 0), name),
            )
            choices.append(fit)
        for g, args in enumerate(itertools.islice(itertools.product(*choices), MAX_GROUNDINGS)):
            named = sum(1 for a in set(args) if a in mentioned)
            ranked.append((-named, t, g, Atom(task.name, tuple(args))))
    ranked.sort(key=lambda r: r[:3])
    return (r[3] for r in ranked)


def _round_robin(ranked: Sequence[Atom]) -> Iterator[Atom]:
    """``ranked`` with the tasks taken in turn: each task's first, then each one's second, ..."""
    by_task: dict[str, list[Atom]] = {}
    for atom in ranked:
        by_task.setdefault(atom.name, []).append(atom)
    for batch in itertools.zip_longest(*by_task.values()):
        yield from (a for a in batch if a is not None)


def _world(state: State) -> frozenset[Atom]:
    """The state's facts of the HDDL world: the translation's own left out."""
    return frozenset(f for f in state.dynamic if not f.name.startswith(RESERVED))


def _breaks_but_mends(
    domain: Domain,
    goal: Atom,
    settings: PlannerSettings,
    end: State,
    trigger: Atom,
    rest: Sequence[Step],
    done: Done | None,
) -> tuple[bool, bool]:
    """Whether the rest of the suspended plan (its first action whole) fails from ``end``,
    and whether the plan upkeep's repair mends it from there."""
    start = domain.clear(end, trigger) if end.holds(suspended_fact(trigger)) else end
    states = [start]
    broken = None
    for i, s in enumerate(rest):
        after = domain.apply(states[-1], s.action)
        if after is None:
            broken = i
            break
        states.append(after)
    if broken is None:
        return False, True
    repairer = Repairer(
        domain,
        goal,
        replace(settings, alternatives=1, budget=REPAIR_BUDGET, time_limit=SEARCH_SECONDS),
        PlanningStats(),
        lambda _: frozenset(),
        SearchMemo(),
        local_budget=LOCAL_BUDGET,
    )
    return True, repairer.repair(Plan(tuple(rest)), broken, states, done) is not None
