"""The SHOP-style forward-decomposition HTN planner (docs/design.md §1).

Pure, synchronous code.  The first task of the task list is always the one
decomposed or applied, so the state is known at every step.  Search is
best-first A* over ``(state, remaining tasks)`` with ``f = g + h``: ``g`` the
cost of the actions so far, ``h`` the domain's estimate for the first compound
task left (see :func:`heuristic`: later tasks start elsewhere, and adding their
estimates could over-estimate).  The planner returns up to ``alternatives`` complete plans
in cost order; each key may be expanded that many times, and when more than
one plan is asked for, a plan never returns to a ``(state, tasks)`` it already
passed through, so alternatives are genuinely different routes rather than
detours with loops (for the first plan alone A* needs no such check).

When the state holds a half-done action (the facts a suspension left), the
planner also tries, before the first task, every applicable ``resume`` and
``rollback`` operator — that is how a plan from scratch gets off the arc.
"""

from __future__ import annotations

import collections
import functools
import gc
import heapq
import itertools
import operator
import queue
import threading
import time
from collections.abc import Callable, Iterator, Sequence
from dataclasses import dataclass, field
from enum import Enum
from typing import Any, NamedTuple

from htnagent.errors import PlanningError, SettingsError
from htnagent.model.actions import ROLLBACK, Actions
from htnagent.model.domain import Domain, Estimate
from htnagent.model.plans import Decomposition, Plan, Step, tidy
from htnagent.model.preconditions import Decomposer, LazyDecomposer, satisfiers
from htnagent.model.state import State
from htnagent.model.terms import Atom, Bindings, substitute, unify
from htnagent.planning.goal_support import GoalSupport, checks_goal
from htnagent.planning.ground_methods import Decompositions
from htnagent.planning.landmarks import GoalLandmarks
from htnagent.planning.one_step import OneStepAhead

TaskEntry = tuple[Atom, Decomposition | None]

_INF = float("inf")

_MIN_EXTRA = 500
"""Expansions the alternatives may always take, however quickly the first plan came."""

_MAX_TASK_LIST = 10_000
"""How long a node's task list may grow (at least four times the tasks given, or what they
decompose into at once): see ``_search``."""


class PlanStatus(Enum):
    """How a planning call ended."""

    SOLVED = "solved"
    """At least one complete plan was found."""
    UNSOLVABLE = "unsolvable"
    """The whole search space was explored and holds no plan."""
    BUDGET_EXHAUSTED = "budget_exhausted"
    """The expansion budget ran out before any plan was found."""
    TIMED_OUT = "timed_out"
    """The time limit (:attr:`PlannerSettings.time_limit`) ran out before any plan was found."""
    INTERRUPTED = "interrupted"
    """The process was asked to stop (:func:`stop_searches`) before any plan was found."""


Guide = Callable[[Sequence[Atom], frozenset[Atom]], float]
"""A node's estimate from its task list and its state's changing facts (see :func:`plan`)."""

DeadEnd = Callable[[Sequence[Atom], frozenset[Atom]], bool]
"""Whether a node has no plan below it, from its task list and its state's changing facts
(:attr:`PlannerSettings.prune`)."""

Progress = Callable[[int, float], None]
"""Told how far a search has got: ``(expansions, seconds)`` so far (see :func:`plan`)."""

PROGRESS_EVERY = 0.25
"""The fewest seconds between two calls of a search's ``progress``."""


class _StopRequest:
    requested = False


_STOP = _StopRequest()


def stop_searches(requested: bool = True) -> None:
    """Make every search under way end at its next look at the clock, and every search
    started until this is called with ``False``, as :attr:`PlanStatus.INTERRUPTED`.

    For a process asked to stop (the command line's Ctrl-C and SIGTERM): a search is
    synchronous code, and a long one would otherwise keep the event loop — and the
    process — from seeing the request until it returned.
    """
    _STOP.requested = requested


def searches_stopped() -> bool:
    """Whether :func:`stop_searches` has asked every search to stop."""
    return _STOP.requested


class Search(Enum):
    """The order in which the search expands its nodes (docs/design.md §1.1)."""

    ASTAR = "astar"
    """Cost-optimal A*: the lowest ``g + h`` first (the default; the museum's)."""
    GBFS = "gbfs"
    """Greedy best-first: the lowest ``h`` first, ties to the larger ``g``, then to the node
    pushed last (depth first on a plateau of ``h``).  Not optimal,
    usually far quicker when ``h`` is informative (the HDDL domains)."""
    DFS = "dfs"
    """Depth-first in method order, SHOP's: the deepest node first, and among the children
    of one node the first method's (and the first binding's) first."""


