"""Grounding one way, then the other (docs/design.md §7.2, step 1): where binding a method's
parameters by the join goes past the cap, by their types may fit, and the methods whose
types make many bindings are then decomposed by their ground methods all the same."""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import ClassVar

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from htnagent.hddl import parse_domain, parse_problem
from htnagent.hddl.check import check_plan
from htnagent.model.domain import Method
from htnagent.model.terms import Atom, Bindings
from htnagent.planning import composition
from htnagent.planning.composition import TooLarge, _Grounder, ground
from htnagent.planning.hddl_translation import HddlPlanning, translate
from htnagent.planning.ipc_output import ipc_plan
from htnagent.planning.planner import PlannerSettings, PlanStatus, Search, plan
from htnagent.planning.producible import ANY, Producible, _Bottom, _match
from tests.test_composition import _workshop

# A chain of cables from the pc's port s to the printer's port t: wire(d1, d2) plugs any two
# ports (bound by their type alone), unplugs two plugged ones, or checks that d1 reaches d2
# from plug to plug through the cables.  Every cable is a device too, so that bottom up --
# where the join works out what can be produced -- wire() can be produced for every pair of
# devices, and wire-unplug joins every plugged pair with each of them; top down, only
# wire(pc, printer) is ever met.
WIRING = """
(define (domain wiring)
  (:requirements :typing :hierarchy :negative-preconditions :method-preconditions)
  (:types port device)
  (:predicates (fits ?a ?b - port) (plugged ?a ?b - port) (used ?p - port)
               (through ?a ?b - port) (on ?p - port ?d - device) (done))
  (:task wire :parameters (?d1 ?d2 - device))
  (:task plug :parameters (?a ?b - port))
  (:task reach :parameters (?a ?b - port))
  (:method wire-plug :parameters (?d1 ?d2 - device ?a ?b - port) :task (wire ?d1 ?d2)
    :ordered-subtasks (and (plug ?a ?b) (wire ?d1 ?d2)))
  (:method wire-unplug :parameters (?d1 ?d2 - device ?a ?b - port) :task (wire ?d1 ?d2)
    :precondition (plugged ?a ?b)
    :ordered-subtasks (and (unplug ?a ?b) (wire ?d1 ?d2)))
  (:method wire-check :parameters (?d1 ?d2 - device ?a ?b - port) :task (wire ?d1 ?d2)
    :precondition (and (on ?a ?d1) (on ?b ?d2))
    :ordered-subtasks (reach ?a ?b))
  (:method reach-next :parameters (?a ?b ?c ?d - port) :task (reach ?a ?b)
    :precondition (and (plugged ?a ?c) (through ?c ?d))
    :ordered-subtasks (reach ?d ?b))
  (:method reach-end :parameters (?a ?b - port) :task (reach ?a ?b)
    :precondition (plugged ?a ?b) :ordered-subtasks (finish))
  (:method plug-m :parameters (?a ?b - port) :task (plug ?a ?b) :ordered-subtasks (connect ?a ?b))
  (:method plug-back :parameters (?a ?b - port) :task (plug ?a ?b)
    :ordered-subtasks (connect-back ?a ?b))
  (:action connect :parameters (?a ?b - port)
    :precondition (and (fits ?a ?b) (not (used ?a)) (not (used ?b)))
    :effect (and (plugged ?a ?b) (used ?a) (used ?b)))
  (:action connect-back :parameters (?a ?b - port)
    :precondition (and (fits ?b ?a) (not (used ?a)) (not (used ?b)))
    :effect (and (plugged ?a ?b) (used ?a) (used ?b)))
  (:action unplug :parameters (?a ?b - port) :precondition (plugged ?a ?b)
    :effect (and (not (plugged ?a ?b)) (not (used ?a)) (not (used ?b))))
  (:action finish :parameters () :effect (done))
)
"""

CABLES = 12
"""Cables of the chain: 26 ports, so wire-plug has 676 bindings of a task by types -- past a
twenty-fifth of :data:`CAP`, so the join is tried first."""
CAP = 3_000
"""Between what the grounding takes bound by types (about 1,500) and by the join (about 5,600)."""


