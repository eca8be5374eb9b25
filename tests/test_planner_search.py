"""The search orders, the time limit, whole-list estimates and lazy decomposition (docs/design.md §1.1).

Written with the Python :class:`~htnagent.model.domain.Domain` builder, so that each
behaviour is seen apart from HDDL.
"""

from __future__ import annotations

import itertools
import time
from collections.abc import Iterator
from pathlib import Path

import pytest

from htnagent.hddl import parse_domain, parse_problem, read_domain, read_problem
from htnagent.hddl.check import check_plan
from htnagent.model.domain import Domain, Method
from htnagent.model.preconditions import compile_method, compile_method_lazy, literals
from htnagent.model.state import State
from htnagent.model.terms import Atom, atom
from htnagent.planning.hddl_solving import solve
from htnagent.planning.hddl_translation import translate
from htnagent.planning.ipc_output import ipc_plan
from htnagent.planning.planner import PlannerSettings, PlanStatus, Search, plan


def _choice_domain(task_costs: bool = False) -> Domain:
    """``get`` has a long way (first) and a short way (second)."""
    d = Domain("choice")
    d.operator("a", cost=1.0)
    d.operator("b", cost=1.0)
    d.method("get", "long", do=["a", "a", "a"])
    d.method("get", "short", do=["b"])
    if task_costs:
        d.task_costs = {"a": 1.0, "b": 1.0, "get": 1.0}
    return d


def _actions(d: Domain, search: Search, **kw: object) -> list[str]:
    settings = PlannerSettings(alternatives=1, search=search, **kw)  # type: ignore[arg-type]
    result = plan(d, State.from_facts([], d.dynamic_predicates), [atom("get")], settings)
    assert result.best is not None
    return result.best.text()


def test_depth_first_takes_the_first_method_astar_the_cheapest() -> None:
    d = _choice_domain()
    assert _actions(d, Search.DFS) == ["a", "a", "a"]
    assert _actions(d, Search.ASTAR) == ["b"]


def test_greedy_follows_the_estimate_of_the_whole_task_list() -> None:
    # With the least costs of the task names, h of [a, a, a] is 3 and of [b] is 1.
    assert _actions(_choice_domain(task_costs=True), Search.GBFS) == ["b"]
    assert _actions(_choice_domain(task_costs=True), Search.ASTAR) == ["b"]


def test_a_task_no_method_ever_finishes_is_dropped_at_once() -> None:
    d = Domain("never")
    d.operator("a")
    d.method("t", "again", do=["a", "t"])  # always one more t
    d.task_costs = {"a": 1.0, "t": float("inf")}
    result = plan(d, State.from_facts([], d.dynamic_predicates), [atom("t")], PlannerSettings(alternatives=1))
    assert result.status is PlanStatus.UNSOLVABLE
    assert result.expansions <= 1


@pytest.mark.parametrize("search", list(Search))
def test_the_time_limit_ends_an_endless_search(search: Search) -> None:
    # t -> t a: the task list grows without end, and no state repeats with the same list.
    d = Domain("endless")
    d.operator("a", add=["p"])
    d.method("t", "grow", do=["t", "a"])
    d.method("t", "stop", when=["q"], do=[])
    started = time.perf_counter()
    settings = PlannerSettings(alternatives=1, budget=10**9, search=search, time_limit=0.2)
    result = plan(d, State.from_facts([], d.dynamic_predicates), [atom("t")], settings)
    assert result.status is PlanStatus.TIMED_OUT
    assert time.perf_counter() - started < 5  # generous: only that it stopped


def test_the_time_limit_is_checked() -> None:
    with pytest.raises(Exception, match="time_limit"):
        PlannerSettings(time_limit=0)


# -- lazy decomposition ----------------------------------------------------------------------------


