"""``python -m bench ipc``: the harness, with stand-in planners (fast; no network, no Aries).

A small suite is made here from the courier files of ``tests/hddl/``; the planner is
a little script that prints a known plan, sleeps, or says why it found none.  The
verifier is a stand-in too (exit 0 or 1), and the real one (``hddl-verify``) where it
has been built.  The bench runs as users run it, ``python -m bench ipc`` in a process of its
own; what it finds and reads with the package's functions (the suite's problems, the plan in
a planner's output, a peer's plan in the IPC format) is tested on those functions.
"""

from __future__ import annotations

import json
import os
import shutil
import signal
import subprocess
import sys
import time
from pathlib import Path
from typing import Any, NamedTuple

import pytest

from htnagent.hddl.plan_file import parse_plan, plan_block
from htnagent.testing.hddl_inputs import SuiteError, find_problems
from htnagent.testing.peer_plans import ipc_plan

HDDL = Path(__file__).resolve().parent / "hddl"
ROOT = Path(__file__).resolve().parent.parent
VERIFY = ROOT.parent / "shared" / "tools" / "hddl-verify" / "hddl-verify"  # the bench's default
VERIFIER_BUILT = (
    Path(os.environ.get("HDDL_VERIFY_HOME", Path.home() / ".cache" / "hddl-verify")) / "pandaPIparser"
)

FAKE_PLANNER = """\
import subprocess, sys, time
mode = sys.argv[1]
if mode == "plan":
    print("searching...")
    print(open(sys.argv[2]).read())
elif mode == "sleep":
    child = subprocess.Popen([sys.executable, "-c", "import time; time.sleep(60)"])
    open(sys.argv[2], "w").write(str(child.pid))
    time.sleep(60)
elif mode == "unsolvable":
    print("unsolvable", file=sys.stderr)
    sys.exit(1)
elif mode == "noplan":
    print("nothing here")
elif mode == "crash":
    print("Traceback (most recent call last):", file=sys.stderr)
    print("ValueError: boom", file=sys.stderr)
    sys.exit(3)
"""

FAKE_PEER = """\
import json, sys, time
mode = sys.argv[1]
if mode == "solved":
    print("read 0.01", flush=True)
    plan = open(sys.argv[2]).read()
    print(json.dumps({"status": "solved", "plan_length": 6, "read_s": 0.01, "reason": None, "plan": plan}))
elif mode == "refused":
    print(json.dumps({"status": "refused", "read_s": 0.01, "reason": "UPException: no"}))
    sys.exit(1)
elif mode == "slow-read":
    time.sleep(60)
"""

FAKE_VERIFIER = """\
#!/bin/sh
# a stand-in verifier: tests/hddl/valid.plan is valid, precondition-fails.plan (hall to office first) not
if /bin/grep -q "switch-off" "$3" && ! /bin/grep -q "2 move r1 hall office" "$3"; then echo VALID; exit 0; fi
echo INVALID; exit 1
"""


@pytest.fixture
def suite(tmp_path: Path) -> Path:
    root = tmp_path / "suite"
    courier = root / "Courier"
    courier.mkdir(parents=True)
    shutil.copy(HDDL / "courier-domain.hddl", courier / "domain.hddl")
    for name in ("p1.hddl", "p2.hddl", "p10.hddl"):
        shutil.copy(HDDL / "courier.hddl", courier / name)
    (courier / "other").mkdir()
    shutil.copy(HDDL / "courier.hddl", courier / "other" / "p0.hddl")  # not a benchmark problem
    (courier / "README.md").write_text("not a problem\n")
    (root / "feature-tests").mkdir()  # no domain.hddl: not a domain
    shutil.copy(HDDL / "courier.hddl", root / "feature-tests" / "x.hddl")
    # The IPC's feature tests give each problem a domain of its own, as Entertainment does;
    # they are not benchmark problems all the same.
    shutil.copy(HDDL / "courier-domain.hddl", root / "feature-tests" / "x-domain.hddl")
    return root


@pytest.fixture
def fake(tmp_path: Path) -> Path:
    path = tmp_path / "fake_planner.py"
    path.write_text(FAKE_PLANNER)
    return path


@pytest.fixture
def fake_verifier(tmp_path: Path) -> Path:
    path = tmp_path / "verify.sh"
    path.write_text(FAKE_VERIFIER)
    path.chmod(0o755)
    return path