def _wiring(n: int = CABLES) -> HddlPlanning:
    ports = ["s", "t"] + [f"c{k}-{end}" for k in range(1, n + 1) for end in "ab"]
    devices = ["pc", "printer"] + [f"d{k}" for k in range(1, n + 1)]
    init = ["(on s pc)", "(on t printer)"]
    for k in range(1, n + 1):
        init += [f"(through c{k}-a c{k}-b)", f"(through c{k}-b c{k}-a)"]
        init += [f"(on c{k}-a d{k})", f"(on c{k}-b d{k})"]
    chain = ["s"] + [f"c{k}-{end}" for k in range(1, n + 1) for end in "ab"] + ["t"]
    init += [f"(fits {a} {b})" for a, b in zip(chain[0::2], chain[1::2], strict=True)]
    domain = parse_domain(WIRING, "wiring.hddl")
    problem = parse_problem(
        f"(define (problem chain) (:domain wiring) (:objects {' '.join(ports)} - port"
        f" {' '.join(devices)} - device) (:htn :ordered-subtasks (wire pc printer))"
        f" (:init {' '.join(init)}))",
        domain,
        "chain.hddl",
    )
    return translate(domain, problem)


def test_where_the_join_passes_the_cap_the_grounder_binds_by_types() -> None:
    planning = _wiring()
    first = _Grounder(planning.domain, planning.state, CAP, None)
    assert first.joining  # wire-plug's 676 bindings of a task by types: the join first ...
    with pytest.raises(TooLarge):
        first.run(planning.tasks)  # ... which goes past the cap, bottom up
    c = ground(planning.domain, planning.state, planning.tasks, cap=CAP)
    assert c is not None  # bound by types, it fits
    # The estimate is the grounding's: plug the 13 gaps of the chain, then finish.
    assert c.estimate(planning.tasks, planning.state.dynamic) == 14
    # Bound by types, wire-plug's 676 ways are pruned to the plugs that can be made (each
    # gap, one way round or the other); the searches decompose by those alone.
    (plug,) = [me for me in planning.domain.methods["wire"] if me.name == "wire-plug"]
    assert plug in c.decompositions
    lifted = plug.compiled(planning.state.dynamic_predicates)(Atom("wire", ("pc", "printer")), planning.state)
    ways = c.decompositions[plug](Atom("wire", ("pc", "printer")), planning.state)
    assert len(lifted) == 26**2
    assert len(ways) == 2 * (CABLES + 1)
    live = {w for w in lifted if c.estimate(w, planning.state.dynamic) < math.inf}
    assert live == set(ways)


def test_the_grounded_search_finds_the_chain() -> None:
    planning = _wiring()
    c = ground(planning.domain, planning.state, planning.tasks, cap=CAP)
    assert c is not None
    estimated = [0]

    def guide(tasks: Sequence[Atom], dynamic: frozenset[Atom]) -> float:
        estimated[0] += 1
        return c.estimate(tasks, dynamic)

    settings = PlannerSettings(
        alternatives=1, search=Search.GBFS, guide=guide, decompositions=c.decompositions
    )
    result = plan(planning.domain, planning.state, planning.tasks, settings)
    assert result.status is PlanStatus.SOLVED and result.best is not None
    assert [str(v) for v in check_plan(planning.hddl, planning.problem, ipc_plan(result.best))] == []
    assert len(result.best.steps) == (CABLES + 1) + 1  # a plug a gap, then finish
    # The ground ways keep the search to the plugs that can be made: each wire task's
    # 26 ways estimated, not its 676 by types (about 3,000 lists estimated, not 55,000).
    assert estimated[0] < 10 * 26**2


class _Spy(_Grounder):
    """The grounder, telling which ways of binding were tried."""

    tried: ClassVar[list[bool]] = []

    def run(self, roots: Sequence[Atom]) -> composition.Composition:
        _Spy.tried.append(self.joining)
        return super().run(roots)


