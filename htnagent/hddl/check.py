"""An independent checker of HTN plans in the IPC format: our own oracle.

:func:`check_plan` takes a domain and problem (:mod:`htnagent.hddl.model`)
and a plan (:mod:`htnagent.hddl.plan_file`) and lists what is wrong with the
plan -- an empty list when it is valid.  It uses nothing but the model: none
of the planner's code, so it can judge the planner.

What it checks, following pandaPIparser's verifier (the IPC's) for total order:

1. every action line names a declared action with objects of its parameter
   types; every decomposition line a compound task, with objects of its types,
   and a method of that task;
2. the decomposition is a tree: ``root`` lists the problem's ``:htn`` tasks in
   order (its ``:parameters`` bound by the plan), every ID is used once below
   the root, every action and decomposition is reached;
3. each method's subtasks are the listed IDs, in the method's order, with the
   same task names and the arguments one binding of the method's parameters
   gives (each of the parameter's type); parameters named only in the
   precondition may take any value that makes it hold;
4. the actions, left to right, are the leaves of the tree in order (total
   order: no interleaving);
5. replaying the actions from ``:init``: each action's precondition holds when
   it starts, and its effects (``forall``, ``when``: conditions read in the
   state before; deletions first, then additions) give the next state; each
   method's precondition and constraints hold in the state where its first
   action starts (for a method with no actions under it, where it stands in
   the order);
6. the goal holds at the end.

The replay stops at the first action whose precondition fails: the states after
it mean nothing.
"""

from __future__ import annotations

import itertools
from collections.abc import Iterable, Iterator, Mapping, Sequence
from dataclasses import dataclass

from htnagent.hddl.model import (
    And,
    AndEffect,
    Domain,
    Effect,
    Equals,
    Forall,
    ForallEffect,
    Formula,
    Imply,
    Literal,
    Method,
    Not,
    Or,
    Pred,
    Problem,
    SortOf,
    Typed,
)
from htnagent.hddl.plan_file import IpcDecomposition, IpcPlan, IpcStep
from htnagent.model.terms import Atom

__all__ = ["Violation", "check_plan"]

Binding = dict[str, str]
Facts = frozenset[Atom]


@dataclass(frozen=True, slots=True)
class Violation:
    """One thing wrong with a plan: what, and the plan line it is on (0: the plan as a whole)."""

    line: int
    reason: str

    def __str__(self) -> str:
        return f"line {self.line}: {self.reason}" if self.line else self.reason


def check_plan(domain: Domain, problem: Problem, plan: IpcPlan) -> list[Violation]:
    """What is wrong with ``plan`` for ``problem`` in ``domain``; empty when the plan is valid."""
    found = _Checker(domain, problem, plan).run()
    return sorted(found, key=lambda v: v.line or float("inf"))  # stable: the goal, with no line, last


@dataclass(slots=True)
class _MethodCheck:
    """A method's precondition to evaluate once ``position`` actions have been carried out."""

    position: int
    method: Method
    binding: Binding
    line: int
    id: int
    task: Atom


class _World:
    """The objects of a problem and their types."""

    def __init__(self, domain: Domain, problem: Problem) -> None:
        self.domain = domain
        declared: dict[str, set[str]] = {}
        for o in (*domain.constants, *problem.objects):
            declared.setdefault(o.name, set()).update(o.types)
        self.types: dict[str, frozenset[str]] = {
            name: frozenset().union(*(domain.supertypes(t) for t in kinds))
            for name, kinds in declared.items()
        }
        self._of: dict[tuple[str, ...], tuple[str, ...]] = {}

    def fits(self, obj: str, types: Sequence[str]) -> bool:
        """Whether ``obj`` is an object of one of ``types``."""
        kinds = self.types.get(obj)
        return kinds is not None and any(t in kinds for t in types)

    def of(self, types: tuple[str, ...]) -> tuple[str, ...]:
        """The objects of one of ``types``."""
        found = self._of.get(types)
        if found is None:
            found = tuple(o for o in self.types if self.fits(o, types))
            self._of[types] = found
        return found