class Run(NamedTuple):
    """What a run of the bench gave: its exit code, the rows it wrote, its stderr."""

    code: int
    rows: list[dict[str, Any]]
    err: str


def run(tmp_path: Path, *args: str, resume: bool = False, env: dict[str, str] | None = None) -> Run:
    """``python -m bench ipc`` on ``tmp_path/ipc.json``: afresh each time, unless ``resume``."""
    out = tmp_path / "ipc.json"
    done = subprocess.run(
        [sys.executable, "-m", "bench", "ipc", *args, "--out", str(out), *([] if resume else ["--fresh"])],
        capture_output=True,
        text=True,
        cwd=ROOT,
        timeout=60,
        env=None if env is None else {**os.environ, **env},
    )
    assert "Traceback" not in done.stderr, done.stderr
    rows = json.loads(out.read_text()) if out.is_file() else []
    return Run(done.returncode, rows, done.stderr)


def test_the_problems_are_the_domain_folders_files_in_natural_order(suite: Path) -> None:
    found = find_problems(suite)
    assert [(p.domain, p.name) for p in found] == [
        ("Courier", "p1.hddl"),
        ("Courier", "p2.hddl"),
        ("Courier", "p10.hddl"),
    ]
    assert all(p.domain_file == suite / "Courier" / "domain.hddl" for p in found)
    assert [p.name for p in find_problems(suite, ["courier"], 2)] == ["p1.hddl", "p2.hddl"]


def test_a_suite_without_the_problems_asked_for_is_a_suite_error(suite: Path, tmp_path: Path) -> None:
    with pytest.raises(SuiteError, match="no such folder") as missing:
        find_problems(tmp_path / "missing")
    assert missing.value.about == "suite"
    with pytest.raises(SuiteError, match="no domain folders"):
        find_problems(suite / "feature-tests")
    with pytest.raises(SuiteError, match=r"no domain Nope in .* \(there: Courier\)") as unknown:
        find_problems(suite, ["Nope"])
    assert unknown.value.about == "domains"


def test_a_valid_plan_is_solved_measured_and_verified(
    suite: Path, fake: Path, fake_verifier: Path, tmp_path: Path
) -> None:
    code, rows, err = run(
        tmp_path,
        *("--suite", str(suite), "--problems", "2", "--verifier", str(fake_verifier)),
        *("--planner-cmd", f"{{python}} {fake} plan {HDDL / 'valid.plan'}"),
    )
    assert code == 0
    assert [r["problem"] for r in rows] == ["p1.hddl", "p2.hddl"]
    for row in rows:
        assert row["domain"] == "Courier"
        assert row["planner"] == "htnagent"
        assert row["solved"] is True
        assert row["valid"] is True
        assert row["plan_length"] == 6
        assert 0 < row["seconds"] < 30
        assert row["reason"] is None
        assert row["timeout"] == 60
    assert "[1/2] Courier/p1.hddl htnagent: solved" in err
    assert "[2/2] Courier/p2.hddl htnagent: solved" in err
    table = (tmp_path / "ipc.md").read_text()
    assert "| Courier | htnagent | 2/2 | 2/2 |" in table


def test_an_invalid_plan_is_solved_but_not_valid(
    suite: Path, fake: Path, fake_verifier: Path, tmp_path: Path
) -> None:
    _, rows, _ = run(
        tmp_path,
        *("--suite", str(suite), "--problems", "1", "--verifier", str(fake_verifier)),
        *("--planner-cmd", f"{{python}} {fake} plan {HDDL / 'precondition-fails.plan'}"),
    )
    assert rows[0]["solved"] is True
    assert rows[0]["valid"] is False
    assert rows[0]["reason"] == "verifier: INVALID"
    assert "(1 invalid)" in (tmp_path / "ipc.md").read_text()


def test_no_plan_found_is_recorded_with_the_planners_reason(suite: Path, fake: Path, tmp_path: Path) -> None:
    common = ("--suite", str(suite), "--problems", "1", "--verifier", str(tmp_path / "none"))
    _, rows, _ = run(tmp_path, *common, "--planner-cmd", f"{{python}} {fake} unsolvable")
    assert rows[0]["solved"] is False
    assert rows[0]["reason"] == "unsolvable"
    assert rows[0]["plan_length"] is None
    _, rows, _ = run(tmp_path, *common, "--planner-cmd", f"{{python}} {fake} noplan")
    assert rows[0]["solved"] is False
    assert "no plan between ==> and <==" in rows[0]["reason"]
    _, rows, _ = run(tmp_path, *common, "--planner-cmd", f"{{python}} {fake} crash")
    assert rows[0]["reason"] == "exit 3: ValueError: boom"


