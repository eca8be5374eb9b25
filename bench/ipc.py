"""The IPC total-order HTN benchmarks, solved and verified (``python -m bench ipc --suite DIR``).

Each domain folder of the suite (one with a ``domain.hddl``) gives its problems:
the other ``.hddl`` files beside it, in natural order (``p2`` before ``p10``);
subfolders (``other/``, further instances) and folders without a ``domain.hddl``
(the feature tests) are not benchmark problems.  One attempt at a time -- never
two side by side, so that timings are fair -- each in its own process group:

- our planner, ``python -m htnagent plan --hddl DOMAIN PROBLEM --format ipc
  --timeout S --anytime [--search NAME]`` (docs/contracts.md "Command line"; with
  ``--first-plan``, without ``--anytime``); its plan is checked by the IPC verifier
  (``hddl-verify``);
- with ``--peers NAME,...``, other planners on the same problem, under the same limit,
  right after ours: the anchors ``panda``, ``hypertension`` and ``lilotane`` (the
  wrappers ``plan-NAME DOMAIN PROBLEM OUT`` of ``--anchors``, by default
  ``../shared/tools/anchors`` from the repository root), and ``aries`` through
  unified-planning (``python -m bench.ipc_peer``, the ``peers`` extra).  ``--peers``
  alone means ``aries``, as it always did.  An anchor that cannot run here (its wrapper
  missing, or Ruby for HyperTensioN) gives a row saying so (``available: false``), which
  counts as neither a win nor a loss.

The limit ``S`` is the wall clock of the whole attempt, from starting the process
to its end (Python's start, reading the files, planning).  A process still running
at ``S`` plus a grace of a few seconds (so that a planner may say ``timeout``
itself) is killed with its whole process group; an answer that comes after ``S``
counts as a timeout.  Our planner runs ``--anytime``, as the IPC's anytime track runs
a planner: it prints every better plan as it finds one; ``first_s`` is the time of the
first, and the plan measured and verified is the last one printed before ``S``.

Every plan is verified, each planner's alike, under ``--verify-timeout`` seconds: a
verifier that gives no verdict in that time (a plan of millions of actions) leaves the
plan solved but unverified (``valid: null``, ``verifier_timeout: true``), for every
planner the same, and the table counts such plans apart.

Rows (``bench/results/ipc.json``, rewritten after every attempt so that an
interrupted run keeps what it measured; Ctrl-C kills the attempt under way and
exits 130): ``{domain, problem, planner, solved, seconds, plan_length, valid,
reason, timeout, read_s, first_s, available, verifier_timeout}`` -- ``solved`` a plan
came back in time; ``valid`` the verifier's verdict on it (``null``: not verified --
the verifier is missing, timed out or gave no verdict); ``reason`` why not solved
(``timeout``, ``unsolvable``, ``budget``, ``refused by unified-planning: ...``,
``cannot run here: ...``), or why not valid; ``timeout`` the limit; ``read_s`` (Aries)
the seconds before unified-planning had read the files (its import included), part of
``seconds``.  A rerun with the same ``--out`` resumes: the attempts already in it for the
same limit are kept and not run again (``--fresh`` starts over; rows of another limit
are dropped).  ``bench/results/ipc.md``: per domain and planner, problems solved, plans
verified, median seconds to the first plan and median and total plan length of the
solved ones; then per planner its coverage beside ours, and over the problems both
solved the geometric mean and the total of our plan lengths against its.
"""

from __future__ import annotations

import argparse
import contextlib
import importlib.util
import json
import math
import os
import shlex
import shutil
import signal
import statistics
import subprocess
import sys
import tempfile
import threading
import time
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import IO, Any

from bench.machine import machine_line
from htnagent.errors import HddlError
from htnagent.hddl.plan_file import parse_plan, plan_block
from htnagent.testing.hddl_inputs import SuiteError, find_problems
from htnagent.testing.hddl_inputs import SuiteProblem as Problem

ROOT = Path(__file__).resolve().parent.parent
RESULTS = ROOT / "bench" / "results"
DEFAULT_VERIFIER = ROOT.parent / "shared" / "tools" / "hddl-verify" / "hddl-verify"
"""``../shared/tools/hddl-verify/hddl-verify`` from the repository root; ``--verifier`` or
the environment variable ``HDDL_VERIFY`` name another."""
DEFAULT_ANCHORS = ROOT.parent / "shared" / "tools" / "anchors"
"""``../shared/tools/anchors`` from the repository root (``plan-panda`` and the others);
``--anchors`` or the environment variable ``HTN_ANCHORS`` name another folder."""

