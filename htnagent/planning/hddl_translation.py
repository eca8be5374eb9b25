"""An HDDL domain and problem as an htnagent :class:`~htnagent.model.domain.Domain` to plan with.

The HDDL model (:mod:`htnagent.hddl`) keeps what the files say; this module makes
of it what the planner (:mod:`htnagent.planning.planner`) reads (docs/design.md §7):

- **Types** become static facts, one predicate per type (``__type_truck(t1)``),
  true of every object of that type or a subtype.  A parameter's type is a literal
  of its method or action: a check when something else binds the variable, an
  enumeration of the type's objects when nothing else does.
- **Equality** is the static predicate ``__eq``, true of every object with itself.
- **Quantifiers and disjunction**: ``forall`` (and ``exists`` under a negation)
  are expanded over the problem's objects; ``exists`` elsewhere becomes fresh
  variables with their type; ``or`` and ``imply`` are multiplied out, a method or
  operator per disjunct (same name).  Conditional effects (``when``) give an
  operator per truth value of their conditions.
- **The problem**: the initial task network is the one method ``__root`` of the
  task ``__top()``; a ``:goal`` is the compound task ``__goal()`` after it, whose
  methods (one per disjunct) do nothing and hold only where the goal does.
- **Methods with no subtasks** do the zero-cost action ``__done()``, so that their
  decomposition appears in the plan's records (the IPC plan format lists it).
- **Suspension** (docs/design.md §7.1): an action named in ``suspendable`` is declared
  with a :class:`~htnagent.model.operators.Suspension`.  Stopped half way it has had no effect;
  the fact ``__suspended_A(args)`` records it.  ``resume(A)`` requires that record and
  A's own precondition (the rest of A is done now, so what A needs must hold now) and
  gives A's effects; ``rollback(A)`` just drops the record.
- **The estimate**: :attr:`Domain.task_costs` holds the least number of actions each
  task takes whatever the state (over the method tree), which the planner sums over
  the task list.

A problem translated is planned by :mod:`htnagent.planning.hddl_solving`, and its plan
given back in the IPC's terms, without the additions above, by
:mod:`htnagent.planning.ipc_output`.
"""

from __future__ import annotations

import functools
import itertools
import math
import time
from collections.abc import Collection, Iterable, Iterator, Mapping, Sequence
from dataclasses import dataclass
from typing import TypeVar

from htnagent.hddl import model as m
from htnagent.model.domain import Domain
from htnagent.model.operators import Effect, Suspension
from htnagent.model.preconditions import Literal
from htnagent.model.state import State
from htnagent.model.terms import Atom, Bindings, substitute

TOP = "__top"
"""The task whose one method is the problem's initial task network."""
ROOT_METHOD = "__root"
"""The method of :data:`TOP`."""
PART = "__part"
"""The prefix of the tasks that bind the network's open parameters where they are used
(:func:`_network_parts`): ``__part1(...)``, with its one method ``__part1_m``."""
GOAL = "__goal"
"""The task checking the problem's ``:goal`` after the initial task network."""
DONE = "__done"
"""The zero-cost action a method with no subtasks does (so its decomposition is recorded)."""
EQ = "__eq"
"""The static predicate of equality."""
TYPE = "__type_"
"""The prefix of the type predicates."""
SUSPENDED = "__suspended_"
"""The prefix of the facts recording a suspended action (``__suspended_move(r1,hall,lab)``)."""
RESERVED = "__"
"""The prefix of every predicate, task and action the translation adds (never an HDDL name)."""

MARKERS = frozenset({DONE})
"""Actions the translation adds: not HDDL actions, left out of an IPC plan."""

MAX_GROUNDINGS = 20_000
"""The most objects (or tuples of objects) one ``forall`` or negated ``exists`` may range over."""

MAX_DISJUNCTS = 256
"""The most methods or operators one HDDL method or action may become (``or``, ``when``)."""

CLOCK_EVERY = 4096
"""How much work the translation does between two readings of the clock, when it has a
deadline (:func:`translate`'s ``deadline``): objects or facts gone through, literals made."""

_T = TypeVar("_T")

_Conjunct = tuple[Literal, ...]
_FALSE: list[_Conjunct] = []
_TRUE: list[_Conjunct] = [()]


@dataclass(frozen=True, slots=True)
class HddlPlanning:
    """A problem ready for the planner: the domain, the start state and the task list."""

    domain: Domain
    state: State
    tasks: tuple[Atom, ...]
    hddl: m.Domain
    problem: m.Problem


class StartedError(ValueError):
    """A started effect the translation cannot undo exactly (``action``, its ``key``:
    ``add[0]``, ``delete[1]``); the scenario reader names the file and key."""

    def __init__(self, action: str, key: str, reason: str) -> None:
        super().__init__(reason)
        self.action = action
        self.key = key


@dataclass(frozen=True, slots=True)
class Started:
    """What holds of an action as soon as it starts (docs/design.md §7.1): facts in the
    text form, over the action's parameters (``at(?r,?from)``) and the problem's objects."""

    add: tuple[str, ...] = ()
    delete: tuple[str, ...] = ()


