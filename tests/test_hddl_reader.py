"""Reading total-order HDDL (htnagent.hddl): every construct into the model, every error one line.

The small HDDL texts are written here.  The IPC benchmark domains are read where
``../shared/data/ipc`` lies beside the repository (skipped otherwise; they are
never copied into the project, most have no licence).
"""

from __future__ import annotations

import os
from pathlib import Path

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from htnagent.errors import HddlError, HtnAgentError
from htnagent.hddl import parse_domain, parse_problem, read_domain, read_problem
from htnagent.hddl.model import (
    And,
    AndEffect,
    Domain,
    Equals,
    Exists,
    Forall,
    ForallEffect,
    Imply,
    Literal,
    Not,
    Or,
    Pred,
    SortOf,
    Subtask,
    Typed,
    When,
)
from htnagent.limits import MAX_HDDL_DEPTH
from htnagent.model.terms import Atom
from htnagent.testing.hddl_inputs import suite_pairs, synthetic

REPO = Path(__file__).resolve().parents[1]
IPC = REPO.parent / "shared" / "data" / "ipc"
HERE = Path(__file__).resolve().parent / "hddl"

DOMAIN = """; every construct the reader knows
(define (domain Every)
  (:requirements :typing :hierarchy :equality :negative-preconditions
                 :universal-preconditions :conditional-effects :method-preconditions)
  (:types room corridor - place
          box - (either thing movable)
          place robot)
  (:constants Hall - room)
  (:predicates (at ?r - robot ?p - place) (in ?b - box ?p - place) (lit ?p - place) (door ?a ?b - place))
  (:task goto :parameters (?r - robot ?to - place))
  (:task fetch :parameters (?b - box))
  (:action move
    :parameters (?r - robot ?from ?to - place)
    :precondition (and (at ?r ?from) (or (door ?from ?to) (door ?to ?from)) (not (= ?from ?to))
                       (imply (lit ?from) (lit ?to)) (exists (?x - place) (lit ?x)))
    :effect (and (not (at ?r ?from)) (at ?r ?to)
                 (forall (?p - place) (when (lit ?p) (not (lit ?p))))))
  (:action noop :parameters ())
  (:method m-here :parameters (?r - robot ?to - place) :task (goto ?r ?to)
    :precondition (at ?r ?to) :ordered-subtasks ())
  (:method m-step :parameters (?r - robot ?to ?from - place) :task (GOTO ?r ?to)
    :precondition (forall (?b - box) (not (in ?b ?from)))
    :ordered-subtasks (and (t1 (move ?r ?from ?to)) (goto ?r ?to)))
  (:method m-partial-syntax :parameters (?r - robot) :task (goto ?r hall)
    :subtasks (and (b (goto ?r hall)) (a (move ?r hall hall)) (c (noop)))
    :ordering (and (< a b) (< b c)))
  (:method m-one :parameters (?b - box) :task (fetch ?b) :tasks (noop)
    :constraints (and (sortof ?b - box) (not (= ?b ?b))))
  (:method m-tasks :parameters (?b - box) :task (fetch ?b) :ordered-tasks (and (noop) (noop)))
)
"""

PROBLEM = """(define (problem p1) (:domain every)
  (:init (at r1 hall) (lit hall) (door hall k))
  (:objects r1 - robot k - room b1 b2 - box)
  (:htn :parameters (?x - place)
        :subtasks (and (t2 (goto r1 ?x)) (t1 (fetch b1)))
        :ordering (< t1 t2))
  (:goal (and (at r1 k)))
)
"""


@pytest.fixture(scope="module")
def every() -> Domain:
    return parse_domain(DOMAIN, "every.hddl")


def test_the_domain_reads_into_typed_immutable_values_lower_case(every: Domain) -> None:
    d = every
    assert d.name == "every"
    assert ":conditional-effects" in d.requirements
    assert d.types["room"] == ("place",)
    assert d.types["box"] == ("thing", "movable")  # either: a box is both
    assert d.types["thing"] == ("object",)  # declared by being named as a supertype
    assert d.types["object"] == ()
    assert d.supertypes("room") == {"room", "place", "object"}
    assert d.constants == (Typed("hall", ("room",)),)
    assert d.predicates["door"].params == (Typed("?a", ("place",)), Typed("?b", ("place",)))
    assert d.tasks["goto"].params == (Typed("?r", ("robot",)), Typed("?to", ("place",)))
    with pytest.raises(TypeError):
        d.tasks["new"] = d.tasks["goto"]  # type: ignore[index]