@dataclass(frozen=True, slots=True)
class PlannerSettings:
    """How hard the planner tries: alternatives kept (K) and the expansion budget."""

    alternatives: int = 2
    budget: int = 200_000
    alternatives_effort: float = 1.0
    """After the first plan, the search for the other alternatives may expand at most
    this many times as many nodes again as the first plan took (and at least 500);
    they are a cache, not worth an unbounded search."""
    rollbacks: bool = True
    """Whether plans may roll a suspended action back.  An agent whose executor is a
    child agent that cannot plan ``rollback(A)`` as a task plans without them
    (docs/design.md §5)."""
    search: Search = Search.ASTAR
    """The order of expansion; every order gives plans with the same decomposition
    records, so plan upkeep works alike with each."""
    time_limit: float | None = None
    """Seconds the search may take (the clock is read every 256 nodes taken off the open
    list); past it the search ends with :attr:`PlanStatus.TIMED_OUT`, or with the plans
    found so far."""
    cost_bound: float | None = None
    """Only plans cheaper than this: a node whose cost so far plus the least cost of its
    tasks (the domain's :attr:`~htnagent.model.domain.Domain.task_costs`, else nothing)
    reaches it is not followed (branch and bound; see :func:`plan`'s ``improving``)."""
    max_tasks: int | None = None
    """The longest task list followed: a child whose list is longer is not (growth: a
    method that puts its own task back in front of more), and the search ends as out of
    budget.  None: at least 10,000, and four times the tasks given (see ``_search``)."""
    guide: Guide | None = field(default=None, compare=False)
    """The estimate every search with these settings uses in place of the domain's, unless
    :func:`plan` is given one: a grounded one (:mod:`htnagent.planning.composition`), for
    an agent whose scenario plans with ``search: grounded``."""
    decompositions: Decompositions | None = field(default=None, compare=False)
    """Decomposers the searches use for some methods in place of their lifted ones: the
    ground methods a grounding kept (:mod:`htnagent.planning.ground_methods`), beside its
    estimate as the :attr:`guide`."""
    prune: DeadEnd | None = field(default=None, compare=False)
    """A sound test asked of a node as the search takes it off its open list to expand, where
    an action led to it (a state not tested yet) or it is the first: where the test says no
    plan lies below the node, it is dropped unexpanded.  For a test too costly to ask of
    every child the search makes: a grounding's
    (:meth:`~htnagent.planning.composition.Composition.dead_end`), beside its estimate as the
    :attr:`guide`."""

    def __post_init__(self) -> None:
        if self.alternatives < 1:
            raise SettingsError(f"planner settings: alternatives must be at least 1, not {self.alternatives}")
        if self.budget < 1:
            raise SettingsError(f"planner settings: budget must be at least 1, not {self.budget}")
        if self.time_limit is not None and not self.time_limit > 0:
            raise SettingsError(f"planner settings: time_limit must be positive, not {self.time_limit}")
        if self.cost_bound is not None and not self.cost_bound > 0:
            raise SettingsError(f"planner settings: cost_bound must be positive, not {self.cost_bound}")
        if self.max_tasks is not None and self.max_tasks < 1:
            raise SettingsError(f"planner settings: max_tasks must be at least 1, not {self.max_tasks}")
        if self.alternatives_effort < 0:
            raise SettingsError(
                f"planner settings: alternatives_effort must not be negative, not {self.alternatives_effort}"
            )


@dataclass(frozen=True, slots=True)
class PlanResult:
    """Plans found (cheapest first), why the search stopped, and what it cost."""

    status: PlanStatus
    plans: tuple[Plan, ...] = ()
    expansions: int = 0
    seconds: float = 0.0
    exhausted: bool = False
    """Every node under the cost bound was explored: with ``improving``, no plan is cheaper
    than the last one found (none cheaper than the bound, if none was found)."""

    @property
    def best(self) -> Plan | None:
        """The cheapest plan, if any."""
        return self.plans[0] if self.plans else None


_Key = tuple[frozenset[Atom], tuple[Atom, ...]]
"""A search node's (state, task list).  A plain tuple: hashed and compared in C, which
costs less than hashing once in Python and comparing in Python."""


class _Node(NamedTuple):
    """A search node, and its own entry on the open list (A*: the lowest ``f = g + h``
    first, then the larger ``g``, then the first pushed; ``seq`` is never the same twice,
    so the fields after it are never compared).  A tuple: made and ordered in C."""

    f: float
    neg_g: float
    seq: int
    dynamic: frozenset[Atom]
    tasks: tuple[Atom, ...]
    records: tuple[_Record, ...]
    step: tuple[Atom, float, _Record] | None
    """The action that led here, its cost and record (a :class:`Step` once a plan is read off)."""
    parent: _Node | None


class _More(NamedTuple):
    """The ways of one method not yet made into nodes (a lazy expansion): on the open list
    with the f its nodes all share, made into the next node each time it is popped."""

    f: float
    neg_g: float
    seq: int
    ways: Iterator[tuple[Atom, ...]]
    parent: _Node
    task: Atom
    method: str
    record: _Record
    rest_tasks: tuple[Atom, ...]
    rest_records: tuple[_Record, ...]


class _Pending(NamedTuple):
    """A decomposition record not made yet: most search nodes never reach a plan.  Every
    node below the decomposition holds this same tuple, so it becomes one record
    (:func:`_steps`), shared as a :class:`Decomposition` made at once would be."""

    task: Atom
    method: str
    parent: _Record


_Record = Decomposition | _Pending | None


LET_GO_AFTER = 0.25
"""Seconds past which a search that ends hands what it made to the :class:`_Graveyard` to
free, rather than freeing it as it returns (a shorter one made too little to matter)."""