ANCHORS = ("panda", "hypertension", "lilotane")
"""The anchors: each one wrapper, ``plan-NAME DOMAIN PROBLEM OUT``."""
PEERS = (*ANCHORS, "aries")
ANCHOR_NEEDS = {"hypertension": ("ruby",)}
"""Programs an anchor's wrapper needs on the PATH (HyperTensioN is Ruby)."""

GRACE_S = 5.0
"""How long past the limit a process may run (to report ``timeout`` itself) before it is killed."""

VERIFY_TIMEOUT_S = 300.0
"""The verifier's own limit by default (its very first call builds it: about 50 s)."""

PROG = "python -m bench ipc"


class UsageError(Exception):
    """A bad option or suite: one line on stderr, exit 2."""


@dataclass
class Outcome:
    """What a process did: exit code (None: killed at the limit), seconds, its output, and
    the plans it printed on stdout with the second each was complete (``<==``)."""

    code: int | None
    seconds: float
    stdout: str
    stderr: str
    plans: list[tuple[float, str]] = field(default_factory=list)


def suite_problems(
    suite: Path, domains: Sequence[str] | None, first: int | None, picks: Sequence[int] = ()
) -> list[Problem]:
    """:func:`htnagent.testing.hddl_inputs.find_problems`, its refusal a :class:`UsageError`
    naming the option."""
    try:
        return find_problems(suite, domains, first, picks)
    except SuiteError as e:
        raise UsageError(f"--domains: {e}" if e.about == "domains" else f"--suite {e}") from None


def _read_lines(stream: IO[str], start: float, lines: list[str], plans: list[tuple[float, str]]) -> None:
    """Keep a process's stdout, noting when each plan (``==>`` ... ``<==``) was complete."""
    block: list[str] | None = None
    for line in stream:
        lines.append(line)
        word = line.strip()
        if word == "==>":
            block = [line]
        elif block is not None:
            block.append(line)
            if word == "<==":
                plans.append((time.perf_counter() - start, "".join(block)))
                block = None


def run_process(argv: Sequence[str], limit: float, grace: float = GRACE_S) -> Outcome:
    """Run ``argv`` in a new process group; kill the group at ``limit + grace`` seconds."""
    with tempfile.TemporaryFile("w+") as err:
        start = time.perf_counter()
        proc = subprocess.Popen(
            list(argv),
            stdout=subprocess.PIPE,
            stderr=err,
            stdin=subprocess.DEVNULL,
            cwd=ROOT,  # python -m bench.ipc_peer is found from the repository root
            start_new_session=True,
            text=True,
            errors="replace",
        )
        lines: list[str] = []
        plans: list[tuple[float, str]] = []
        assert proc.stdout is not None
        reader = threading.Thread(target=_read_lines, args=(proc.stdout, start, lines, plans), daemon=True)
        reader.start()
        code: int | None = None
        try:
            code = proc.wait(timeout=limit + grace)
        except subprocess.TimeoutExpired:
            code = None
        finally:  # also on Ctrl-C: nothing the bench started outlives it
            seconds = time.perf_counter() - start
            # The whole group goes, also what the planner started (Aries runs a server process).
            with contextlib.suppress(ProcessLookupError, PermissionError):
                os.killpg(proc.pid, signal.SIGKILL)
            proc.wait()
            reader.join(timeout=10)
            proc.stdout.close()
        err.seek(0)
        return Outcome(code, seconds, "".join(lines), err.read(), plans)


def file_block(text: str) -> str | None:
    """The plan in an anchor's output file: from ``==>`` to ``<==``, or to the end of the
    file (PANDA's plans have no closing line, and the verifier takes them so)."""
    block = plan_block(text)
    if block is not None:
        return block
    lines = text.splitlines()
    starts = [i for i, line in enumerate(lines) if line.strip() == "==>"]
    if not starts:
        return None
    return "\n".join(lines[starts[0] :]) + "\n"


def plan_length(block: str) -> int | None:
    """Primitive actions of the plan, as the package reads IPC plans (PANDA's output has
    no closing ``<==``: one is added to count); None when it cannot be read."""
    closed = block if plan_block(block) is not None else block + "<==\n"
    try:
        return len(parse_plan(closed).steps)
    except HddlError:
        return None


