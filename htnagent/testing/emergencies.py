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
- **Which.** Candidates are the domain's tasks grounded with the problem's objects (and the
  domain's constants) of each parameter's type, tried in rounds: its compound tasks first,
  then -- only when none of them will do -- its primitive tasks (actions; an HDDL network
  may name them too).  In a round the tasks are taken in turn (each one's best grounding,
  then each one's second, ...), a task's groundings ranked by how many objects the rest of
  the plan names, most first, so that the tasks most likely to touch what the rest needs
  are tried first.  Each candidate is planned by the same search within
  :data:`CANDIDATE_BUDGET` expansions, from the belief at the emergency (the suspended
  action's record in it); a round ends after :data:`MAX_CANDIDATES` candidates whose plan
  changes a fact, after :data:`MAX_BEYOND_REPAIR` of them broke the rest beyond repair, or
  when its searches have spent :data:`CANDIDATES_BUDGET` expansions.
  A candidate is taken when its plan
  1. changes some fact of the world -- beyond what the rest of the kept plan does next
     (compared with the world after each of its next :data:`ALONG` steps: an emergency
     that only finishes the suspended action, or does the rest's own next steps,
     changes nothing),
  2. **breaks the rest of the suspended plan**: the agent's own on-line plan keeping
     (:class:`~htnagent.upkeep.online.OnlinePlanSet`, docs/design.md §2-§3), taken through
     the plan's first half and the suspension as the agent takes it there, then given the
     emergency's actions as the agent gives them (§2.1: a plan that meant to do one moves
     on), keeps no plan whose every action still finds its precondition true -- the
     emergency undid a fact the rest needs (or made true one it needs false), so the
     suspended plan must be kept valid, not merely resumed (an emergency that only
     finishes the suspended action breaks nothing) -- and
  3. leaves the **rest still solvable**: that plan keeping still has a plan for the goal
     when it resumes (repaired, §2.4, or made afresh, §2.7), within :data:`REPAIR_BUDGET`
     expansions a search.
  The first candidate that passes all three is the emergency.  When none does, the
  candidate seen whose plan changes the most facts while it leaves the rest solvable is
  taken instead (one that leaves the rest valid before one that breaks it; ties to the
  first), and :attr:`Interruption.breaks` says so.  When every candidate so far leaves the
  goal with no plan, or changes nothing, a last round takes all the tasks, the groundings
  naming fewest objects of the rest first, to find one that changes something and leaves
  the rest valid.  Failing that, the first candidate whose plan only did what the rest
  does next (``changed`` 0): the network stays finishable.  Only when there is none either
  is one taken that leaves the goal with no plan (:attr:`Interruption.solvable` False).

Everything is bounded by counts (candidates, expansions): the choice is the same on every
machine -- unless a search hits :data:`SEARCH_SECONDS`, a backstop on the clock for the
searches that run long without counting expansions, or the choice hits
:data:`CHOICE_SECONDS`, a backstop on its whole time.
"""

from __future__ import annotations

import itertools
import time
from collections.abc import Iterable, Iterator, Sequence
from dataclasses import dataclass, replace

from htnagent.hddl import model as m
from htnagent.model.domain import Domain
from htnagent.model.plans import Plan, Step
from htnagent.model.state import State
from htnagent.model.terms import Atom
from htnagent.planning.hddl_translation import MARKERS, RESERVED
from htnagent.planning.planner import PlannerSettings, PlanStatus, plan
from htnagent.upkeep.online import OnlinePlanSet

__all__ = [
    "ALONG",
    "CANDIDATES_BUDGET",
    "CANDIDATE_BUDGET",
    "CHOICE_SECONDS",
    "MAX_BEYOND_REPAIR",
    "MAX_CANDIDATES",
    "MAX_GROUNDINGS",
    "REPAIR_BUDGET",
    "Interruption",
    "choose_interruption",
    "half_way",
    "is_marker",
]

MAX_CANDIDATES = 40
"""The most candidates whose plan changes a fact judged in each round of the choice."""
MAX_GROUNDINGS = 2_000
"""The most groundings of one task looked at (the rest's objects first) before ranking."""
CANDIDATE_BUDGET = 20_000
"""Expansions a candidate's plan may take."""
CANDIDATES_BUDGET = 200_000
"""Expansions all the candidates' plans of one round of the choice may take."""
ALONG = 200
"""How many of the rest's next steps an emergency's effect is compared with: one that only
does what they do changes nothing."""
MAX_BEYOND_REPAIR = 16
"""The most candidates that may break the rest beyond repair, in all rounds but the last:
each costs a search of the goal from scratch, and when that many leave it unfinishable,
the domain's tasks use up what the network needs (Childsnack's sandwiches)."""
REPAIR_BUDGET = 20_000
"""Expansions each search of the check that the rest is still solvable may take (the
repair's re-plan of the whole goal, its last resort, included)."""
CHOICE_SECONDS = 40.0
"""A backstop on the whole choice's time, read between candidates: past it the best
candidate seen is taken (the domains whose searches run into :data:`SEARCH_SECONDS` one
after the other -- a recursive task's list growing at every step -- would otherwise keep
a problem's preparation past the bench's limit)."""
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
    """Whether the goal is known to have a plan when it resumes after it (the agent's plan
    keeping mends the rest, or plans it afresh); False only for a fallback when no candidate
    left it one."""


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
    keeper, struck = _struck(domain, goal, settings, state, steps[:at], trigger)
    rest = steps[at:]
    trial = _Trial(domain, settings, keeper, struck)
    for kind in (hddl.tasks.values(), hddl.actions.values()):
        found = trial.first_breaking(_round_robin(candidates(kind, hddl, problem, rest)))
        if found is not None:
            return Interruption(trigger, index, count, found[0], True, found[1], trial.tried, True)
    if trial.fallback is None or trial.fallback[0] < (True, True, 1):
        # Every candidate so far leaves the goal with no plan or changes nothing: look among
        # those that touch the rest least for one that changes something and leaves it valid.
        least = candidates([*hddl.tasks.values(), *hddl.actions.values()], hddl, problem, rest, fewest=True)
        trial.first_breaking(iter(least), breaking=False)
    if trial.fallback is None:
        return Interruption(trigger, index, count, None, False, 0, trial.tried, False)
    (mends, _, changed), emergency = trial.fallback
    return Interruption(trigger, index, count, emergency, False, changed, trial.tried, mends)


class _Trial:
    """Candidates planned from the belief at the emergency and judged (the module's steps
    1-3); the best fallback seen so far is kept."""

    def __init__(
        self,
        domain: Domain,
        settings: PlannerSettings,
        keeper: OnlinePlanSet,
        struck: State,
    ) -> None:
        self.domain, self.settings, self.keeper, self.struck = domain, settings, keeper, struck
        self.along = _along(domain, struck, keeper)
        """The world at the emergency, and after each of the next steps of the kept plan."""
        self.tried = 0
        """Candidates planned, in all."""
        self.beyond_repair = 0
        """Candidates whose plan broke the rest beyond repair, in all."""
        self.deadline = time.perf_counter() + CHOICE_SECONDS
        """When no more candidates are tried (:data:`CHOICE_SECONDS`)."""
        self.fallback: tuple[tuple[bool, bool, int], Atom] | None = None
        """``((rest solvable, rest valid, facts changed), task)``: the best candidate that
        does not break the rest and leave it solvable both."""

    def first_breaking(self, order: Iterator[Atom], *, breaking: bool = True) -> tuple[Atom, int] | None:
        """The first candidate of ``order`` whose plan changes a fact, breaks the rest and
        leaves it solvable, with the facts it changes.  None when none does among the
        first :data:`MAX_CANDIDATES` whose plan changes a fact, or before
        :data:`MAX_BEYOND_REPAIR` candidates in all broke the rest beyond repair, or before the
        searches of the candidates' plans spent :data:`CANDIDATES_BUDGET` expansions.
        Not ``breaking``: look only for one that leaves the rest valid (a fallback)."""
        judged = spent = 0
        for candidate in order:
            if judged >= MAX_CANDIDATES or spent >= CANDIDATES_BUDGET or time.perf_counter() > self.deadline:
                return None
            if breaking and self.beyond_repair >= MAX_BEYOND_REPAIR:
                return None
            budget = min(CANDIDATE_BUDGET, CANDIDATES_BUDGET - spent)
            found = plan(self.domain, self.struck, [candidate], self._one(budget))
            self.tried += 1
            spent += found.expansions
            if found.status is not PlanStatus.SOLVED or found.best is None:
                continue
            actions = [s.action for s in found.best.steps]
            end = self.struck
            for action in actions:
                end = self.domain.progress(end, action)
            # What the emergency changes beyond doing what the rest does next (its plan may
            # finish the suspended action first): one that only does that changes nothing.
            world = _world(end)
            changed = min(len(world ^ w) for w in self.along)
            if changed == 0:
                self._note_no_change(candidate, actions)
                continue
            waiting, breaks = _taken(self.keeper, self.struck, actions)
            if breaks and not breaking:
                continue  # cheap to pass over: no repair searched
            judged += 1
            # The costly part: a repair, or a search of the goal from scratch (§2.4, §2.7).
            waiting.lazy = False
            mends = waiting.ensure(end)
            if breaks and mends:
                return candidate, changed
            self.beyond_repair += breaks and not mends
            rank = (mends, not breaks, changed)
            if self.fallback is None or rank > self.fallback[0]:
                self.fallback = (rank, candidate)
        return None

    def _note_no_change(self, candidate: Atom, actions: Sequence[Atom]) -> None:
        """The last fallback, better only than one that leaves the goal with no plan: the
        first candidate whose plan does what the rest does next and leaves it valid."""
        if self.fallback is None or not self.fallback[0][0]:
            _, breaks = _taken(self.keeper, self.struck, actions)
            if not breaks:
                self.fallback = ((True, True, 0), candidate)

    def _one(self, budget: int) -> PlannerSettings:
        return replace(self.settings, alternatives=1, budget=budget, time_limit=SEARCH_SECONDS)


def candidates(
    tasks: Iterable[m.Task | m.Action],
    hddl: m.Domain,
    problem: m.Problem,
    rest: Sequence[Step],
    *,
    fewest: bool = False,
) -> list[Atom]:
    """``tasks`` (of ``hddl``: its compound tasks, its actions, or both) grounded with
    objects of their parameters' types: the groundings naming most objects of ``rest`` first
    (``fewest``: least first), then the tasks' order, then each task's groundings in order
    (the rest's objects first, by first mention); at most :data:`MAX_GROUNDINGS` a task."""
    mentioned: dict[str, int] = {}
    for s in rest:
        for arg in s.action.args:
            if isinstance(arg, str):
                mentioned.setdefault(arg, len(mentioned))
    objects = [*hddl.constants, *problem.objects]
    ranked: list[tuple[int, int, int, Atom]] = []
    for t, task in enumerate(tasks):
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
            ranked.append((named if fewest else -named, t, g, Atom(task.name, tuple(args))))
    ranked.sort(key=lambda r: r[:3])
    return [r[3] for r in ranked]


def _round_robin(ranked: Sequence[Atom]) -> Iterator[Atom]:
    """``ranked`` with the tasks taken in turn: each task's first, then each one's second, ..."""
    by_task: dict[str, list[Atom]] = {}
    for atom in ranked:
        by_task.setdefault(atom.name, []).append(atom)
    for batch in itertools.zip_longest(*by_task.values()):
        yield from (a for a in batch if a is not None)


def _along(domain: Domain, struck: State, keeper: OnlinePlanSet) -> list[frozenset[Atom]]:
    """The world at the emergency (``struck``), and after each of the next :data:`ALONG`
    steps of ``keeper``'s best plan (as far as they can be taken)."""
    worlds = [_world(struck)]
    state = struck
    for s in keeper.plans[0].steps[:ALONG] if keeper.plans else ():
        after = domain.apply(state, s.action)
        if after is None:
            break
        worlds.append(_world(after))
        state = after
    return worlds


def _world(state: State) -> frozenset[Atom]:
    """The state's facts of the HDDL world: the translation's own left out."""
    return frozenset(f for f in state.dynamic if not f.name.startswith(RESERVED))


def _struck(
    domain: Domain,
    goal: Atom,
    settings: PlannerSettings,
    state: State,
    before: Sequence[Step],
    trigger: Atom,
) -> tuple[OnlinePlanSet, State]:
    """The agent's on-line plan keeping of ``goal`` taken through the steps ``before`` the
    emergency and the suspension of ``trigger``, as the agent takes it there, and the belief
    then; the plans wait on the stack from there (``lazy``, Algorithm 3)."""
    # The goal's first plan as the agent makes it (its own settings: the same plan it runs);
    # the searches after the emergency are this module's, bounded.
    keeper = OnlinePlanSet(domain, goal, settings)
    if not keeper.ensure(state):
        raise ValueError(f"no plan for {goal} from the state")
    keeper.settings = replace(settings, budget=REPAIR_BUDGET, time_limit=SEARCH_SECONDS)
    for s in before:
        after = domain.apply(state, s.action)
        if after is None:
            raise ValueError(f"the plan is not valid from the state: {s.action} at step {before.index(s)}")
        keeper.action_succeeded(s.action, state, after)
        state = after
    if domain.can_suspend(trigger):
        struck = domain.suspend(state, trigger)
        keeper.action_suspended(trigger, state, struck)
        state = struck
    keeper.lazy = True
    return keeper, state


def _taken(keeper: OnlinePlanSet, struck: State, emergency: Sequence[Atom]) -> tuple[OnlinePlanSet, bool]:
    """The waiting goal's plan keeping (a fork of ``keeper``, from ``struck``) once it has
    taken the ``emergency``'s actions, and whether that breaks the rest: no kept plan is
    still valid after them.

    The waiting goal's plans take each action as the agent gives them every action that
    succeeds (§2.1: a plan that meant to do it moves on -- an emergency that only
    finishes the suspended action breaks nothing), and follow it while the goal waits
    (``lazy``); they are re-checked and repaired (§2.4), or the goal planned afresh
    (§2.7), when it is about to run again: ``ensure`` on the fork does that."""
    waiting = keeper.fork()
    domain = waiting.domain
    state = struck
    for action in emergency:
        after = domain.progress(state, action)
        waiting.action_succeeded(action, state, after)
        state = after
    waiting.catch_up()  # the rewrites a waiting goal logs, made
    return waiting, not any(_valid(domain, state, p) for p in waiting.plans)


def _valid(domain: Domain, state: State, the_plan: Plan) -> bool:
    """Whether every action of ``the_plan`` finds its precondition true, from ``state`` on."""
    for s in the_plan.steps:
        after = domain.apply(state, s.action)
        if after is None:
            return False
        state = after
    return True
