"""The definition of a planning domain: operators, methods, estimates, and the :class:`Domain`.

A :class:`Domain` is built step by step — it is a **mutable builder** — with
:meth:`Domain.operator`, :meth:`Domain.method` and :meth:`Domain.estimate`; what
it is made of (:class:`Method` here; :class:`~htnagent.model.operators.Operator`, and the
:class:`~htnagent.model.operators.Suspension` / :class:`~htnagent.model.operators.Effect`
declarations behind resume and rollback, in :mod:`htnagent.model.operators`) are
immutable values that check themselves when built.  A method reads as "when this holds, do these
subtasks" (docs/design.md §1)::

    d = Domain("nav")
    d.operator("move(?f,?t,?a)", pre=["at(?f)", "arc(?f,?t,?a)"],
               add=["at(?t)"], delete=["at(?f)"], cost=1.0)
    d.method("goto(?n)", "arrived", when=["at(?n)"], do=[])
    d.method("goto(?n)", "step", when=["not at(?n)", "at(?x)", "arc(?x,?y,?a)"],
             do=["move(?x,?y,?a)", "goto(?n)"])

Besides what was declared, a domain keeps two caches, both emptied whenever an
operator is added: the set of dynamic predicates, and ``domain.actions`` (an
:class:`~htnagent.model.actions.Actions`: ground actions compiled once, and what each
does to a belief).  For convenience the domain forwards the belief transitions
to it (:meth:`Domain.apply`, :meth:`~Domain.progress`, :meth:`~Domain.suspend`,
:meth:`~Domain.clear`, :meth:`~Domain.can_suspend`); their meaning is defined in
:mod:`htnagent.model.actions`.

Related modules: beliefs are :mod:`htnagent.model.state`, precondition literals and
their matching :mod:`htnagent.model.preconditions`, A*'s estimate over a task list is
:func:`htnagent.planning.planner.heuristic`.  The names of the model a domain's author
needs (operators, states, literals) are importable from here too, so one import serves.
"""

from __future__ import annotations

from collections.abc import Callable, Iterable
from dataclasses import dataclass, field
from typing import TypeVar

from htnagent.errors import DomainError
from htnagent.model.actions import RECOVERY, RESUME, ROLLBACK, Actions, CompiledAction, action_recovered_by
from htnagent.model.operators import CostSpec, Effect, Operator, Suspension
from htnagent.model.preconditions import (
    Decomposer,
    LazyDecomposer,
    Literal,
    all_satisfiers,
    bound_by,
    compile_method,
    compile_method_lazy,
    literals,
    satisfiers,
)
from htnagent.model.state import FactBase, State
from htnagent.model.terms import Atom, atom, is_variable

_F = TypeVar("_F")

_STARTS = 16
"""Start nodes a domain keeps its start belief for (the oldest is forgotten first)."""

Estimate = Callable[[Atom, State], float]
"""A compound task's estimate of the cost left, from a state (A*'s h; admissible if it
never over-estimates)."""


