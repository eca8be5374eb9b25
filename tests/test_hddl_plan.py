"""Planning HDDL problems: the translation (docs/design.md §7), the search orders, ``plan --hddl``.

Every plan found here is checked by the plan checker of :mod:`htnagent.hddl.check`,
which replays actions and decomposition against the HDDL model alone (it never
sees the translation), and, where it has been built, by the IPC's own verifier.
The small domains are written in this file or in ``tests/hddl/``.
"""

from __future__ import annotations

import collections
import json
import os
import random
import re
import subprocess
from pathlib import Path

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from htnagent.cli.commands import main
from htnagent.errors import HddlError
from htnagent.hddl import parse_domain, parse_problem, read_domain, read_problem
from htnagent.hddl.check import check_plan
from htnagent.hddl.model import Domain, Problem
from htnagent.hddl.plan_file import format_plan, parse_plan, spellings
from htnagent.model.terms import Atom
from htnagent.planning.hddl_solving import solve
from htnagent.planning.ipc_output import actions_of, ipc_plan
from htnagent.planning.planner import PlanStatus, Search

HERE = Path(__file__).resolve().parent / "hddl"
MUSEUM = str(Path(__file__).resolve().parents[1] / "scenarios" / "museum.yaml")
SHARED = Path(__file__).resolve().parents[2] / "shared"
VERIFY = SHARED / "tools" / "hddl-verify" / "hddl-verify"
VERIFIER_BUILT = (
    Path(os.environ.get("HDDL_VERIFY_HOME", Path.home() / ".cache" / "hddl-verify")) / "pandaPIparser"
)
ORDERS = list(Search)


def _solved(
    domain: Domain, problem: Problem, search: Search = Search.GBFS, budget: int = 200_000
) -> list[str]:
    """Solve, check the plan with the independent checker, return its actions as text."""
    result = solve(domain, problem, search=search, budget=budget).result
    assert result.status is PlanStatus.SOLVED, result.status
    assert result.best is not None
    ipc = ipc_plan(result.best)
    assert [str(v) for v in check_plan(domain, problem, ipc)] == []
    # What the IPC format says is what is read back.
    again = parse_plan(format_plan(ipc))
    assert [s.action for s in again.steps] == actions_of(result.best)
    return [str(a) for a in actions_of(result.best)]


def _hddl(domain_text: str, problem_text: str) -> tuple[Domain, Problem]:
    domain = parse_domain(domain_text, "d.hddl")
    return domain, parse_problem(problem_text, domain, "p.hddl")


# -- the courier (tests/hddl): or, forall, exists, when, equality, :ordering -------------------------


@pytest.fixture(scope="module")
def courier() -> Domain:
    return read_domain(HERE / "courier-domain.hddl")


@pytest.mark.parametrize("search", ORDERS)
def test_the_courier_is_solved_in_every_search_order(courier: Domain, search: Search) -> None:
    actions = _solved(courier, read_problem(HERE / "courier.hddl", courier), search)
    assert actions[-1] == "switch-off"
    assert "drop(r1,p1,office)" in actions


def test_astar_finds_the_shortest_courier_plan(courier: Domain) -> None:
    problem = read_problem(HERE / "courier.hddl", courier)
    lengths = {s: len(_solved(courier, problem, s)) for s in ORDERS}
    # hall -> kitchen, pick, -> hall -> office, drop, switch off: six actions at least.
    assert lengths[Search.ASTAR] == 6
    assert all(n >= 6 for n in lengths.values())


@pytest.mark.parametrize("name", ["courier-held", "courier-lit", "courier-oneway"])
@pytest.mark.parametrize("search", ORDERS)
def test_a_courier_problem_without_a_plan_is_unsolvable_in_every_order(
    courier: Domain, name: str, search: Search
) -> None:
    # held: the robot holds p2 and pick needs free hands; lit: the goal wants the office
    # lit, but tidy switches every light off; oneway: no door from the hall to the kitchen
    # that the goto method may take.
    result = solve(courier, read_problem(HERE / f"{name}.hddl", courier), search=search).result
    assert result.status is PlanStatus.UNSOLVABLE


# -- one construct at a time -------------------------------------------------------------------------

