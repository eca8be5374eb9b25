"""The domain model: facts and states, operators, methods and the :class:`Domain`.

Everything here is an immutable value that checks itself when built.  A method
reads as "when this holds, do these subtasks"::

    d = Domain("nav")
    d.operator("move(?f,?t,?a)", pre=["at(?f)", "arc(?f,?t,?a)"],
               add=["at(?t)"], delete=["at(?f)"], cost=1.0)
    d.method("goto(?n)", "arrived", when=["at(?n)"], do=[])
    d.method("goto(?n)", "step", when=["not at(?n)", "at(?x)", "arc(?x,?y,?a)"],
             do=["move(?x,?y,?a)", "goto(?n)"])

States split facts into *static* ones (predicates no operator changes, such as
the map) kept in an indexed :class:`FactBase` shared between states, and
*dynamic* ones (predicates some effect changes) kept in a small frozenset, so
that applying an action copies only what actions can change.
"""

from __future__ import annotations

import itertools
from collections import defaultdict
from collections.abc import Callable, Iterable, Iterator, Sequence
from dataclasses import dataclass, field

from htnagent.errors import DomainError, PlanningError
from htnagent.terms import Atom, Bindings, Term, atom, is_variable, substitute, unify

CostSpec = float | int | Callable[[Atom], float]
Estimate = Callable[[Atom, "State"], float]


class FactBase:
    """An immutable set of ground facts, indexed by predicate and argument on demand.

    Facts keep the order they were given in: SHOP tries them in that order, so ties
    between equal-cost plans are broken the same way in every run.
    """

    __slots__ = ("_by_arg", "_by_name", "_facts", "_indexed", "_order")

    def __init__(self, facts: Iterable[Atom] = ()) -> None:
        self._order: tuple[Atom, ...] = tuple(dict.fromkeys(facts))
        self._facts: frozenset[Atom] = frozenset(self._order)
        self._by_name: dict[str, list[Atom]] | None = None
        self._by_arg: dict[tuple[str, int, Term], list[Atom]] = {}
        self._indexed: set[tuple[str, int]] = set()

    def __contains__(self, fact: object) -> bool:
        return fact in self._facts

    def __iter__(self) -> Iterator[Atom]:
        return iter(self._order)

    def __len__(self) -> int:
        return len(self._facts)

    @property
    def facts(self) -> frozenset[Atom]:
        """The facts as a frozenset."""
        return self._facts

    def with_changes(self, add: Iterable[Atom] = (), delete: Iterable[Atom] = ()) -> FactBase:
        """A new fact base with ``delete`` removed and ``add`` added."""
        gone = frozenset(delete)
        return FactBase(itertools.chain((f for f in self._order if f not in gone), add))

    def candidates(self, name: str, position: int | None, value: Term) -> list[Atom]:
        """Facts named ``name`` (whose argument ``position`` is ``value``, if given)."""
        if self._by_name is None:
            by_name: dict[str, list[Atom]] = defaultdict(list)
            for f in self._order:
                by_name[f.name].append(f)
            self._by_name = dict(by_name)
        if position is None:
            return self._by_name.get(name, [])
        if (name, position) not in self._indexed:
            self._indexed.add((name, position))
            for f in self._by_name.get(name, []):
                if position < len(f.args):
                    self._by_arg.setdefault((name, position, f.args[position]), []).append(f)
        return self._by_arg.get((name, position, value), [])