def test_preconditions_and_effects_keep_their_formula_trees(every: Domain) -> None:
    move = every.actions["move"]
    assert isinstance(move.precondition, And)
    at, either_door, differ, implies, exists = move.precondition.args
    assert at == Pred(Atom("at", ("?r", "?from")))
    assert either_door == Or((Pred(Atom("door", ("?from", "?to"))), Pred(Atom("door", ("?to", "?from")))))
    assert differ == Not(Equals("?from", "?to"))
    assert implies == Imply(Pred(Atom("lit", ("?from",))), Pred(Atom("lit", ("?to",))))
    assert exists == Exists((Typed("?x", ("place",)),), Pred(Atom("lit", ("?x",))))
    assert move.effect == AndEffect(
        (
            Literal(Atom("at", ("?r", "?from")), positive=False),
            Literal(Atom("at", ("?r", "?to"))),
            ForallEffect(
                (Typed("?p", ("place",)),),
                When(Pred(Atom("lit", ("?p",))), Literal(Atom("lit", ("?p",)), positive=False)),
            ),
        )
    )
    assert every.actions["noop"].precondition == And() and every.actions["noop"].effect == AndEffect()


def test_methods_keep_their_subtasks_in_total_order(every: Domain) -> None:
    m = every.methods
    assert m["m-here"].subtasks == ()
    assert m["m-step"].task == Atom("goto", ("?r", "?to"))
    assert m["m-step"].subtasks == (
        Subtask(Atom("move", ("?r", "?from", "?to")), "t1"),
        Subtask(Atom("goto", ("?r", "?to")), None),
    )
    assert isinstance(m["m-step"].precondition, Forall)
    # :subtasks with an :ordering that orders them totally: read in that order.
    assert [s.id for s in m["m-partial-syntax"].subtasks] == ["a", "b", "c"]
    assert m["m-one"].subtasks == (Subtask(Atom("noop"), None),)  # one subtask, no 'and'
    assert m["m-one"].constraints == And((SortOf("?b", ("box",)), Not(Equals("?b", "?b"))))
    assert [s.call.name for s in m["m-tasks"].subtasks] == ["noop", "noop"]
    assert [x.name for x in every.methods_for("goto")] == ["m-here", "m-step", "m-partial-syntax"]


def test_the_problem_reads_with_its_sections_in_any_order(every: Domain) -> None:
    p = parse_problem(PROBLEM, every, "p1.hddl")
    assert (p.name, p.domain) == ("p1", "every")
    assert [o.name for o in p.objects] == ["r1", "k", "b1", "b2"]
    assert p.init == (Atom("at", ("r1", "hall")), Atom("lit", ("hall",)), Atom("door", ("hall", "k")))
    assert p.htn_params == (Typed("?x", ("place",)),)
    assert [s.call for s in p.htn] == [Atom("fetch", ("b1",)), Atom("goto", ("r1", "?x"))]
    assert p.goal == And((Pred(Atom("at", ("r1", "k"))),))


def test_positions_are_kept_for_messages_but_not_compared(every: Domain) -> None:
    step = every.methods["m-step"]
    assert every.source.where(step.at) == (21, 3)
    assert Pred(Atom("lit", ("?x",)), at=5) == Pred(Atom("lit", ("?x",)), at=99)


# -- one line per error, at its place -------------------------------------------------------------


def _domain(body: str) -> str:
    return f"(define (domain d) (:types t) (:predicates (p ?x - t))\n{body}\n)"