def test_a_lazy_method_gives_the_same_ways_in_the_same_order() -> None:
    head = atom("pick(?x)")
    pre = literals(["item(?x,?y)", "not bad(?y)", "near(?y,?z)"])
    subtasks = (atom("take(?x,?y)"), atom("go(?z)"))
    facts = [atom(f"item(x,y{i})") for i in range(6)] + [atom(f"near(y{i},z{i % 3})") for i in range(6)]
    facts += [atom("bad(y2)"), atom("near(y1,z9)")]
    d = Domain("lazy")
    d.operator("take(?x,?y)")
    d.operator("go(?z)")
    st = State.from_facts(facts, d.dynamic_predicates)
    eager = compile_method(head, pre, subtasks, st.dynamic_predicates)
    lazy = compile_method_lazy(head, pre, subtasks, st.dynamic_predicates)
    task = atom("pick(x)")
    assert list(lazy(task, st)) == eager(task, st)
    assert len(eager(task, st)) == 6
    assert list(lazy(atom("pick(nobody)"), st)) == []


def test_the_search_draws_only_the_ways_it_needs(monkeypatch: pytest.MonkeyPatch) -> None:
    # take(?x) for any of 1,000 items: the first way is a plan.
    d = Domain("many")
    d.operator("take(?x)", pre=["item(?x)"])
    d.method("get", "any", when=["item(?x)"], do=["take(?x)"])
    d.task_costs = {"take": 1.0, "get": 1.0}
    drawn = itertools.count()
    real = Method.compiled_lazy

    def counting(self: Method, dynamic: frozenset[str]):  # type: ignore[no-untyped-def]
        run = real(self, dynamic)

        def each(task: Atom, st: State) -> Iterator[tuple[Atom, ...]]:
            for way in run(task, st):
                next(drawn)
                yield way

        return each

    eager = Method.compiled

    def counting_eager(self: Method, dynamic: frozenset[str]):  # type: ignore[no-untyped-def]
        run = eager(self, dynamic)

        def all_ways(task: Atom, st: State) -> list[tuple[Atom, ...]]:
            ways = run(task, st)
            for _ in ways:
                next(drawn)
            return ways

        return all_ways

    monkeypatch.setattr(Method, "compiled_lazy", counting)
    monkeypatch.setattr(Method, "compiled", counting_eager)
    state = State.from_facts([atom(f"item(i{n})") for n in range(1000)], d.dynamic_predicates)
    for search in Search:
        result = plan(d, state, [atom("get")], PlannerSettings(alternatives=1, search=search))
        assert result.best is not None and result.best.text() == ["take(i0)"]
    assert 1 <= next(drawn) <= 2 * len(Search)


# -- preconditions of the subtasks checked when the method is chosen (docs/design.md §7) --------------

BAKERY = """
(define (domain bakery) (:requirements :typing :hierarchy :negative-preconditions)
  (:types bread)
  (:predicates (fresh ?b - bread) (sold ?b - bread) (open))
  (:task sell-one :parameters ())
  (:method m :parameters (?b - bread) :task (sell-one) :ordered-subtasks (and (wrap ?b) (sell ?b)))
  (:action wrap :parameters (?b - bread) :precondition (fresh ?b) :effect ())
  (:action sell :parameters (?b - bread) :precondition (and (open) (not (sold ?b))) :effect (sold ?b)))
"""


def _bakery(fresh: str, opened: bool = True) -> tuple[object, object]:
    domain = parse_domain(BAKERY, "bakery.hddl")
    breads = " ".join(f"b{i}" for i in range(40))
    problem = parse_problem(
        f"(define (problem p) (:domain bakery) (:objects {breads} - bread)"
        f" (:htn :ordered-subtasks (sell-one)) (:init (fresh {fresh}) {'(open)' if opened else ''}))",
        domain,
        "p.hddl",
    )
    return domain, problem


def test_the_subtasks_preconditions_bind_the_methods_parameters() -> None:
    domain, problem = _bakery("b39")
    planning = translate(domain, problem)  # type: ignore[arg-type]
    (method,) = planning.domain.methods["sell-one"]
    texts = [str(lit) for lit in method.pre]
    # wrap's precondition binds ?b by the fresh breads; sell's, whose predicates wrap does
    # not change, are checked too.
    assert texts.index("fresh(?b)") < texts.index("__type_bread(?b)")
    assert "open" in texts
    assert "not sold(?b)" in texts
    for search in Search:
        result = solve(domain, problem, search=search).result  # type: ignore[arg-type]
        assert result.best is not None
        assert [str(s.action) for s in result.best.steps] == ["wrap(b39)", "sell(b39)"]
        # Without the early check, every one of the 40 breads would be tried in turn.
        assert result.expansions <= 6