class _Graveyard:
    """Frees what finished searches made, in a thread of its own.

    A long search takes seconds to free what it made -- greedy search on Hiking p28 at a
    limit of 8 s answered 1.5 s after its time was up, depth-first search 0.6 s after 3 s
    -- and its answer, or the next search of a portfolio, should not wait for that.  The
    thread frees a thousand entries at a time and takes turns with the others (the
    interpreter runs one thread at a time): the freeing costs the same work, only beside
    what comes next.  A daemon thread: a process that ends (the command line ends by
    ``os._exit``) does not free at all.

    While it has remains to free, the objects alive when they came are frozen out of the
    cyclic collector's sight (``gc.freeze``; thawed once it is done): a collection would
    otherwise walk the millions of nodes still waiting (Hiking p28: the portfolio answered
    7 s late, the collector back on and the nodes not yet freed).
    """

    def __init__(self) -> None:
        self._graves: queue.SimpleQueue[tuple[list[Any] | dict[Any, Any], ...]] = queue.SimpleQueue()
        self._lock = threading.Lock()
        self._thread: threading.Thread | None = None
        self._waiting = 0  # remains buried and not yet freed
        self.empty = threading.Event()
        """Set while nothing buried waits to be freed."""
        self.empty.set()

    def bury(self, remains: tuple[list[Any] | dict[Any, Any], ...]) -> None:
        """Free the lists and dicts of ``remains`` in the graveyard's thread (started the
        first time); the caller keeps no reference to them."""
        with self._lock:
            if self._thread is None:
                self._thread = threading.Thread(target=self._dig, name="htnagent-graveyard", daemon=True)
                self._thread.start()
            gc.freeze()
            self._waiting += 1
            self.empty.clear()
            self._graves.put(remains)

    def _dig(self) -> None:
        while True:
            remains = self._graves.get()
            for made in remains:
                # A little at a time: freeing a whole list or dict is one step of the
                # interpreter, which no other thread could interrupt.
                if isinstance(made, list):
                    while made:
                        del made[-_CHUNK:]
                elif isinstance(made, dict):
                    while made:
                        for _ in range(min(_CHUNK, len(made))):
                            made.popitem()
            del remains  # (each list or dict of it is empty now)
            with self._lock:
                self._waiting -= 1
                if not self._waiting:
                    gc.unfreeze()
                    self.empty.set()


_CHUNK = 1_000
"""Entries freed at a time in the graveyard."""


_GRAVEYARD = _Graveyard()

_new = tuple.__new__
_name = operator.attrgetter("name")


def _revisits(parent: _Node, dynamic: frozenset[Atom], tasks: tuple[Atom, ...]) -> bool:
    """Whether ``parent`` or an ancestor has the same state and task list (a loop)."""
    node: _Node | None = parent
    while node is not None:
        if node.dynamic == dynamic and node.tasks == tasks:
            return True
        node = node.parent
    return False


def _steps(end: _Node, made: dict[int, tuple[object, object]]) -> list[Step]:
    """The steps that led to ``end``.  A node's step and a pending record are made once
    (``made``, by id, keeps what they were made from so that the id is not reused): plans
    that share the node or the decomposition share the step or the record."""
    steps: list[Step] = []
    node: _Node | None = end
    while node is not None:
        if node.step is not None:
            known = made.get(id(node))
            if known is None:
                action, cost, record = node.step
                known = made[id(node)] = (node, Step(action, cost, _record(record, made)))
            assert isinstance(known[1], Step)
            steps.append(known[1])
        node = node.parent
    steps.reverse()
    return steps


def _record(record: _Record, made: dict[int, tuple[object, object]]) -> Decomposition | None:
    """The decomposition record of a pending one, made once (``made``, as in :func:`_steps`).

    A loop, not a recursion: a record's chain of parents is as deep as the decomposition,
    thousands of levels in a recursive HDDL domain (Towers).
    """
    chain: list[_Pending] = []
    at: _Record = record
    base: Decomposition | None = None
    while isinstance(at, _Pending):
        known = made.get(id(at))
        if known is not None:
            assert isinstance(known[1], Decomposition)
            base = known[1]
            break
        chain.append(at)
        at = at.parent
    else:
        base = at
    for pending in reversed(chain):
        base = Decomposition(pending.task, pending.method, base)
        made[id(pending)] = (pending, base)
    return base


def plan(
    domain: Domain,
    state: State,
    tasks: Sequence[Atom | TaskEntry],
    settings: PlannerSettings | None = None,
    *,
    recover: bool = True,
    avoid: frozenset[Atom] = frozenset(),
    progress: Progress | None = None,
    improving: Callable[[Plan], None] | None = None,
    checkpoint: Callable[[], bool] | None = None,
    guide: Guide | None = None,
    then: Sequence[Atom | TaskEntry] = (),
) -> PlanResult:
    """Plan the task list from the state: up to K plans in cost order.

    ``guide(tasks, dynamic)``, if given, is the estimate of a node's task list from its
    state's changing facts, in place of the domain's (``inf``: a dead end, not followed):
    a grounded one (:mod:`htnagent.planning.composition`).

    ``checkpoint()``, if given, is called where the search reads its clock (every 256
    nodes): True ends the search as :attr:`PlanStatus.INTERRUPTED` (with the plans found
    so far).  A portfolio of searches run side by side stops one through it, or slows it
    down (it may sleep there, letting another thread run).

    ``improving`` (K = 1 only): branch and bound.  Each complete plan cheaper than the
    bound so far is told to ``improving`` at once and becomes the bound
    (:attr:`PlannerSettings.cost_bound` the first), and the search goes on for a cheaper
    one until its time, budget or nodes run out; a state and task list is expanded again
    when it is reached at a lower cost.  The result holds the last plan found;
    ``exhausted`` says it is the cheapest there is.

    ``progress(expansions, seconds)``, if given, hears how far the search has got, at most
    every :data:`PROGRESS_EVERY` seconds (it is called where the search reads its clock,
    every 256 nodes, so the search is no slower for it).

    ``avoid``: actions not to take in the state itself (its executor has just said it
    cannot do them from there); elsewhere in the plan they are allowed.

    ``then``: tasks that come after the list, not planned: a plan ends where they are
    all that is left.  They are there to be counted: by the estimate, by the cost bound
    (a bound is then on the plan's cost plus their least cost), and by the goal's check
    (design §7.3), which drops a node that leaves them no way to the goal.

    ``tasks`` are atoms or ``(atom, record)`` pairs (a record places re-planned
    tasks under an existing decomposition, for repair).  With ``recover`` the
    planner may start with an applicable ``resume``/``rollback``.  Raises
    :class:`PlanningError` for a task name the domain does not know.

    Python's cyclic garbage collector is paused while the search runs and restored
    after: the search makes many nodes that live until it ends, and the collector
    would scan them again and again (a search of 17,000 steps took twice as long
    with it).  The nodes form no cycles: reference counting frees them.
    """
    if guide is None and settings is not None:
        guide = settings.guide
    search = functools.partial(
        _search,
        domain,
        state,
        tasks,
        settings,
        recover,
        avoid,
        progress=progress,
        improving=improving,
        checkpoint=checkpoint,
        guide=guide,
        then=then,
    )
    if not gc.isenabled():
        return search()
    gc.disable()
    try:
        return search()
    finally:
        gc.enable()


