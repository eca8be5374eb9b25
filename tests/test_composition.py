"""The grounded estimate (relaxed composition, docs/design.md §7.2): values worked out by hand
on a small domain written here, dead ends, the cap, and the searches it guides."""

from __future__ import annotations

import math

import pytest

from htnagent.hddl import parse_domain, parse_problem
from htnagent.hddl.check import check_plan
from htnagent.planning import composition
from htnagent.planning.composition import ground
from htnagent.planning.hddl_solving import solve
from htnagent.planning.hddl_translation import HddlPlanning, translate
from htnagent.planning.ipc_output import ipc_plan
from htnagent.planning.planner import PlannerSettings, PlanStatus, Search, plan
from tests.support import fact, grounded

# Ports joined by wires: join(a, c) links a to c directly or through another port, each
# link then checked.  A link needs its first port free and the bench unlocked; lock() is
# for ever.
DOMAIN = """
(define (domain cables)
  (:requirements :typing :hierarchy :negative-preconditions)
  (:types port)
  (:predicates (wire ?a ?b - port) (linked ?a ?b - port) (free ?p - port) (locked))
  (:task join :parameters (?a ?b - port))
  (:task connect :parameters (?a ?b - port))
  (:method join-direct :parameters (?a ?b - port) :task (join ?a ?b)
    :ordered-subtasks (connect ?a ?b))
  (:method join-via :parameters (?a ?b ?c - port) :task (join ?a ?c)
    :precondition (wire ?a ?b)
    :ordered-subtasks (and (connect ?a ?b) (join ?b ?c)))
  (:method connect-m :parameters (?a ?b - port) :task (connect ?a ?b)
    :ordered-subtasks (and (link ?a ?b) (check ?a ?b)))
  (:action link :parameters (?a ?b - port)
    :precondition (and (wire ?a ?b) (free ?a) (not (locked)))
    :effect (and (linked ?a ?b) (not (free ?a))))
  (:action check :parameters (?a ?b - port) :precondition (linked ?a ?b))
  (:action lock :parameters () :effect (locked))
)
"""


def _problem(task: str) -> str:
    return f"""
(define (problem two-wires) (:domain cables)
  (:objects p1 p2 p3 p4 - port)
  (:htn :ordered-subtasks ({task}))
  (:init (wire p1 p2) (wire p2 p3) (free p1) (free p2) (free p3) (free p4))
)
"""


def _planning(task: str = "join p1 p3") -> HddlPlanning:
    domain = parse_domain(DOMAIN, "cables.hddl")
    return translate(domain, parse_problem(_problem(task), domain, "p.hddl"))


def test_least_cost_is_the_cheapest_decomposition_whatever_the_state() -> None:
    # join(p1,p3): no wire p1-p3, so through p2: connect(p1,p2) + connect(p2,p3), two
    # actions each (link, check).
    c = grounded(_planning())
    assert c.least[fact("join", "p1", "p3")] == 4
    assert c.least[fact("connect", "p1", "p2")] == 2
    # No wire p1-p3: link(p1,p3) never applies (the translation even checks it in the method).
    assert c.least.get(fact("connect", "p1", "p3"), math.inf) == math.inf
    assert c.least[fact("join", "p3", "p3")] == math.inf  # met (through p2), but nothing leaves p3


def test_estimate_from_the_start_adds_what_each_task_needs() -> None:
    # h_add by hand: link(p1,p2) 1 (free p1, unlocked: true now); check(p1,p2) 1 + the link
    # that makes linked(p1,p2) = 2; connect(p1,p2) = 1 + 2 = 3; likewise connect(p2,p3) = 3;
    # join(p1,p3) = 6, and the network's root task the same.
    planning = _planning()
    c = grounded(planning)
    start = planning.state.dynamic
    assert c.estimate([fact("join", "p1", "p3")], start) == 6
    assert c.estimate(planning.tasks, start) == 6
    assert c.estimate([fact("connect", "p1", "p2"), fact("join", "p2", "p3")], start) == 6


def test_estimate_follows_the_state() -> None:
    # After link(p1,p2): check(p1,p2) costs 1 (linked holds), join(p2,p3) still 3.
    planning = _planning()
    c = grounded(planning)
    after = (planning.state.dynamic - {fact("free", "p1")}) | {fact("linked", "p1", "p2")}
    assert c.estimate([fact("check", "p1", "p2"), fact("join", "p2", "p3")], after) == 4
    # p1 is no longer free and nothing frees it: linking it again cannot be done.
    assert c.estimate([fact("connect", "p1", "p2")], after) == math.inf