def translate(
    domain: m.Domain,
    problem: m.Problem,
    suspendable: Collection[str] = (),
    started: Mapping[str, Started] | None = None,
    *,
    deadline: float | None = None,
) -> HddlPlanning:
    """The planning domain, start state and tasks of an HDDL domain and problem.

    The actions named in ``suspendable`` can be stopped half way (see the module's
    docstring); each must be an action of the domain that :func:`unsuspendable` accepts.
    ``started`` gives, for some of them, the effects that hold as soon as they start:
    what a half-done one has already changed.

    Raises :class:`~htnagent.errors.HddlError` (with the file and place) for what the
    translation cannot take: a formula that multiplies out past :data:`MAX_DISJUNCTS`.
    With a ``deadline`` (a :func:`time.perf_counter` value), the translation reads the
    clock as it goes (every :data:`CLOCK_EVERY` objects, facts or literals) and raises
    :class:`OutOfTime` once it has passed.
    """
    return _Translator(domain, problem, frozenset(suspendable), dict(started or {}), deadline).run()


def initial_network(planning: HddlPlanning) -> tuple[Atom, ...]:
    """The problem's initial task network as the tasks a network goal does in order
    (docs/contracts.md ``tasks: problem``): the network's own tasks when the translation
    made them one ground list with nothing to check first, else ``__top()`` (its
    parameters bound by the planner); then ``__goal()`` when the problem has a ``:goal``,
    so that the network is done only where the goal holds."""
    roots = planning.domain.methods.get(TOP, [])
    tasks: tuple[Atom, ...] = (Atom(TOP),)
    if (
        len(roots) == 1
        and not roots[0].pre
        and roots[0].subtasks
        and all(t.is_ground for t in roots[0].subtasks)
    ):
        tasks = roots[0].subtasks
    return tasks + tuple(t for t in planning.tasks if t.name == GOAL)


def unsuspendable(domain: m.Domain, name: str) -> str | None:
    """Why the domain's action ``name`` cannot be declared suspendable; None when it can.

    A suspended action's ``resume`` has one precondition and one set of effects
    (docs/design.md §7.1): an action whose precondition has alternatives (``or``,
    ``imply``, ``exists`` under ``not``) or whose effects have conditions (``when``)
    would need several.
    """
    action = domain.actions.get(name)
    if action is None:
        known = ", ".join(domain.actions) or "none"
        return f"domain {domain.name} has no action {name} (its actions: {known})"
    if _has_when(action.effect):
        return f"action {name} has conditional effects (when), so a suspended one has no one resume"
    if _has_choice(action.precondition, True):
        return f"action {name}'s precondition has alternatives (or), so a suspended one has no one resume"
    return None


def suspended_fact(action: Atom) -> Atom:
    """The fact recording that the ground (or lifted) ``action`` is suspended half way."""
    return Atom(SUSPENDED + action.name, action.args)


class OutOfTime(Exception):
    """The deadline given to :func:`translate` passed (a solver makes it a timed-out result)."""