def _search(
    domain: Domain,
    state: State,
    tasks: Sequence[Atom | TaskEntry],
    settings: PlannerSettings | None,
    recover: bool,
    avoid: frozenset[Atom],
    progress: Progress | None = None,
    improving: Callable[[Plan], None] | None = None,
    checkpoint: Callable[[], bool] | None = None,
    guide: Guide | None = None,
    then: Sequence[Atom | TaskEntry] = (),
) -> PlanResult:
    settings = settings or PlannerSettings()
    if improving is not None and settings.alternatives != 1:
        raise SettingsError("planner settings: improving plans are searched for one plan (K = 1)")
    started = time.perf_counter()
    entries: list[TaskEntry] = [(t, None) if isinstance(t, Atom) else t for t in (*tasks, *then)]
    # The tasks after the list are never reached: the first task is always the one decomposed
    # or applied, so the list is down to them exactly when every task before them is done.
    left_at_end = len(then)
    for t, _ in entries:
        if not domain.knows(t):
            raise PlanningError(f"domain {domain.name} has no operator or method for {t}")
    static = state.static
    static_facts = static.facts
    dyn_preds = state.dynamic_predicates
    # Ties in f go to the first node pushed, or, in greedy search, to the last: on a plateau
    # of h it then goes on from where it just was, depth first, instead of widening.
    counter = itertools.count(0, -1) if settings.search is Search.GBFS else itertools.count()
    heap: list[_Node | _More] = []
    heappush, heappop = heapq.heappush, heapq.heappop
    k = settings.alternatives
    check_loops = k > 1
    # With K = 1 a key is expanded at most once: nothing to gain from caching its successors.
    reuse = k > 1

    estimates = domain.estimates
    methods = domain.methods
    operators = domain.operators
    search = settings.search
    # f = wg * g + h: A* weighs the cost so far, greedy best-first does not; depth-first
    # ignores both and takes the deepest node (f falls by one a level; docs/design.md §1.1).
    wg = 1.0 if search is Search.ASTAR else 0.0
    dfs = search is Search.DFS
    task_costs = domain.task_costs
    goal_facts = domain.goal_facts if search is Search.GBFS else ()
    # Where h reads only the task names, all the ways of one method share their f: they are
    # made into nodes one at a time, as the search reaches them (_More) -- a method with
    # thousands of bindings costs only those the search takes.
    # A guide tells the ways of one method apart: each is made into a node at once.
    lazy = task_costs is not None and k == 1 and guide is None
    lazy_methods: dict[str, list[tuple[str, LazyDecomposer]]] = {}
    ground = settings.decompositions or {}

    def runs_of(name: str) -> list[tuple[str, LazyDecomposer]]:
        """The task name's methods as lazy decomposers, made once."""
        runs = lazy_methods.get(name)
        if runs is None:
            runs = lazy_methods[name] = [
                (m.name, _lazy(ground[m]) if m in ground else m.compiled_lazy(dyn_preds))
                for m in methods.get(name, ())
            ]
        return runs

    # Design §7.5: greedy search by the lifted estimate also weighs the next decomposition,
    # where the problem is a task network alone (with a goal, the estimate counts what the
    # goal still needs, and a cost added would hold back the nodes that move towards it).
    one_step = None
    if lazy and task_costs is not None and search is Search.GBFS and not domain.goal_facts:
        one_step = OneStepAhead(domain, static, dyn_preds, task_costs, runs_of)
    deadline = started + settings.time_limit if settings.time_limit is not None else None
    prune = settings.prune
    # What each task name means to h (heuristic below): its estimate, None for a compound
    # task without one (h is 0), absent for a primitive task (h looks further).
    h_role: dict[str, Estimate | None] = {name: None for name in methods}
    h_role.update(estimates)
    h_cache: dict[tuple[frozenset[Atom], Atom], float] = {}

    last: tuple[object, object, float] = (None, None, 0.0)  # the last look-up, by identity

    # The task-cost sum in C: task lists run to hundreds of tasks (Blocksworld's 300 blocks),
    # and h is worked out for every child.  A name without a cost counts 0, as before.
    cost_of = collections.defaultdict(float, task_costs or {}).__getitem__
    goal_set = frozenset(goal_facts)
    # Depth-first search reads h only for ``inf`` (a task that can never be done): with the
    # lifted sum, a child's list is its parent's with the first task replaced, so only the
    # new tasks need looking at -- not the whole list, thousands long (Blocksworld).
    new_only = dfs and task_costs is not None and guide is None
    distinct_goals = len(goal_set) == len(goal_facts)
    landmarks = GoalLandmarks.of(domain, dyn_preds) if goal_facts and task_costs is not None else None
    if landmarks is not None and not landmarks.beyond_goals:
        landmarks = None  # the false goal facts alone, counted below as they always were
    # A state goal checked at the end of the list: a node where a goal fact (or a mark behind
    # it) is still needed and no task left may add it is a dead end (design §7.3), whatever the
    # search -- found where it happens, not at the end.  Greedy search also weighs how far
    # ahead in the list the next mark can come (design §7.4).
    given_tasks = [t for t, _ in entries]
    support = GoalSupport.of(domain, static, dyn_preds) if checks_goal(domain, given_tasks) else None
    ahead = support.before_next_marks if support is not None and support.marks and landmarks else None
    dropped = support.lost_after_decomposing if support is not None else None

    def h_of(tasks: tuple[Atom, ...], dynamic: frozenset[Atom], st: State | None) -> float:
        if guide is not None:
            return guide(tasks, dynamic)
        if task_costs is not None:
            # Each task's least cost whatever the state: their sum never over-estimates.
            h = sum(map(cost_of, map(_name, tasks)))
            if landmarks is not None:
                # Design §7.4: the false goal facts and the landmarks still needed behind them.
                h += landmarks.count(dynamic)
                if ahead is not None:
                    h += ahead(tasks, dynamic, cost_of)
            elif goal_facts:
                if distinct_goals:
                    h += len(goal_set.difference(dynamic))
                else:
                    h += sum([f not in dynamic for f in goal_facts])
            return h
        # The first compound task's estimate; the children of one node mostly share their
        # state and that task (often the very same objects), so it is worked out once for them.
        nonlocal last
        for t in tasks:
            name = t.name
            if name in h_role:
                fn = h_role[name]
                if fn is None:
                    return 0.0
                if t is last[1] and dynamic is last[0]:
                    return last[2]
                key = (dynamic, t)
                cached = h_cache.get(key)
                if cached is None:
                    cached = h_cache[key] = fn(t, st if st is not None else State(static, dynamic, dyn_preds))
                last = (dynamic, t, cached)
                return cached
        return 0.0

    # Branch and bound (plan's ``improving``, or a bound given): a node goes only where its
    # cost so far plus the least cost of its tasks stays under the bound.
    bound = settings.cost_bound if settings.cost_bound is not None else _INF
    bounded = improving is not None or settings.cost_bound is not None
    least = task_costs or {}

    def lb(tasks: tuple[Atom, ...]) -> float:
        return sum([least.get(t.name, 0.0) for t in tasks]) if least else 0.0

    # A*'s f is exactly that sum where h is the task costs' (no guide, no goal facts).
    exact_f = bounded and search is Search.ASTAR and guide is None and task_costs is not None
    best_g: dict[_Key, float] = {}  # improving: the lowest cost at which each key was expanded
    wanted = k if improving is None else _INF
    root_tasks = tuple(t for t, _ in entries)
    # A method that puts its own task back in front of more (t -> t t) grows the task list
    # by one at each expansion, and each node copies its list: a search that would take
    # time and memory growing as the square of the budget.  Lists longer than this are
    # not followed (the search then ends as out of budget, not as unsolvable).  What the
    # tasks given decompose into at once is given too (HDDL's initial network is one task).
    given = settings.max_tasks
    max_tasks = given if given is not None else max(_MAX_TASK_LIST, 4 * len(root_tasks))
    # The clock is read every 256 nodes; with task lists of thousands, each node costs as
    # much as its list is long, and it is read at every node.
    every = 255 if max_tasks <= _MAX_TASK_LIST else 0
    cut = False

    def too_long(tasks: int, parent: _Node) -> bool:
        """A child's list of ``tasks`` is past the bound: growth, not followed — unless its
        parent is the root, whose decomposition is the network given (the bound follows it)."""
        nonlocal max_tasks, every, cut
        if parent is not root:
            cut = True
            return True
        max_tasks, every = 4 * tasks, 0
        return False

    root = _new(
        _Node,
        (
            h_of(root_tasks, state.dynamic, state),
            -0.0,
            next(counter),
            state.dynamic,
            root_tasks,
            tuple(r for _, r in entries),
            None,
            None,
        ),
    )
    if new_only and root.f == _INF:
        pass  # a task that can never be done: no plan (its children are not checked again)
    elif support is None or not support.lost_at_start(state.dynamic, root_tasks):
        heappush(heap, root)  # (else no task may add some goal fact: no plan)
    if recover and (recovery := domain.recovery_operators()):
        # A suspended action's facts are in the state: try finishing or undoing it first.
        # One pass over the state's changing facts first: a resume or rollback whose
        # precondition names a changing fact of which the state holds none cannot apply,
        # and looking it up would read them all again, once an operator (Depots: ten such
        # reads were half of a short repair search's time).
        present = {f.name for f in state.dynamic}
        changing = state.dynamic_predicates
        for op in recovery:
            if op.name == ROLLBACK and not settings.rollbacks:
                continue
            names = (lit.atom.name for lit in op.pre if lit.positive)
            if any(name in changing and name not in present for name in names):
                continue
            for b in satisfiers(op.pre, state, {}):
                action = substitute(op.head, b)
                if not action.is_ground or action in avoid:
                    continue
                cost = op.action_cost(action)
                dynamic = op.effects_on(state.dynamic, b)
                h = h_of(root.tasks, dynamic, None)
                if h == _INF:
                    continue
                first: tuple[Atom, float, _Record] = (action, cost, None)
                f = root.f - 1.0 if dfs else cost * wg + h
                heappush(
                    heap,
                    _new(
                        _Node,
                        (f, -cost, next(counter), dynamic, root.tasks, root.records, first, root),
                    ),
                )

    ground_actions = domain.actions
    known = ground_actions.known
    compiled: _Compiled = {}
    popped: dict[_Key, int] = {}
    primitive_cache: dict[tuple[frozenset[Atom], Atom], list[tuple[Atom, float, frozenset[Atom]]]] = {}
    compound_cache: dict[tuple[frozenset[Atom], Atom], list[tuple[str, list[tuple[Atom, ...]]]]] = {}
    found: list[Plan] = []
    seen_plans: set[tuple[Atom, ...]] = set()
    made: dict[int, tuple[object, object]] = {}
    expansions = 0
    limit = settings.budget
    timed_out = halted = False
    stop = _STOP
    # The clock is read every 256 nodes taken off the open list -- not expansions: a long
    # run of nodes already expanded (or of lazy ways) expands nothing.
    ticks = 0
    next_report = started + PROGRESS_EVERY
    ended: PlanStatus | None = None  # how the search ran out of budget or time, if it did

    def read_clock() -> None:
        """Out of time, or told to stop (a signal, the checkpoint): the search ends at the
        next node, as when the budget runs out."""
        nonlocal limit, timed_out, halted
        if stop.requested or (deadline is not None and time.perf_counter() > deadline):
            limit = expansions
            timed_out = True
        elif checkpoint is not None and checkpoint():
            limit = expansions
            timed_out = halted = True

    def next_kept(
        ways: Iterator[tuple[Atom, ...]], task: Atom, dynamic: frozenset[Atom], rest: tuple[Atom, ...]
    ) -> tuple[Atom, ...] | None:
        """The next of a method's ways the goal's check keeps (design §7.3).  A method bound
        by types may make millions of ways the check drops (Woodworking's network, fifteen
        parameters): the clock is read every 256 of them, as every 256 nodes."""
        assert dropped is not None
        way = next(ways, None)
        dropped_ways = 0
        while way is not None and dropped(task, dynamic, way + rest):
            dropped_ways += 1
            if not dropped_ways & 255:
                read_clock()
                if expansions >= limit:
                    return None
            way = next(ways, None)
        return way

    while heap and len(found) < wanted:
        ticks += 1
        if not ticks & every:
            if progress is not None and (now := time.perf_counter()) >= next_report:
                next_report = now + PROGRESS_EVERY
                progress(expansions, now - started)
            read_clock()
        if expansions >= limit:
            if found and limit < settings.budget:
                break  # the alternatives' share of the search is spent
            out_of = PlanStatus.TIMED_OUT if timed_out else PlanStatus.BUDGET_EXHAUSTED
            if timed_out and (stop.requested or halted):
                out_of = PlanStatus.INTERRUPTED
            ended = PlanStatus.SOLVED if found else out_of
            break
        popped_entry = heappop(heap)
        if isinstance(popped_entry, _More):
            more = popped_entry
            if dropped is None:
                way = next(more.ways, None)
            else:
                way = next_kept(more.ways, more.task, more.parent.dynamic, more.rest_tasks)
            if way is not None:
                up = more.parent
                rec = _new(_Pending, (more.task, more.method, more.record))
                # The node before the ways still to come, whichever way ties are broken.
                seq, later = sorted((next(counter), next(counter)))
                child_tasks = way + more.rest_tasks
                extra = 0.0 if one_step is None else one_step.extra(child_tasks, up.dynamic)
                if extra != _INF:
                    child = (
                        more.f + extra,
                        more.neg_g,
                        seq,
                        up.dynamic,
                        child_tasks,
                        (rec,) * len(way) + more.rest_records,
                        None,
                        up,
                    )
                    heappush(heap, _new(_Node, child))
                heappush(heap, more._replace(seq=later))
            continue
        node = popped_entry
        if exact_f and node.f >= bound:
            # A* whose f is the cost so far plus the least cost of the tasks: the nodes come
            # in the order of that bound, so no node left can lead under it.
            heap.clear()
            break
        node_tasks = node.tasks
        # (Where f is exactly that sum, the test above has made this one.)
        if bounded and not exact_f and -node.neg_g + lb(node_tasks) >= bound:
            continue  # the bound fell since it was pushed
        if len(node_tasks) == left_at_end:
            # Complete plans all share the key of their final state: they are told apart
            # by their actions, so a repeat never takes an alternative's place.
            steps = tidy(domain, _steps(node, made))
            if improving is not None:
                better = Plan(steps)
                if better.cost < bound:
                    bound = better.cost
                    found[:] = [better]
                    improving(better)
                continue
            actions = tuple(s.action for s in steps)
            if actions not in seen_plans:
                seen_plans.add(actions)
                found.append(Plan(steps))
                if len(found) == 1:
                    extra = max(int(expansions * settings.alternatives_effort), _MIN_EXTRA)
                    limit = min(settings.budget, expansions + extra)
            continue
        dynamic = node.dynamic
        node_key = (dynamic, node_tasks)
        g = -node.neg_g
        if improving is not None:
            # Again only if reached more cheaply: a cheaper plan may pass through it.
            if best_g.get(node_key, _INF) <= g:
                continue
            best_g[node_key] = g
        else:
            count = popped.get(node_key, 0)
            if count >= k:
                continue
            popped[node_key] = count + 1
        if prune is not None and (node.step is not None or node is root) and prune(node_tasks, dynamic):
            continue  # nothing below the list reaches its tasks (design §7.2, step 7)
        expansions += 1
        task = node_tasks[0]
        record = node.records[0]
        rest_t = node_tasks[1:]
        rest_r = node.records[1:]
        # A key may be expanded up to K times: its successors are worked out once.
        if task.name in operators:
            if reuse:
                cache_key = (dynamic, task)
                applied = primitive_cache.get(cache_key)
                if applied is None:
                    st = State(static, dynamic, dyn_preds)
                    applied = primitive_cache[cache_key] = _apply_task(domain, ground_actions, st, task)
            else:
                # The usual case inline: a ground action met before, of a one-operator task,
                # its precondition made ground (no State made).
                action_of = known(task) if len(operators[task.name]) == 1 else None
                if action_of is not None and action_of.checks is not None:
                    after = action_of.after(dynamic, static_facts, dyn_preds)
                    applied = [] if after is None else [(task, action_of.cost, after)]
                else:
                    applied = _apply_task(domain, ground_actions, State(static, dynamic, dyn_preds), task)
            for action, c, dyn in applied:
                if avoid and action in avoid and dynamic == state.dynamic:
                    continue
                if check_loops and _revisits(node, dyn, rest_t):
                    continue
                if support is not None and support.lost_after_action(action, dynamic, dyn, rest_t):
                    continue
                child_g = g + c
                if bounded and child_g + lb(rest_t) >= bound:
                    continue
                h = 0.0 if new_only else h_of(rest_t, dyn, None)
                if h == _INF:
                    continue
                step = (action, c, record)
                f = node.f - 1.0 if dfs else child_g * wg + h
                heappush(
                    heap,
                    _new(_Node, (f, -child_g, next(counter), dyn, rest_t, rest_r, step, node)),
                )
            continue
        st = State(static, dynamic, dyn_preds)
        if lazy:
            for method_name, run in runs_of(task.name):
                ways = run(task, st)
                first_way = next(ways, None) if dropped is None else next_kept(ways, task, dynamic, rest_t)
                if first_way is None:
                    continue
                child_tasks = first_way + rest_t
                if len(child_tasks) > max_tasks and too_long(len(child_tasks), node):
                    continue
                if bounded and g + lb(child_tasks) >= bound:
                    continue  # every way alike: the same names
                # The same for every way: the same names.
                h = h_of(first_way if new_only else child_tasks, dynamic, st)
                if h == _INF:
                    continue
                f = node.f - 1.0 if dfs else g * wg + h
                rec = _new(_Pending, (task, method_name, record))
                child_records = (rec,) * len(first_way) + rest_r
                seq, later = sorted((next(counter), next(counter)))
                # One step ahead tells the ways apart; the ways to come keep the f they share.
                extra = 0.0 if one_step is None else one_step.extra(child_tasks, dynamic)
                if extra != _INF:
                    heappush(
                        heap,
                        _new(_Node, (f + extra, -g, seq, dynamic, child_tasks, child_records, None, node)),
                    )
                more_entry = (f, -g, later, ways, node, task, method_name, record, rest_t, rest_r)
                heappush(heap, _new(_More, more_entry))
            continue
        if reuse:
            cache_key = (dynamic, task)
            decompositions = compound_cache.get(cache_key)
            if decompositions is None:
                decompositions = compound_cache[cache_key] = _methods_ways(domain, st, task, compiled, ground)
        else:
            decompositions = _methods_ways(domain, st, task, compiled, ground)
        # An expansion that makes hundreds of ways (a guided search binding a dozen
        # parameters by type: Woodworking's) is worth as much as hundreds of nodes: the
        # next node reads the clock, so a search under a limit or a portfolio's pacing
        # never waits for the next 256 of them.
        if sum(len(listed) for _, listed in decompositions) > every:
            ticks |= every
        for method_name, listed in decompositions:
            for subtasks in listed:
                rec = _new(_Pending, (task, method_name, record))
                child_tasks = subtasks + rest_t
                if len(child_tasks) > max_tasks and too_long(len(child_tasks), node):
                    continue
                if bounded and g + lb(child_tasks) >= bound:
                    continue
                # The estimate first: where it drops most ways (a grounded one, of ways bound
                # by type to subtasks nothing can do), the goal's check is then spared.
                h = h_of(subtasks if new_only else child_tasks, dynamic, st)
                if h == _INF:
                    continue
                if dropped is not None and dropped(task, dynamic, child_tasks):
                    continue
                child_records = (rec,) * len(subtasks) + rest_r
                f = node.f - 1.0 if dfs else g * wg + h
                heappush(
                    heap,
                    _new(_Node, (f, -g, next(counter), dynamic, child_tasks, child_records, None, node)),
                )
    # Tidying (rollback(A), A -> resume(A)) can make a later plan cheaper.
    found.sort(key=lambda p: p.cost)
    if ended is not None:  # out of budget or time
        status = ended
    elif found:
        status = PlanStatus.SOLVED
    elif timed_out:  # out of time among a method's ways, its node the last on the list
        status = PlanStatus.INTERRUPTED if stop.requested or halted else PlanStatus.TIMED_OUT
    elif heap or cut:
        status = PlanStatus.BUDGET_EXHAUSTED
    else:
        status = PlanStatus.UNSOLVABLE  # (under the bound, if one was given)
    exhausted = ended is None and not heap and not cut and not timed_out
    seconds = time.perf_counter() - started
    if seconds > LET_GO_AFTER:
        # What the search made goes to the graveyard to be freed there: this frame keeps
        # no reference to it, so its answer does not wait for the freeing.
        seen_ahead = {} if one_step is None else one_step.let_go()
        _GRAVEYARD.bury((heap, popped, best_g, h_cache, primitive_cache, compound_cache, seen_ahead))
        heap, popped, best_g, h_cache, primitive_cache, compound_cache = [], {}, {}, {}, {}, {}
    return PlanResult(status, tuple(found), expansions, seconds, exhausted)


