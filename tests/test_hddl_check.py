"""The HDDL plan checker (htnagent.hddl.check), the IPC plan format, and ``check|verify --hddl``.

The courier domain in ``tests/hddl/`` is written for these tests: typing with a
constant, equality, ``or``, ``forall`` and ``exists`` in preconditions,
``forall`` and ``when`` in effects, method preconditions, ``:subtasks`` with an
``:ordering``.  Its plans, valid and invalid, are also given to the IPC's own
verifier (pandaPIparser, ``../shared/tools/hddl-verify``) when it has been built,
and the verdicts compared.
"""

from __future__ import annotations

import os
import subprocess
from pathlib import Path

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from htnagent.cli.commands import main
from htnagent.errors import HddlError
from htnagent.hddl import parse_domain, parse_problem, read_domain, read_problem
from htnagent.hddl.check import Violation, check_plan
from htnagent.hddl.model import Domain, Problem
from htnagent.hddl.plan_file import IpcDecomposition, IpcStep, parse_plan, read_plan
from htnagent.model.terms import Atom
from htnagent.testing.hddl_inputs import suite_pairs

HERE = Path(__file__).resolve().parent / "hddl"
REPO = Path(__file__).resolve().parents[1]
SHARED = REPO.parent / "shared"
IPC = SHARED / "data" / "ipc"
FEATURES = IPC / "feature-tests"
VERIFY = SHARED / "tools" / "hddl-verify" / "hddl-verify"
VERIFIER_BUILT = (
    Path(os.environ.get("HDDL_VERIFY_HOME", Path.home() / ".cache" / "hddl-verify")) / "pandaPIparser"
)

PROBLEMS = ["courier", "courier-oneway", "courier-held", "courier-lit"]
PLANS = sorted(p.stem for p in HERE.glob("*.plan"))


@pytest.fixture(scope="module")
def courier() -> Domain:
    return read_domain(HERE / "courier-domain.hddl")


def _problem(domain: Domain, name: str = "courier") -> Problem:
    return read_problem(HERE / f"{name}.hddl", domain)


def _check(domain: Domain, problem: str, plan: str) -> list[str]:
    return [str(v) for v in check_plan(domain, _problem(domain, problem), read_plan(HERE / f"{plan}.plan"))]


def _edited(plan: str, old: str, new: str) -> str:
    text = (HERE / f"{plan}.plan").read_text()
    assert old in text
    return text.replace(old, new)


def _check_text(domain: Domain, text: str, problem: str = "courier") -> list[str]:
    return [str(v) for v in check_plan(domain, _problem(domain, problem), parse_plan(text, "x.plan"))]


# -- the plan format ------------------------------------------------------------------------------


def test_a_plan_reads_into_steps_root_and_decompositions() -> None:
    plan = parse_plan(
        "solver says hi\n==>\n0 (move r1 hall kitchen)\nroot 2\n2 (goto r1 kitchen) -> m-step 0 3\n"
        "3 GOTO r1 kitchen -> m-goto-here\n<==\ntrailing words\n"
    )
    assert plan.steps == (IpcStep(0, Atom("move", ("r1", "hall", "kitchen"))),)
    assert plan.root == (2,)
    assert plan.decompositions == (
        IpcDecomposition(2, Atom("goto", ("r1", "kitchen")), "m-step", (0, 3)),
        IpcDecomposition(3, Atom("goto", ("r1", "kitchen")), "m-goto-here", ()),
    )