def test_a_planner_past_the_limit_is_killed_with_what_it_started(
    suite: Path, fake: Path, tmp_path: Path
) -> None:
    pid_file = tmp_path / "child.pid"
    start = time.perf_counter()
    _, rows, _ = run(
        tmp_path,
        *("--suite", str(suite), "--problems", "1", "--verifier", str(tmp_path / "none")),
        *("--timeout", "1", "--grace", "0.5", "--planner-cmd", f"{{python}} {fake} sleep {pid_file}"),
    )
    assert time.perf_counter() - start < 10
    assert rows[0]["solved"] is False
    assert rows[0]["reason"] == "timeout"
    assert 1.4 <= rows[0]["seconds"] < 10
    child = int(pid_file.read_text())
    deadline = time.monotonic() + 5
    while time.monotonic() < deadline and _alive(child):
        time.sleep(0.05)
    assert not _alive(child), "the planner's own child outlived the kill"


def _alive(pid: int) -> bool:
    try:
        status = Path(f"/proc/{pid}/status").read_text()
    except OSError:
        return False
    return "\nState:\tZ" not in status


def test_the_verifier_missing_is_said_and_the_plan_left_unverified(
    suite: Path, fake: Path, tmp_path: Path
) -> None:
    _, rows, err = run(
        tmp_path,
        *("--suite", str(suite), "--problems", "1", "--verifier", str(tmp_path / "nowhere")),
        *("--planner-cmd", f"{{python}} {fake} plan {HDDL / 'valid.plan'}"),
    )
    assert rows[0]["solved"] is True
    assert rows[0]["valid"] is None
    assert rows[0]["reason"] == "not verified: no verifier"
    assert f"no verifier at {tmp_path / 'nowhere'}" in err


def test_the_peer_rows(suite: Path, fake: Path, fake_verifier: Path, tmp_path: Path) -> None:
    peer = tmp_path / "fake_peer.py"
    peer.write_text(FAKE_PEER)
    common = ("--suite", str(suite), "--problems", "1", "--verifier", str(fake_verifier))
    ours = ("--planner-cmd", f"{{python}} {fake} unsolvable")
    _, rows, _ = run(
        tmp_path, *common, *ours, "--peers", "--peer-cmd", f"{{python}} {peer} solved {HDDL / 'valid.plan'}"
    )
    assert [r["planner"] for r in rows] == ["htnagent", "aries"]
    aries = rows[1]
    assert aries["solved"] is True
    assert aries["plan_length"] == 6
    assert aries["valid"] is True
    assert aries["read_s"] == 0.01
    _, rows, _ = run(tmp_path, *common, "--peers-only", "--peer-cmd", f"{{python}} {peer} refused")
    assert [r["planner"] for r in rows] == ["aries"]
    assert rows[0]["solved"] is False
    assert rows[0]["reason"] == "refused by unified-planning: UPException: no"
    _, rows, _ = run(
        tmp_path,
        *common,
        *("--peers-only", "--timeout", "0.5", "--grace", "0.5"),
        *("--peer-cmd", f"{{python}} {peer} slow-read"),
    )
    assert rows[0]["reason"] == "timeout while reading (unified-planning)"


def test_peers_without_the_extra_is_one_clear_error(suite: Path, tmp_path: Path) -> None:
    # The extra made absent whether it is installed or not: importlib finds no spec for a
    # module that is None in sys.modules (sitecustomize runs before the bench).
    hide = tmp_path / "hide"
    hide.mkdir()
    (hide / "sitecustomize.py").write_text(
        "import sys\nsys.modules['unified_planning'] = None\nsys.modules['up_aries'] = None\n"
    )
    code, rows, err = run(tmp_path, "--suite", str(suite), "--peers", env={"PYTHONPATH": str(hide)})
    assert code == 2
    assert rows == []  # not even written
    assert err.strip().splitlines() == [
        "python -m bench ipc: error: --peers aries needs unified_planning, up_aries: "
        "pip install -e '.[peers]' (the peers extra)"
    ]