def test_an_early_check_that_fails_makes_the_method_fail_at_once() -> None:
    domain, problem = _bakery("b3", opened=False)
    result = solve(domain, problem).result  # type: ignore[arg-type]
    assert result.status is PlanStatus.UNSOLVABLE
    assert result.expansions <= 3


LOGISTICS = """
(define (domain logistics) (:requirements :typing :hierarchy)
  (:types place thing - object truck parcel - thing)
  (:predicates (at ?x - thing ?p - place) (road ?a ?b - place) (in ?x - parcel ?t - truck))
  (:task deliver :parameters (?x - parcel ?to - place))
  (:task get-to :parameters (?t - truck ?to - place))
  (:task load :parameters (?t - truck ?p - place ?x - parcel))
  (:method m-deliver :parameters (?x - parcel ?from ?to - place ?t - truck) :task (deliver ?x ?to)
    :ordered-subtasks (and (get-to ?t ?from) (load ?t ?from ?x) (get-to ?t ?to) (drop ?t ?to ?x)))
  (:method m-load :parameters (?t - truck ?p - place ?x - parcel) :task (load ?t ?p ?x)
    :ordered-subtasks (pick ?t ?p ?x))
  (:method m-here :parameters (?t - truck ?p - place) :task (get-to ?t ?p)
    :precondition (at ?t ?p) :ordered-subtasks ())
  (:method m-drive :parameters (?t - truck ?a ?b ?p - place) :task (get-to ?t ?p)
    :precondition (and (at ?t ?a) (road ?a ?b)) :ordered-subtasks (and (drive ?t ?a ?b) (get-to ?t ?p)))
  (:action drive :parameters (?t - truck ?a ?b - place) :precondition (and (at ?t ?a) (road ?a ?b))
    :effect (and (not (at ?t ?a)) (at ?t ?b)))
  (:action pick :parameters (?t - truck ?p - place ?x - parcel) :precondition (and (at ?t ?p) (at ?x ?p))
    :effect (and (not (at ?x ?p)) (in ?x ?t)))
  (:action drop :parameters (?t - truck ?p - place ?x - parcel) :precondition (and (at ?t ?p) (in ?x ?t))
    :effect (and (not (in ?x ?t)) (at ?x ?p))))
"""


def test_what_a_later_compound_subtask_needs_is_checked_early_when_nothing_before_changes_it() -> None:
    places = " ".join(f"c{i}" for i in range(30))
    roads = " ".join(f"(road c{i} c{i + 1}) (road c{i + 1} c{i})" for i in range(29))
    domain = parse_domain(LOGISTICS, "logistics.hddl")
    problem = parse_problem(
        f"(define (problem p) (:domain logistics) (:objects {places} - place t1 - truck x1 - parcel)"
        f" (:htn :ordered-subtasks (deliver x1 c0)) (:init (at t1 c0) (at x1 c3) {roads}))",
        domain,
        "p.hddl",
    )
    (method,) = translate(domain, problem).domain.methods["deliver"]
    texts = [str(lit) for lit in method.pre]
    # load -> pick needs the parcel at ?from, which driving (it moves trucks) never changes;
    # the truck at ?from it does change, so that one waits for the action itself.
    assert "at(?x,?from)" in texts
    assert "at(?t,?from)" not in texts
    result = solve(domain, problem, search=Search.GBFS).result
    assert result.best is not None
    assert [str(a) for a in result.best.actions if a.name == "pick"] == ["pick(t1,c3,x1)"]
    # Bound by the parcel's place, not by each of the 30 places in turn.
    assert result.expansions < 200


IPC = Path(__file__).resolve().parents[2] / "shared" / "data" / "ipc"


@pytest.mark.skipif(not (IPC / "Blocksworld-GTOHP").is_dir(), reason="no IPC suite beside the checkout")
def test_greedy_search_counts_the_goal_facts_still_missing() -> None:
    # Blocksworld-GTOHP p15: the network leaves choices (a block put on the table or not)
    # that only the goal, checked at the end, tells apart.  Counting the goal's missing
    # facts as it goes, greedy search finds a plan in a few hundred expansions; without
    # that count it runs through 5,000 without one.
    domain = read_domain(IPC / "Blocksworld-GTOHP" / "domain.hddl")
    problem = read_problem(IPC / "Blocksworld-GTOHP" / "p15.hddl", domain)
    assert len(translate(domain, problem).domain.goal_facts) > 10
    result = solve(domain, problem, search=Search.GBFS, budget=5_000).result
    assert result.best is not None
    assert check_plan(domain, problem, ipc_plan(result.best)) == []