class _Checker:
    def __init__(self, domain: Domain, problem: Problem, plan: IpcPlan) -> None:
        self.d = domain
        self.p = problem
        self.plan = plan
        self.world = _World(domain, problem)
        self.out: list[Violation] = []
        self.steps: dict[int, IpcStep] = {s.id: s for s in plan.steps}
        self.decs: dict[int, IpcDecomposition] = {x.id: x for x in plan.decompositions}
        self.htn_binding: Binding = {}

    def bad(self, line: int, reason: str) -> None:
        self.out.append(Violation(line, reason))

    def run(self) -> list[Violation]:
        for s in self.plan.steps:
            self.action_line(s)
        for x in self.plan.decompositions:
            if x.id in self.steps:
                self.bad(x.line, f"ID {x.id} is an action (line {self.steps[x.id].line}) and a task")
        checks = self.tree()
        self.replay(checks)
        return self.out

    # -- lines on their own -----------------------------------------------------------------------

    def action_line(self, s: IpcStep) -> None:
        a = self.d.actions.get(s.action.name)
        if a is None:
            kind = "a compound task, not an action" if s.action.name in self.d.tasks else "no declared action"
            self.bad(s.line, f"action {s.id}: {s.action.name} is {kind}")
            return
        self.arguments(s.line, f"action {s.id} ({_text(s.action)})", s.action, a.params)

    def arguments(self, line: int, what: str, call: Atom, params: Sequence[Typed]) -> bool:
        if len(call.args) != len(params):
            self.bad(line, f"{what}: {call.name} takes {len(params)} arguments, given {len(call.args)}")
            return False
        ok = True
        for value, p in zip(call.args, params, strict=True):
            if not isinstance(value, str) or value not in self.world.types:
                self.bad(line, f"{what}: {value} is no object of the problem")
                ok = False
            elif not self.world.fits(value, p.types):
                self.bad(line, f"{what}: {value} is not of type {' or '.join(p.types)} ({p.name})")
                ok = False
        return ok

    # -- the tree ------------------------------------------------------------------------------------

    def call_of(self, ident: int) -> Atom | None:
        step = self.steps.get(ident)
        if step is not None:
            return step.action
        dec = self.decs.get(ident)
        return dec.task if dec is not None else None

    def tree(self) -> list[_MethodCheck]:
        """Check the decomposition; the method preconditions to evaluate during the replay."""
        root_line = self.plan.root_line
        parent: dict[int, int] = {}
        for r in self.plan.root:
            if r in parent:
                self.bad(root_line, f"ID {r} is listed twice as a root task")
            parent[r] = -1
        for x in self.plan.decompositions:
            for c in x.subtasks:
                if c in parent:
                    where = "a root task" if parent[c] == -1 else f"a subtask of {parent[c]} too"
                    self.bad(x.line, f"task {x.id} ({_text(x.task)}): its subtask {c} is {where}")
                else:
                    parent[c] = x.id
        self.root_tasks()
        checks: list[_MethodCheck] = []
        leaves: list[int] = []
        seen: set[int] = set()
        for r in self.plan.root:
            self.walk(r, root_line, leaves, checks, seen)
        for s in self.plan.steps:
            if s.id not in seen:
                self.bad(s.line, f"action {s.id} ({_text(s.action)}) is not reached from the root tasks")
        for x in self.plan.decompositions:
            if x.id not in seen:
                self.bad(x.line, f"task {x.id} ({_text(x.task)}) is not reached from the root tasks")
        reached = set(leaves)
        in_plan = [s.id for s in self.plan.steps if s.id in reached]
        if leaves != in_plan:
            k = next(k for k, (a, b) in enumerate(zip(leaves, in_plan, strict=True)) if a != b)
            self.bad(
                self.steps[in_plan[k]].line,
                f"the actions are not in the order of the decomposition: action {k + 1} of the plan is "
                f"{in_plan[k]}, the decomposition's is {leaves[k]} (total order: no interleaving)",
            )
        return checks

    def walk(
        self, root: int, line: int, leaves: list[int], checks: list[_MethodCheck], seen: set[int]
    ) -> None:
        """Depth first, left to right, with an explicit stack (a plan may be a deep chain)."""
        stack: list[tuple[int, int]] = [(root, line)]
        while stack:
            ident, line = stack.pop()
            if ident in seen:
                self.bad(line, f"ID {ident} is reached twice (a cycle or a shared subtask)")
                continue
            seen.add(ident)
            if ident in self.steps:
                leaves.append(ident)
                continue
            dec = self.decs.get(ident)
            if dec is None:
                self.bad(line, f"ID {ident} is neither an action nor a decomposed task")
                continue
            check = self.decomposition(dec, len(leaves))
            if check is not None:
                checks.append(check)
            stack.extend((c, dec.line) for c in reversed(dec.subtasks))

    def decomposition(self, x: IpcDecomposition, position: int) -> _MethodCheck | None:
        what = f"task {x.id} ({_text(x.task)})"
        task = self.d.tasks.get(x.task.name)
        if task is None:
            kind = (
                "an action, which is not decomposed" if x.task.name in self.d.actions else "no compound task"
            )
            self.bad(x.line, f"{what}: {x.task.name} is {kind}")
            return None
        if not self.arguments(x.line, what, x.task, task.params):
            return None
        method = self.d.methods.get(x.method)
        if method is None:
            self.bad(x.line, f"{what}: no method is named {x.method}")
            return None
        if method.task.name != x.task.name:
            self.bad(x.line, f"{what}: method {x.method} decomposes {method.task.name}, not {x.task.name}")
            return None
        if len(method.subtasks) != len(x.subtasks):
            self.bad(
                x.line,
                f"{what}: method {x.method} has {len(method.subtasks)} subtasks, "
                f"the line lists {len(x.subtasks)}",
            )
            return None
        binding: Binding = {}
        if not self.bind(method.task, x.task, binding, x.line, f"{what}: method {x.method}'s task"):
            return None
        for k, (sub, ident) in enumerate(zip(method.subtasks, x.subtasks, strict=True), start=1):
            call = self.call_of(ident)
            if call is None:
                continue  # said by walk
            if call.name != sub.call.name:
                self.bad(
                    x.line,
                    f"{what}: subtask {k} of method {x.method} is {sub.call.name}, but ID {ident} "
                    f"is {call.name}",
                )
                return None
            if not self.bind(sub.call, call, binding, x.line, f"{what}: subtask {k} of method {x.method}"):
                return None
        params = {p.name: p for p in method.params}
        for var, value in binding.items():
            p = params.get(var)
            if p is not None and not self.world.fits(value, p.types):
                self.bad(
                    x.line,
                    f"{what}: method {x.method} binds {var} to {value}, not of type {' or '.join(p.types)}",
                )
                return None
        return _MethodCheck(position, method, binding, x.line, x.id, x.task)

    def bind(self, pattern: Atom, ground: Atom, binding: Binding, line: int, what: str) -> bool:
        if len(pattern.args) != len(ground.args):
            self.bad(line, f"{what}: {len(pattern.args)} arguments expected, {len(ground.args)} given")
            return False
        for p, g in zip(pattern.args, ground.args, strict=True):
            assert isinstance(p, str) and isinstance(g, str)
            if p[0] == "?":
                bound = binding.setdefault(p, g)
                if bound != g:
                    self.bad(line, f"{what}: {p} would be both {bound} and {g}")
                    return False
            elif p != g:
                self.bad(line, f"{what}: {_text(ground)} does not match {_text(pattern)}")
                return False
        return True

    def root_tasks(self) -> None:
        """``root`` against the problem's initial task network."""
        line = self.plan.root_line
        htn = self.p.htn
        if len(htn) != len(self.plan.root):
            self.bad(
                line, f"the problem has {_count(len(htn), 'initial task')}, root lists {len(self.plan.root)}"
            )
            return
        binding: Binding = {}
        for k, (sub, ident) in enumerate(zip(htn, self.plan.root, strict=True), start=1):
            call = self.call_of(ident)
            if call is None:
                continue
            if call.name != sub.call.name:
                self.bad(
                    line, f"root task {k} is {sub.call.name} in the problem, but ID {ident} is {call.name}"
                )
                return
            if not self.bind(sub.call, call, binding, line, f"root task {k}"):
                return
        for p in self.p.htn_params:
            value = binding.get(p.name)
            if value is not None and not self.world.fits(value, p.types):
                self.bad(
                    line,
                    f"the initial task network binds {p.name} to {value}, not of type {' or '.join(p.types)}",
                )
        self.htn_binding = binding

    # -- the replay ---------------------------------------------------------------------------------

    def replay(self, checks: list[_MethodCheck]) -> None:
        state: set[Atom] = set(self.p.init)
        pending = sorted(checks, key=lambda c: c.position)  # stable: at one position, outer methods first
        k = 0
        steps = self.plan.steps
        for position in range(len(steps) + 1):
            while k < len(pending) and pending[k].position <= position:
                self.method_holds(pending[k], state)
                k += 1
            if position == len(steps):
                break
            step = steps[position]
            action = self.d.actions.get(step.action.name)
            if action is None or len(action.params) != len(step.action.args):
                self.bad(step.line, f"the replay stops at action {step.id}: it is not a valid action")
                return
            binding = {p.name: str(v) for p, v in zip(action.params, step.action.args, strict=True)}
            if not self.holds(action.precondition, state, binding):
                self.bad(
                    step.line,
                    f"action {step.id} ({_text(step.action)}): its precondition does not hold"
                    " (the replay stops here)",
                )
                return
            deletes: set[Atom] = set()
            adds: set[Atom] = set()
            self.effects(action.effect, state, binding, adds, deletes)
            state -= deletes
            state |= adds
        htn = self.p.htn_constraints
        if not self.satisfiable(htn, list(self.p.htn_params), state, dict(self.htn_binding)):
            self.bad(self.plan.root_line, "the initial task network's constraints do not hold")
        if not self.holds(self.p.goal, state, {}):
            self.bad(0, "the goal does not hold after the last action")

    def method_holds(self, c: _MethodCheck, state: set[Atom]) -> None:
        m = c.method
        free = [p for p in m.params if p.name not in c.binding]
        condition = And((m.precondition, m.constraints))
        if not self.satisfiable(condition, free, state, dict(c.binding)):
            self.bad(
                c.line,
                f"task {c.id} ({_text(c.task)}): the precondition of method {m.name} does not hold "
                f"where its first action starts (after {c.position} actions)",
            )

    # -- formulas ----------------------------------------------------------------------------------

    def ground(self, atom: Atom, binding: Mapping[str, str]) -> Atom:
        return Atom(atom.name, tuple(binding.get(a, a) if isinstance(a, str) else a for a in atom.args))

    def holds(self, f: Formula, state: set[Atom], b: Mapping[str, str]) -> bool:
        if isinstance(f, Pred):
            return self.ground(f.atom, b) in state
        if isinstance(f, And):
            return all(self.holds(x, state, b) for x in f.args)
        if isinstance(f, Not):
            return not self.holds(f.arg, state, b)
        if isinstance(f, Equals):
            return b.get(f.left, f.left) == b.get(f.right, f.right)
        if isinstance(f, Or):
            return any(self.holds(x, state, b) for x in f.args)
        if isinstance(f, Imply):
            return not self.holds(f.cond, state, b) or self.holds(f.then, state, b)
        if isinstance(f, SortOf):
            return self.world.fits(b.get(f.var, f.var), f.types)
        if isinstance(f, Forall):
            return all(self.holds(f.body, state, {**b, **e}) for e in self.every(f.params))
        return any(self.holds(f.body, state, {**b, **e}) for e in self.every(f.params))

    def every(self, params: Sequence[Typed]) -> Iterator[dict[str, str]]:
        """Every binding of ``params`` to objects of their types."""
        names = [p.name for p in params]
        for values in itertools.product(*(self.world.of(p.types) for p in params)):
            yield dict(zip(names, values, strict=True))

    def satisfiable(self, f: Formula, free: list[Typed], state: set[Atom], b: Binding) -> bool:
        """Whether some values of ``free`` (of their types) make ``f`` hold, given ``b``.

        Candidates come from the facts the positive literals of ``f``'s top-level
        conjunction match, so a precondition like ``(and (at ?x) (road ?x ?y))``
        costs a pass over the state, not a pass over every pair of objects; what
        no such literal binds is tried over all objects of its type.
        """
        if not free:
            return self.holds(f, state, b)
        unbound = {p.name: p for p in free}
        literals = [x for x in _conjuncts(f) if isinstance(x, Pred)]
        return self._search(f, literals, unbound, state, b)

    def _search(
        self, f: Formula, literals: list[Pred], unbound: dict[str, Typed], state: set[Atom], b: Binding
    ) -> bool:
        open_vars = {v for v in unbound if v not in b}
        if not open_vars:
            return self.holds(f, state, b)
        lit = next((x for x in literals if any(a in open_vars for a in x.atom.args)), None)
        if lit is None:
            rest = [unbound[v] for v in unbound if v in open_vars]
            return any(self.holds(f, state, {**b, **e}) for e in self.every(rest))
        for fact in state:
            if fact.name != lit.atom.name or len(fact.args) != len(lit.atom.args):
                continue
            extended = dict(b)
            pairs = zip(lit.atom.args, fact.args, strict=True)
            if all(_match(p, g, extended, unbound, self.world) for p, g in pairs) and self._search(
                f, literals, unbound, state, extended
            ):
                return True
        return False

    def effects(
        self, e: Effect, state: set[Atom], b: Mapping[str, str], adds: set[Atom], deletes: set[Atom]
    ) -> None:
        if isinstance(e, Literal):
            (adds if e.positive else deletes).add(self.ground(e.atom, b))
        elif isinstance(e, AndEffect):
            for x in e.args:
                self.effects(x, state, b, adds, deletes)
        elif isinstance(e, ForallEffect):
            for extra in self.every(e.params):
                self.effects(e.body, state, {**b, **extra}, adds, deletes)
        elif self.holds(e.cond, state, b):
            self.effects(e.body, state, b, adds, deletes)


def _conjuncts(f: Formula) -> Iterable[Formula]:
    if isinstance(f, And):
        for x in f.args:
            yield from _conjuncts(x)
    else:
        yield f


def _match(p: object, g: object, b: Binding, unbound: Mapping[str, Typed], world: _World) -> bool:
    assert isinstance(p, str) and isinstance(g, str)
    if p[0] != "?":
        return p == g
    bound = b.get(p)
    if bound is not None:
        return bound == g
    param = unbound.get(p)
    if param is not None and not world.fits(g, param.types):
        return False
    b[p] = g
    return True


def _count(n: int, noun: str) -> str:
    return f"{n} {noun}" if n == 1 else f"{n} {noun}s"


def _text(atom: Atom) -> str:
    return " ".join((atom.name, *(str(a) for a in atom.args)))