DOMAIN_ERRORS = [
    ("", "d.hddl: the file is empty (or only comments); expected an HDDL domain"),
    ("; nothing\n  ; at all\n", "d.hddl: the file is empty (or only comments); expected an HDDL domain"),
    ("(define (domain d))\n)", "d.hddl:2:1: this ')' closes no '('"),
    ("(define (domain d)\n  (:types t", "d.hddl:2:3: this '(' is never closed"),
    ("(define (domain d) (:types a))) (", "d.hddl:1:31: this ')' closes no '('"),
    ("hello", "d.hddl:1:1: expected (define (domain NAME) ...), got 'hello'"),
    ("(define (problem d))", "d.hddl:1:9: expected (domain NAME), got '(problem d)'"),
    (
        "(define (domain d)) (define (domain e))",
        "d.hddl:1:21: unexpected '(define (domain e))' after the end of the domain definition",
    ),
    ("(define (domain d) (:types t) (:constants c - u))", "d.hddl:1:43: c: unknown type u"),
    (_domain("(:task go :parameters (?x - u))"), "d.hddl:2:24: ?x: unknown type u"),
    (
        _domain("(:action a :parameters (?x - t) :precondition (q ?x))"),
        "d.hddl:2:47: action a: unknown predicate q",
    ),
    (
        _domain("(:action a :parameters (?x - t) :effect (p ?x ?x))"),
        "d.hddl:2:41: action a: predicate p takes 1 argument, given 2",
    ),
    (
        _domain("(:action a :parameters (?x - t) :precondition (p ?y))"),
        "d.hddl:2:47: action a: variable ?y is not declared",
    ),
    (
        _domain("(:action a :parameters () :precondition (p c))"),
        "d.hddl:2:41: action a: c is no declared constant",
    ),
    (
        _domain("(:method m :parameters () :task (go))"),
        "d.hddl:2:1: method m decomposes go, which is no declared task",
    ),
    (
        _domain("(:action go) (:method m :task (go))"),
        "d.hddl:2:14: method m decomposes go, which is an action, not a compound task",
    ),
    (
        _domain("(:task go) (:method m :task (go) :ordered-subtasks (come))"),
        "d.hddl:2:52: method m: no task or action is named come",
    ),
    (
        _domain("(:task go) (:method m :task (go) :ordered-subtasks (go x))"),
        "d.hddl:2:52: method m: task go takes 0 arguments, given 1",
    ),
    (
        _domain("(:task go :parameters (?x - t)) (:method m :task (go ?y))"),
        "d.hddl:2:33: method m: variable ?y is not declared",
    ),
    (_domain("(:predicates (p))"), "d.hddl:2:14: predicate p is declared twice (first at 1:44)"),
    (_domain("(:task go) (:action go)"), "d.hddl:2:12: task or action go is declared twice (first at 2:1)"),
    (
        _domain("(:task go) (:method m :task (go)) (:method m :task (go))"),
        "d.hddl:2:35: method m is declared twice (first at 2:12)",
    ),
    (
        _domain("(:task go :parameters (?x ?x - t))"),
        "d.hddl:2:27: ?x is declared twice in this list (first at 2:24)",
    ),
    ("(define (domain d) (:types a b) (:types a))", "d.hddl:1:41: type a is declared twice (first at 1:28)"),
    ("(define (domain d) (:types a - b b - a))", "d.hddl:1:28: type a is its own supertype (a cycle)"),
    (
        _domain("(:task go) (:method m :task (go) :subtasks (and (x (go)) (y (go))))"),
        "d.hddl:2:12: method m: its subtasks are only partially ordered (x and y may come in either "
        "order); only total-order HDDL is read",
    ),
    (
        _domain(
            "(:task go) (:method m :task (go) :subtasks (and (x (go)) (y (go))) :ordering (and (< x y) (< "
            "y x)))"
        ),
        "d.hddl:2:12: method m: the ordering has a cycle (through x)",
    ),
    (
        _domain("(:task go) (:method m :task (go) :subtasks (and (x (go)) (y (go))) :ordering (< x z))"),
        "d.hddl:2:78: method m: the ordering names z, which is no subtask id",
    ),
    (
        _domain("(:task go) (:method m :task (go) :subtasks (and (x (go)) (x (go))))"),
        "d.hddl:2:58: subtask id x is used twice (first at 2:49)",
    ),
    (
        _domain("(:task go) (:method m :task (go) :ordered-subtasks (go) :subtasks (go))"),
        "d.hddl:2:67: method m gives its subtasks twice (:ordered-subtasks and :subtasks)",
    ),
    (
        _domain("(:task go) (:method m :task (go) :effect ())"),
        "d.hddl:2:34: method m has no :effect (expected one of :constraints, :ordered-subtasks, "
        ":ordered-tasks, :ordering, :parameters, :precondition, :subtasks, :task, :tasks)",
    ),
    (
        _domain("(:task go) (:method m :task (go) :task (go))"),
        "d.hddl:2:34: :task is given twice in method m",
    ),
    (
        _domain("(:action a :effect (increase (total-cost) 1))"),
        "d.hddl:2:20: numeric effects (increase ...) and action costs are not supported",
    ),
    (
        _domain("(:functions (total-cost) - number)"),
        "d.hddl:2:1: :functions (numeric fluents, action costs) is not supported",
    ),
    (_domain("(:action a :precondition (not (p ?x) (p ?x)))"), "d.hddl:2:26: (not ...) takes 1 part, got 2"),
    (
        _domain("(:action a :precondition (when (p ?x) (p ?x)))"),
        "d.hddl:2:26: (when ...) is an effect, not a condition",
    ),
    (
        _domain("(:action a :effect (not (and)))"),
        "d.hddl:2:25: (not ...) in an effect deletes a fact; got '(and)'",
    ),
    (
        _domain("(:action a :parameters (?x - t) :precondition (p ?x!))"),
        "d.hddl:2:50: expected a variable or a constant, got '?x!'",
    ),
    (
        _domain("(:action 9a)"),
        "d.hddl:2:10: expected the action's name, got '9a' (a name is a letter, then letters, digits, '-' "
        "or '_')",
    ),
    (
        _domain("(:action a :parameters (x - t))"),
        "d.hddl:2:25: expected a parameter (a variable such as ?x), got 'x'",
    ),
    (_domain("(:action a :parameters (?x -))"), "d.hddl:2:28: '-' with no type after it"),
    (
        _domain("(:action a :parameters (- t))"),
        "d.hddl:2:25: '-' with nothing before it (expected a parameter, then '- type')",
    ),
    (_domain("(:action a :parameters (?x - t) :precondition)"), "d.hddl:2:33: :precondition has no value"),
    (
        _domain("(:hello)"),
        "d.hddl:2:1: a domain has no :hello section (expected :requirements, :types, :constants, "
        ":predicates, :task, :method, :action)",
    ),
]