@pytest.mark.parametrize(
    ("text", "message"),
    [
        ("0 move a b\nroot 0\n", "p.plan: no '==>' line; a plan in the IPC format starts with '==>'"),
        ("==>\n0 move a b\n<==\n", "p.plan: no 'root' line after the actions (it lists the root task IDs)"),
        ("==>\nx move a b\nroot\n", "p.plan:2:1: expected an ID (a whole number), got 'x'"),
        ("==>\n-1 move\nroot\n", "p.plan:2:1: expected an ID (a whole number), got '-1'"),
        ("==>\n0 move\n 0 move\nroot\n", "p.plan:3:2: ID 0 is given twice (first on line 2)"),
        ("==>\n0\nroot\n", "p.plan:2:1: ID 0 names no action"),
        ("==>\n0 go -> m\nroot\n", "p.plan:2:6: a decomposition line before the root line"),
        ("==>\nroot 1\n1 go m 2\n", "p.plan:3:1: expected 'ID task args -> method subtask-IDs' (no '->')"),
        ("==>\nroot 1\n1 -> m\n", "p.plan:3:3: ID 1 names no task before '->'"),
        ("==>\nroot 1\n1 go ->\n", "p.plan:3:6: no method after '->'"),
        ("==>\nroot 1\n1 go -> m x\n", "p.plan:3:11: expected an ID (a whole number), got 'x'"),
        ("==>\nroot 1\nroot 2\n", "p.plan:3:1: a second root line (the first is line 2)"),
        ("==>\n()\nroot\n", "p.plan:2:1: expected an action, root or decomposition line, got '()'"),
        ("==>\n0 move a b\nroot 0\n", "p.plan:3: no '<==' line after the plan; was it cut short?"),
    ],
)
def test_each_malformed_plan_is_one_line_at_its_place(text: str, message: str) -> None:
    with pytest.raises(HddlError) as caught:
        parse_plan(text, "p.plan")
    assert str(caught.value) == message


# -- valid plans ----------------------------------------------------------------------------------


def test_the_courier_plan_is_valid(courier: Domain) -> None:
    """It needs the conditional effect (switch-off wants a lit place: the moves light them), the forall
    effect (the goal wants the office dark), the forall-exists method precondition (tidy) and the
    ordering of m-goto-step (move before goto)."""
    assert _check(courier, "courier", "valid") == []


def test_a_method_parameter_only_its_precondition_names_may_take_any_value_that_holds() -> None:
    domain = parse_domain(
        """(define (domain free) (:types item)
             (:predicates (ok ?x - item) (done))
             (:task t) (:action work :effect (done))
             (:method m :parameters (?x - item) :task (t) :precondition (ok ?x) :ordered-subtasks (work)))""",
        "free.hddl",
    )
    plan = "==>\n0 work\nroot 1\n1 t -> m 0\n<==\n"

    def verdict(init: str) -> list[str]:
        problem = parse_problem(
            f"(define (problem q) (:domain free) (:objects a b - item) (:htn :ordered-subtasks (t)) (:init "
            f"{init}))",
            domain,
            "q.hddl",
        )
        return [str(v) for v in check_plan(domain, problem, parse_plan(plan))]

    assert verdict("(ok b)") == []
    assert verdict("") == [
        "line 4: task 1 (t): the precondition of method m does not hold where its first action starts "
        "(after 0 actions)"
    ]


@pytest.mark.skipif(not FEATURES.is_dir(), reason=f"no IPC feature tests at {FEATURES}")
@pytest.mark.parametrize("name", ["empty-methods-empty-plan", "forall", "only-primitive", "sortof"])
def test_the_ipc_feature_test_plans_are_valid(name: str) -> None:
    domain = read_domain(FEATURES / f"{name}-domain.hddl")
    problem = read_problem(FEATURES / f"{name}.hddl", domain)
    plan = FEATURES / "plans" / f"{name}.plan"
    if not plan.is_file():
        plan = FEATURES / "plans" / f"{name}.hddl"  # sortof's plan is named so in the suite
    assert check_plan(domain, problem, read_plan(plan)) == []


# -- each kind of violation -----------------------------------------------------------------------


def test_an_action_whose_precondition_fails_stops_the_replay(courier: Domain) -> None:
    assert _check(courier, "courier-held", "valid") == [
        "line 3: action 1 (pick r1 p1 kitchen): its precondition does not hold (the replay stops here)"
    ]


def test_a_method_precondition_is_checked_where_its_first_action_starts(courier: Domain) -> None:
    # The door opens only from the kitchen: move (either way) may pass it, m-goto-step may not.
    assert _check(courier, "courier-oneway", "valid") == [
        "line 10: task 13 (goto r1 kitchen): the precondition of method m-goto-step does not hold where its "
        "first action starts (after 0 actions)"
    ]