def last_line(text: str) -> str:
    lines = [line.strip() for line in text.splitlines() if line.strip()]
    return lines[-1][:300] if lines else ""


def verify(
    verifier: Path, problem: Problem, block: str, limit: float = VERIFY_TIMEOUT_S
) -> tuple[bool | None, str | None]:
    """The verifier's verdict on the plan: ``(True, None)``, ``(False, why)`` or ``(None, why)``."""
    with tempfile.NamedTemporaryFile("w", suffix=".plan", delete=False) as f:
        f.write(block)
        plan_file = f.name
    try:
        # In a process group of its own, killed whole at the limit: the IPC verifier is a
        # script whose parser would otherwise go on after it, a core taken from what follows.
        done = run_process(
            [str(verifier), str(problem.domain_file), str(problem.problem_file), plan_file], limit, 0
        )
    except OSError as e:
        return None, f"verifier: cannot run {verifier}: {e.strerror}"
    finally:
        os.unlink(plan_file)
    if done.code is None:
        return None, f"verifier: no verdict in {limit:g} s (time-out)"
    verdict = last_line(done.stdout) or last_line(done.stderr)
    if done.code == 0:
        return True, None
    if done.code == 1:
        return False, f"verifier: {verdict}"
    return None, f"verifier: {verdict or f'exit {done.code}'}"


@dataclass(frozen=True)
class Checker:
    """The verifier (None: missing) and its limit in seconds."""

    verifier: Path | None
    limit: float = VERIFY_TIMEOUT_S

    def judge(self, row: dict[str, Any], problem: Problem, block: str) -> None:
        """The plan's verdict into the row (``valid``, ``reason``, ``verifier_timeout``)."""
        if self.verifier is None:
            row["reason"] = "not verified: no verifier"
            return
        row["valid"], row["reason"] = verify(self.verifier, problem, block, self.limit)
        row["verifier_timeout"] = row["valid"] is None and "(time-out)" in (row["reason"] or "")


def _filled(template: str, problem: Problem, timeout: float, ours: Sequence[str] = ()) -> list[str]:
    """The template's words filled in; the word ``{ours}`` stands for all of ``ours``."""
    argv: list[str] = []
    for word in shlex.split(template):
        if word == "{ours}":
            argv += ours
            continue
        argv.append(
            word.format(
                domain=problem.domain_file,
                problem=problem.problem_file,
                timeout=f"{timeout:g}",
                python=sys.executable,
            )
        )
    return argv


def our_command(
    template: str | None, problem: Problem, timeout: float, search: str | None, anytime: bool = True
) -> list[str]:
    """Our planner's command line (``--planner-cmd`` replaces it: ``{domain}``, ``{problem}``,
    ``{timeout}``, ``{python}`` filled in, and ``{ours}`` the command it replaces, word by word)."""
    argv = [sys.executable, "-m", "htnagent", "plan", "--hddl", str(problem.domain_file)]
    argv += [str(problem.problem_file), "--format", "ipc", "--timeout", f"{timeout:g}"]
    if search:
        argv += ["--search", search]
    if anytime:
        argv += ["--anytime"]
    return argv if template is None else _filled(template, problem, timeout, argv)


def ours(
    problem: Problem,
    planner: str,
    argv: Sequence[str],
    timeout: float,
    checker: Checker | Path | None,
    grace: float = GRACE_S,
) -> dict[str, Any]:
    """One attempt of our planner: its row (with ``--anytime``, the last plan printed in time)."""
    if not isinstance(checker, Checker):
        checker = Checker(checker)
    done = run_process(argv, timeout, grace)
    row = _row(problem, planner, done.seconds, timeout)
    in_time = [(t, block) for t, block in done.plans if t <= timeout]
    if in_time and done.code in (0, None):
        # Anytime: killed at the limit after printing plans is still solved -- by its last one.
        row["solved"] = True
        row["first_s"] = round(in_time[0][0], 3)
        block = in_time[-1][1]
        row["plan_length"] = plan_length(block)
        checker.judge(row, problem, block)
    elif done.code is None:
        row["reason"] = "timeout"
    elif done.code == 0:
        if plan_block(done.stdout) is None:
            row["reason"] = "exit 0 but no plan between ==> and <== on stdout"
        else:
            row["reason"] = "timeout"  # an answer after the limit does not count
    elif done.code == 1:
        row["reason"] = last_line(done.stderr) or "exit 1"
    elif done.code == 2:
        row["reason"] = f"invalid input: {last_line(done.stderr)}"
    else:
        row["reason"] = f"exit {done.code}: {last_line(done.stderr)}"
    return row