class _Translator:
    def __init__(
        self,
        domain: m.Domain,
        problem: m.Problem,
        suspendable: frozenset[str],
        started: dict[str, Started],
        deadline: float | None = None,
    ) -> None:
        self.hddl = domain
        self.problem = problem
        self.suspendable = suspendable
        self.started = started
        # With a deadline (a time.perf_counter() value), the work since the clock was last read.
        self.deadline = deadline
        self.work = 0
        self.out = Domain(domain.name)
        self.objects: dict[str, frozenset[str]] = {}  # object -> its types and their supertypes
        # Millions of objects may share a few types: each type's supertypes are found once,
        # and objects of the same types share one set.
        above = functools.cache(domain.supertypes)
        shared: dict[frozenset[str], frozenset[str]] = {}
        for o in self.timed((*domain.constants, *problem.objects)):
            kinds: set[str] = set(self.objects.get(o.name, ()))
            for t in o.types:
                kinds |= above(t)
            frozen = frozenset(kinds)
            self.objects[o.name] = shared.setdefault(frozen, frozen)
        self.type_predicates: dict[tuple[str, ...], str] = {}
        self.fresh = itertools.count()
        # What the early checks of :meth:`early` work from, each made once.
        self.requires: dict[str, tuple[Literal, ...]] = {}
        self.needing: dict[str, tuple[tuple[str, ...], tuple[Literal, ...]] | None] = {}
        self.reaching: dict[str, list[tuple[str, tuple[frozenset[str], ...]]]] = {}
        self.patterns: dict[str, list[tuple[str, tuple[frozenset[str], ...]]]] = {}
        self.typed_objects: dict[tuple[str, ...], frozenset[str]] = {}

    # -- the clock ---------------------------------------------------------------------------

    def spend(self, work: int) -> None:
        """Count ``work`` done; after every :data:`CLOCK_EVERY`, stop if the deadline has passed.

        The unit is one object or fact gone through, or one literal made: what a large
        problem has millions of, each costing about the same (a fraction of a microsecond).
        """
        if self.deadline is None:
            return
        self.work += work
        if self.work >= CLOCK_EVERY:
            self.work = 0
            if time.perf_counter() > self.deadline:
                raise OutOfTime

    def timed(self, items: Iterable[_T]) -> Iterable[_T]:
        """The items, with the clock read every :data:`CLOCK_EVERY` of them (see :meth:`spend`)."""
        if self.deadline is None:
            return items
        return self._timed(items)

    def _timed(self, items: Iterable[_T]) -> Iterator[_T]:
        for item in items:
            self.spend(1)
            yield item

    # -- the whole ---------------------------------------------------------------------------

    def run(self) -> HddlPlanning:
        for action in self.hddl.actions.values():
            self.action(action)
        self.out.operator(f"{DONE}", cost=0.0)
        for method in self.hddl.methods.values():
            self.method(method)
        p = self.problem
        kept, htn, parts = _network_parts(p)
        root = m.Method(ROOT_METHOD, kept, Atom(TOP), m.TRUE, htn, p.htn_constraints, at=p.domain_at)
        self.method(root, source=p.source)
        for part in parts:
            self.method(part, source=p.source)
        tasks = [Atom(TOP)]
        if p.goal != m.TRUE:
            conjuncts = self.dnf(p.goal, {}, True, p.source, p.domain_at)
            for i, conjunct in enumerate(conjuncts):
                pre = self.order(conjunct, (), set())
                self.out.method(f"{GOAL}()", f"goal{i}", when=[str(lit) for lit in pre], do=[f"{DONE}()"])
            if not conjuncts:
                self.out.method(f"{GOAL}()", "goal", when=[f"{EQ}(a,b)"], do=[])  # false
            tasks.append(Atom(GOAL))
            if len(conjuncts) == 1:
                # Greedy search counts what is still missing of the goal (docs/design.md §7).
                dynamic = self.out.dynamic_predicates
                self.out.goal_facts = tuple(
                    lit.atom
                    for lit in conjuncts[0]
                    if lit.positive and not lit.variables and lit.atom.name in dynamic
                )
        facts: list[Atom] = list(p.init)
        typing = [(frozenset(types), predicate) for types, predicate in self.type_predicates.items()]
        for name, kinds in self.timed(self.objects.items()):
            facts.append(Atom(EQ, (name, name)))
            for types, predicate in typing:
                if kinds & types:
                    facts.append(Atom(predicate, (name,)))
        self.out.facts = tuple(facts)
        self.out.task_costs = _least_costs(self.out)
        # The start state indexes every fact at once (a second or so for millions of them):
        # the clock is read before and after.
        self.spend(CLOCK_EVERY)
        state = State.from_facts(self.out.facts, self.out.dynamic_predicates)
        self.spend(CLOCK_EVERY)
        return HddlPlanning(self.out, state, tuple(tasks), self.hddl, p)

    # -- actions and methods -----------------------------------------------------------------

    def action(self, a: m.Action) -> None:
        src = self.hddl.source
        head = Atom(a.name, tuple(p.name for p in a.params))
        typing = tuple(self.type_literal(p.name, p.types) for p in a.params)
        pre = self.dnf(a.precondition, {}, True, src, a.at)
        effects = list(self.effects(a.effect, {}, ()))
        conditions = list(dict.fromkeys(c for c, _, _ in effects if c))
        if len(conditions) > 8:
            raise src.error(
                a.at, f"action {a.name}: more than 8 conditional effects, which htnagent does not take"
            )
        for truth in itertools.product((True, False), repeat=len(conditions)):
            holds = dict(zip(conditions, truth, strict=True))
            variant = pre
            for cs, value in holds.items():
                variant = self.product(variant, self.dnf(m.And(cs), {}, value, src, a.at), src, a.at)
            add = [str(atom) for c, atom, positive in effects if positive and (not c or holds[c])]
            delete = [str(atom) for c, atom, positive in effects if not positive and (not c or holds[c])]
            for conjunct in variant:
                lits = [*(t for t in typing if t is not None), *conjunct]
                ordered = self.order(tuple(lits), a.params, set(head.variables()))
                text = [str(x) for x in ordered]
                suspend = (
                    self.suspension(head, text, add, delete, self.started.get(a.name, Started()))
                    if a.name in self.suspendable
                    else None
                )
                self.out.operator(str(head), pre=text, add=add, delete=delete, cost=1.0, suspend=suspend)
                self.spend(len(text) + len(add) + len(delete))

    @staticmethod
    def suspension(
        head: Atom, pre: list[str], add: list[str], delete: list[str], started: Started
    ) -> Suspension:
        """How the action ``head`` is stopped half way, resumed and rolled back (docs/design.md §7.1).

        Stopped, it has had only its ``started`` effects, and the record ``__suspended_A``
        says it is half done.  ``resume(A)`` does the rest of A now -- what A needs must
        hold now, but for what its start changed -- and costs half of A.  With no
        ``started`` effects, ``rollback(A)`` forgets the half done, at no cost, and so
        does a clear (nothing was changed).  With some, the half-done action is in the
        world: ``rollback(A)`` undoes its start, at half the cost of A, and a clear
        leaves it there to be resumed or rolled back later.
        """
        record = str(suspended_fact(head))
        # Undoing the start is exact only if what it changes is known at the start: a fact
        # it deletes held (A's precondition says so), one it adds did not (likewise).
        held = {lit for lit in pre if not lit.startswith("not ")}
        absent = {lit[4:] for lit in pre if lit.startswith("not ")}
        for i, fact in enumerate(started.delete):
            if fact not in held:
                raise StartedError(
                    head.name,
                    f"delete[{i}]",
                    f"{fact} is not in {head.name}'s precondition: a start "
                    "can only take away what held when the action started",
                )
        for i, fact in enumerate(started.add):
            if fact not in absent:
                raise StartedError(
                    head.name,
                    f"add[{i}]",
                    f"{head.name}'s precondition must say (not {fact}): what a "
                    "start adds must be false before it, for rollback to undo it",
                )
        changes = bool(started.add or started.delete)
        # What A needs and its start has changed held when A began; the rest must hold now.
        still = [
            lit
            for lit in pre
            if lit not in started.delete and not (lit.startswith("not ") and lit[4:] in started.add)
        ]
        return Suspension(
            add=(record, *started.add),
            delete=started.delete,
            resume=Effect(
                # A's end, from where its start left things: A's own effects, and the
                # start's undone where A does not change the same facts.
                add=(*add, *(f for f in started.delete if f not in delete)),
                delete=(*delete, *(f for f in started.add if f not in add), record),
                pre=(record, *still),
                cost=0.5,
            ),
            # Nothing of A is in the world without started effects: a rollback costs
            # nothing, and a clear forgets A; with some, both leave the world to undo.
            rollback=Effect(add=started.delete, delete=(*started.add, record), cost=0.5 if changes else 0.0),
            cleared=() if changes else (record,),
        )

    def method(self, method: m.Method, source: m.Source | None = None) -> None:
        src = source or self.hddl.source
        head = method.task
        formula = m.And((method.precondition, method.constraints))
        calls = [s.call for s in method.subtasks] or [Atom(DONE)]
        declared = self.hddl.tasks.get(head.name)
        typing: list[Literal] = []
        for p in method.params:
            if not any(p.name in c.variables() for c in (*calls, head)) and not _mentions(formula, p.name):
                continue  # a parameter used nowhere (any object of its type would do)
            if declared is not None and self.implied(p.types, p.name, head, declared.params):
                continue
            lit = self.type_literal(p.name, p.types)
            if lit is not None:
                typing.append(lit)
        # The task's own parameter types hold of its arguments too (where the method's
        # parameter type does not already say so).
        kinds = {p.name: p.types for p in method.params}
        for arg, d in zip(head.args, declared.params if declared is not None else (), strict=False):
            if isinstance(arg, str) and arg.startswith("?"):
                own = kinds.get(arg, (m.OBJECT,))
                if all(set(d.types) & self.hddl.supertypes(t) for t in own):
                    continue
                lit = self.type_literal(arg, d.types)
                if lit is not None and lit not in typing:
                    typing.append(lit)
        early = self.early(calls, {p.name: p.types for p in method.params})
        for conjunct in self.dnf(formula, {}, True, src, method.at):
            ordered = self.order((*conjunct, *early, *typing), method.params, set(head.variables()))
            self.out.method(
                str(head), method.name, when=[str(x) for x in ordered], do=[str(c) for c in calls]
            )
            self.spend(len(ordered) + len(calls))

    def early(self, calls: Sequence[Atom], kinds: Mapping[str, tuple[str, ...]]) -> tuple[Literal, ...]:
        """What the subtasks require that must already hold when the method is chosen.

        A subtask requires, when it starts, its action's precondition -- or, for a compound
        task with one method, that method's precondition and what its own subtasks require
        early (:meth:`needs`).  Such a literal holds when the subtask starts exactly when it
        holds now, if no earlier subtask of the method can change it: no action an earlier
        subtask may come down to (:meth:`reach`) has an effect on its predicate for objects
        of its arguments' types (a truck driving changes where trucks are, not where
        packages are).  Checked at the decomposition, such literals bind the method's
        parameters by facts (the package's place) instead of by their type (every place),
        and drop decompositions that would fail later -- without changing which plans exist.
        ``kinds``: the method's parameters' types.
        """
        out: list[Literal] = []
        changing: list[tuple[str, tuple[frozenset[str], ...]]] = []
        for call in calls:
            need = self.needs(call.name)
            if need is not None:
                head, lits = need
                mapping: dict[str, str] = {}
                fits = len(head) == len(call.args)
                for h, arg in zip(head, call.args, strict=False):
                    if h.startswith("?"):
                        mapping[h] = str(arg)
                    elif h != arg:
                        fits = False
                for lit in lits if fits else ():
                    if lit.variables - mapping.keys():
                        continue
                    ground = Literal(substitute(lit.atom, mapping), lit.positive)
                    if not self.may_change(ground, changing, kinds):
                        out.append(ground)
            changing.extend(self.reach_effects(call.name))
        return tuple(dict.fromkeys(out))

    def needs(self, name: str) -> tuple[tuple[str, ...], tuple[Literal, ...]] | None:
        """What a task requires when it starts, over its head's terms: an action's
        precondition, or the one method of a compound task's precondition and early
        literals; None when that is not known (several methods, a disjunction)."""
        if name in self.needing:
            return self.needing[name]
        self.needing[name] = None  # a recursion through this task learns nothing of it
        found: tuple[tuple[str, ...], tuple[Literal, ...]] | None = None
        action = self.hddl.actions.get(name)
        if action is not None:
            found = (tuple(p.name for p in action.params), self.required(action))
        else:
            methods = self.hddl.methods_for(name)
            if len(methods) == 1:
                method = methods[0]
                formula = m.And((method.precondition, method.constraints))
                conjuncts = self.dnf(formula, {}, True, self.hddl.source, method.at)
                if len(conjuncts) == 1:
                    kinds = {p.name: p.types for p in method.params}
                    typing = [
                        lit for p in method.params if (lit := self.type_literal(p.name, p.types)) is not None
                    ]
                    inner = self.early([s.call for s in method.subtasks], kinds)
                    head = tuple(str(a) for a in method.task.args)
                    known = {h for h in head if h.startswith("?")}
                    lits = [x for x in (*conjuncts[0], *typing, *inner) if x.variables <= known]
                    found = (head, tuple(dict.fromkeys(lits)))
        self.needing[name] = found
        return found

    def reach_effects(self, name: str) -> list[tuple[str, tuple[frozenset[str], ...]]]:
        """The effects of every action the task may come down to: each as its predicate
        and, per argument, the objects it may name."""
        if name not in self.reaching:
            self.reaching[name] = []  # recursion: the fixed point is reached below
            actions: set[str] = set()
            todo = [name]
            seen: set[str] = set()
            while todo:
                t = todo.pop()
                if t in seen:
                    continue
                seen.add(t)
                if t in self.hddl.actions:
                    actions.add(t)
                for method in self.hddl.methods_for(t):
                    todo.extend(s.call.name for s in method.subtasks)
            self.reaching[name] = [p for a in sorted(actions) for p in self.effect_patterns(a)]
        return self.reaching[name]

    def effect_patterns(self, action_name: str) -> list[tuple[str, tuple[frozenset[str], ...]]]:
        found = self.patterns.get(action_name)
        if found is None:
            action = self.hddl.actions[action_name]
            kinds = {p.name: p.types for p in action.params}
            found = self.patterns[action_name] = [
                (a.name, tuple(self.objects_of(str(x), kinds) for x in a.args))
                for _, a, _ in self.effects(action.effect, {}, ())
            ]
        return found

    def objects_of(self, term: str, kinds: Mapping[str, tuple[str, ...]]) -> frozenset[str]:
        """The objects a term may name: a constant itself, a variable those of its type."""
        if not term.startswith("?"):
            return frozenset((term,))
        types = kinds.get(term, (m.OBJECT,))
        found = self.typed_objects.get(types)
        if found is None:
            found = self.typed_objects[types] = frozenset(self.of_type(types))
        return found

    def may_change(
        self,
        lit: Literal,
        changing: Sequence[tuple[str, tuple[frozenset[str], ...]]],
        kinds: Mapping[str, tuple[str, ...]],
    ) -> bool:
        """Whether one of the effects could make the literal's truth other than it is now."""
        name = lit.atom.name
        args: tuple[frozenset[str], ...] | None = None
        for predicate, may_name in changing:
            if predicate != name or len(may_name) != len(lit.atom.args):
                continue
            if args is None:
                args = tuple(self.objects_of(str(x), kinds) for x in lit.atom.args)
            if all(a & b for a, b in zip(args, may_name, strict=True)):
                return True
        return False

    def required(self, action: m.Action) -> tuple[Literal, ...]:
        """The literals every way of running the action requires (none for a disjunction)."""
        found = self.requires.get(action.name)
        if found is None:
            typing = tuple(
                lit for p in action.params if (lit := self.type_literal(p.name, p.types)) is not None
            )
            conjuncts = self.dnf(action.precondition, {}, True, self.hddl.source, action.at)
            found = (*typing, *conjuncts[0]) if len(conjuncts) == 1 else typing
            self.requires[action.name] = found
        return found

    def implied(self, types: tuple[str, ...], var: str, head: Atom, declared: Sequence[m.Typed]) -> bool:
        """Whether the task's own parameter type already makes ``var`` of one of ``types``."""
        wanted = set(types)
        for arg, d in zip(head.args, declared, strict=False):
            if arg == var and all(wanted & self.hddl.supertypes(t) for t in d.types):
                return True
        return False

    def type_literal(self, term: str, types: tuple[str, ...], positive: bool = True) -> Literal | None:
        """The literal "``term`` is of one of ``types``"; None when every object is."""
        if m.OBJECT in types:
            return None
        key = tuple(sorted(set(types)))
        name = self.type_predicates.get(key)
        if name is None:
            name = self.type_predicates[key] = TYPE + "_or_".join(key)
        return Literal(Atom(name, (term,)), positive)

    def of_type(self, types: tuple[str, ...]) -> list[str]:
        wanted = set(types)
        return [o for o, kinds in self.timed(self.objects.items()) if kinds & wanted]

    # -- formulas ----------------------------------------------------------------------------

    def dnf(
        self, f: m.Formula, b: Mapping[str, str], positive: bool, src: m.Source, at: int
    ) -> list[_Conjunct]:
        """``f`` (or its negation) as a disjunction of conjunctions of literals."""
        match f:
            case m.Pred(atom=a):
                return [(Literal(_sub(a, b), positive),)]
            case m.Equals(left=left, right=right):
                x, y = b.get(left, left), b.get(right, right)
                if x == y:
                    return _TRUE if positive else _FALSE
                if not x.startswith("?") and not y.startswith("?"):
                    return _FALSE if positive else _TRUE
                return [(Literal(Atom(EQ, (x, y)), positive),)]
            case m.SortOf(var=v, types=types):
                t = b.get(v, v)
                if not t.startswith("?"):
                    fits = bool(self.objects.get(t, frozenset()) & set(types)) or m.OBJECT in types
                    return _TRUE if fits == positive else _FALSE
                lit = self.type_literal(t, types, positive)
                return (_TRUE if positive else _FALSE) if lit is None else [(lit,)]
            case m.Not(arg=inner):
                return self.dnf(inner, b, not positive, src, at)
            case m.And(args=args):
                parts = [self.dnf(x, b, positive, src, at) for x in args]
                return self.all_of(parts, src, at) if positive else self.any_of(parts, src, at)
            case m.Or(args=args):
                parts = [self.dnf(x, b, positive, src, at) for x in args]
                return self.any_of(parts, src, at) if positive else self.all_of(parts, src, at)
            case m.Imply(cond=cond, then=then):
                parts = [self.dnf(cond, b, not positive, src, at), self.dnf(then, b, positive, src, at)]
                return self.any_of(parts, src, at) if positive else self.all_of(parts, src, at)
            case m.Forall(params=params, body=body):
                parts = [
                    self.dnf(body, {**b, **g}, positive, src, at) for g in self.groundings(params, src, f.at)
                ]
                return self.all_of(parts, src, at) if positive else self.any_of(parts, src, at)
            case m.Exists(params=params, body=body):
                if not positive:
                    parts = [
                        self.dnf(body, {**b, **g}, False, src, at) for g in self.groundings(params, src, f.at)
                    ]
                    return self.all_of(parts, src, at)
                # Some objects: fresh variables of their types, bound when matched.
                fresh = {p.name: f"?__{next(self.fresh)}_{p.name.lstrip('?')}" for p in params}
                typing = tuple(
                    lit for p in params if (lit := self.type_literal(fresh[p.name], p.types)) is not None
                )
                return [(*c, *typing) for c in self.dnf(body, {**b, **fresh}, True, src, at)]
        raise AssertionError(f"not a formula: {f!r}")  # pragma: no cover

    def groundings(self, params: Sequence[m.Typed], src: m.Source, at: int) -> Iterator[dict[str, str]]:
        """Every binding of a quantifier's variables to objects of their types."""
        domains = [self.of_type(p.types) for p in params]
        if math.prod(len(d) for d in domains) > MAX_GROUNDINGS:
            raise src.error(
                at, f"this quantifier stands for over {MAX_GROUNDINGS:,} formulas (one per object)"
            )
        for values in self.timed(itertools.product(*domains)):
            yield {p.name: v for p, v in zip(params, values, strict=True)}

    def all_of(self, parts: Iterable[list[_Conjunct]], src: m.Source, at: int) -> list[_Conjunct]:
        out = _TRUE
        for part in parts:
            out = self.product(out, part, src, at)
            if not out:
                return _FALSE
        return out

    def product(self, xs: list[_Conjunct], ys: list[_Conjunct], src: m.Source, at: int) -> list[_Conjunct]:
        if len(xs) * len(ys) > MAX_DISJUNCTS:
            raise src.error(at, f"this formula multiplies out to over {MAX_DISJUNCTS} alternatives")
        out = []
        for x in xs:
            for y in ys:
                merged = _merge(x, y)
                if merged is not None:
                    out.append(merged)
                self.spend(len(x) + len(y))  # what merging them cost
        return out

    def any_of(self, parts: Iterable[list[_Conjunct]], src: m.Source, at: int) -> list[_Conjunct]:
        out: list[_Conjunct] = []
        for part in parts:
            for c in part:
                if c not in out:
                    out.append(c)
        if len(out) > MAX_DISJUNCTS:
            raise src.error(at, f"this formula multiplies out to over {MAX_DISJUNCTS} alternatives")
        return out

    def order(self, conjunct: _Conjunct, params: Sequence[m.Typed], bound: set[str]) -> tuple[Literal, ...]:
        """The literals in the order SHOP should match them.

        Binders in turn -- literals matching facts (in the file's order), then equalities
        with one side bound, then types (enumerating a type's objects) -- and after each,
        every literal whose variables are now all bound, as a check: a negative literal
        prunes as soon as it can, never after the loops of later variables.
        """
        bound = set(bound)
        todo = list(dict.fromkeys(conjunct))
        out: list[Literal] = []

        def flush() -> None:
            for x in [x for x in todo if x.variables <= bound]:
                todo.remove(x)
                out.append(x)

        def binder() -> Literal | None:
            for wanted in ("fact", "equal", "type"):
                for x in todo:
                    if x.positive and _kind(x) == wanted and (wanted != "equal" or x.variables & bound):
                        return x
            return None

        flush()
        while todo:
            x = binder()
            if x is None:
                # Left: negative literals, or equalities, of free variables: any object will
                # do for one of them (of its type, when it is a parameter).
                var = min(v for y in todo for v in y.variables - bound)
                kinds = next((p.types for p in params if p.name == var), (m.OBJECT,))
                x = self.type_literal(var, kinds) or Literal(Atom(EQ, (var, var)))
                todo.insert(0, x)
            todo.remove(x)
            out.append(x)
            bound |= x.variables
            flush()
        return tuple(out)

    # -- effects -----------------------------------------------------------------------------

    def effects(
        self, e: m.Effect, b: Mapping[str, str], conditions: tuple[m.Formula, ...]
    ) -> Iterator[tuple[tuple[m.Formula, ...], Atom, bool]]:
        """Each effect literal with the conditions it is under (``when``), quantifiers expanded."""
        match e:
            case m.Literal(atom=a, positive=positive):
                yield conditions, _sub(a, b), positive
            case m.AndEffect(args=args):
                for x in args:
                    yield from self.effects(x, b, conditions)
            case m.ForallEffect(params=params, body=body, at=at):
                for g in self.groundings(params, self.hddl.source, at):
                    yield from self.effects(body, {**b, **g}, conditions)
            case m.When(cond=cond, body=body):
                yield from self.effects(body, b, (*conditions, _bound_formula(cond, b)))