def _apply_task(
    domain: Domain, actions: Actions, st: State, task: Atom
) -> list[tuple[Atom, float, frozenset[Atom]]]:
    """The ways to apply a primitive task: (action, cost, dynamic facts after)."""
    operators = domain.operators[task.name]
    if len(operators) == 1:
        compiled = actions.known(task)  # a ground action met before, if it is one
        if compiled is None and task.is_ground:
            compiled = actions.compiled_or_none(task)
            if compiled is None:
                return []  # e.g. rollback(A) for an A of another domain: a dead end, not an error
        if compiled is not None:
            dynamic = compiled.apply_dynamic(st)
            return [] if dynamic is None else [(task, compiled.cost, dynamic)]
    out = []
    for op in domain.operators[task.name]:
        hb = _unify_head(op.head, task)
        if hb is None:
            continue
        b = op.applicable(st, hb)
        if b is None:
            continue
        action = substitute(op.head, b)
        out.append((action, op.action_cost(action), op.effects_on(st.dynamic, b)))
    return out


_Compiled = dict[str, list[tuple[str, bool, Decomposer]]]
"""A search's compiled methods by task name: name, whether its ways all differ, function."""


def _decompose(domain: Domain, st: State, task: Atom) -> list[tuple[str, tuple[Atom, ...]]]:
    """The ways to decompose a compound task: (method name, subtasks), without repeats."""
    return [(name, subtasks) for name, ways in _methods_ways(domain, st, task) for subtasks in ways]