def anchor_missing(anchors: Path, name: str) -> str | None:
    """Why the anchor ``name`` cannot run on this machine, or None when it can."""
    wrapper = anchors / f"plan-{name}"
    if not wrapper.is_file():
        return f"no {wrapper} (--anchors or HTN_ANCHORS)"
    if not os.access(wrapper, os.X_OK):
        return f"{wrapper} is not executable"
    for program in ANCHOR_NEEDS.get(name, ()):
        if shutil.which(program) is None:
            return f"needs {program} on the PATH (apt-get install -y {program})"
    return None


def anchor(
    problem: Problem, name: str, anchors: Path, timeout: float, checker: Checker, grace: float = GRACE_S
) -> dict[str, Any]:
    """One attempt of an anchor through its wrapper: its row, its plan verified as ours are."""
    missing = anchor_missing(anchors, name)
    if missing is not None:
        row = _row(problem, name, 0.0, timeout)
        row["available"] = False
        row["reason"] = f"cannot run here: {missing}"
        return row
    with tempfile.TemporaryDirectory(prefix="htnagent-anchor-") as tmp:
        out = Path(tmp) / "out.plan"
        argv = [str(anchors / f"plan-{name}"), str(problem.domain_file), str(problem.problem_file), str(out)]
        done = run_process(argv, timeout, grace)
        row = _row(problem, name, done.seconds, timeout)
        log = Path(f"{out}.log")
        said = last_line(log.read_text(errors="replace")) if log.is_file() else ""
        said = said or last_line(done.stderr)
        block = file_block(out.read_text(errors="replace")) if out.is_file() else None
        if done.code is None or (done.code == 0 and done.seconds > timeout):
            row["reason"] = "timeout"
        elif done.code in (126, 127):  # the shell could not start what the wrapper runs
            row["available"] = False
            row["reason"] = f"cannot run here: exit {done.code}: {said}"
        elif done.code != 0:
            row["reason"] = f"exit {done.code}: {said}" if said else f"exit {done.code}"
        elif block is None:
            row["reason"] = "exit 0 but no plan between ==> and <== in its output file"
        else:
            row["solved"] = True
            row["first_s"] = row["seconds"]
            row["plan_length"] = plan_length(block)
            checker.judge(row, problem, block)
    return row


def peer_command(template: str | None, problem: Problem, timeout: float, name: str) -> list[str]:
    if template is not None:
        return _filled(template, problem, timeout)
    argv = [sys.executable, "-m", "bench.ipc_peer", str(problem.domain_file), str(problem.problem_file)]
    return [*argv, "--timeout", f"{timeout:g}", "--planner", name]


def peer(
    problem: Problem,
    planner: str,
    argv: Sequence[str],
    timeout: float,
    checker: Checker | Path | None,
    grace: float = GRACE_S,
) -> dict[str, Any]:
    """One attempt of a peer through ``bench.ipc_peer``: its row, its plan verified as ours are."""
    if not isinstance(checker, Checker):
        checker = Checker(checker)
    done = run_process(argv, timeout, grace)
    row = _row(problem, planner, done.seconds, timeout)
    report: dict[str, Any] = {}
    read = False
    for line in done.stdout.splitlines():
        if line.startswith("read "):
            read = True
        elif line.startswith("{"):
            with contextlib.suppress(ValueError):
                report = json.loads(line)
    if done.code is None:
        row["reason"] = "timeout" if read else "timeout while reading (unified-planning)"
        return row
    if report.get("read_s") is not None:
        row["read_s"] = report["read_s"]
    status = report.get("status")
    if status == "solved" and done.seconds <= timeout:
        row["solved"] = True
        row["first_s"] = row["seconds"]
        row["plan_length"] = report.get("plan_length")
        block = plan_block(report.get("plan") or "")
        if block is None:
            row["reason"] = f"not verified: {report.get('reason') or 'no IPC plan'}"
        else:
            checker.judge(row, problem, block)
    elif status == "solved":
        row["reason"] = "timeout"
    elif status == "refused":
        row["reason"] = f"refused by unified-planning: {report.get('reason')}"
    elif status is not None:
        why = report.get("reason")
        row["reason"] = str(status) if why in (None, status) else f"{status}: {why}"
    else:
        row["reason"] = f"exit {done.code}: {last_line(done.stderr)}"
    return row