VEHICLES = """
(define (domain vehicles)
  (:requirements :typing :hierarchy :negative-preconditions :equality)
  (:types truck car - vehicle place)
  (:predicates (at ?v - vehicle ?p - place) (honked ?v - vehicle) (parked ?v - vehicle))
  (:task park :parameters (?v - vehicle))
  (:method m-truck :parameters (?t - truck) :task (park ?t)
    :ordered-subtasks (and (honk ?t) (stop ?t)))
  (:method m-car :parameters (?c - car) :task (park ?c)
    :ordered-subtasks (stop ?c))
  (:action honk :parameters (?v - vehicle) :effect (honked ?v))
  (:action stop :parameters (?v - vehicle) :precondition (not (parked ?v)) :effect (parked ?v)))
"""


def test_a_method_for_a_subtype_applies_to_objects_of_that_subtype_only() -> None:
    domain, problem = _hddl(
        VEHICLES,
        "(define (problem p) (:domain vehicles) (:objects c1 - car t1 - truck)"
        " (:htn :ordered-subtasks (and (park c1) (park t1))) (:init))",
    )
    for search in ORDERS:
        assert _solved(domain, problem, search) == ["stop(c1)", "honk(t1)", "stop(t1)"]


def test_equality_and_a_parameter_bound_only_by_its_type() -> None:
    domain, problem = _hddl(
        """(define (domain pairs) (:requirements :typing :hierarchy :equality :negative-preconditions)
          (:types person)
          (:predicates (met ?a ?b - person))
          (:task meet-someone :parameters (?a - person))
          (:method m :parameters (?a ?b - person) :task (meet-someone ?a)
            :precondition (and (not (= ?a ?b)) (not (met ?a ?b)))
            :ordered-subtasks (meet ?a ?b))
          (:action meet :parameters (?a ?b - person) :effect (met ?a ?b)))""",
        "(define (problem p) (:domain pairs) (:objects ann bob cy - person)"
        " (:htn :ordered-subtasks (and (meet-someone ann) (meet-someone ann))) (:init (met ann bob)))",
    )
    # ann has met bob and is not to meet herself: cy, then nobody new is left.
    result = solve(domain, problem, search=Search.ASTAR).result
    assert result.status is PlanStatus.UNSOLVABLE
    domain, problem = _hddl(
        domain.source.text,
        "(define (problem p) (:domain pairs) (:objects ann bob cy - person)"
        " (:htn :ordered-subtasks (and (meet-someone ann))) (:init (met ann bob)))",
    )
    assert _solved(domain, problem, Search.ASTAR) == ["meet(ann,cy)"]


LIGHTS = """
(define (domain lights)
  (:requirements :typing :hierarchy :negative-preconditions :universal-preconditions
                 :existential-preconditions :conditional-effects :disjunctive-preconditions)
  (:types room)
  (:predicates (on ?r - room) (alarm) (key) (badge) (open ?r - room))
  (:task shut :parameters ())
  (:task enter :parameters (?r - room))
  (:method m-shut-done :parameters () :task (shut)
    :precondition (forall (?r - room) (not (on ?r))) :ordered-subtasks ())
  (:method m-shut :parameters (?r - room) :task (shut)
    :precondition (on ?r) :ordered-subtasks (and (off ?r) (shut)))
  (:method m-enter :parameters (?r - room) :task (enter ?r) :ordered-subtasks (unlock ?r))
  (:action off :parameters (?r - room) :precondition (on ?r)
    :effect (and (not (on ?r)) (when (alarm) (not (alarm)))))
  (:action unlock :parameters (?r - room)
    :precondition (and (or (key) (badge)) (exists (?x - room) (not (on ?x))))
    :effect (open ?r)))
"""


def test_forall_in_a_method_and_when_in_an_effect() -> None:
    domain, problem = _hddl(
        LIGHTS,
        "(define (problem p) (:domain lights) (:objects a b c - room)"
        " (:htn :ordered-subtasks (shut)) (:init (on a) (on c) (alarm)) (:goal (not (alarm))))",
    )
    assert _solved(domain, problem, Search.ASTAR) == ["off(a)", "off(c)"]