@pytest.mark.parametrize(
    ("args", "message"),
    [
        (["--suite", "{tmp}/missing"], "--suite {tmp}/missing: no such folder"),
        (["--suite", "{tmp}/suite/Courier/p1.hddl"], "not a folder"),
        (["--suite", "{tmp}/suite/feature-tests"], "no domain folders"),
        (["--suite", "{tmp}/suite", "--domains", "Nope"], "--domains: no domain Nope in"),
    ],
)
def test_a_bad_suite_is_one_line_and_exit_2(
    suite: Path, tmp_path: Path, args: list[str], message: str
) -> None:
    done = subprocess.run(
        [sys.executable, "-m", "bench", "ipc", *(a.format(tmp=tmp_path) for a in args)],
        capture_output=True,
        text=True,
        cwd=ROOT,
        timeout=30,
    )
    assert done.returncode == 2
    lines = done.stderr.strip().splitlines()
    assert len(lines) == 1, done.stderr
    assert message.format(tmp=tmp_path) in lines[0]
    assert "Traceback" not in done.stderr


RECORDER = """\
import json, sys
open(sys.argv[1], "w").write(json.dumps(sys.argv[2:]))
print("unsolvable", file=sys.stderr)
sys.exit(1)
"""


def test_our_planners_command_line(suite: Path, tmp_path: Path) -> None:
    # A stand-in that records the command the bench would run ({ours}) and finds no plan.
    recorder = tmp_path / "recorder.py"
    recorder.write_text(RECORDER)
    said = tmp_path / "argv.json"
    common = ("--suite", str(suite), "--problems", "1", "--verifier", str(tmp_path / "none"))
    record = ("--planner-cmd", f"{{python}} {recorder} {said} {{ours}}")
    run(tmp_path, *common, "--search", "gbfs", *record)
    courier = suite / "Courier"
    assert json.loads(said.read_text()) == [
        *(sys.executable, "-m", "htnagent", "plan", "--hddl", str(courier / "domain.hddl")),
        *(str(courier / "p1.hddl"), "--format", "ipc", "--timeout", "60", "--search", "gbfs", "--anytime"),
    ]
    _, rows, _ = run(tmp_path, *common, "--timeout", "2.5", "--first-plan", *record)
    assert json.loads(said.read_text())[-2:] == ["--timeout", "2.5"]
    assert rows[0]["planner"] == "htnagent-first"


def test_the_search_strategy_names_the_planner(suite: Path, fake: Path, tmp_path: Path) -> None:
    _, rows, _ = run(
        tmp_path,
        *("--suite", str(suite), "--problems", "1", "--verifier", str(tmp_path / "none")),
        *("--search", "gbfs", "--planner-cmd", f"{{python}} {fake} unsolvable"),
    )
    assert rows[0]["planner"] == "htnagent-gbfs"


def test_the_plan_is_found_in_a_planners_output() -> None:
    block = plan_block("noise\n" + (HDDL / "valid.plan").read_text() + "more noise\n")
    assert block is not None
    assert block.startswith("==>\n") and block.endswith("<==\n")
    assert len(parse_plan(block).steps) == 6  # the bench's plan_length
    assert plan_block("==>\n0 a\n") is None
    assert plan_block("0 a\n<==\n") is None


@pytest.mark.skipif(not VERIFIER_BUILT.is_file() or not VERIFY.is_file(), reason="hddl-verify is not built")
def test_the_real_verifier_judges_the_plans(suite: Path, fake: Path, tmp_path: Path) -> None:
    common = ("--suite", str(suite), "--problems", "1", "--verifier", str(VERIFY))
    _, rows, _ = run(tmp_path, *common, "--planner-cmd", f"{{python}} {fake} plan {HDDL / 'valid.plan'}")
    assert (rows[0]["solved"], rows[0]["valid"]) == (True, True)
    bad = HDDL / "precondition-fails.plan"
    _, rows, _ = run(tmp_path, *common, "--planner-cmd", f"{{python}} {fake} plan {bad}")
    assert (rows[0]["solved"], rows[0]["valid"]) == (True, False)