def _row(problem: Problem, planner: str, seconds: float, timeout: float) -> dict[str, Any]:
    return {
        "domain": problem.domain,
        "problem": problem.name,
        "planner": planner,
        "solved": False,
        "seconds": round(seconds, 3),
        "plan_length": None,
        "valid": None,
        "reason": None,
        "timeout": timeout,
        "read_s": None,
        "first_s": None,
        "available": True,
        "verifier_timeout": False,
    }


def _ran(row: dict[str, Any]) -> bool:
    return row.get("available", True) is not False


def _first_s(row: dict[str, Any]) -> float:
    first = row.get("first_s")
    return float(row["seconds"] if first is None else first)


def summary(rows: Sequence[dict[str, Any]]) -> list[dict[str, Any]]:
    """Per domain and planner: problems, solved, verified, median seconds (to the first plan)
    and plan length (solved ones); ``unavailable`` the attempts that could not run here."""
    groups: dict[tuple[str, str], list[dict[str, Any]]] = {}
    for row in rows:
        groups.setdefault((row["domain"], row["planner"]), []).append(row)
    out = []
    for (domain, planner), group in groups.items():
        solved = [r for r in group if r["solved"]]
        lengths = [r["plan_length"] for r in solved if r["plan_length"] is not None]
        out.append(
            {
                "domain": domain,
                "planner": planner,
                "problems": len(group),
                "unavailable": sum(1 for r in group if not _ran(r)),
                "solved": len(solved),
                "verified": sum(1 for r in solved if r["valid"] is True),
                "invalid": sum(1 for r in solved if r["valid"] is False),
                "verifier_timeouts": sum(1 for r in solved if r.get("verifier_timeout")),
                "median_s": round(statistics.median(_first_s(r) for r in solved), 2) if solved else None,
                "median_length": statistics.median(lengths) if lengths else None,
                "total_length": sum(lengths),
            }
        )
    return out


def comparison(rows: Sequence[dict[str, Any]], ours_name: str) -> list[dict[str, Any]]:
    """Each other planner against ours: coverage where both ran, and over the problems both
    solved the geometric mean of our plan length over its (per problem), the totals, and the
    median seconds to the first plan."""
    by_planner: dict[str, dict[tuple[str, str], dict[str, Any]]] = {}
    for row in rows:
        by_planner.setdefault(row["planner"], {})[(row["domain"], row["problem"])] = row
    mine = by_planner.get(ours_name, {})
    out = []
    for planner, theirs in by_planner.items():
        if planner == ours_name:
            continue
        ran = [key for key, row in theirs.items() if _ran(row) and key in mine]
        both = [key for key in ran if theirs[key]["solved"] and mine[key]["solved"]]
        lengths = [
            (mine[key]["plan_length"], theirs[key]["plan_length"])
            for key in both
            if mine[key]["plan_length"] is not None and theirs[key]["plan_length"] is not None
        ]
        # A plan of no action (the network is already done) counts as one, so that ratios exist.
        ratios = [math.log(max(a, 1) / max(b, 1)) for a, b in lengths]
        out.append(
            {
                "planner": planner,
                "problems": len(ran),
                "unavailable": sum(1 for row in theirs.values() if not _ran(row)),
                "ours_solved": sum(1 for key in ran if mine[key]["solved"]),
                "solved": sum(1 for key in ran if theirs[key]["solved"]),
                "both": len(both),
                "length_geomean": round(math.exp(statistics.fmean(ratios)), 3) if ratios else None,
                "ours_total_length": sum(a for a, _ in lengths),
                "total_length": sum(b for _, b in lengths),
                "ours_median_s": round(statistics.median(_first_s(mine[k]) for k in both), 3)
                if both
                else None,
                "median_s": round(statistics.median(_first_s(theirs[k]) for k in both), 3) if both else None,
            }
        )
    return out


def all_solved_times(rows: Sequence[dict[str, Any]]) -> tuple[int, dict[str, float]]:
    """Over the problems every planner that ran solved: their count, and each planner's
    median seconds to the first plan."""
    planners = sorted({r["planner"] for r in rows if _ran(r)})
    by_problem: dict[tuple[str, str], dict[str, dict[str, Any]]] = {}
    for row in rows:
        if _ran(row):
            by_problem.setdefault((row["domain"], row["problem"]), {})[row["planner"]] = row
    common = [
        got
        for got in by_problem.values()
        if len(got) == len(planners) and all(r["solved"] for r in got.values())
    ]
    if not common:
        return 0, {}
    return len(common), {p: round(statistics.median(_first_s(got[p]) for got in common), 3) for p in planners}