def _methods_ways(
    domain: Domain,
    st: State,
    task: Atom,
    compiled: _Compiled | None = None,
    ground: Decompositions | None = None,
) -> list[tuple[str, list[tuple[Atom, ...]]]]:
    """:func:`_decompose`, by method: each method's name and its subtask lists, in order.

    ``compiled`` keeps the task's compiled methods for the next call (one search: the
    same dynamic predicates throughout); ``ground`` decomposes some methods in place of
    their lifted form (:attr:`PlannerSettings.decompositions`).
    """
    methods = compiled.get(task.name) if compiled is not None else None
    if methods is None:
        dyn = st.dynamic_predicates
        ground = ground or {}
        methods = [
            (m.name, m.distinct, ground[m] if m in ground else m.compiled(dyn))
            for m in domain.methods.get(task.name, ())
        ]
        if compiled is not None:
            compiled[task.name] = methods
    found = [(name, distinct, ways) for name, distinct, run in methods if (ways := run(task, st))]
    if len(found) == 1 and found[0][1]:
        name, _, ways = found[0]  # one method, whose ways all differ: nothing to remove
        return [(name, ways)]
    out: list[tuple[str, list[tuple[Atom, ...]]]] = []
    seen: set[tuple[Atom, ...]] = set()
    for name, _, ways in found:
        kept = []
        for subtasks in ways:
            if subtasks not in seen:
                seen.add(subtasks)
                kept.append(subtasks)
        if kept:
            out.append((name, kept))
    return out