@pytest.mark.parametrize(("text", "message"), DOMAIN_ERRORS)
def test_each_invalid_domain_is_one_line_at_its_place(text: str, message: str) -> None:
    with pytest.raises(HddlError) as caught:
        parse_domain(text, "d.hddl")
    assert str(caught.value) == message
    assert isinstance(caught.value, HtnAgentError)


PROBLEM_ERRORS = [
    (
        "(define (problem q) (:domain other))",
        "q.hddl:1:30: the problem is for domain other, but the domain is every",
    ),
    (
        "(define (problem q) (:domain every) (:init (at r9 hall)))",
        "q.hddl:1:44: :init: r9 is no declared object or constant",
    ),
    ("(define (problem q) (:domain every) (:init (on hall)))", "q.hddl:1:44: :init: unknown predicate on"),
    (
        "(define (problem q) (:domain every) (:init (lit)))",
        "q.hddl:1:44: :init: predicate lit takes 1 argument, given 0",
    ),
    (
        "(define (problem q) (:domain every) (:init (lit ?x)))",
        "q.hddl:1:49: expected an object in an initial fact, got '?x'",
    ),
    (
        "(define (problem q) (:domain every) (:init (= (cost) 1)))",
        "q.hddl:1:44: '(= (cost) 1)' in :init: numeric fluents are not supported",
    ),
    (
        "(define (problem q) (:domain every) (:init) (:init))",
        "q.hddl:1:45: a second :init section (the first is at 1:37)",
    ),
    ("(define (problem q) (:domain every) (:objects a - nowhere))", "q.hddl:1:47: a: unknown type nowhere"),
    (
        "(define (problem q) (:domain every) (:objects a a - room))",
        "q.hddl:1:49: a is declared twice in this list (first at 1:47)",
    ),
    (
        "(define (problem q) (:domain every) (:htn :ordered-subtasks (fly)))",
        "q.hddl:1:61: :htn: no task or action is named fly",
    ),
    (
        "(define (problem q) (:domain every) (:htn :ordered-subtasks (goto ?r hall)))",
        "q.hddl:1:61: :htn: variable ?r is not declared",
    ),
    (
        "(define (problem q) (:domain every) (:goal (lit ?x)))",
        "q.hddl:1:44: :goal: variable ?x is not declared",
    ),
]