def test_a_negative_precondition_nothing_restores_is_a_dead_end() -> None:
    # Once locked, no link can be made (nothing deletes locked): the delete relaxation
    # alone would miss it; the negated fact does not.
    planning = _planning()
    c = grounded(planning)
    locked = planning.state.dynamic | {fact("locked")}
    assert c.estimate([fact("join", "p1", "p3")], locked) == math.inf
    assert c.estimate([fact("check", "p1", "p2")], locked) == math.inf


def test_a_task_no_decomposition_reaches_is_infinite() -> None:
    # No wire reaches p4.
    planning = _planning("join p1 p4")
    c = grounded(planning)
    assert c.least[fact("join", "p1", "p4")] == math.inf
    assert c.estimate(planning.tasks, planning.state.dynamic) == math.inf


def test_past_the_cap_there_is_no_grounding_and_solving_falls_back(monkeypatch: pytest.MonkeyPatch) -> None:
    planning = _planning()
    assert ground(planning.domain, planning.state, planning.tasks, cap=3) is None
    # A checkpoint that says stop ends the grounding the same way (a portfolio stopping it).
    monkeypatch.setattr(composition, "CHECK_EVERY", 1)
    assert ground(planning.domain, planning.state, planning.tasks, checkpoint=lambda: True) is None
    assert ground(planning.domain, planning.state, planning.tasks, checkpoint=lambda: False) is not None
    domain = parse_domain(DOMAIN, "cables.hddl")
    problem = parse_problem(_problem("join p1 p3"), domain, "p.hddl")
    solved = solve(domain, problem, timeout=10)
    assert solved.result.status is PlanStatus.SOLVED


@pytest.mark.parametrize("search", [Search.GBFS, Search.ASTAR])
def test_the_guided_search_finds_a_plan_the_checker_accepts(search: Search) -> None:
    planning = _planning()
    c = grounded(planning)
    settings = PlannerSettings(alternatives=1, search=search)
    result = plan(planning.domain, planning.state, planning.tasks, settings, guide=c.estimate)
    assert result.status is PlanStatus.SOLVED and result.best is not None
    actions = [str(s.action) for s in result.best.steps if not s.action.name.startswith("__")]
    assert actions == ["link(p1,p2)", "check(p1,p2)", "link(p2,p3)", "check(p2,p3)"]
    assert [str(v) for v in check_plan(planning.hddl, planning.problem, ipc_plan(result.best))] == []


def test_the_guided_search_proves_a_dead_end_unsolvable_at_once() -> None:
    planning = _planning("join p1 p4")
    c = grounded(planning)
    settings = PlannerSettings(alternatives=1, search=Search.GBFS)
    result = plan(planning.domain, planning.state, planning.tasks, settings, guide=c.estimate)
    assert result.status is PlanStatus.UNSOLVABLE
    assert result.expansions <= 1  # the root's, whose children are all dead ends


def test_the_portfolio_says_unsolvable_where_only_the_grounded_search_can_tell() -> None:
    # t ends only where q holds, and nothing makes q: the lifted searches decompose t into
    # t and one more action for ever (the task list grows without end), while the grounded
    # estimate of t is infinite from the start.
    text = (
        "(define (domain forever) (:requirements :hierarchy) (:predicates (p) (q))"
        " (:task t :parameters ()) (:method m :parameters () :task (t) :ordered-subtasks (and (t) (a)))"
        " (:method end :parameters () :task (t) :precondition (q) :ordered-subtasks ())"
        " (:action a :parameters () :effect (p)))"
    )
    domain = parse_domain(text, "forever.hddl")
    problem = parse_problem(
        "(define (problem p) (:domain forever) (:htn :ordered-subtasks (t)) (:init))", domain, "p.hddl"
    )
    assert solve(domain, problem, search=Search.GBFS, timeout=0.5).result.status is PlanStatus.TIMED_OUT
    assert solve(domain, problem, timeout=30).result.status is PlanStatus.UNSOLVABLE