@dataclass(frozen=True, slots=True)
class Method:
    """A way to decompose a compound task: when ``pre`` holds, do ``subtasks``."""

    head: Atom
    name: str
    pre: tuple[Literal, ...] = ()
    subtasks: tuple[Atom, ...] = ()
    distinct: bool = field(init=False, repr=False, compare=False)
    """Two ways the precondition holds never give the same subtasks: every variable it
    binds appears in them (so :meth:`subtasks_in` has no repeats to remove)."""
    _compiled: dict[frozenset[str], Decomposer] = field(
        default_factory=dict, init=False, repr=False, compare=False
    )
    _lazy: dict[frozenset[str], LazyDecomposer] = field(
        default_factory=dict, init=False, repr=False, compare=False
    )

    def __post_init__(self) -> None:
        known = self.head.variables() | bound_by(self.pre)
        used: set[str] = set()
        for t in self.subtasks:
            unknown = t.variables() - known
            if unknown:
                raise DomainError(
                    f"method {self.name} of {self.head}: subtask {t} uses unbound {sorted(unknown)}"
                )
            used |= t.variables()
        object.__setattr__(self, "distinct", bound_by(self.pre) - self.head.variables() <= used)

    def subtasks_in(self, task: Atom, state: State) -> list[tuple[Atom, ...]]:
        """The subtask lists for ``task`` in ``state``: one for each way the precondition
        holds, in SHOP's order (that of :func:`~htnagent.model.preconditions.all_satisfiers`);
        none when the head does not match the task.

        The head and precondition are compiled once per set of dynamic predicates
        (docs/design.md §1: the planner decomposes at every search step).
        """
        return self.compiled(state.dynamic_predicates)(task, state)

    def compiled(self, dynamic_predicates: frozenset[str]) -> Decomposer:
        """:meth:`subtasks_in` for states with these dynamic predicates, as one function
        (made once; see :func:`~htnagent.model.preconditions.compile_method`)."""
        return self._once(self._compiled, compile_method, dynamic_predicates)

    def compiled_lazy(self, dynamic_predicates: frozenset[str]) -> LazyDecomposer:
        """:meth:`compiled` as a generator (see :func:`~htnagent.model.preconditions.compile_method_lazy`)."""
        return self._once(self._lazy, compile_method_lazy, dynamic_predicates)

    def _once(
        self,
        made: dict[frozenset[str], _F],
        compile_as: Callable[..., _F],
        dynamic: frozenset[str],
    ) -> _F:
        run = made.get(dynamic)
        if run is None:
            label = f"method {self.name} of {self.head}"
            run = made[dynamic] = compile_as(self.head, self.pre, self.subtasks, dynamic, label=label)
        return run

    def __str__(self) -> str:
        return f"{self.name}: when {', '.join(map(str, self.pre)) or 'always'} do " + (
            ", ".join(map(str, self.subtasks)) or "nothing"
        )