def markdown(
    rows: Sequence[dict[str, Any]], timeout: float, machine: str, ours_name: str = "htnagent"
) -> str:
    """The table: one line per domain and planner, then the planners compared."""
    lines = [
        f"IPC 2020 total-order problems, {timeout:g} s a problem, one at a time; {machine}.",
        "Seconds: to the first plan, start-up included (median of the solved ones); plan length:",
        "the last plan printed in time.",
        "",
        "| domain | planner | solved | verified | median s | median plan length | total plan length |",
        "|---|---|---:|---:|---:|---:|---:|",
    ]
    totals: dict[str, list[int]] = {}
    for s in summary(rows):
        t = totals.setdefault(s["planner"], [0, 0, 0, 0, 0])
        t[0] += s["solved"]
        t[1] += s["problems"] - s["unavailable"]
        t[2] += s["verified"]
        t[3] += s["verifier_timeouts"]
        t[4] += s["unavailable"]
        if s["unavailable"] == s["problems"]:
            lines.append(f"| {s['domain']} | {s['planner']} | cannot run here | | | | |")
            continue
        verified = f"{s['verified']}/{s['solved']}"
        if s["invalid"]:
            verified += f" ({s['invalid']} invalid)"
        if s["verifier_timeouts"]:
            verified += f" ({s['verifier_timeouts']} verifier time-out)"
        median_s = "—" if s["median_s"] is None else f"{s['median_s']:.2f}"
        median_len = "—" if s["median_length"] is None else f"{s['median_length']:g}"
        ran = s["problems"] - s["unavailable"]
        lines.append(
            f"| {s['domain']} | {s['planner']} | {s['solved']}/{ran} | {verified} "
            f"| {median_s} | {median_len} | {s['total_length']} |"
        )
    for planner, (n_solved, n_problems, n_verified, n_timeouts, n_unavailable) in totals.items():
        if n_problems == 0:
            lines.append(f"| **all** | {planner} | cannot run here ({n_unavailable}) | | | | |")
            continue
        note = f" ({n_timeouts} verifier time-out)" if n_timeouts else ""
        lines.append(
            f"| **all** | {planner} | {n_solved}/{n_problems} | {n_verified}/{n_solved}{note} | | | |"
        )
    compared = comparison(rows, ours_name)
    if compared:
        lines += [
            "",
            f"{ours_name} against each planner, on the problems both ran: coverage; over the problems",
            f"both solved, the geometric mean of {ours_name}'s plan length over the other's, both totals,",
            "and both median seconds to the first plan.",
            "",
            f"| planner | problems | {ours_name} solved | it solved | both | length ratio (geomean) "
            f"| {ours_name} total length | its total length | {ours_name} median s | its median s |",
            "|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|",
        ]
        for c in compared:
            ratio = "—" if c["length_geomean"] is None else f"{c['length_geomean']:.3f}"
            ours_s = "—" if c["ours_median_s"] is None else f"{c['ours_median_s']:.3f}"
            its_s = "—" if c["median_s"] is None else f"{c['median_s']:.3f}"
            lines.append(
                f"| {c['planner']} | {c['problems']} | {c['ours_solved']} | {c['solved']} | {c['both']} "
                f"| {ratio} | {c['ours_total_length']} | {c['total_length']} | {ours_s} | {its_s} |"
            )
        count, medians = all_solved_times(rows)
        if count:
            each = ", ".join(f"{p} {s:.3f} s" for p, s in medians.items())
            lines += [
                "",
                f"Median seconds to the first plan on the {count} problems every planner solved: {each}.",
            ]
    return "\n".join(lines) + "\n"


def write(path: Path, rows: Sequence[dict[str, Any]]) -> None:
    """Replace ``path`` with the rows, atomically (an interrupted run keeps the last complete file)."""
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = path.with_name(path.name + ".tmp")
    tmp.write_text(json.dumps(list(rows), indent=1) + "\n")
    tmp.replace(path)