def test_the_goal_must_hold_at_the_end(courier: Domain) -> None:
    assert _check(courier, "courier-lit", "valid") == ["the goal does not hold after the last action"]


def test_root_tasks_are_the_problems_in_order(courier: Domain) -> None:
    assert _check(courier, "courier", "swapped-roots") == [
        "line 8: root task 1: deliver p2 office does not match deliver p1 office"
    ]
    assert _check(courier, "courier", "no-tidy")[0] == "line 7: the problem has 3 initial tasks, root lists 2"


def test_subtasks_are_in_the_methods_order(courier: Domain) -> None:
    assert _check(courier, "courier", "swapped-subtasks")[0] == (
        "line 10: task 13 (goto r1 kitchen): subtask 1 of method m-goto-step is move, but ID 15 is goto"
    )


def test_a_method_must_have_as_many_subtasks_as_listed(courier: Domain) -> None:
    assert _check(courier, "courier", "wrong-method") == [
        "line 15: task 11 (deliver p2 office): method m-deliver has 4 subtasks, the line lists 0"
    ]


def test_actions_follow_the_order_of_the_decomposition(courier: Domain) -> None:
    assert _check(courier, "courier", "actions-out-of-order")[0] == (
        "line 4: the actions are not in the order of the decomposition: action 3 of the plan is 3, "
        "the decomposition's is 2 (total order: no interleaving)"
    )


def test_every_action_is_reached_from_the_root(courier: Domain) -> None:
    assert _check(courier, "courier", "extra-action")[0] == (
        "line 3: action 6 (move r1 kitchen hall) is not reached from the root tasks"
    )


@pytest.mark.parametrize(
    ("old", "new", "violation"),
    [
        ("0 move r1 hall kitchen", "0 fly r1 hall kitchen", "line 2: action 0: fly is no declared action"),
        (
            "0 move r1 hall kitchen",
            "0 goto r1 kitchen",
            "line 2: action 0: goto is a compound task, not an action",
        ),
        (
            "0 move r1 hall kitchen",
            "0 move r1 hall",
            "line 2: action 0 (move r1 hall): move takes 3 arguments, given 2",
        ),
        (
            "0 move r1 hall kitchen",
            "0 move r1 hall garage",
            "line 2: action 0 (move r1 hall garage): garage is no object of the problem",
        ),
        (
            "0 move r1 hall kitchen",
            "0 move p1 hall kitchen",
            "line 2: action 0 (move p1 hall kitchen): p1 is not of type robot (?r)",
        ),
        (
            "12 tidy -> m-tidy 5",
            "12 tidy -> m-nothing 5",
            "line 16: task 12 (tidy): no method is named m-nothing",
        ),
        (
            "12 tidy -> m-tidy 5",
            "12 tidy -> m-already 5",
            "line 16: task 12 (tidy): method m-already decomposes deliver, not tidy",
        ),
        (
            "12 tidy -> m-tidy 5",
            "12 switch-off -> m-tidy 5",
            "line 16: task 12 (switch-off): switch-off is an action, which is not decomposed",
        ),
        (
            "12 tidy -> m-tidy 5",
            "12 tidy -> m-tidy 99",
            "line 16: ID 99 is neither an action nor a decomposed task",
        ),
        (
            "17 goto r1 office -> m-goto-here",
            "17 goto r1 kitchen -> m-goto-here",
            "line 13: task 16 (goto r1 office): subtask 2 of method m-goto-step: ?to would be both office "
            "and kitchen",
        ),
        (
            "11 deliver p2 office -> m-already",
            "11 deliver p2 office -> m-already\n18 tidy -> m-tidy",
            "line 16: task 18 (tidy) is not reached from the root tasks",
        ),
        (
            "12 tidy -> m-tidy 5",
            "12 tidy -> m-tidy 12",
            "line 16: ID 12 is reached twice (a cycle or a shared subtask)",
        ),
        (
            "11 deliver p2 office -> m-already",
            "11 deliver p2 office -> m-already 17",
            "line 15: task 11 (deliver p2 office): its subtask 17 is a subtask of 16 too",
        ),
    ],
)
def test_each_kind_of_violation_is_named_with_its_line(
    courier: Domain, old: str, new: str, violation: str
) -> None:
    assert violation in _check_text(courier, _edited("valid", old, new))