def _sub(a: Atom, b: Mapping[str, str]) -> Atom:
    if not b:
        return a
    bindings: Bindings = dict(b)
    return substitute(a, bindings)


def _bound_formula(f: m.Formula, b: Mapping[str, str]) -> m.Formula:
    """``f`` with the quantified variables of ``b`` replaced (for a condition kept for later)."""
    if not b:
        return f
    match f:
        case m.Pred(atom=a):
            return m.Pred(_sub(a, b))
        case m.Equals(left=x, right=y):
            return m.Equals(b.get(x, x), b.get(y, y))
        case m.SortOf(var=v, types=t):
            return m.SortOf(b.get(v, v), t)
        case m.Not(arg=x):
            return m.Not(_bound_formula(x, b))
        case m.And(args=xs):
            return m.And(tuple(_bound_formula(x, b) for x in xs))
        case m.Or(args=xs):
            return m.Or(tuple(_bound_formula(x, b) for x in xs))
        case m.Imply(cond=c, then=t):
            return m.Imply(_bound_formula(c, b), _bound_formula(t, b))
        case m.Forall(params=ps, body=x):
            inner = {k: v for k, v in b.items() if k not in {p.name for p in ps}}
            return m.Forall(ps, _bound_formula(x, inner))
        case m.Exists(params=ps, body=x):
            inner = {k: v for k, v in b.items() if k not in {p.name for p in ps}}
            return m.Exists(ps, _bound_formula(x, inner))
    raise AssertionError(f"not a formula: {f!r}")  # pragma: no cover