class State:
    """A belief: static facts (shared, indexed) plus dynamic facts (small, per state)."""

    __slots__ = ("dynamic", "dynamic_predicates", "static")

    def __init__(
        self, static: FactBase, dynamic: frozenset[Atom], dynamic_predicates: frozenset[str]
    ) -> None:
        self.static = static
        self.dynamic = dynamic
        self.dynamic_predicates = dynamic_predicates

    @classmethod
    def from_facts(cls, facts: Iterable[Atom | str], domain: Domain) -> State:
        """Split ``facts`` into static and dynamic parts as the domain's effects dictate."""
        parsed = [atom(f) for f in facts]
        dyn = domain.dynamic_predicates
        return cls(
            FactBase(f for f in parsed if f.name not in dyn),
            frozenset(f for f in parsed if f.name in dyn),
            dyn,
        )

    def key(self) -> tuple[object, ...]:
        """What tells this belief from others, cheaply: its dynamic facts and its static
        fact base by identity (a fact base compares by identity; the key keeps it alive)."""
        return (self.dynamic, self.static)

    def holds(self, fact: Atom) -> bool:
        """Whether the ground fact is true in this state."""
        if fact.name in self.dynamic_predicates:
            return fact in self.dynamic
        return fact in self.static

    def with_dynamic(self, dynamic: frozenset[Atom]) -> State:
        """The same static facts with other dynamic facts."""
        return State(self.static, dynamic, self.dynamic_predicates)

    def updated(self, add: Iterable[Atom] = (), delete: Iterable[Atom] = ()) -> State:
        """A new state with facts deleted then added (a belief change from outside)."""
        add, delete = list(add), list(delete)
        dyn = self.dynamic_predicates
        static = self.static
        s_add = [f for f in add if f.name not in dyn]
        s_del = [f for f in delete if f.name not in dyn]
        if s_add or s_del:
            static = static.with_changes(s_add, s_del)
        d_del = frozenset(f for f in delete if f.name in dyn)
        d_add = frozenset(f for f in add if f.name in dyn)
        return State(static, (self.dynamic - d_del) | d_add, dyn)

    def facts(self) -> frozenset[Atom]:
        """Every fact of the state."""
        return self.static.facts | self.dynamic

    def match(self, pattern: Atom, bindings: Bindings) -> Iterator[Bindings]:
        """Every extension of ``bindings`` under which ``pattern`` is a fact of the state."""
        if pattern.name in self.dynamic_predicates:
            found = [f for f in self.dynamic if f.name == pattern.name]
            if len(found) > 1:
                # A frozenset's order changes with the hash seed: bind in text order instead.
                found.sort(key=str)
            for f in found:
                b = unify(pattern, f, bindings)
                if b is not None:
                    yield b
            return
        position: int | None = None
        value: Term = ""
        for i, a in enumerate(pattern.args):
            if isinstance(a, str):
                if a.startswith("?"):
                    bound = bindings.get(a)
                    if bound is None:
                        continue
                    a = bound
                position, value = i, a
                break
        for f in self.static.candidates(pattern.name, position, value):
            b = unify(pattern, f, bindings)
            if b is not None:
                yield b

    def __eq__(self, other: object) -> bool:
        return (
            isinstance(other, State)
            and self.dynamic == other.dynamic
            and (self.static is other.static or self.static.facts == other.static.facts)
        )

    def __hash__(self) -> int:
        return hash(self.dynamic)

    def __repr__(self) -> str:
        return f"State(dynamic={sorted(map(str, self.dynamic))}, static={len(self.static)} facts)"


@dataclass(frozen=True, slots=True)
class Literal:
    """A positive or negated atom in a precondition."""

    atom: Atom
    positive: bool = True
    variables: frozenset[str] = field(init=False, repr=False, compare=False)

    def __post_init__(self) -> None:
        object.__setattr__(self, "variables", frozenset(self.atom.variables()))

    @classmethod
    def parse(cls, text: str | Literal | Atom) -> Literal:
        """Read ``"at(?x)"`` or ``"not at(?x)"``."""
        if isinstance(text, Literal):
            return text
        if isinstance(text, Atom):
            return cls(text)
        stripped = text.strip()
        if stripped.startswith("not "):
            return cls(atom(stripped[4:].strip()), positive=False)
        return cls(atom(stripped))

    def __str__(self) -> str:
        return str(self.atom) if self.positive else f"not {self.atom}"