def _lazy(run: Decomposer) -> LazyDecomposer:
    """A decomposer as a lazy one: its list, one way at a time."""
    return lambda task, st: iter(run(task, st))


def heuristic(domain: Domain, tasks: Sequence[Atom], state: State) -> float:
    """A*'s estimate of the cost of the task list: the first compound task's estimate.

    Estimates are computed from the current state, which is right for the first
    compound task only: adding those of later tasks (as if each started here)
    could over-estimate — ``[goto(A), goto(B)]`` costs d(here,A) + d(A,B), not
    d(here,A) + d(here,B) — and an over-estimate costs A* its optimality.  0 when
    the first compound task has no estimate.  (The search inlines the same rule,
    caching it per node.)
    """
    est = domain.estimates
    if not est:
        return 0.0
    methods = domain.methods
    for t in tasks:
        fn = est.get(t.name)
        if fn is not None:
            return fn(t, state)
        if t.name in methods:
            return 0.0  # a compound task without an estimate comes first
    return 0.0


def _unify_head(head: Atom, task: Atom) -> Bindings | None:
    return unify(head, task, {})


def achieved_by_nothing(domain: Domain, state: State, task: Atom, budget: int = 10_000) -> bool:
    """Whether the task decomposes to no action at all from the state (docs/design.md §2.8).

    Such a task is achieved now.  Only decompositions are explored (the state never
    changes), so this is a small search over method choices; past ``budget`` task
    lists it answers False, which costs at most a needless plan from scratch.
    """
    if domain.is_primitive(task):
        return False
    seen: set[tuple[Atom, ...]] = set()
    frontier: list[tuple[Atom, ...]] = [(task,)]
    while frontier and len(seen) < budget:
        tasks = frontier.pop()
        if not tasks:
            return True
        if tasks in seen or domain.is_primitive(tasks[0]):
            continue
        seen.add(tasks)
        for _, subtasks in _decompose(domain, state, tasks[0]):
            frontier.append(subtasks + tasks[1:])
    return False