KEYS = """
(define (domain keys)
  (:requirements :typing :hierarchy :existential-preconditions)
  (:types key door)
  (:predicates (fits ?k - key ?d - door) (have ?k - key) (spare ?k - key) (open ?d - door))
  (:task enter :parameters (?d - door))
  (:method by-spare :parameters (?d - door ?k - key) :task (enter ?d)
    :precondition (fits ?k ?d) :ordered-subtasks (and (get ?k) (unlock ?d)))
  (:method at-once :parameters (?d - door) :task (enter ?d) :ordered-subtasks (unlock ?d))
  (:action get :parameters (?k - key) :precondition (spare ?k) :effect (have ?k))
  (:action unlock :parameters (?d - door)
    :precondition (exists (?k - key) (and (fits ?k ?d) (have ?k))) :effect (open ?d))
)
"""


def test_every_binding_of_a_precondition_only_variable_is_a_way_of_its_own() -> None:
    # unlock(d) holds with either key: k2 is in hand, k1 must be got first.  The grounding
    # keeps both ways, whichever it meets first: from the start unlock costs 1, and where
    # only the spare k1 is left, 2 (get it, then unlock).
    domain = parse_domain(KEYS, "keys.hddl")
    problem = parse_problem(
        "(define (problem p) (:domain keys) (:objects k1 k2 - key d - door)"
        " (:htn :ordered-subtasks (enter d)) (:init (fits k1 d) (fits k2 d) (spare k1) (have k2)))",
        domain,
        "p.hddl",
    )
    planning = translate(domain, problem)
    c = grounded(planning)
    start = planning.state.dynamic
    assert c.estimate([fact("unlock", "d")], start) == 1
    assert c.estimate([fact("enter", "d")], start) == 1
    without_k2 = start - {fact("have", "k2")}
    assert c.estimate([fact("unlock", "d")], without_k2) == 2


# A workshop: finish(i) coats the item in some colour with some brush, then sands it with
# some tool.  The method's colour, brush and tool appear only in its subtasks, so only their
# types bound them: N**3 bindings an item.  coat and sand have several methods each, so their
# actions' preconditions are not pulled up into finish-m (design §7) to bind them by facts.
# sand-done's tool is bound by nothing at all (the task's declared type is its type).
WORKSHOP = """
(define (domain workshop)
  (:requirements :typing :hierarchy)
  (:types item colour brush tool)
  (:predicates (fits ?b - brush ?c - colour) (wanted ?i - item ?c - colour) (sharp ?t - tool)
               (painted ?i - item) (smooth ?i - item))
  (:task finish :parameters (?i - item))
  (:task coat :parameters (?i - item ?c - colour ?b - brush))
  (:task sand :parameters (?i - item ?t - tool))
  (:method finish-m :parameters (?i - item ?c - colour ?b - brush ?t - tool) :task (finish ?i)
    :ordered-subtasks (and (coat ?i ?c ?b) (sand ?i ?t)))
  (:method coat-once :parameters (?i - item ?c - colour ?b - brush) :task (coat ?i ?c ?b)
    :ordered-subtasks (paint ?i ?c ?b))
  (:method coat-twice :parameters (?i - item ?c - colour ?b - brush) :task (coat ?i ?c ?b)
    :ordered-subtasks (and (paint ?i ?c ?b) (paint ?i ?c ?b)))
  (:method sand-once :parameters (?i - item ?t - tool) :task (sand ?i ?t)
    :ordered-subtasks (polish ?i ?t))
  (:method sand-twice :parameters (?i - item ?t - tool) :task (sand ?i ?t)
    :ordered-subtasks (and (polish ?i ?t) (polish ?i ?t)))
  (:method sand-done :parameters (?i - item ?t - tool) :task (sand ?i ?t)
    :precondition (smooth ?i) :ordered-subtasks ())
  (:action paint :parameters (?i - item ?c - colour ?b - brush)
    :precondition (and (wanted ?i ?c) (fits ?b ?c)) :effect (painted ?i))
  (:action polish :parameters (?i - item ?t - tool)
    :precondition (and (painted ?i) (sharp ?t)) :effect (smooth ?i))
)
"""


def _workshop(n: int, domain_text: str = WORKSHOP) -> HddlPlanning:
    """Two items, each wanted in its own colour; brush k fits colour k; tool t1 alone is
    sharp; n colours, brushes and tools (in the workshop domain, or ``domain_text``)."""
    objects = " ".join([f"c{k} - colour b{k} - brush t{k} - tool" for k in range(1, n + 1)])
    fits = " ".join(f"(fits b{k} c{k})" for k in range(1, n + 1))
    domain = parse_domain(domain_text, "workshop.hddl")
    problem = parse_problem(
        f"(define (problem p) (:domain workshop) (:objects i1 i2 - item {objects})"
        " (:htn :ordered-subtasks (and (finish i1) (finish i2)))"
        f" (:init {fits} (wanted i1 c1) (wanted i2 c2) (sharp t1)))",
        domain,
        "p.hddl",
    )
    return translate(domain, problem)