def satisfiers(
    pre: Sequence[Literal], state: State, bindings: Bindings, start: int = 0
) -> Iterator[Bindings]:
    """Every binding under which the conjunction holds, SHOP-style, left to right.

    A negative literal holds when no fact matches it under the bindings so far.
    """
    # Literals whose variables are all bound are plain look-ups: check them in a row.
    n = len(pre)
    i = start
    while i < n:
        lit = pre[i]
        names = lit.variables
        if names and not all(v in bindings for v in names):
            break
        fact = substitute(lit.atom, bindings) if names else lit.atom
        if state.holds(fact) != lit.positive:
            return
        i += 1
    if i == n:
        yield bindings
        return
    lit = pre[i]
    if lit.positive:
        for b in state.match(lit.atom, bindings):
            yield from satisfiers(pre, state, b, i + 1)
    else:
        if next(state.match(lit.atom, bindings), None) is not None:
            return
        yield from satisfiers(pre, state, bindings, i + 1)


def all_satisfiers(pre: Sequence[Literal], state: State, bindings: Bindings) -> list[Bindings]:
    """Every binding of :func:`satisfiers`, as a list, in the same order — its fast form.

    The planner decomposes with it at every search step: no generators, and flat
    facts are matched argument by argument without building atoms.
    """
    out: list[Bindings] = []
    _collect(pre, 0, state, bindings, out)
    return out


def _collect(pre: Sequence[Literal], i: int, state: State, bindings: Bindings, out: list[Bindings]) -> None:
    n = len(pre)
    while i < n:
        lit = pre[i]
        names = lit.variables
        if names and not names <= bindings.keys():
            break
        fact = substitute(lit.atom, bindings) if names else lit.atom
        if state.holds(fact) != lit.positive:
            return
        i += 1
    if i == n:
        out.append(bindings)
        return
    lit = pre[i]
    if not lit.positive:
        if next(state.match(lit.atom, bindings), None) is None:
            _collect(pre, i + 1, state, bindings, out)
        return
    pattern = lit.atom
    args = pattern.args
    if any(not isinstance(a, str) for a in args):
        for b in state.match(pattern, bindings):
            _collect(pre, i + 1, state, b, out)
        return
    # Flat pattern: each argument is a constant, a bound variable or a free one.
    wanted: list[tuple[int, Term]] = []
    free: list[tuple[int, str]] = []
    for k, a in enumerate(args):
        assert isinstance(a, str)
        if a[:1] == "?":
            value = bindings.get(a)
            if value is None:
                free.append((k, a))
            else:
                wanted.append((k, value))
        else:
            wanted.append((k, a))
    name, arity = pattern.name, len(args)
    if name in state.dynamic_predicates:
        facts: Iterable[Atom] = sorted((f for f in state.dynamic if f.name == name), key=str)
    elif wanted:
        facts = state.static.candidates(name, wanted[0][0], wanted[0][1])
    else:
        facts = state.static.candidates(name, None, "")
    for f in facts:
        fargs = f.args
        if len(fargs) != arity or any(fargs[k] != v for k, v in wanted):
            continue
        b = dict(bindings)
        ok = True
        for k, var in free:
            seen = b.get(var)
            if seen is None:
                b[var] = fargs[k]
            elif seen != fargs[k]:  # the same free variable twice in the pattern
                ok = False
                break
        if ok:
            _collect(pre, i + 1, state, b, out)


def _literals(items: Iterable[str | Literal | Atom]) -> tuple[Literal, ...]:
    return tuple(Literal.parse(i) for i in items)


def _bound_by(pre: Sequence[Literal]) -> set[str]:
    out: set[str] = set()
    for lit in pre:
        if lit.positive:
            out |= lit.atom.variables()
    return out


@dataclass(frozen=True, slots=True)
class Effect:
    """Precondition, effects and cost of a resume or rollback operator."""

    add: tuple[str, ...] = ()
    delete: tuple[str, ...] = ()
    pre: tuple[str, ...] | None = None
    cost: CostSpec | None = None