def test_the_goal_rejects_what_the_network_alone_allows() -> None:
    # Without the alarm nothing turns it off: no plan reaches the goal.
    domain, problem = _hddl(
        LIGHTS,
        "(define (problem p) (:domain lights) (:objects a - room)"
        " (:htn :ordered-subtasks (shut)) (:init (on a)) (:goal (alarm)))",
    )
    assert solve(domain, problem).result.status is PlanStatus.UNSOLVABLE


@pytest.mark.parametrize(
    ("init", "solvable"),
    [("(key) (on a)", True), ("(badge) (on a)", True), ("(on a)", False), ("(key) (on a) (on b)", False)],
)
def test_or_and_exists_in_an_action_precondition(init: str, solvable: bool) -> None:
    domain, problem = _hddl(
        LIGHTS,
        f"(define (problem p) (:domain lights) (:objects a b - room)"
        f" (:htn :ordered-subtasks (enter a)) (:init {init}))",
    )
    if solvable:
        assert _solved(domain, problem) == ["unlock(a)"]
    else:
        assert solve(domain, problem).result.status is PlanStatus.UNSOLVABLE


def test_the_networks_parameters_are_bound_by_their_type() -> None:
    domain, problem = _hddl(
        VEHICLES,
        "(define (problem p) (:domain vehicles) (:objects c1 - car t1 - truck)"
        " (:htn :parameters (?t - truck) :ordered-subtasks (and (park ?t))) (:init))",
    )
    assert _solved(domain, problem) == ["honk(t1)", "stop(t1)"]


def test_a_method_with_no_subtasks_is_in_the_ipc_plan_and_names_keep_their_spelling() -> None:
    text = """(define (domain Mixed) (:requirements :typing :hierarchy)
      (:types Spot)
      (:predicates (At ?s - Spot))
      (:task GoTo :parameters (?s - Spot))
      (:method Already :parameters (?s - Spot) :task (GoTo ?s) :precondition (At ?s) :subtasks ())
      (:method Walk :parameters (?s ?f - Spot) :task (GoTo ?s) :precondition (At ?f)
        :ordered-subtasks (and (Step ?f ?s) (GoTo ?s)))
      (:action Step :parameters (?f ?s - Spot) :precondition (At ?f) :effect (and (not (At ?f)) (At ?s))))"""
    problem_text = (
        "(define (problem P) (:domain Mixed) (:objects Home Work - Spot)"
        " (:htn :ordered-subtasks (GoTo Work)) (:init (At Home)))"
    )
    domain, problem = _hddl(text, problem_text)
    result = solve(domain, problem, search=Search.ASTAR).result
    assert result.best is not None
    out = format_plan(ipc_plan(result.best), spellings(text, problem_text))
    assert out.splitlines() == [
        "==>",
        "0 Step Home Work",
        "root 1",
        "1 GoTo Work -> Walk 0 2",
        "2 GoTo Work -> Already",
        "<==",
    ]


def test_the_default_portfolio_solves_in_depth_first_order_or_else_greedily(courier: Domain) -> None:
    solved = solve(courier, read_problem(HERE / "courier.hddl", courier))
    assert solved.result.status is PlanStatus.SOLVED
    assert solved.search is Search.DFS
    held = solve(courier, read_problem(HERE / "courier-held.hddl", courier))
    assert held.result.status is PlanStatus.UNSOLVABLE  # depth-first search saw every node
    # The first method recurses without end: depth-first search never leaves it, the greedy
    # search (told by the estimate that "done" is cheaper) takes the second at once.
    domain, problem = _hddl(
        "(define (domain deep) (:requirements :hierarchy) (:predicates (p))"
        " (:task t :parameters ()) (:method grow :parameters () :task (t) :ordered-subtasks (and (t) (a)))"
        " (:method done :parameters () :task (t) :ordered-subtasks (a))"
        " (:action a :parameters () :effect (p)))",
        "(define (problem p) (:domain deep) (:htn :ordered-subtasks (t)) (:init))",
    )
    for timeout in (None, 0.5):
        solved = solve(domain, problem, timeout=timeout)
        assert solved.search is Search.GBFS
        assert solved.result.best is not None
        assert actions_of(solved.result.best) == [Atom("a")]


# -- random problems: every order agrees on whether a plan exists; A* is never longer -------------