@dataclass(slots=True)
class Domain:
    """Operators, methods and estimates of one planning agent, by task name — a mutable builder.

    Build it with :meth:`operator`, :meth:`method` and :meth:`estimate`, and set
    :attr:`facts` / :attr:`world_facts` for the start belief.  ``actions`` (read
    only) holds the ground actions met so far and answers what they do.
    """

    name: str
    operators: dict[str, list[Operator]] = field(default_factory=dict)
    methods: dict[str, list[Method]] = field(default_factory=dict)
    estimates: dict[str, Estimate] = field(default_factory=dict)
    facts: tuple[Atom, ...] = ()
    """Facts the agent believes from the start, whatever the world."""
    world_facts: Callable[[str], Iterable[Atom]] | None = None
    """For map-based domains: the belief about a world whose robot stands at a node."""
    goal_facts: tuple[Atom, ...] = ()
    """Dynamic facts the problem's goal wants at the end (HDDL's ``:goal``): greedy search
    adds the number still missing to its estimate."""
    task_costs: dict[str, float] | None = None
    """The least cost of each task name whatever the state (``inf``: the task can never be
    done).  When set, the planner's estimate of a task list is the sum over its tasks (in
    place of :attr:`estimates`): admissible, and it sees the whole list.  The HDDL
    translation sets it (:mod:`htnagent.planning.hddl_translation`)."""
    actions: Actions = field(init=False, repr=False, compare=False)
    """The ground actions of this domain and what they do (a cache; see :mod:`htnagent.model.actions`)."""
    _dynamic: frozenset[str] | None = field(default=None, repr=False, compare=False)
    _read: tuple[frozenset[str], frozenset[str]] | None = field(default=None, repr=False, compare=False)
    _starts: dict[str | None, tuple[object, object, State]] = field(
        default_factory=dict, init=False, repr=False, compare=False
    )

    def __post_init__(self) -> None:
        self.actions = Actions(self)

    # -- building -------------------------------------------------------------

    def operator(
        self,
        head: str,
        *,
        pre: Iterable[str] = (),
        add: Iterable[str] = (),
        delete: Iterable[str] = (),
        cost: CostSpec = 1.0,
        suspend: Suspension | None = None,
        undo: str | None = None,
    ) -> Operator:
        """Add a primitive task; with ``suspend`` it also gets resume/rollback operators."""
        h = atom(head)
        if h.name in self.methods:
            raise DomainError(f"domain {self.name}: {h.name} is already a compound task")
        if h.name in RECOVERY:
            raise DomainError(f"domain {self.name}: {h.name} is reserved for suspension")
        pre_l = literals(pre)
        resume = rollback = None
        s_add: tuple[Atom, ...] = ()
        s_del: tuple[Atom, ...] = ()
        c_del: tuple[Atom, ...] = ()
        if suspend is not None:
            c_del = tuple(atom(a) for a in suspend.cleared)
            s_add = tuple(atom(a) for a in suspend.add)
            s_del = tuple(atom(a) for a in suspend.delete)
            resume = self._half(h, RESUME, suspend.resume, s_add, cost)
            rollback = self._half(h, ROLLBACK, suspend.rollback, s_add, cost)
        op = Operator(
            head=h,
            pre=pre_l,
            add=tuple(atom(a) for a in add),
            delete=tuple(atom(a) for a in delete),
            cost=cost,
            suspendable=suspend is not None,
            suspend_add=s_add,
            suspend_delete=s_del,
            clear_delete=c_del,
            resume=resume,
            rollback=rollback,
            undo=atom(undo) if undo is not None else None,
        )
        self._register(op)
        for extra in (resume, rollback):
            if extra is not None:
                self._register(extra)
        return op

    def _half(
        self,
        head: Atom,
        kind: str,
        effect: Effect | None,
        suspension_add: tuple[Atom, ...],
        cost: CostSpec,
    ) -> Operator | None:
        """The ``resume(A)`` or ``rollback(A)`` operator (``kind``) of the operator ``head``."""
        if effect is None:
            return None
        pre = literals(effect.pre) if effect.pre is not None else literals(suspension_add)
        return Operator(
            head=Atom(kind, (head,)),
            pre=pre,
            add=tuple(atom(a) for a in effect.add),
            delete=tuple(atom(a) for a in effect.delete),
            cost=_inner_cost(effect.cost if effect.cost is not None else cost),
        )

    def _register(self, op: Operator) -> None:
        self.operators.setdefault(op.name, []).append(op)
        self._dynamic = self._read = None
        self.actions.forget()

    def method(
        self, head: str | Atom, name: str, *, when: Iterable[str] = (), do: Iterable[str | Atom] = ()
    ) -> Method:
        """Add a method: to do ``head``, when ``when`` holds, do the tasks ``do`` in order
        (each task in the text form or as an atom)."""
        h = atom(head)
        if h.name in self.operators:
            raise DomainError(f"domain {self.name}: {h.name} is already a primitive task")
        m = Method(head=h, name=name, pre=literals(when), subtasks=tuple(atom(t) for t in do))
        self.methods.setdefault(h.name, []).append(m)
        self._read = None
        return m

    def estimate(self, task_name: str, fn: Estimate) -> None:
        """Give the planner an estimate of the cost left in a compound task (A*'s h)."""
        if task_name in self.operators:
            raise DomainError(f"domain {self.name}: {task_name} is primitive; estimate is for compound tasks")
        self.estimates[task_name] = fn

    def initial_state(self, start: str | None = None) -> State:
        """The belief at the start: the domain's own facts plus the world's, if any.

        Made once per start (while :attr:`facts`, :attr:`world_facts` and the operators stay
        as they were) and shared: a state is a value.  Robots of a fleet plan with one domain
        (:meth:`~htnagent.scenario.Scenario.share_domains`); sharing their start belief means
        one static fact base for them all, so what is kept per fact base -- its indexes, an
        action's ways (:mod:`htnagent.model.actions`, kept for a few bases only) -- is made
        once, not once a robot (a 100-robot fleet's parent made its guides' actions' ways
        1,612 times in a museum run; now 24).
        """
        dynamic = self.dynamic_predicates
        kept = self._starts.get(start)
        if kept is not None and kept[0] is self.facts and kept[1] is self.world_facts:
            state = kept[2]
            if state.dynamic_predicates is dynamic:
                return state
        facts: list[Atom] = list(self.facts)
        if self.world_facts is not None and start is not None:
            facts.extend(self.world_facts(start))
        state = State.from_facts(facts, dynamic)
        for _, _, other in self._starts.values():
            if other.dynamic_predicates is dynamic and other.static.facts == state.static.facts:
                state = State(other.static, state.dynamic, dynamic)  # another start, the same map
                break
        if len(self._starts) >= _STARTS:
            self._starts.pop(next(iter(self._starts)))
        self._starts[start] = (self.facts, self.world_facts, state)
        return state

    # -- what was declared ----------------------------------------------------------

    @property
    def dynamic_predicates(self) -> frozenset[str]:
        """Predicates that some operator effect changes; all others are static."""
        if self._dynamic is None:
            names: set[str] = set()
            for ops in self.operators.values():
                for op in ops:
                    for a in (*op.add, *op.delete, *op.suspend_add, *op.suspend_delete):
                        names.add(a.name)
            self._dynamic = frozenset(names)
        return self._dynamic

    def opens_ways(self, before: State, after: State) -> bool:
        """Whether going from ``before`` to ``after`` can make some action or method
        applicable where it was not: a fact appeared whose predicate a precondition
        reads as true, or one went that a precondition reads as false (a door opened).
        A change that cannot do so never makes a plan cheaper than one still valid."""
        if self._read is None:
            positive: set[str] = set()
            negative: set[str] = set()
            pres = [m.pre for ms in self.methods.values() for m in ms]
            for ops in self.operators.values():
                for op in ops:
                    pres += [o.pre for o in (op, op.resume, op.rollback) if o is not None]
            for pre in pres:
                for lit in pre:
                    (positive if lit.positive else negative).add(lit.atom.name)
            self._read = (frozenset(positive), frozenset(negative))
        positive_read, negative_read = self._read
        came = before.dynamic ^ after.dynamic
        if after.static is not before.static:
            came |= before.static.facts ^ after.static.facts
        return any(f.name in (negative_read if before.holds(f) else positive_read) for f in came)

    def is_primitive(self, task: Atom) -> bool:
        """Whether the task is an action (some operator implements it)."""
        return task.name in self.operators

    def knows(self, task: Atom) -> bool:
        """Whether some operator or method can handle a task of this name."""
        return task.name in self.operators or task.name in self.methods

    def recovery_operators(self) -> list[Operator]:
        """Every resume and rollback operator (tried by the planner first, see planner)."""
        return [op for name in RECOVERY for op in self.operators.get(name, ())]

    # -- belief transitions, forwarded to ``actions`` (defined in htnagent.model.actions) ----------

    def apply(self, state: State, action: Atom) -> State | None:
        """The state after the action, or None when its precondition is false."""
        return self.actions.apply(state, action)

    def progress(self, state: State, action: Atom) -> State:
        """The state after an action the executor reports done (see :meth:`Actions.progress`)."""
        return self.actions.progress(state, action)

    def suspend(self, state: State, action: Atom) -> State:
        """The belief after the running action is stopped half way (see :meth:`Actions.suspend`)."""
        return self.actions.suspend(state, action)

    def clear(self, state: State, action: Atom) -> State:
        """The belief once a suspended action will never be resumed (see :meth:`Actions.clear`)."""
        return self.actions.clear(state, action)

    def can_suspend(self, action: Atom) -> bool:
        """Whether the belief can follow the action being stopped half way (:meth:`Actions.can_suspend`)."""
        return self.actions.can_suspend(action)


def _inner_cost(cost: CostSpec) -> CostSpec:
    """A resume/rollback cost function receives ``resume(A)``; hand it A instead."""
    if callable(cost):
        fn = cost

        def inner(action: Atom) -> float:
            a = action.args[0]
            return fn(a if isinstance(a, Atom) else action)

        return inner
    return cost


# Besides its own names, the module exports those of the model's other modules that a
# domain's author needs (Operator, Suspension, State, Literal, satisfiers, action_recovered_by...).
__all__ = [
    "Atom",
    "CompiledAction",
    "CostSpec",
    "Domain",
    "Effect",
    "Estimate",
    "FactBase",
    "Literal",
    "Method",
    "Operator",
    "State",
    "Suspension",
    "action_recovered_by",
    "all_satisfiers",
    "is_variable",
    "satisfiers",
]