@pytest.mark.parametrize(("text", "message"), PROBLEM_ERRORS)
def test_each_invalid_problem_is_one_line_at_its_place(every: Domain, text: str, message: str) -> None:
    with pytest.raises(HddlError) as caught:
        parse_problem(text, every, "q.hddl")
    assert str(caught.value) == message


def test_nesting_is_bounded_without_recursion_error() -> None:
    deep = "(define (domain d) " + "(" * 100_000
    with pytest.raises(HddlError) as caught:
        parse_domain(deep, "d.hddl")
    assert (
        str(caught.value)
        == f"d.hddl:1:{20 + MAX_HDDL_DEPTH - 1}: nested more than {MAX_HDDL_DEPTH} parentheses deep"
    )


def test_formulas_nested_to_the_bound_are_read_and_checked() -> None:
    depth = MAX_HDDL_DEPTH - 6
    body = "(not " * depth + "(p ?x)" + ")" * depth
    d = parse_domain(_domain(f"(:action a :parameters (?x - t) :precondition {body})"), "d.hddl")
    f = d.actions["a"].precondition
    for _ in range(depth):
        assert isinstance(f, Not)
        f = f.arg
    assert f == Pred(Atom("p", ("?x",)))


def test_files_are_read_safely(tmp_path: Path) -> None:
    with pytest.raises(HddlError, match=r"is a directory, not a HDDL domain file"):
        read_domain(tmp_path)
    with pytest.raises(HddlError, match=r"no such file; expected a HDDL domain file"):
        read_domain(tmp_path / "missing.hddl")
    garbage = tmp_path / "garbage.hddl"
    garbage.write_bytes(b"(define \xff\xfe\x00 (domain")
    with pytest.raises(HddlError) as caught:
        read_domain(garbage)
    assert (
        str(caught.value) == f"{garbage}:1: not UTF-8 text (byte 0xff at byte 8); expected a HDDL domain file"
    )
    nul = tmp_path / "nul.hddl"
    nul.write_bytes(b"(define (domain d\x00))")
    with pytest.raises(HddlError, match=r"nul.hddl:1:17: expected the domain's name, got 'd\\x00'"):
        read_domain(nul)
    big = tmp_path / "big.hddl"
    big.write_text("(define (domain d))" + " " * 100)
    with pytest.raises(HddlError, match=r"the file is too big"):
        read_domain(big, max_bytes=50)
    assert read_problem(HERE / "courier.hddl", read_domain(HERE / "courier-domain.hddl")).name == "courier-1"


def test_unicode_that_lowers_to_two_characters_keeps_positions() -> None:
    with pytest.raises(HddlError) as caught:
        parse_domain("(define (domain İİİ))", "d.hddl")
    assert (
        str(caught.value)
        == "d.hddl:1:17: expected the domain's name, got 'İİİ' (a name is a letter, then letters, digits, "
        "'-' or '_')"
    )


# -- fuzz: nothing but HddlError, ever ------------------------------------------------------------

_TOKENS = [
    "(",
    ")",
    "(",
    ")",
    "define",
    "domain",
    "problem",
    "(domain d)",
    ":types",
    ":predicates",
    ":task",
    ":method",
    ":action",
    ":parameters",
    ":precondition",
    ":effect",
    ":task",
    ":ordered-subtasks",
    ":subtasks",
    ":ordering",
    ":constraints",
    ":objects",
    ":init",
    ":htn",
    ":goal",
    "and",
    "or",
    "not",
    "imply",
    "forall",
    "exists",
    "when",
    "either",
    "sortof",
    "=",
    "<",
    "-",
    "?x",
    "?y",
    "t",
    "p",
    "go",
    "object",
    "increase",
    ";",
    "\n",
    "\x00",
    "İ",
    "1",
]