def test_a_unified_planning_plan_is_written_in_the_ipc_format() -> None:
    # bench/ipc_peer.py's writer on stand-ins shaped like unified-planning's plan objects
    # (the real ones need the peers extra): the courier's deliver p1 as m-deliver, its gotos
    # as m-goto-step / m-goto-here.
    from types import SimpleNamespace as NS

    def obj(name: str) -> NS:
        return NS(is_object_exp=lambda: True, object=lambda: NS(name=name))

    def act(name: str, *args: str) -> NS:
        return NS(action=NS(name=name), actual_parameters=[obj(a) for a in args])

    def method(name: str, task: str, params: list[str], task_params: list[str], order: list[str]) -> NS:
        return NS(
            name=name,
            parameters=[NS(name=p) for p in params],
            achieved_task=NS(task=NS(name=task), parameters=[NS(name=p) for p in task_params]),
            total_order=lambda: order,
        )

    def instance(m: NS, args: list[str], subtasks: dict[str, object]) -> NS:
        return NS(method=m, parameters=[obj(a) for a in args], decomposition=NS(subtasks=subtasks))

    move, pick = act("move", "r1", "hall", "kitchen"), act("pick", "r1", "p1", "kitchen")
    here = method("m-goto-here", "goto", ["r", "to"], ["r", "to"], [])
    step = method("m-goto-step", "goto", ["r", "to", "from", "mid"], ["r", "to"], ["s1", "s2"])
    deliver = method("m-deliver", "deliver", ["x", "to", "from", "r"], ["x", "to"], ["t1", "t2"])
    goto = instance(
        step,
        ["r1", "kitchen", "hall", "kitchen"],
        {"s2": instance(here, ["r1", "kitchen"], {}), "s1": move},
    )
    top = instance(deliver, ["p1", "kitchen", "kitchen", "r1"], {"t2": pick, "t1": goto})
    plan = NS(action_plan=NS(actions=[move, pick]), decomposition=NS(subtasks={"task0": top}))
    problem = NS(task_network=NS(total_order=lambda: ["task0"]))
    text = ipc_plan(problem, plan, {"r1": "R1"})
    assert text == (
        "==>\n0 move R1 hall kitchen\n1 pick R1 p1 kitchen\nroot 2\n"
        "2 deliver p1 kitchen -> m-deliver 3 1\n3 goto R1 kitchen -> m-goto-step 0 4\n"
        "4 goto R1 kitchen -> m-goto-here\n<==\n"
    )
    assert len(parse_plan(text).steps) == 2


def test_ctrl_c_keeps_the_rows_and_leaves_no_planner_running(suite: Path, fake: Path, tmp_path: Path) -> None:
    pid_file = tmp_path / "child.pid"
    out = tmp_path / "ipc.json"
    command = [sys.executable, "-m", "bench", "ipc", "--suite", str(suite), "--out", str(out)]
    command += ["--verifier", str(tmp_path / "none"), "--planner-cmd", f"{{python}} {fake} sleep {pid_file}"]
    bench = subprocess.Popen(
        command,
        cwd=ROOT,
        stderr=subprocess.PIPE,
        text=True,
    )
    deadline = time.monotonic() + 20
    while not (pid_file.is_file() and pid_file.read_text()) and time.monotonic() < deadline:
        time.sleep(0.05)
    bench.send_signal(signal.SIGINT)
    _, err = bench.communicate(timeout=20)
    assert bench.returncode == 130, err
    assert "interrupted; 0 rows kept" in err
    assert json.loads(out.read_text()) == []
    assert "Traceback" not in err
    child = int(pid_file.read_text())
    deadline = time.monotonic() + 5
    while time.monotonic() < deadline and _alive(child):
        time.sleep(0.05)
    assert not _alive(child), "the planner's own child outlived Ctrl-C"


FAKE_ANCHOR = """\
#!/bin/sh
# a stand-in anchor: plan-NAME DOMAIN PROBLEM OUT, as the real wrappers are called
case "$0" in  # (no basename: the PATH may be empty)
  */plan-panda) /bin/grep -v "<==" "{plan}" > "$3"; exit 0 ;;  # PANDA: no closing line
  */plan-lilotane) echo "no plan: out of layers" > "$3.log"; exit 1 ;;
  */plan-hypertension) /bin/cat "{plan}" > "$3"; exit 0 ;;
esac
exit 9
"""


@pytest.fixture
def anchors(tmp_path: Path) -> Path:
    folder = tmp_path / "anchors"
    folder.mkdir()
    for name in ("panda", "lilotane", "hypertension"):
        wrapper = folder / f"plan-{name}"
        wrapper.write_text(FAKE_ANCHOR.format(plan=HDDL / "valid.plan"))
        wrapper.chmod(0o755)
    return folder