@dataclass(frozen=True, slots=True)
class Suspension:
    """What stopping an action half way does, and how to finish or undo the half.

    ``add``/``delete`` are the suspension effect on the belief (applied to the
    state before the action); ``resume`` and ``rollback`` describe the operators
    ``resume(A)`` and ``rollback(A)``, whose precondition defaults to the facts
    the suspension added.  ``cleared`` names the facts that only record that A
    can be resumed — they leave the belief when the suspension is cleared —
    as opposed to facts about the world (a robot on an arc stays there).
    """

    add: tuple[str, ...] = ()
    delete: tuple[str, ...] = ()
    resume: Effect | None = None
    rollback: Effect | None = None
    cleared: tuple[str, ...] = ()


@dataclass(frozen=True, slots=True)
class Operator:
    """A primitive task: precondition, add and delete effects, cost.

    For suspension it may carry ``suspend_add``/``suspend_delete`` (the suspension
    effect), ``resume``/``rollback`` operators and an ``undo`` pattern naming the
    inverse action.
    """

    head: Atom
    pre: tuple[Literal, ...] = ()
    add: tuple[Atom, ...] = ()
    delete: tuple[Atom, ...] = ()
    cost: CostSpec = 1.0
    suspendable: bool = False
    suspend_add: tuple[Atom, ...] = ()
    suspend_delete: tuple[Atom, ...] = ()
    clear_delete: tuple[Atom, ...] = ()
    resume: Operator | None = None
    rollback: Operator | None = None
    undo: Atom | None = None

    def __post_init__(self) -> None:
        known = self.head.variables() | _bound_by(self.pre)
        for part, items in (
            ("add", self.add),
            ("delete", self.delete),
            ("suspension add", self.suspend_add),
            ("suspension delete", self.suspend_delete),
            ("suspension cleared", self.clear_delete),
        ):
            for a in items:
                unknown = a.variables() - known
                if unknown:
                    raise DomainError(
                        f"operator {self.head}: {part} effect {a} uses unbound {sorted(unknown)}"
                    )
        if self.undo is not None and self.undo.variables() - self.head.variables():
            raise DomainError(f"operator {self.head}: undo {self.undo} uses unbound variables")
        if isinstance(self.cost, int | float) and self.cost < 0:
            raise DomainError(f"operator {self.head}: negative cost {self.cost}")

    @property
    def name(self) -> str:
        """The task name this operator implements."""
        return self.head.name

    def action_cost(self, action: Atom) -> float:
        """The cost of the ground action."""
        c = self.cost
        value = float(c(action)) if callable(c) else float(c)
        if value < 0:
            raise DomainError(f"operator {self.head}: negative cost {value} for {action}")
        return value

    def applicable(self, state: State, bindings: Bindings) -> Bindings | None:
        """The first binding that satisfies the precondition, or None."""
        return next(satisfiers(self.pre, state, bindings), None)

    def progress(self, dynamic: frozenset[Atom], bindings: Bindings) -> frozenset[Atom]:
        """The dynamic facts after the action's delete then add effects."""
        return _apply(dynamic, self.delete, self.add, bindings)

    def suspended(self, dynamic: frozenset[Atom], bindings: Bindings) -> frozenset[Atom]:
        """The dynamic facts after the action is stopped half way (suspension effect)."""
        return _apply(dynamic, self.suspend_delete, self.suspend_add, bindings)


def _apply(
    dynamic: frozenset[Atom],
    delete: tuple[Atom, ...],
    add: tuple[Atom, ...],
    bindings: Bindings,
) -> frozenset[Atom]:
    if not delete and not add:
        return dynamic
    out = set(dynamic)
    for d in delete:
        out.discard(substitute(d, bindings))
    for a in add:
        out.add(substitute(a, bindings))
    return frozenset(out)