def _network_parts(p: m.Problem) -> tuple[tuple[m.Typed, ...], tuple[m.Subtask, ...], list[m.Method]]:
    """The initial network with its open parameters bound where they are used: the
    parameters the root keeps, its subtasks, and one method per part.

    A parameter the network's constraints do not mention is bound by a task of its own,
    ``__partK(...)``, whose one method does the stretch of the network from the first task
    using it to the last (stretches that overlap are one part).  So each is bound when its
    stretch starts, and a grounding takes the parts one by one -- not all at once at the
    root, where a dozen parameters of a few objects each (Woodworking's surfaces and
    colours) make millions of roots.  The same plans exist; the parts are left out of an
    IPC plan (:mod:`htnagent.planning.ipc_output`).
    """
    calls = [s.call for s in p.htn]
    open_names = {
        q.name
        for q in p.htn_params
        if not _mentions(p.htn_constraints, q.name) and any(q.name in c.variables() for c in calls)
    }
    spans = sorted(
        (used[0], used[-1])
        for q in p.htn_params
        if q.name in open_names
        for used in [[i for i, c in enumerate(calls) if q.name in c.variables()]]
    )
    if not spans:
        return p.htn_params, p.htn, []
    merged: list[list[int]] = []
    for first, last in spans:
        if merged and first <= merged[-1][1]:
            merged[-1][1] = max(merged[-1][1], last)
        else:
            merged.append([first, last])
    htn: list[m.Subtask] = []
    parts: list[m.Method] = []
    done = 0
    for first, last in merged:
        htn.extend(p.htn[done:first])
        stretch = p.htn[first : last + 1]
        inside = {v for s in stretch for v in s.call.variables()}
        given = tuple(q for q in p.htn_params if q.name in inside and q.name not in open_names)
        own = tuple(q for q in p.htn_params if q.name in inside and q.name in open_names)
        name = f"{PART}{len(parts) + 1}"
        head = Atom(name, tuple(q.name for q in given))
        parts.append(m.Method(f"{name}_m", given + own, head, m.TRUE, stretch, at=p.domain_at))
        htn.append(m.Subtask(head, at=stretch[0].at))
        done = last + 1
    htn.extend(p.htn[done:])
    kept = tuple(q for q in p.htn_params if q.name not in open_names)
    return kept, tuple(htn), parts