def test_the_anchors_run_one_at_a_time_beside_ours_and_are_verified_alike(
    suite: Path,
    fake: Path,
    fake_verifier: Path,
    anchors: Path,
    tmp_path: Path,
) -> None:
    # HyperTensioN needs Ruby, which an empty PATH lacks: a row saying so, not a loss.
    # (Everything else the bench runs here is named by its full path.)
    empty = tmp_path / "empty"
    empty.mkdir()
    code, rows, _ = run(
        tmp_path,
        *("--suite", str(suite), "--problems", "2", "--verifier", str(fake_verifier)),
        *("--planner-cmd", f"{{python}} {fake} plan {HDDL / 'precondition-fails.plan'}"),
        *("--peers", "panda,hypertension,lilotane", "--anchors", str(anchors)),
        env={"PATH": str(empty)},
    )
    assert code == 0
    assert [r["planner"] for r in rows] == ["htnagent", "panda", "hypertension", "lilotane"] * 2
    panda = rows[1]
    assert (panda["solved"], panda["valid"], panda["plan_length"]) == (True, True, 6)
    assert panda["first_s"] == panda["seconds"]
    hyper = rows[2]
    assert hyper["available"] is False and hyper["solved"] is False
    assert hyper["reason"] == "cannot run here: needs ruby on the PATH (apt-get install -y ruby)"
    lilotane = rows[3]
    assert (lilotane["solved"], lilotane["reason"]) == (False, "exit 1: no plan: out of layers")
    assert rows[0]["valid"] is False  # ours is judged by the same verifier
    table = (tmp_path / "ipc.md").read_text()
    assert "| Courier | hypertension | cannot run here |" in table
    assert "| Courier | panda | 2/2 | 2/2 |" in table
    assert "| **all** | hypertension | cannot run here (2) |" in table
    # Against PANDA: both solved both problems, plans of the same length.
    assert "| panda | 2 | 2 | 2 | 2 | 1.000 | 12 | 12 |" in table
    # HyperTensioN never ran: no problems to compare on.
    assert "| hypertension | 0 | 0 | 0 | 0 | — |" in table


def test_an_anchor_folder_without_the_wrapper_is_a_row_saying_so(
    suite: Path, fake: Path, tmp_path: Path
) -> None:
    _, rows, _ = run(
        tmp_path,
        *("--suite", str(suite), "--problems", "1", "--verifier", str(tmp_path / "none")),
        *("--peers-only", "--peers", "lilotane", "--anchors", str(tmp_path / "nowhere")),
    )
    assert [r["planner"] for r in rows] == ["lilotane"]
    assert rows[0]["available"] is False
    assert rows[0]["reason"].startswith(f"cannot run here: no {tmp_path / 'nowhere' / 'plan-lilotane'}")


def test_a_rerun_resumes_where_the_last_one_stopped(
    suite: Path, fake: Path, fake_verifier: Path, tmp_path: Path
) -> None:
    common = ("--suite", str(suite), "--verifier", str(fake_verifier))
    good = ("--planner-cmd", f"{{python}} {fake} plan {HDDL / 'valid.plan'}")
    crash = ("--planner-cmd", f"{{python}} {fake} crash")
    _, rows, _ = run(tmp_path, *common, "--problems", "1", *good, resume=True)
    assert [(r["problem"], r["solved"]) for r in rows] == [("p1.hddl", True)]
    # Same limit: p1 is kept as it was, only p2 and p10 are attempted (and crash).
    code, rows, err = run(tmp_path, *common, *crash, resume=True)
    assert code == 0
    assert [(r["problem"], r["solved"]) for r in rows] == [
        ("p1.hddl", True),
        ("p2.hddl", False),
        ("p10.hddl", False),
    ]
    assert "resuming: 1 rows kept, 2 attempts to go" in err
    # Another limit, or --fresh: everything again.
    _, rows, err = run(tmp_path, *common, "--timeout", "30", *good, resume=True)
    assert [(r["solved"], r["timeout"]) for r in rows] == [(True, 30)] * 3
    assert "3 rows of another limit dropped" in err
    _, rows, _ = run(tmp_path, *common, "--timeout", "30", "--fresh", *crash, resume=True)
    assert [r["solved"] for r in rows] == [False] * 3