@dataclass(frozen=True, slots=True)
class Method:
    """A way to decompose a compound task: when ``pre`` holds, do ``subtasks``."""

    head: Atom
    name: str
    pre: tuple[Literal, ...] = ()
    subtasks: tuple[Atom, ...] = ()

    def __post_init__(self) -> None:
        known = self.head.variables() | _bound_by(self.pre)
        for t in self.subtasks:
            unknown = t.variables() - known
            if unknown:
                raise DomainError(
                    f"method {self.name} of {self.head}: subtask {t} uses unbound {sorted(unknown)}"
                )

    def __str__(self) -> str:
        return f"{self.name}: when {', '.join(map(str, self.pre)) or 'always'} do " + (
            ", ".join(map(str, self.subtasks)) or "nothing"
        )


@dataclass(frozen=True, slots=True)
class CompiledAction:
    """A ground action's operator, bindings, ground precondition and effects, and cost.

    ``checks`` is None when the precondition binds variables the head does not.
    """

    op: Operator
    bindings: Bindings
    checks: tuple[tuple[Atom, bool], ...] | None
    delete: frozenset[Atom]
    add: frozenset[Atom]
    cost: float


@dataclass(slots=True)
class Domain:
    """Operators, methods and estimates of one planning agent, by task name.

    Build it with :meth:`operator`, :meth:`method` and :meth:`estimate`.
    """

    name: str
    operators: dict[str, list[Operator]] = field(default_factory=dict)
    methods: dict[str, list[Method]] = field(default_factory=dict)
    estimates: dict[str, Estimate] = field(default_factory=dict)
    facts: tuple[Atom, ...] = ()
    """Facts the agent believes from the start, whatever the world."""
    world_facts: Callable[[str], Iterable[Atom]] | None = None
    """For map-based domains: the belief about a world whose robot stands at a node."""
    _dynamic: frozenset[str] | None = None
    _ground: dict[Atom, tuple[Operator, Bindings] | None] = field(default_factory=dict)
    _compiled: dict[Atom, CompiledAction] = field(default_factory=dict)

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
        if h.name in ("resume", "rollback"):
            raise DomainError(f"domain {self.name}: {h.name} is reserved for suspension")
        pre_l = _literals(pre)
        resume = rollback = None
        s_add: tuple[Atom, ...] = ()
        s_del: tuple[Atom, ...] = ()
        c_del: tuple[Atom, ...] = ()
        if suspend is not None:
            c_del = tuple(atom(a) for a in suspend.cleared)
            s_add = tuple(atom(a) for a in suspend.add)
            s_del = tuple(atom(a) for a in suspend.delete)
            resume = self._half(h, "resume", suspend.resume, s_add, cost)
            rollback = self._half(h, "rollback", suspend.rollback, s_add, cost)
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
        if effect is None:
            return None
        pre = _literals(effect.pre) if effect.pre is not None else _literals(suspension_add)
        return Operator(
            head=Atom(kind, (head,)),
            pre=pre,
            add=tuple(atom(a) for a in effect.add),
            delete=tuple(atom(a) for a in effect.delete),
            cost=_inner_cost(effect.cost if effect.cost is not None else cost),
        )

    def _register(self, op: Operator) -> None:
        self.operators.setdefault(op.name, []).append(op)
        self._dynamic = None
        self._ground.clear()
        self._compiled.clear()

    def method(self, head: str, name: str, *, when: Iterable[str] = (), do: Iterable[str] = ()) -> Method:
        """Add a method: to do ``head``, when ``when`` holds, do the tasks ``do`` in order."""
        h = atom(head)
        if h.name in self.operators:
            raise DomainError(f"domain {self.name}: {h.name} is already a primitive task")
        m = Method(head=h, name=name, pre=_literals(when), subtasks=tuple(atom(t) for t in do))
        self.methods.setdefault(h.name, []).append(m)
        return m

    def estimate(self, task_name: str, fn: Estimate) -> None:
        """Give the planner an estimate of the cost left in a compound task (A*'s h)."""
        if task_name in self.operators:
            raise DomainError(f"domain {self.name}: {task_name} is primitive; estimate is for compound tasks")
        self.estimates[task_name] = fn

    def initial_state(self, start: str | None = None) -> State:
        """The belief at the start: the domain's own facts plus the world's, if any."""
        facts: list[Atom] = list(self.facts)
        if self.world_facts is not None and start is not None:
            facts.extend(self.world_facts(start))
        return State.from_facts(facts, self)

    # -- queries ----------------------------------------------------------------

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

    def is_primitive(self, task: Atom) -> bool:
        """Whether the task is an action (some operator implements it)."""
        return task.name in self.operators

    def knows(self, task: Atom) -> bool:
        """Whether some operator or method can handle a task of this name."""
        return task.name in self.operators or task.name in self.methods

    def ground(self, action: Atom) -> tuple[Operator, Bindings]:
        """The operator implementing the ground action, and its head bindings."""
        cached = self._ground.get(action, _MISSING)
        if cached is _MISSING:
            cached = None
            for op in self.operators.get(action.name, ()):
                b = unify(op.head, action, {})
                if b is not None:
                    cached = (op, b)
                    break
            self._ground[action] = cached
        if cached is None:
            raise PlanningError(f"domain {self.name}: no operator for action {action}")
        return cached  # type: ignore[return-value]

    def compiled_or_none(self, action: Atom) -> CompiledAction | None:
        """:meth:`compiled`, or None when no operator implements the action."""
        found = self._compiled.get(action)
        if found is not None:
            return found
        if self._ground.get(action, _MISSING) is None:
            return None
        try:
            return self.compiled(action)
        except PlanningError:
            return None

    def compiled(self, action: Atom) -> CompiledAction:
        """The ground action with its precondition and effects worked out once (cached)."""
        found = self._compiled.get(action)
        if found is None:
            op, b = self.ground(action)
            checks: tuple[tuple[Atom, bool], ...] | None = None
            delete: frozenset[Atom] = frozenset()
            add: frozenset[Atom] = frozenset()
            if all(lit.variables <= b.keys() for lit in op.pre):
                checks = tuple((substitute(lit.atom, b), lit.positive) for lit in op.pre)
                delete = frozenset(substitute(a, b) for a in op.delete)
                add = frozenset(substitute(a, b) for a in op.add)
            found = CompiledAction(op, b, checks, delete, add, op.action_cost(action))
            self._compiled[action] = found
        return found

    def known_action(self, action: Atom) -> CompiledAction | None:
        """The compiled ground action if it was compiled before (a plain look-up)."""
        return self._compiled.get(action)

    def step(self, state: State, action: Atom) -> frozenset[Atom] | None:
        """The dynamic facts after the ground action, or None when its precondition is false."""
        return self.step_compiled(state, self.compiled(action))

    def step_compiled(self, state: State, c: CompiledAction) -> frozenset[Atom] | None:
        """:meth:`step` for an action already compiled."""
        if c.checks is None:
            full = c.op.applicable(state, c.bindings)
            return None if full is None else c.op.progress(state.dynamic, full)
        for fact, positive in c.checks:
            if state.holds(fact) != positive:
                return None
        if not c.delete and not c.add:
            return state.dynamic
        return (state.dynamic - c.delete) | c.add

    def apply(self, state: State, action: Atom) -> State | None:
        """The state after the action, or None when its precondition is false."""
        dynamic = self.step(state, action)
        return None if dynamic is None else state.with_dynamic(dynamic)

    def progress(self, state: State, action: Atom) -> State:
        """The state after an action reported done, even if the belief doubted it could run.

        The executor is the authority on what happened: the effects are applied
        with the precondition's bindings when it holds, the head's otherwise.
        """
        op, b = self.ground(action)
        full = op.applicable(state, b) or b
        return state.with_dynamic(op.progress(state.dynamic, full))

    def cost(self, action: Atom) -> float:
        """The cost of a ground action."""
        return self.compiled(action).cost

    def can_suspend(self, action: Atom) -> bool:
        """Whether the belief can follow the ground action being stopped half way.

        True when its operator declares a suspension, and for ``resume(A)`` and
        ``rollback(A)`` of such an A: stopping either leaves A suspended, with
        less (or more) of it left to do (ALGORITHMS.md §4, Algorithm 3).
        """
        target = half_done(action) or action
        try:
            op, _ = self.ground(target)
        except PlanningError:
            return False
        return op.suspendable

    def suspend(self, state: State, action: Atom) -> State:
        """The belief after the running action is stopped half way (Algorithm 1, step 1).

        Stopping ``resume(A)`` or ``rollback(A)`` leaves A suspended as it was before
        they started: the belief already says so, and stays as it is.
        """
        if half_done(action) is not None:
            return state
        op, b = self.ground(action)
        if not op.suspendable:
            raise PlanningError(f"domain {self.name}: action {action} is not suspendable")
        full = next(satisfiers(op.pre, state, b), b)
        return state.with_dynamic(op.suspended(state.dynamic, full))

    def clear(self, state: State, action: Atom) -> State:
        """The belief once a suspended action will never be resumed.

        The facts that only recorded that it could be resumed (its suspension's
        ``cleared``) go; facts about the world stay.
        """
        op, b = self.ground(action)
        gone = {substitute(a, b) for a in op.clear_delete}
        if not gone & state.dynamic:
            return state
        return state.with_dynamic(state.dynamic - gone)

    def undo_of(self, action: Atom) -> Atom | None:
        """The action that undoes a finished action, if the domain declares one."""
        if action.name in ("resume", "rollback"):
            # Undoing a resumed half would not lead back to the half-done state.
            return None
        op, b = self.ground(action)
        return substitute(op.undo, b) if op.undo is not None else None

    def resume_of(self, action: Atom) -> Atom | None:
        """``resume(action)`` when the action's operator can resume."""
        op, _ = self.ground(action)
        return Atom("resume", (action,)) if op.resume is not None else None

    def rollback_of(self, action: Atom) -> Atom | None:
        """``rollback(action)`` when the action's operator can roll back."""
        op, _ = self.ground(action)
        return Atom("rollback", (action,)) if op.rollback is not None else None

    def recovery_operators(self) -> list[Operator]:
        """Every resume and rollback operator (tried by the planner first, see planner)."""
        return [op for name in ("resume", "rollback") for op in self.operators.get(name, ())]

    def h(self, tasks: Sequence[Atom], state: State) -> float:
        """A*'s estimate of the cost of the task list: the first compound task's estimate.

        Estimates are computed from the current state, which is right for the first
        compound task only: adding those of later tasks (as if each started here)
        could over-estimate — ``[goto(A), goto(B)]`` costs d(here,A) + d(A,B), not
        d(here,A) + d(here,B) — and an over-estimate costs A* its optimality.
        """
        est = self.estimates
        if not est:
            return 0.0
        for t in tasks:
            fn = est.get(t.name)
            if fn is not None:
                return fn(t, state)
            if t.name in self.methods:
                return 0.0  # a compound task without an estimate comes first
        return 0.0


_MISSING: object = object()

RECOVERY = ("resume", "rollback")
"""The names of the actions that finish or undo a suspended action."""


def half_done(action: Atom) -> Atom | None:
    """A for ``resume(A)`` or ``rollback(A)``; None for any other action."""
    if action.name in RECOVERY and len(action.args) == 1 and isinstance(action.args[0], Atom):
        return action.args[0]
    return None


def _inner_cost(cost: CostSpec) -> CostSpec:
    """A resume/rollback cost function receives ``resume(A)``; hand it A instead."""
    if callable(cost):
        fn = cost

        def inner(action: Atom) -> float:
            a = action.args[0]
            return fn(a if isinstance(a, Atom) else action)

        return inner
    return cost


__all__ = [
    "Atom",
    "Domain",
    "Effect",
    "FactBase",
    "Literal",
    "Method",
    "Operator",
    "State",
    "Suspension",
    "half_done",
    "is_variable",
    "satisfiers",
]