def earlier_rows(path: Path, timeout: float) -> tuple[list[dict[str, Any]], int]:
    """The rows of an earlier run with the same limit, to resume from (and how many of
    another limit were dropped); none when the file is missing or not a list of rows."""
    try:
        rows = json.loads(path.read_text())
    except (OSError, ValueError):
        return [], 0
    if not isinstance(rows, list):
        return [], 0
    fit = [
        r
        for r in rows
        if isinstance(r, dict)
        and {"domain", "problem", "planner", "solved", "seconds"} <= r.keys()
        and r.get("timeout") == timeout
    ]
    return fit, len(rows) - len(fit)


def positive(text: str) -> float:
    value = float(text)
    if not value > 0:
        raise argparse.ArgumentTypeError(f"must be more than 0, not {text}")
    return value


def at_least_one(text: str) -> int:
    value = int(text)
    if value < 1:
        raise argparse.ArgumentTypeError(f"must be at least 1, not {text}")
    return value


def positions(text: str) -> tuple[int, ...]:
    """``--also 6,10``: 1-based positions in a domain's problems."""
    try:
        picked = tuple(int(part) for part in text.split(",") if part.strip())
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected positions like 6,10, not {text!r}") from None
    if not picked or min(picked) < 1:
        raise argparse.ArgumentTypeError(f"positions count from 1, not {text!r}")
    return picked


def peer_names(text: str) -> tuple[str, ...]:
    """``--peers panda,hypertension``: known names, each once, in the order given."""
    names: list[str] = []
    for part in text.split(","):
        name = part.strip().lower()
        if not name:
            continue
        if name not in PEERS:
            raise argparse.ArgumentTypeError(f"no peer {part.strip()!r} (known: {', '.join(PEERS)})")
        if name not in names:
            names.append(name)
    if not names:
        raise argparse.ArgumentTypeError(f"name at least one peer ({', '.join(PEERS)})")
    return tuple(names)


def parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(prog=PROG, description=__doc__, formatter_class=argparse.RawTextHelpFormatter)
    p.add_argument("--suite", type=Path, required=True, help="the folder of IPC domains (../shared/data/ipc)")
    p.add_argument("--timeout", type=positive, default=60.0, help="seconds a problem, each planner (60)")
    p.add_argument(
        "--peers",
        type=peer_names,
        nargs="?",
        const=("aries",),
        default=(),
        metavar="NAME,...",
        help=f"also these planners ({', '.join(PEERS)}); alone: aries",
    )
    p.add_argument("--peers-only", action="store_true", help="only the peers (to refresh their figures)")
    p.add_argument(
        "--anchors",
        type=Path,
        default=None,
        help=f"the anchors' wrappers plan-NAME (default $HTN_ANCHORS, else {DEFAULT_ANCHORS})",
    )
    p.add_argument("--domains", default=None, help="NAME,... (folder names; default all)")
    p.add_argument("--problems", type=at_least_one, default=None, help="the first N problems of each domain")
    p.add_argument(
        "--also",
        type=positions,
        default=(),
        metavar="I,...",
        help="these positions (6,10), besides the first --problems N",
    )
    p.add_argument("--search", default=None, help="our planner's search strategy (--search NAME)")
    p.add_argument(
        "--first-plan",
        action="store_true",
        help="our planner without --anytime: its first plan counts (planner htnagent-first)",
    )
    p.add_argument(
        "--verifier",
        type=Path,
        default=None,
        help=f"hddl-verify (default $HDDL_VERIFY, else {DEFAULT_VERIFIER})",
    )
    p.add_argument(
        "--verify-timeout",
        type=positive,
        default=VERIFY_TIMEOUT_S,
        help=f"seconds the verifier may take on one plan ({VERIFY_TIMEOUT_S:g})",
    )
    p.add_argument("--out", type=Path, default=RESULTS / "ipc.json", help="the rows (bench/results/ipc.json)")
    p.add_argument("--fresh", action="store_true", help="start over: ignore the rows already in --out")
    p.add_argument("--grace", type=float, default=GRACE_S, help=argparse.SUPPRESS)
    p.add_argument("--planner-cmd", default=None, help=argparse.SUPPRESS)  # tests: a stand-in planner
    p.add_argument("--peer-cmd", default=None, help=argparse.SUPPRESS)  # tests: a stand-in peer
    return p