def _mentions(f: m.Formula, var: str) -> bool:
    match f:
        case m.Pred(atom=a):
            return var in a.variables()
        case m.Equals(left=x, right=y):
            return var in (x, y)
        case m.SortOf(var=v):
            return v == var
        case m.Not(arg=x):
            return _mentions(x, var)
        case m.And(args=xs) | m.Or(args=xs):
            return any(_mentions(x, var) for x in xs)
        case m.Imply(cond=c, then=t):
            return _mentions(c, var) or _mentions(t, var)
        case m.Forall(params=ps, body=x) | m.Exists(params=ps, body=x):
            return var not in {p.name for p in ps} and _mentions(x, var)


def _has_when(e: m.Effect) -> bool:
    match e:
        case m.When():
            return True
        case m.AndEffect(args=args):
            return any(_has_when(x) for x in args)
        case m.ForallEffect(body=body):
            return _has_when(body)
    return False


def _has_choice(f: m.Formula, positive: bool) -> bool:
    """Whether ``f`` (or its negation) multiplies out to several conjunctions (see ``dnf``)."""
    match f:
        case m.Or(args=args):
            return positive or any(_has_choice(x, positive) for x in args)
        case m.And(args=args):
            return not positive or any(_has_choice(x, positive) for x in args)
        case m.Imply(cond=cond, then=then):
            return positive or _has_choice(cond, True) or _has_choice(then, False)
        case m.Not(arg=inner):
            return _has_choice(inner, not positive)
        case m.Forall(body=body):
            return not positive or _has_choice(body, positive)
        case m.Exists(body=body):
            return _has_choice(body, positive)
    return False