def _random_courier(
    rooms: int, doors: list[tuple[int, int]], parcels: list[tuple[int, int]], start: int
) -> str:
    names = [f"r{i}" for i in range(rooms)]
    objects = " ".join(names) + " - room " + " ".join(f"p{i}" for i in range(len(parcels))) + " - parcel"
    init = [f"(at bot {('hall', *names)[start]})"]
    init += [f"(door {('hall', *names)[a]} {('hall', *names)[b]})" for a, b in doors]
    init += [f"(in p{i} {('hall', *names)[src]})" for i, (src, _) in enumerate(parcels)]
    tasks = " ".join(f"(deliver p{i} {('hall', *names)[dst]})" for i, (_, dst) in enumerate(parcels))
    return (
        f"(define (problem rnd) (:domain courier) (:objects bot - robot {objects})"
        f" (:htn :ordered-subtasks (and {tasks})) (:init {' '.join(init)}))"
    )


@st.composite
def _couriers(draw: st.DrawFn) -> str:
    rooms = draw(st.integers(1, 4))
    places = rooms + 1
    doors = draw(st.lists(st.tuples(st.integers(0, rooms), st.integers(0, rooms)), max_size=8, unique=True))
    parcels = draw(st.lists(st.tuples(st.integers(0, rooms), st.integers(0, rooms)), min_size=1, max_size=2))
    start = draw(st.integers(0, places - 1))
    return _random_courier(rooms, [(a, b) for a, b in doors if a != b], parcels, start)