def test_depth_first_search_drops_a_task_that_can_never_be_done_wherever_it_comes_from() -> None:
    # Depth-first search looks only at a child's new tasks for one that can never be done
    # (cost inf): one in the list given ends the search at once, one a method brings is
    # dropped with its way, and the other way is taken.
    d = _choice_domain(task_costs=True)
    d.method("stuck", "never", do=["stuck"])
    d.method("pick", "bad", do=["stuck", "a"])
    d.method("pick", "good", do=["b"])
    assert d.task_costs is not None
    d.task_costs.update({"stuck": float("inf"), "pick": 1.0})
    settings = PlannerSettings(alternatives=1, budget=1_000, search=Search.DFS)
    given = plan(d, State.from_facts((), d.dynamic_predicates), [atom("a"), atom("stuck")], settings)
    assert given.status is PlanStatus.UNSOLVABLE and given.expansions == 0
    found = plan(d, State.from_facts((), d.dynamic_predicates), [atom("pick"), atom("a")], settings)
    assert found.best is not None
    assert [s.action.name for s in found.best.steps] == ["b", "a"]
    assert found.expansions <= 3


def test_an_expansion_making_hundreds_of_ways_reads_the_clock_next() -> None:
    # pick(x) has 300 ways, one an object; a guided search makes them all into nodes at
    # once.  That is hundreds of nodes' work: the next node reads the clock (and asks the
    # checkpoint), as a portfolio's pacing and the time limit need, not 256 nodes later --
    # by when this search has its plan.
    d = Domain("many")
    d.operator("take(?x)", pre=["thing(?x)"])
    d.method("pick", "any", when=["thing(?x)"], do=["take(?x)"])
    state = State.from_facts([f"thing(o{i})" for i in range(300)], d.dynamic_predicates)
    asked: list[int] = []

    def checkpoint() -> bool:
        asked.append(1)
        return True

    settings = PlannerSettings(alternatives=1, search=Search.GBFS)
    result = plan(
        d, state, [atom("pick")], settings, guide=lambda tasks, _: float(len(tasks)), checkpoint=checkpoint
    )
    assert asked and result.status is PlanStatus.INTERRUPTED
    assert result.expansions == 1


DROPS = """(define (domain drops) (:requirements :typing :hierarchy)
  (:types thing)
  (:predicates (done) (noted ?a ?b ?c ?d - thing))
  (:task main :parameters ())
  (:method wander :parameters (?a ?b ?c ?d - thing) :task (main)
    :ordered-subtasks (and (note ?a ?b ?c ?d)))
  (:method finish :parameters () :task (main) :ordered-subtasks (and (do-it)))
  (:action note :parameters (?a ?b ?c ?d - thing) :effect (noted ?a ?b ?c ?d))
  (:action do-it :parameters () :effect (done)))"""


@pytest.mark.parametrize("search", list(Search))
def test_the_time_limit_holds_among_a_methods_dropped_ways(search: Search) -> None:
    # wander's 60**4 ways by type (about 13 million) each leave the goal fact to a task that
    # cannot add it: the goal's check drops them one by one (design §7.3), in one expansion.
    # The clock is read among them, as among nodes.
    domain = parse_domain(DROPS, "drops.hddl")
    things = " ".join(f"o{i}" for i in range(60))
    problem = parse_problem(
        f"(define (problem p) (:domain drops) (:objects {things} - thing)"
        " (:htn :ordered-subtasks (and (main))) (:init) (:goal (done)))",
        domain,
        "p.hddl",
    )
    planning = translate(domain, problem)
    started = time.perf_counter()
    settings = PlannerSettings(alternatives=1, search=search, time_limit=0.3)
    result = plan(planning.domain, planning.state, planning.tasks, settings)
    assert result.status is PlanStatus.TIMED_OUT and not result.exhausted
    assert time.perf_counter() - started < 5  # generous: only that it stopped