_PLAN_TOKENS = [
    "==>",
    "<==",
    "root",
    "->",
    "0",
    "1",
    "2",
    "3",
    "7",
    "move",
    "pick",
    "goto",
    "deliver",
    "tidy",
    "switch-off",
    "r1",
    "p1",
    "p2",
    "hall",
    "kitchen",
    "office",
    "m-goto-here",
    "m-goto-step",
    "m-deliver",
    "m-already",
    "m-tidy",
    "(",
    ")",
    "\n",
    "\n",
    "\n",
    "x",
]


@settings(max_examples=300, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(st.lists(st.sampled_from(_PLAN_TOKENS), max_size=60))
def test_random_plans_give_violations_or_one_error_never_a_crash(courier: Domain, tokens: list[str]) -> None:
    text = "==>\n" + " ".join(tokens)
    try:
        plan = parse_plan(text, "r.plan")
    except HddlError as e:
        assert "\n" not in str(e)
        return
    found = check_plan(courier, _problem(courier), plan)
    assert all(isinstance(v, Violation) and "\n" not in v.reason for v in found)


def test_violations_are_values_with_a_line() -> None:
    assert str(Violation(3, "x")) == "line 3: x"
    assert str(Violation(0, "the goal")) == "the goal"


# -- the IPC verifier agrees ----------------------------------------------------------------------


@pytest.mark.skipif(not VERIFIER_BUILT.is_file() or not VERIFY.is_file(), reason="hddl-verify is not built")
@pytest.mark.parametrize("problem", PROBLEMS)
def test_the_ipc_verifier_gives_the_same_verdicts(courier: Domain, problem: str) -> None:
    for plan in PLANS:
        ours = check_plan(courier, _problem(courier, problem), read_plan(HERE / f"{plan}.plan")) == []
        run = subprocess.run(
            [
                str(VERIFY),
                str(HERE / "courier-domain.hddl"),
                str(HERE / f"{problem}.hddl"),
                str(HERE / f"{plan}.plan"),
            ],
            capture_output=True,
            text=True,
            timeout=60,
            env={**os.environ, "VALIDATE_TIMEOUT": "30"},
        )
        assert run.returncode in (0, 1), run.stdout + run.stderr
        assert (run.returncode == 0) == ours, (
            f"{problem} {plan}: ours {ours}, pandaPIparser {run.stdout.strip()}"
        )


TINY = SHARED / "tools" / "hddl-verify" / "tiny"
TINY_VERDICTS = [
    # (problem, plan, the verifier's verdict as its selftest.sh states it, ours)
    ("problem", "valid", True, True),
    ("problem", "valid-parens", True, True),
    ("problem", "valid-nospace", True, True),
    ("problem", "invalid-precond", False, False),
    ("problem", "invalid-nohier", False, False),
    ("problem", "invalid-method", False, False),
    ("problem", "orphan", False, False),
    ("problem", "goal-miss", False, False),
    ("problem-goal", "goal-miss", False, False),
    # HDDL names are case-insensitive; pandaPIparser compares plan names as written (unless -l).
    ("problem", "upper", False, True),
]


@pytest.mark.skipif(not TINY.is_dir(), reason=f"no hddl-verify test files at {TINY}")
@pytest.mark.parametrize(("problem", "plan", "theirs", "ours"), TINY_VERDICTS)
def test_the_verifiers_own_examples_get_its_verdicts(
    problem: str, plan: str, theirs: bool, ours: bool
) -> None:
    domain = read_domain(TINY / "domain.hddl")
    found = check_plan(
        domain, read_problem(TINY / f"{problem}.hddl", domain), read_plan(TINY / f"{plan}.plan")
    )
    assert (found == []) == ours, found
    assert ours == theirs or plan == "upper"


@pytest.mark.skipif(not TINY.is_dir(), reason=f"no hddl-verify test files at {TINY}")
@pytest.mark.parametrize("plan", ["garbage", "noarrow"])
def test_what_the_verifier_calls_malformed_is_bad_input_here(plan: str) -> None:
    with pytest.raises(HddlError):
        read_plan(TINY / f"{plan}.plan")
    with pytest.raises(HddlError, match=r"bad-domain.hddl:2:23: this '\)' closes no '\('"):
        read_domain(TINY / "bad-domain.hddl")


# -- the command line -----------------------------------------------------------------------------


def _one_error_line(err: str) -> str:
    assert "Traceback" not in err
    lines = err.splitlines()
    assert len(lines) == 1, err
    return lines[0]


def test_check_hddl_prints_one_summary_line(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["check", "--hddl", str(HERE / "courier-domain.hddl"), str(HERE / "courier.hddl")]) == 0
    assert capsys.readouterr() == (
        "ok: domain courier: 5 types, 6 predicates, 3 tasks, 5 methods, 4 actions; "
        "problem courier-1: 6 objects, 7 initial facts, 3 initial tasks\n",
        "",
    )


def test_check_hddl_refuses_bad_input_in_one_line(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    bad = tmp_path / "bad.hddl"
    bad.write_text("(define (domain d)\n  (:types t)))\n")
    assert main(["check", "--hddl", str(bad), str(HERE / "courier.hddl")]) == 2
    assert _one_error_line(capsys.readouterr().err) == f"htnagent: error: {bad}:2:14: this ')' closes no '('"
    assert main(["check", "--hddl", str(HERE / "courier-domain.hddl")]) == 2
    assert _one_error_line(capsys.readouterr().err) == (
        "htnagent: error: check --hddl takes DOMAIN PROBLEM, not 1 files (see htnagent check --help)"
    )
    assert main(["check", str(HERE / "courier-domain.hddl"), str(HERE / "courier.hddl")]) == 2
    assert "check takes one SCENARIO" in _one_error_line(capsys.readouterr().err)


SWEEP_DOMAIN = """(define (domain sweep) (:requirements :typing :hierarchy :conditional-effects)
  (:types room) (:predicates (dirty ?x - room) (swept))
  (:task clean :parameters ())
  (:method m-clean :parameters () :task (clean) :ordered-subtasks (sweep))
  (:action sweep :parameters ()
    :effect (and (swept) (forall (?x - room) (when (dirty ?x) (not (dirty ?x)))))))
"""


def _sweep(tmp_path: Path, rooms: int) -> tuple[str, str, str]:
    """The sweep domain, a problem with ``rooms`` rooms, and a scenario with an agent on them."""
    domain = tmp_path / "sweep-domain.hddl"
    domain.write_text(SWEEP_DOMAIN)
    names = " ".join(f"room{i}" for i in range(rooms))
    problem = tmp_path / "sweep.hddl"
    problem.write_text(
        f"(define (problem p) (:domain sweep) (:objects {names} - room) (:htn :ordered-subtasks (clean))"
        " (:init (dirty room0)))"
    )
    agent = "{name: sweeper, domain: {hddl: sweep-domain.hddl, problem: sweep.hddl}, executor: robot}"
    scenario = tmp_path / "sweep.yaml"
    scenario.write_text(
        f"name: sweep\nrobot: {{}}\nagents: [{agent}]\ngoals: [{{agent: sweeper, task: clean}}]\n"
    )
    return str(domain), str(problem), str(scenario)


def test_check_hddl_refuses_what_plan_hddl_refuses(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    # A when under a forall is a conditional effect per room: the translation into a planning
    # domain takes 8, and refuses a ninth at the action.  check --hddl translates as plan
    # --hddl and a scenario agent do, so it refuses in the same line.
    domain, problem, scenario = _sweep(tmp_path, rooms=9)
    refused = (
        f"htnagent: error: {domain}:5:3: action sweep: more than 8 conditional effects, "
        "which htnagent does not take"
    )
    for args in (
        ["plan", "--hddl", domain, problem],
        ["check", "--hddl", domain, problem],
        ["check", scenario],
    ):
        assert main(args) == 2, args
        out, err = capsys.readouterr()
        assert out == ""
        assert _one_error_line(err) == refused


def test_check_hddl_takes_what_plan_hddl_takes(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    domain, problem, scenario = _sweep(tmp_path, rooms=8)
    assert main(["check", "--hddl", domain, problem]) == 0
    assert capsys.readouterr().out.startswith("ok: domain sweep:")
    assert main(["plan", "--hddl", domain, problem]) == 0
    assert capsys.readouterr().out == "sweep\n"
    assert main(["check", scenario]) == 0


def _first_and_last_of_each_suite() -> list[tuple[Path, Path]]:
    pairs: dict[str, list[tuple[Path, Path]]] = {}
    if IPC.is_dir():
        for suite, domain, problem in suite_pairs(IPC):
            pairs.setdefault(suite, []).append((domain, problem))
    return [pair for found in pairs.values() for pair in dict.fromkeys((found[0], found[-1]))]


@pytest.mark.skipif(not IPC.is_dir(), reason=f"no IPC benchmark domains at {IPC}")
@pytest.mark.parametrize(
    ("domain", "problem"), _first_and_last_of_each_suite(), ids=lambda p: f"{p.parent.name}/{p.name}"
)
def test_check_hddl_takes_the_ipc_problems(
    domain: Path, problem: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    # plan --hddl takes them all (bench ipc); check --hddl, translating them too, must as well.
    assert main(["check", "--hddl", str(domain), str(problem)]) == 0
    assert capsys.readouterr().out.startswith("ok: domain ")


def test_verify_exits_0_for_a_valid_plan(capsys: pytest.CaptureFixture[str]) -> None:
    args = ["verify", "--hddl", str(HERE / "courier-domain.hddl"), str(HERE / "courier.hddl")]
    assert main([*args, str(HERE / "valid.plan")]) == 0
    assert capsys.readouterr() == ("valid: 6 actions, 8 decomposed tasks\n", "")


def test_verify_exits_1_listing_the_problems(capsys: pytest.CaptureFixture[str]) -> None:
    plan = HERE / "swapped-roots.plan"
    args = ["verify", "--hddl", str(HERE / "courier-domain.hddl"), str(HERE / "courier-lit.hddl"), str(plan)]
    assert main(args) == 1
    out, err = capsys.readouterr()
    assert err == ""
    assert out.splitlines() == [
        "invalid: 2 problems (6 actions)",
        f"  {plan}:8: root task 1: deliver p2 office does not match deliver p1 office",
        f"  {plan}: the goal does not hold after the last action",
    ]


def test_verify_exits_2_for_bad_input(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    domain, problem = str(HERE / "courier-domain.hddl"), str(HERE / "courier.hddl")
    plan = tmp_path / "p.plan"
    plan.write_text("==>\n0 move r1 hall kitchen\nroot 1\n1 goto r1 kitchen m-goto-step 0\n")
    assert main(["verify", "--hddl", domain, problem, str(plan)]) == 2
    assert _one_error_line(capsys.readouterr().err) == (
        f"htnagent: error: {plan}:4:1: expected 'ID task args -> method subtask-IDs' (no '->')"
    )
    assert main(["verify", "--hddl", domain, problem, str(tmp_path)]) == 2
    assert "is a directory" in _one_error_line(capsys.readouterr().err)
    assert main(["verify", domain, problem, str(plan)]) == 2
    assert _one_error_line(capsys.readouterr().err) == (
        "htnagent: error: the following arguments are required: --hddl (see htnagent verify --help)"
    )


@pytest.mark.parametrize("end", ["\r", "\r\n"])
def test_hddl_files_with_other_line_ends_read_alike(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], end: str
) -> None:
    # Written with \r alone (old Mac style), a file was one line: its first ';' comment ran
    # to the end of the file, and the file read as empty.
    names = []
    for kind in ("domain", "problem"):
        source = REPO / "scenarios" / f"courier_hddl_{kind}.hddl"
        target = tmp_path / source.name
        target.write_bytes(source.read_bytes().replace(b"\n", end.encode()))
        names.append(str(target))
    assert main(["check", "--hddl", *names]) == 0
    assert capsys.readouterr().out.startswith("ok")