def test_binding_by_types_is_tried_only_where_one_task_fits(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setattr(composition, "_Grounder", _Spy)
    planning = _wiring()
    # A cap of 2,000: the join goes past it, and wire-plug's 676 bindings fit: by types next.
    _Spy.tried = []
    assert ground(planning.domain, planning.state, planning.tasks, cap=2_000) is not None
    assert _Spy.tried == [True, False]
    # A cap of 600: one wire task's bindings by types pass it, so types are not tried.
    _Spy.tried = []
    assert ground(planning.domain, planning.state, planning.tasks, cap=600) is None
    assert _Spy.tried == [True]
    # Bound by types first, the grounder tries nothing else where they pass the cap: told to
    # bind by types, the workshop's 1,728 bindings of finish-m an item pass a cap of 1,000,
    # though by the join it would fit (tests/test_composition.py).  Of the 210 problems of
    # both IPC suites past the cap by types, none fits by the join.
    monkeypatch.setattr(composition, "JOIN_ABOVE", math.inf)
    workshop = _workshop(12)
    _Spy.tried = []
    assert ground(workshop.domain, workshop.state, workshop.tasks, cap=1_000) is None
    assert _Spy.tried == [False]


def test_a_grounding_stopped_by_its_checkpoint_is_not_tried_again() -> None:
    planning = _wiring()
    asked = [0]

    def stop() -> bool:
        asked[0] += 1
        return True

    assert ground(planning.domain, planning.state, planning.tasks, cap=CAP, checkpoint=stop) is None
    assert asked[0] == 1


def test_past_the_cap_both_ways_there_is_no_grounding() -> None:
    planning = _wiring()
    assert ground(planning.domain, planning.state, planning.tasks, cap=1_000) is None


_VARS = ["?x", "?y", "?z", "?w"]
_ARG = st.sampled_from([*_VARS, "a", "b"])
_VALUE = st.sampled_from(["a", "b", "c", ANY])
_OBJECT = st.sampled_from(["a", "b", "c"])
_NAME = st.sampled_from(["p", "q"])


def _naive_join(
    producible: Producible, rows: list[Bindings], subtasks: list[Atom], kept: frozenset[str]
) -> set[frozenset[tuple[str, object]]]:
    """Every row extended by every choice of a task for each subtask, by unification, then
    projected on ``kept``: what the join must give, worked out the slow way."""
    out: set[frozenset[tuple[str, object]]] = set()
    for row in rows:
        found = [dict(row)]
        for t in subtasks:
            tasks = producible._tasks.get(t.name, ())
            found = [b for a in found for task in tasks if (b := _match(t, task, a)) is not None]
        out |= {frozenset((v, x) for v, x in b.items() if v in kept) for b in found}
    return out


@settings(max_examples=300)
@given(
    subtasks=st.lists(st.tuples(_NAME, st.lists(_ARG, min_size=1, max_size=3)), min_size=1, max_size=3),
    tasks=st.lists(st.tuples(_NAME, st.lists(_VALUE, min_size=1, max_size=3)), max_size=12),
    rows=st.lists(st.dictionaries(st.sampled_from(_VARS), _OBJECT, min_size=1, max_size=2), max_size=4),
    kept=st.sets(st.sampled_from(_VARS)),
)
def test_the_hash_join_gives_what_unification_gives(
    subtasks: list[tuple[str, list[str]]],
    tasks: list[tuple[str, list[str]]],
    rows: list[dict[str, str]],
    kept: set[str],
) -> None:
    # The join projects each subtask's producible tasks on the variables that matter and
    # looks them up by the rows' key: the same bindings, counted once, as joining every
    # row with every task by unification and projecting after.  ANY binds nothing.
    rows = rows or [{}]  # the first round's one empty row, or rows bound in the round before
    producible = object.__new__(Producible)
    producible._tasks = {}
    for name, args in tasks:
        producible._tasks.setdefault(name, set()).add(Atom(name, tuple(args)))
    producible._tick = producible._count = lambda: None
    pattern = [Atom(name, tuple(args)) for name, args in subtasks]
    head = Atom("m", tuple(sorted({v for t in pattern for v in t.variables()})))  # the method as written
    method = Method(name="m", head=head, pre=(), subtasks=tuple(pattern))
    way = _Bottom(method, {t: () for t in pattern}, (), frozenset(kept))
    joined = producible._project_join([dict(r) for r in rows], list(pattern), way)
    got = [frozenset(b.items()) for b in joined]
    assert len(got) == len(set(got))  # each binding kept once
    assert set(got) == _naive_join(producible, [dict(r) for r in rows], pattern, frozenset(kept))