@settings(max_examples=40, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(problem_text=_couriers())
def test_random_couriers_every_order_agrees_and_every_plan_checks(courier: Domain, problem_text: str) -> None:
    problem = parse_problem(problem_text, courier, "rnd.hddl")
    found: dict[Search, int | None] = {}
    for search in ORDERS:
        result = solve(courier, problem, search=search, budget=50_000).result
        if result.status is PlanStatus.BUDGET_EXHAUSTED:
            return  # too big to compare: say nothing
        if result.best is None:
            assert result.status is PlanStatus.UNSOLVABLE
            found[search] = None
            continue
        assert [str(v) for v in check_plan(courier, problem, ipc_plan(result.best))] == []
        found[search] = len(actions_of(result.best))
    assert len({n is None for n in found.values()}) == 1, found
    shortest = found[Search.ASTAR]
    if shortest is not None:
        assert all(n is not None and n >= shortest for n in found.values()), found


# -- the IPC verifier, where built ---------------------------------------------------------------


@pytest.mark.skipif(not VERIFIER_BUILT.is_file() or not VERIFY.is_file(), reason="hddl-verify is not built")
@pytest.mark.parametrize("search", ORDERS)
def test_the_ipc_verifier_accepts_the_plans(tmp_path: Path, search: Search) -> None:
    domain = read_domain(HERE / "courier-domain.hddl")
    problem = read_problem(HERE / "courier.hddl", domain)
    result = solve(domain, problem, search=search).result
    assert result.best is not None
    plan_file = tmp_path / "plan.txt"
    plan_file.write_text(
        format_plan(ipc_plan(result.best), spellings(domain.source.text, problem.source.text))
    )
    done = subprocess.run(
        [str(VERIFY), str(HERE / "courier-domain.hddl"), str(HERE / "courier.hddl"), str(plan_file)],
        capture_output=True,
        text=True,
        timeout=120,
        check=False,
    )
    assert done.returncode == 0, done.stdout + done.stderr


# -- the command line ----------------------------------------------------------------------------


def _files(name: str = "courier") -> list[str]:
    return [str(HERE / "courier-domain.hddl"), str(HERE / f"{name}.hddl")]


def test_plan_hddl_prints_the_actions(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["plan", "--hddl", *_files(), "--search", "astar"]) == 0
    out = capsys.readouterr().out.split()
    assert len(out) == 6
    assert out[-1] == "switch-off"


def test_plan_hddl_json(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["plan", "--hddl", *_files(), "--format", "json", "--search", "astar"]) == 0
    line = json.loads(capsys.readouterr().out)
    assert line["cost"] == 6.0
    assert len(line["plan"]) == 6
    assert line["search"] == "astar"


def test_plan_hddl_ipc_is_what_the_checker_accepts(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["plan", "--hddl", *_files(), "--format", "ipc"]) == 0
    plan = parse_plan(capsys.readouterr().out)
    domain = read_domain(HERE / "courier-domain.hddl")
    assert check_plan(domain, read_problem(HERE / "courier.hddl", domain), plan) == []


def test_plan_hddl_without_a_plan_exits_1_saying_why(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["plan", "--hddl", *_files("courier-held")]) == 1
    err = capsys.readouterr().err
    assert "unsolvable" in err
    assert len(err.strip().splitlines()) == 1


def test_plan_hddl_timeout(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    # A task that decomposes into itself and one more action, or ends where q holds, which
    # it never does: the task list grows without end.
    domain = tmp_path / "d.hddl"
    domain.write_text(
        "(define (domain forever) (:requirements :hierarchy) (:predicates (p) (q))"
        " (:task t :parameters ()) (:method m :parameters () :task (t) :ordered-subtasks (and (t) (a)))"
        " (:method end :parameters () :task (t) :precondition (q) :ordered-subtasks ())"
        " (:action a :parameters () :effect (p)))"
    )
    problem = tmp_path / "p.hddl"
    problem.write_text("(define (problem p) (:domain forever) (:htn :ordered-subtasks (t)) (:init))")
    assert main(["plan", "--hddl", str(domain), str(problem), "--timeout", "0.3", "--search", "dfs"]) == 1
    assert "timeout" in capsys.readouterr().err


@pytest.mark.parametrize("search", [*ORDERS, None])
def test_the_timeout_bounds_the_translation_too(courier: Domain, search: Search | None) -> None:
    # The time limit counts from when the files have been read: one that has passed before
    # the translation is done ends the solve there, as a search out of time ends.  (Without
    # the translation's own clock, the courier is solved before the search first reads it.)
    problem = read_problem(HERE / "courier.hddl", courier)
    solved = solve(courier, problem, search=search, timeout=1e-9)
    assert solved.result.status is PlanStatus.TIMED_OUT
    assert solved.result.expansions == 0
    assert solved.planning is None


def test_plan_hddl_timeout_while_a_large_problem_is_translated(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    # 100,000 rooms: read in a fraction of a second, translated (a type and an equality fact
    # for each) in several times the limit; the search would be over at once.
    rooms = " ".join(f"o{i}" for i in range(100_000))
    problem = tmp_path / "big.hddl"
    problem.write_text(
        "(define (problem big) (:domain courier)"
        f" (:objects r1 - robot p1 - parcel hall office {rooms} - room)"
        " (:htn :ordered-subtasks (and (deliver p1 office)))"
        " (:init (at r1 hall) (in p1 hall) (door hall office)))"
    )
    domain = Path(__file__).resolve().parents[1] / "scenarios" / "courier_hddl_domain.hddl"
    assert main(["plan", "--hddl", str(domain), str(problem), "--timeout", "0.01"]) == 1
    assert capsys.readouterr() == ("", "htnagent: no plan: timeout (no plan within 0.01 s)\n")


@pytest.mark.parametrize(
    ("args", "says"),
    [
        (["plan", "--hddl", str(HERE / "courier-domain.hddl")], "takes DOMAIN PROBLEM, not 1 file"),
        (["plan", "--hddl", *_files(), "--timeout", "-1"], "positive number of seconds"),
        (["plan", "--hddl", *_files(), "--timeout", "nan"], "positive number of seconds"),
        (["plan", "--hddl", *_files(), "--search", "bogo"], "invalid choice"),
        (["plan", "--hddl", *_files(), "--agent", "guide"], "takes no --agent"),
        (["plan", "--hddl", *_files(), "--json", "--format", "ipc"], "disagree"),
        (["plan", MUSEUM, "--agent", "guide", "--task", "goto(n1)", "--format", "ipc"], "--format"),
        (["plan", MUSEUM, "--task", "goto(n1)"], "needs --agent"),
    ],
)
def test_plan_hddl_usage_errors_exit_2_in_one_line(
    args: list[str], says: str, capsys: pytest.CaptureFixture[str]
) -> None:
    assert main(args) == 2
    err = capsys.readouterr().err
    assert says in err
    assert len(err.strip().splitlines()) == 1


def test_plan_hddl_bad_input_names_file_line_and_column(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    bad = tmp_path / "bad.hddl"
    bad.write_text(
        "(define (problem p) (:domain courier)\n  (:objects r1 - robot)\n"
        "  (:htn :ordered-subtasks (fly r1))\n  (:init))"
    )
    assert main(["plan", "--hddl", str(HERE / "courier-domain.hddl"), str(bad)]) == 2
    err = capsys.readouterr().err
    assert f"{bad}:3:" in err
    assert "fly" in err


def test_a_quantifier_over_too_many_objects_is_refused_with_its_place(
    capsys: pytest.CaptureFixture[str],
) -> None:
    objects = " ".join(f"o{i}" for i in range(200))
    domain, problem = _hddl(
        "(define (domain wide) (:requirements :hierarchy :universal-preconditions)"
        " (:predicates (p ?x ?y)) (:task t :parameters ())\n"
        " (:method m :parameters () :task (t)\n"
        "  :precondition (forall (?x ?y) (not (p ?x ?y))) :ordered-subtasks ()))",
        f"(define (problem p) (:domain wide) (:objects {objects}) (:htn :ordered-subtasks (t)) (:init))",
    )
    with pytest.raises(HddlError, match=r"d\.hddl:3:17: this quantifier stands for over 20,000"):
        solve(domain, problem)


def test_an_object_keeps_its_own_spelling_when_a_type_shares_its_name(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    # HDDL reads the type A and the constant a as one word; the IPC verifier does not.
    domain = tmp_path / "d.hddl"
    domain.write_text(
        "(define (domain D) (:requirements :typing :hierarchy) (:types A) (:constants a - A)"
        " (:predicates (foo ?x - A)) (:task Task1 :parameters ())"
        " (:method DoIt :parameters (?x - A) :task (Task1) :subtasks (and (Noop ?x)))"
        " (:action Noop :parameters (?x - A) :precondition (foo ?x)))"
    )
    problem = tmp_path / "p.hddl"
    problem.write_text("(define (problem P) (:domain D) (:htn :subtasks (and (t0 (Task1)))) (:init (foo a)))")
    assert main(["plan", "--hddl", str(domain), str(problem), "--format", "ipc"]) == 0
    out = capsys.readouterr().out
    assert out.splitlines()[1:4] == ["0 Noop a", "root 1", "1 Task1 -> DoIt 0"]
    if VERIFIER_BUILT.is_file() and VERIFY.is_file():
        plan = tmp_path / "plan.txt"
        plan.write_text(out)
        done = subprocess.run(
            [str(VERIFY), str(domain), str(problem), str(plan)], capture_output=True, timeout=120
        )
        assert done.returncode == 0, done.stdout


# -- hostile input: edited domains either are refused in one line or are planned -------------------


def _edited(words: list[str], rng: random.Random) -> str:
    """The words with a few of them deleted, repeated, swapped or negated."""
    words = list(words)
    for _ in range(rng.randint(1, 4)):
        i = rng.randrange(len(words))
        kind = rng.choice(["delete", "repeat", "swap", "not"])
        if kind == "delete":
            del words[i]
        elif kind == "repeat":
            words.insert(i, words[i])
        elif kind == "swap":
            j = rng.randrange(len(words))
            words[i], words[j] = words[j], words[i]
        else:
            words[i:i] = ["(not"]
            words.insert(i + 2, ")")
    return " ".join(words)


def test_edited_domains_are_refused_in_one_line_or_planned_and_checked() -> None:
    text = re.sub(r";[^\n]*", "", (HERE / "courier-domain.hddl").read_text())  # comments end at a newline
    words = text.replace("(", " ( ").replace(")", " ) ").split()
    problem_text = (HERE / "courier.hddl").read_text()
    rng = random.Random(2026)
    outcomes: collections.Counter[str] = collections.Counter()
    for _ in range(1500):
        edited = _edited(words, rng)
        try:
            domain = parse_domain(edited, "edited.hddl")
            problem = parse_problem(problem_text, domain, "courier.hddl")
            solved = solve(domain, problem, budget=3_000)
        except HddlError as e:
            assert "\n" not in str(e)
            outcomes["refused"] += 1
            continue
        outcomes[solved.result.status.value] += 1
        if solved.result.best is not None:
            assert check_plan(domain, problem, ipc_plan(solved.result.best)) == [], edited
    # Most edits break the syntax; enough of them still make a domain to plan with.
    assert outcomes["solved"] >= 5, outcomes