def _kind(lit: Literal) -> str:
    name = lit.atom.name
    return "equal" if name == EQ else "type" if name.startswith(TYPE) else "fact"


def _merge(x: _Conjunct, y: _Conjunct) -> _Conjunct | None:
    """The conjunction of two conjunctions; None when one literal contradicts another."""
    out = list(x)
    seen = {(lit.atom, lit.positive) for lit in x}
    for lit in y:
        if (lit.atom, not lit.positive) in seen and not lit.variables:
            return None
        if (lit.atom, lit.positive) not in seen:
            seen.add((lit.atom, lit.positive))
            out.append(lit)
    return tuple(out)


def _least_costs(domain: Domain) -> dict[str, float]:
    """The least cost of each task name over the method tree, whatever the state: a
    primitive task costs its operator's least cost, a compound one its cheapest method's
    subtasks' sum (a fixed point; ``inf`` for a task no method ever finishes)."""
    inf = float("inf")
    costs: dict[str, float] = {}
    for name, ops in domain.operators.items():
        costs[name] = min(float(op.cost) if isinstance(op.cost, int | float) else 0.0 for op in ops)
    for name in domain.methods:
        costs[name] = inf
    changed = True
    while changed:
        changed = False
        for name, methods in domain.methods.items():
            best = min(
                (sum(costs.get(t.name, inf) for t in method.subtasks) for method in methods), default=inf
            )
            if best < costs[name]:
                costs[name] = best
                changed = True
    return costs


__all__ = [
    "DONE",
    "GOAL",
    "MARKERS",
    "PART",
    "RESERVED",
    "SUSPENDED",
    "TOP",
    "HddlPlanning",
    "OutOfTime",
    "Started",
    "StartedError",
    "initial_network",
    "suspended_fact",
    "translate",
    "unsuspendable",
]