@settings(max_examples=300, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(st.lists(st.sampled_from(_TOKENS), max_size=80), st.booleans())
def test_token_soup_raises_nothing_but_hddl_error(tokens: list[str], as_problem: bool) -> None:
    text = " ".join(tokens)
    try:
        if as_problem:
            parse_problem(text, parse_domain(DOMAIN, "every.hddl"), "soup.hddl")
        else:
            parse_domain(text, "soup.hddl")
    except HddlError as e:
        assert "\n" not in str(e) and str(e).startswith("soup.hddl")


@settings(max_examples=200, deadline=None)
@given(st.text(max_size=300))
def test_any_text_raises_nothing_but_hddl_error(text: str) -> None:
    try:
        parse_domain(text, "any.hddl")
    except HddlError as e:
        assert "\n" not in str(e)


@settings(max_examples=200, deadline=None)
@given(st.data())
def test_a_valid_domain_cut_or_repeated_anywhere_raises_nothing_but_hddl_error(data: st.DataObject) -> None:
    start = data.draw(st.integers(0, len(DOMAIN)))
    end = data.draw(st.integers(start, min(len(DOMAIN), start + 40)))
    text = data.draw(st.sampled_from([DOMAIN[:start] + DOMAIN[end:], DOMAIN[:end] + DOMAIN[start:]]))
    try:
        parse_domain(text, "cut.hddl")
    except HddlError as e:
        assert "\n" not in str(e)


# -- the IPC total-order domains -----------------------------------------------------------------

ipc = pytest.mark.skipif(not IPC.is_dir(), reason=f"no IPC benchmark domains at {IPC}")


@ipc
def test_every_ipc_total_order_problem_reads_and_passes_the_semantic_checks() -> None:
    suites: dict[str, int] = {}
    domains: dict[Path, Domain] = {}
    for suite, domain_file, problem_file in suite_pairs(IPC):
        if suite == "feature-tests":
            continue
        domain = domains.get(domain_file) or domains.setdefault(domain_file, read_domain(domain_file))
        problem = read_problem(problem_file, domain)
        assert problem.htn, problem_file
        suites[suite] = suites.get(suite, 0) + 1
    assert len(suites) == 11
    assert sum(suites.values()) == 300
    assert suites["Transport"] == 40 and suites["Robot"] == 30


@ipc
def test_ipc_feature_tests_read_or_are_refused_as_not_total_order() -> None:
    read, refused = [], []
    for _, domain_file, problem_file in suite_pairs(IPC):
        if domain_file.parent.name != "feature-tests":
            continue
        try:
            read_problem(problem_file, read_domain(domain_file))
            read.append(problem_file.stem)
        except HddlError as e:
            assert "only partially ordered" in str(e), str(e)
            refused.append(problem_file.stem)
    # The feature tests copied here are all total-order (those of :subtasks order one subtask,
    # or order them with :ordering); sortof's :constraints and the synonymes' :tasks are read.
    assert sorted(read) == [
        "abort-iteration",
        "arguments",
        "constants",
        "empty-methods-empty-plan",
        "forall",
        "forall2",
        "only-primitive",
        "sortof",
        "synonymes",
    ]
    assert refused == []


def test_a_partial_order_method_is_refused_naming_it() -> None:
    text = _domain(
        "(:task go) (:action a) (:action b)\n"
        "(:method m-free :task (go) :subtasks (and (x (a)) (y (b)) (z (go))) :ordering (and (< x z) (< y z)))"
    )
    with pytest.raises(HddlError) as caught:
        parse_domain(text, "po.hddl")
    assert str(caught.value) == (
        "po.hddl:3:1: method m-free: its subtasks are only partially ordered (x and y may come in either "
        "order); only total-order HDDL is read"
    )


@pytest.mark.skipif(os.cpu_count() == 1, reason="one core: leave the 4 MB read to the bench")
def test_a_problem_of_four_megabytes_reads() -> None:
    domain_text, problem_text = synthetic()
    assert 3_900_000 < len(problem_text) < 4_300_000
    problem = parse_problem(problem_text, parse_domain(domain_text, "grid.hddl"), "grid-big.hddl")
    assert len(problem.init) > 100_000