def test_a_verifier_time_out_leaves_the_plan_solved_unverified_and_said(
    suite: Path, fake: Path, tmp_path: Path
) -> None:
    slow = tmp_path / "slow-verify.sh"
    slow.write_text("#!/bin/sh\nexec sleep 30\n")
    slow.chmod(0o755)
    _, rows, _ = run(
        tmp_path,
        *("--suite", str(suite), "--problems", "1", "--verifier", str(slow), "--verify-timeout", "0.3"),
        *("--planner-cmd", f"{{python}} {fake} plan {HDDL / 'valid.plan'}"),
    )
    row = rows[0]
    assert (row["solved"], row["valid"], row["verifier_timeout"]) == (True, None, True)
    assert row["reason"] == "verifier: no verdict in 0.3 s (time-out)"
    assert "(1 verifier time-out)" in (tmp_path / "ipc.md").read_text()


def test_a_verifier_out_of_time_leaves_nothing_of_its_own_running(
    suite: Path, fake: Path, tmp_path: Path
) -> None:
    # The IPC verifier is a script that runs its parser as a child: both go at the limit.
    child = tmp_path / "child.pid"
    slow = tmp_path / "slow-verify.sh"
    slow.write_text(f"#!/bin/sh\nsleep 30 &\necho $! > {child}\nwait\n")
    slow.chmod(0o755)
    run(
        tmp_path,
        *("--suite", str(suite), "--problems", "1", "--verifier", str(slow), "--verify-timeout", "0.3"),
        *("--planner-cmd", f"{{python}} {fake} plan {HDDL / 'valid.plan'}"),
    )
    pid = int(child.read_text())
    for _ in range(50):
        try:
            os.kill(pid, 0)
        except ProcessLookupError:
            return
        time.sleep(0.05)
    os.kill(pid, signal.SIGKILL)
    pytest.fail("the verifier's child outlived its time-out")


ANYTIME_PLANNER = """\
import sys, time
plan = open(sys.argv[1]).read()
longer = plan.replace("root", "9 noop\\nroot")
print(longer, flush=True)
time.sleep(0.4)
print(plan, flush=True)
if sys.argv[2] == "hang":
    time.sleep(60)
"""


@pytest.mark.parametrize("ending", ["exit", "hang"])
def test_anytime_times_the_first_plan_and_measures_the_last_in_time(
    suite: Path, fake_verifier: Path, tmp_path: Path, ending: str
) -> None:
    script = tmp_path / "anytime.py"
    script.write_text(ANYTIME_PLANNER)
    _, rows, _ = run(
        tmp_path,
        *("--suite", str(suite), "--problems", "1", "--verifier", str(fake_verifier)),
        *("--timeout", "2", "--grace", "0.2"),
        *("--planner-cmd", f"{{python}} {script} {HDDL / 'valid.plan'} {ending}"),
    )
    row = rows[0]
    assert row["planner"] == "htnagent"
    assert row["solved"] is True
    assert row["plan_length"] == 6  # the last, shorter plan
    assert row["first_s"] is not None and row["first_s"] + 0.3 < row["seconds"]


def test_peers_are_a_list_of_known_names(suite: Path, tmp_path: Path) -> None:
    done = subprocess.run(
        [sys.executable, "-m", "bench", "ipc", "--suite", str(suite), "--peers", "panda,fastdownward"],
        capture_output=True,
        text=True,
        cwd=ROOT,
        timeout=30,
    )
    assert done.returncode == 2
    assert "no peer 'fastdownward' (known: panda, hypertension, lilotane, aries)" in done.stderr
    assert "Traceback" not in done.stderr


def test_a_problem_with_a_domain_of_its_own_is_solved_with_it(suite: Path) -> None:
    own = suite / "Own"
    own.mkdir()
    for name in ("p1", "p2"):
        shutil.copy(HDDL / "courier.hddl", own / f"{name}.hddl")
        shutil.copy(HDDL / "courier-domain.hddl", own / f"{name}-domain.hddl")
    found = find_problems(suite, ["Own"])
    assert [(p.name, p.domain_file.name) for p in found] == [
        ("p1.hddl", "p1-domain.hddl"),
        ("p2.hddl", "p2-domain.hddl"),
    ]


def test_also_adds_positions_to_the_first_problems(suite: Path) -> None:
    picked = find_problems(suite, None, 1, (3,))
    assert [p.name for p in picked] == ["p1.hddl", "p10.hddl"]