def _verifier(option: Path | None) -> Path | None:
    """The verifier's path, or None (said on stderr) when it is not there."""
    chosen = option or Path(os.environ.get("HDDL_VERIFY") or DEFAULT_VERIFIER)
    if chosen.is_file() and os.access(chosen, os.X_OK):
        return chosen
    print(
        f"{PROG}: warning: no verifier at {chosen} (--verifier or HDDL_VERIFY): "
        "plans will NOT be verified (valid = null)",
        file=sys.stderr,
    )
    return None


def compiled() -> None:
    """htnagent's bytecode written once, as installing a wheel writes it: with
    ``PYTHONDONTWRITEBYTECODE`` set, every attempt would otherwise compile the planner
    again (a tenth of a second each time, counted in its start)."""
    import compileall

    compileall.compile_dir(ROOT / "htnagent", quiet=1)


def main(argv: Sequence[str] | None = None) -> int:
    p = parser()
    args = p.parse_args(argv)
    peers: tuple[str, ...] = args.peers or (("aries",) if args.peers_only else ())
    anchors = args.anchors or Path(os.environ.get("HTN_ANCHORS") or DEFAULT_ANCHORS)
    try:
        domains = [d.strip() for d in args.domains.split(",") if d.strip()] if args.domains else None
        problems = suite_problems(args.suite, domains, args.problems, args.also)
        if "aries" in peers and args.peer_cmd is None:
            missing = [m for m in ("unified_planning", "up_aries") if importlib.util.find_spec(m) is None]
            if missing:
                raise UsageError(
                    f"--peers aries needs {', '.join(missing)}: pip install -e '.[peers]' (the peers extra)"
                )
    except UsageError as e:
        print(f"{PROG}: error: {e}", file=sys.stderr)
        return 2
    checker = Checker(_verifier(args.verifier), args.verify_timeout)
    ours_name = "htnagent" + (f"-{args.search}" if args.search else "")
    ours_name += "-first" if args.first_plan else ""
    planners = ([] if args.peers_only else [ours_name]) + list(peers)
    rows, dropped = ([], 0) if args.fresh else earlier_rows(args.out, args.timeout)
    done = {(r["domain"], r["problem"], r["planner"]) for r in rows if _ran(r)}
    rows = [r for r in rows if _ran(r)]  # an anchor that could not run is tried again
    todo = sum(1 for q in problems for name in planners if (q.domain, q.name, name) not in done)
    print(
        f"{len(problems)} problems, {args.timeout:g} s each, {', '.join(planners)}; rows to {args.out}"
        + (f"; resuming: {len(rows)} rows kept, {todo} attempts to go" if rows else "")
        + (f"; {dropped} rows of another limit dropped" if dropped else ""),
        file=sys.stderr,
    )
    write(args.out, rows)  # this run's file from the start, even if it is stopped before a row
    if args.planner_cmd is None and not args.peers_only:
        compiled()
    try:
        for i, problem in enumerate(problems, 1):
            for planner in planners:
                if (problem.domain, problem.name, planner) in done:
                    continue
                if planner == "aries":
                    argv_peer = peer_command(args.peer_cmd, problem, args.timeout, "aries")
                    row = peer(problem, planner, argv_peer, args.timeout, checker, args.grace)
                elif planner in ANCHORS:
                    row = anchor(problem, planner, anchors, args.timeout, checker, args.grace)
                else:
                    argv_ours = our_command(
                        args.planner_cmd, problem, args.timeout, args.search, not args.first_plan
                    )
                    row = ours(problem, planner, argv_ours, args.timeout, checker, args.grace)
                rows.append(row)
                write(args.out, rows)
                verdict = {True: "valid", False: "INVALID", None: "not verified"}[row["valid"]]
                status = (
                    f"solved in {row['seconds']:.2f} s, {row['plan_length']} actions, {verdict}"
                    if row["solved"]
                    else f"not solved ({row['reason']}) after {row['seconds']:.2f} s"
                )
                where = f"[{i}/{len(problems)}] {problem.domain}/{problem.name}"
                print(f"{where} {planner}: {status}", file=sys.stderr)
    except KeyboardInterrupt:
        print(f"{PROG}: interrupted; {len(rows)} rows kept in {args.out}", file=sys.stderr)
        args.out.with_suffix(".md").write_text(markdown(rows, args.timeout, machine_line(), ours_name))
        return 130
    table = markdown(rows, args.timeout, machine_line(), ours_name)
    args.out.with_suffix(".md").write_text(table)
    print(table, file=sys.stderr)
    return 0