def _by_types(monkeypatch: pytest.MonkeyPatch) -> None:
    """The grounder as it was: every parameter the precondition leaves is bound by its type."""
    monkeypatch.setattr(composition, "JOIN_ABOVE", math.inf)


def test_parameters_only_subtasks_name_are_bound_by_what_can_occur() -> None:
    # 12 colours, brushes and tools: 1,728 bindings of finish-m an item by types -- past a
    # cap of 1,000 -- but only one colour and brush an item can be coated with.
    planning = _workshop(12)
    c = ground(planning.domain, planning.state, planning.tasks, cap=1_000)
    assert c is not None
    # finish(i1): paint (1), then sanding, which may be nothing whatever the state (0).
    # From the start, h_add: coat 1; sand needs smooth (2: a polish and the paint before
    # it) for sand-done, or for sand-once painted (1) and polish (1 + painted's 1): 3; and
    # both items add up.
    assert c.least[fact("finish", "i1")] == 1
    assert c.estimate([fact("finish", "i1")], planning.state.dynamic) == 3
    assert c.estimate(planning.tasks, planning.state.dynamic) == 6
    # A coat nothing can do (i1 is not wanted in c2) is a dead end, though no method met it.
    assert fact("coat", "i1", "c2", "b2") not in c.least
    assert c.estimate([fact("coat", "i1", "c2", "b2")], planning.state.dynamic) == math.inf
    # Sanding with a blunt tool: only once the item is smooth (sand-done, with any tool):
    # polish(i1,t1) and the paint before it -- which only a task before it can do (step 6).
    assert c.estimate([fact("finish", "i1"), fact("sand", "i1", "t2")], planning.state.dynamic) == 3 + 2
    assert c.estimate([fact("sand", "i1", "t2")], planning.state.dynamic) == math.inf
    assert c.estimate([fact("sand", "i1", "t2")], planning.state.dynamic | {fact("smooth", "i1")}) == 0
    # Bound by types alone, the grounding goes past the cap.
    with pytest.raises(composition.TooLarge):
        composition._Grounder(planning.domain, planning.state, 1_000, None, joining=False).run(planning.tasks)


def test_binding_by_what_can_occur_leaves_the_estimate_as_it_was(monkeypatch: pytest.MonkeyPatch) -> None:
    # Small enough for both ways: every ground task's least cost and estimate, from the start
    # and after painting, are the same joined as bound by types (7**3 bindings of finish-m
    # an item: past a twenty-fifth of a cap of 2,000, so the join is what runs).
    planning = _workshop(7)
    joined = ground(planning.domain, planning.state, planning.tasks, cap=2_000)
    assert joined is not None
    _by_types(monkeypatch)
    typed = grounded(planning)
    start = planning.state.dynamic
    painted = start | {fact("painted", "i1")}
    tasks = [t for t in typed.least if not t.name.startswith("__")]
    assert len(tasks) > 100  # the types' bindings: every colour, brush and tool met
    for t in tasks:
        assert joined.least.get(t, math.inf) == typed.least[t], t
        for state in (start, painted):
            assert joined.estimate([t], state) == typed.estimate([t], state), t
    for state in (start, painted):
        assert joined.estimate(planning.tasks, state) == typed.estimate(planning.tasks, state)
    assert len(joined.least) < len(typed.least) / 3  # what nothing can do is never met


def test_the_joined_grounding_guides_a_search_to_a_plan_the_checker_accepts() -> None:
    planning = _workshop(12)
    c = ground(planning.domain, planning.state, planning.tasks, cap=1_000)
    assert c is not None
    settings = PlannerSettings(alternatives=1, search=Search.GBFS)
    result = plan(planning.domain, planning.state, planning.tasks, settings, guide=c.estimate)
    assert result.status is PlanStatus.SOLVED and result.best is not None
    actions = [str(s.action) for s in result.best.steps if not s.action.name.startswith("__")]
    assert actions == ["paint(i1,c1,b1)", "polish(i1,t1)", "paint(i2,c2,b2)", "polish(i2,t1)"]
    assert [str(v) for v in check_plan(planning.hddl, planning.problem, ipc_plan(result.best))] == []
