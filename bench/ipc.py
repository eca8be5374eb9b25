"""The IPC total-order HTN benchmarks, solved and verified (``python -m bench ipc --suite DIR``).

Each domain folder of the suite (one with a ``domain.hddl``) gives its problems:
the other ``.hddl`` files beside it, in natural order (``p2`` before ``p10``);
subfolders (``other/``, further instances) and folders without a ``domain.hddl``
(the feature tests) are not benchmark problems.  One attempt at a time -- never
two side by side, so that timings are fair -- each in its own process group:

- our planner, ``python -m htnagent plan --hddl DOMAIN PROBLEM --format ipc
  --timeout S [--search NAME]`` (docs/contracts.md "Command line"); its plan is
  written to a temporary file and checked by the IPC verifier (``hddl-verify``);
- with ``--peers``, the Aries planner through unified-planning
  (``python -m bench.ipc_peer``, the ``peers`` extra) on the same problem, under
  the same limit, right after ours.

The limit ``S`` is the wall clock of the whole attempt, from starting the process
to its end (Python's start, reading the files, planning).  A process still running
at ``S`` plus a grace of a few seconds (so that a planner may say ``timeout``
itself) is killed with its whole process group; an answer that comes after ``S``
counts as a timeout.

Rows (``bench/results/ipc.json``, rewritten after every attempt so that an
interrupted run keeps what it measured; Ctrl-C kills the attempt under way and
exits 130): ``{domain, problem, planner, solved, seconds, plan_length, valid,
reason, timeout, read_s}`` -- ``solved`` a plan came back in
time; ``valid`` the verifier's verdict on it, the peers' plans too (``null``: not
verified -- the verifier is missing or gave no verdict); ``reason`` why not solved
(``timeout``, ``unsolvable``, ``budget``, ``refused by unified-planning: ...``), or
why not valid; ``timeout`` the limit; ``read_s`` (peers) the seconds
before unified-planning had read the files (its import included), part of ``seconds``.
``bench/results/ipc.md``: per domain and planner, problems solved, plans verified,
median seconds and median plan length of the solved ones.
"""

from __future__ import annotations

import argparse
import contextlib
import importlib.util
import json
import os
import re
import shlex
import signal
import statistics
import subprocess
import sys
import tempfile
import time
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from bench.machine import machine_line

ROOT = Path(__file__).resolve().parent.parent
RESULTS = ROOT / "bench" / "results"
DEFAULT_VERIFIER = ROOT.parent / "shared" / "tools" / "hddl-verify" / "hddl-verify"
"""``../shared/tools/hddl-verify/hddl-verify`` from the repository root; ``--verifier`` or
the environment variable ``HDDL_VERIFY`` name another."""

GRACE_S = 5.0
"""How long past the limit a process may run (to report ``timeout`` itself) before it is killed."""

VERIFY_TIMEOUT_S = 900.0
"""The verifier's own limit (its first call builds it: about 50 s)."""

PROG = "python -m bench ipc"


class UsageError(Exception):
    """A bad option or suite: one line on stderr, exit 2."""


@dataclass(frozen=True)
class Problem:
    domain: str
    domain_file: Path
    problem_file: Path

    @property
    def name(self) -> str:
        return self.problem_file.name


@dataclass
class Outcome:
    """What a process did: exit code (None: killed at the limit), seconds, its output."""

    code: int | None
    seconds: float
    stdout: str
    stderr: str


def natural_key(name: str) -> list[Any]:
    """``p2`` before ``p10``: digits compared as numbers."""
    return [int(part) if part.isdigit() else part.lower() for part in re.split(r"(\d+)", name)]


def find_problems(
    suite: Path, domains: Sequence[str] | None = None, first: int | None = None
) -> list[Problem]:
    """The suite's benchmark problems, by domain (natural order), ``first`` of each at most."""
    if not suite.exists():
        raise UsageError(f"--suite {suite}: no such folder")
    if not suite.is_dir():
        raise UsageError(f"--suite {suite}: not a folder")
    folders = sorted(
        (p for p in suite.iterdir() if p.is_dir() and (p / "domain.hddl").is_file()),
        key=lambda p: natural_key(p.name),
    )
    if not folders:
        raise UsageError(f"--suite {suite}: no domain folders (a folder with a domain.hddl) in it")
    if domains:
        known = {p.name.casefold(): p for p in folders}
        unknown = [d for d in domains if d.casefold() not in known]
        if unknown:
            raise UsageError(
                f"--domains: no domain {', '.join(unknown)} in {suite} "
                f"(there: {', '.join(p.name for p in folders)})"
            )
        folders = [known[d.casefold()] for d in domains]
    found: list[Problem] = []
    for folder in folders:
        domain_file = folder / "domain.hddl"
        files = sorted(
            (f for f in folder.glob("*.hddl") if f.is_file() and f.name != "domain.hddl"),
            key=lambda f: natural_key(f.name),
        )
        found += [Problem(folder.name, domain_file, f) for f in files[:first]]
    return found


def run_process(argv: Sequence[str], limit: float, grace: float = GRACE_S) -> Outcome:
    """Run ``argv`` in a new process group; kill the group at ``limit + grace`` seconds."""
    with tempfile.TemporaryFile("w+") as out, tempfile.TemporaryFile("w+") as err:
        start = time.perf_counter()
        proc = subprocess.Popen(
            list(argv),
            stdout=out,
            stderr=err,
            stdin=subprocess.DEVNULL,
            cwd=ROOT,  # python -m bench.ipc_peer is found from the repository root
            start_new_session=True,
        )
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
        out.seek(0)
        err.seek(0)
        return Outcome(code, seconds, out.read(), err.read())


def plan_block(text: str) -> str | None:
    """The plan between the lines ``==>`` and ``<==`` (both kept), or None."""
    lines = text.splitlines()
    starts = [i for i, line in enumerate(lines) if line.strip() == "==>"]
    if not starts:
        return None
    for j in range(starts[0] + 1, len(lines)):
        if lines[j].strip() == "<==":
            return "\n".join(lines[starts[0] : j + 1]) + "\n"
    return None


def plan_length(block: str) -> int:
    """Primitive actions: the ``ID name arg...`` lines before ``root``."""
    count = 0
    for line in block.splitlines()[1:]:
        words = line.split()
        if not words or words[0] == "<==" or words[0] == "root":
            break
        if words[0].isdigit():
            count += 1
    return count


def last_line(text: str) -> str:
    lines = [line.strip() for line in text.splitlines() if line.strip()]
    return lines[-1][:300] if lines else ""


def verify(verifier: Path, problem: Problem, block: str) -> tuple[bool | None, str | None]:
    """The verifier's verdict on the plan: ``(True, None)``, ``(False, why)`` or ``(None, why)``."""
    with tempfile.NamedTemporaryFile("w", suffix=".plan", delete=False) as f:
        f.write(block)
        plan_file = f.name
    try:
        done = subprocess.run(
            [str(verifier), str(problem.domain_file), str(problem.problem_file), plan_file],
            capture_output=True,
            text=True,
            timeout=VERIFY_TIMEOUT_S,
            stdin=subprocess.DEVNULL,
        )
    except subprocess.TimeoutExpired:
        return None, f"verifier: no verdict in {VERIFY_TIMEOUT_S:.0f} s"
    except OSError as e:
        return None, f"verifier: cannot run {verifier}: {e.strerror}"
    finally:
        os.unlink(plan_file)
    verdict = last_line(done.stdout) or last_line(done.stderr)
    if done.returncode == 0:
        return True, None
    if done.returncode == 1:
        return False, f"verifier: {verdict}"
    return None, f"verifier: {verdict or f'exit {done.returncode}'}"


def our_command(template: str | None, problem: Problem, timeout: float, search: str | None) -> list[str]:
    """Our planner's command line (``--planner-cmd`` replaces it: ``{domain}``, ``{problem}``,
    ``{timeout}``, ``{python}`` filled in)."""
    if template is not None:
        return [
            word.format(
                domain=problem.domain_file,
                problem=problem.problem_file,
                timeout=f"{timeout:g}",
                python=sys.executable,
            )
            for word in shlex.split(template)
        ]
    argv = [sys.executable, "-m", "htnagent", "plan", "--hddl", str(problem.domain_file)]
    argv += [str(problem.problem_file), "--format", "ipc", "--timeout", f"{timeout:g}"]
    if search:
        argv += ["--search", search]
    return argv


def ours(
    problem: Problem,
    planner: str,
    argv: Sequence[str],
    timeout: float,
    verifier: Path | None,
    grace: float = GRACE_S,
) -> dict[str, Any]:
    """One attempt of our planner: its row."""
    done = run_process(argv, timeout, grace)
    row = _row(problem, planner, done.seconds, timeout)
    if done.code is None:
        row["reason"] = "timeout"
    elif done.code == 0:
        block = plan_block(done.stdout)
        if block is None:
            row["reason"] = "exit 0 but no plan between ==> and <== on stdout"
        elif done.seconds > timeout:
            row["reason"] = "timeout"  # an answer after the limit does not count
        else:
            row["solved"] = True
            row["plan_length"] = plan_length(block)
            if verifier is None:
                row["reason"] = "not verified: no verifier"
            else:
                row["valid"], row["reason"] = verify(verifier, problem, block)
    elif done.code == 1:
        row["reason"] = last_line(done.stderr) or "exit 1"
    elif done.code == 2:
        row["reason"] = f"invalid input: {last_line(done.stderr)}"
    else:
        row["reason"] = f"exit {done.code}: {last_line(done.stderr)}"
    return row


def peer_command(template: str | None, problem: Problem, timeout: float, name: str) -> list[str]:
    if template is not None:
        return [
            word.format(
                domain=problem.domain_file,
                problem=problem.problem_file,
                timeout=f"{timeout:g}",
                python=sys.executable,
            )
            for word in shlex.split(template)
        ]
    argv = [sys.executable, "-m", "bench.ipc_peer", str(problem.domain_file), str(problem.problem_file)]
    return [*argv, "--timeout", f"{timeout:g}", "--planner", name]


def peer(
    problem: Problem,
    planner: str,
    argv: Sequence[str],
    timeout: float,
    verifier: Path | None,
    grace: float = GRACE_S,
) -> dict[str, Any]:
    """One attempt of a peer through ``bench.ipc_peer``: its row, its plan verified as ours are."""
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
        row["plan_length"] = report.get("plan_length")
        block = plan_block(report.get("plan") or "")
        if block is None:
            row["reason"] = f"not verified: {report.get('reason') or 'no IPC plan'}"
        elif verifier is None:
            row["reason"] = "not verified: no verifier"
        else:
            row["valid"], row["reason"] = verify(verifier, problem, block)
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
    }


def summary(rows: Sequence[dict[str, Any]]) -> list[dict[str, Any]]:
    """Per domain and planner: problems, solved, verified, median seconds and plan length (solved ones)."""
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
                "solved": len(solved),
                "verified": sum(1 for r in solved if r["valid"] is True),
                "invalid": sum(1 for r in solved if r["valid"] is False),
                "median_s": round(statistics.median(r["seconds"] for r in solved), 2) if solved else None,
                "median_length": statistics.median(lengths) if lengths else None,
            }
        )
    return out


def markdown(rows: Sequence[dict[str, Any]], timeout: float, machine: str) -> str:
    """The README's table: one line per domain and planner."""
    lines = [
        f"IPC 2020 total-order problems, {timeout:g} s a problem, one at a time; {machine}.",
        "",
        "| domain | planner | solved | verified | median s | median plan length |",
        "|---|---|---:|---:|---:|---:|",
    ]
    for s in summary(rows):
        verified = f"{s['verified']}/{s['solved']}"
        if s["invalid"]:
            verified += f" ({s['invalid']} invalid)"
        median_s = "—" if s["median_s"] is None else f"{s['median_s']:.2f}"
        median_len = "—" if s["median_length"] is None else f"{s['median_length']:g}"
        lines.append(
            f"| {s['domain']} | {s['planner']} | {s['solved']}/{s['problems']} | {verified} "
            f"| {median_s} | {median_len} |"
        )
    totals: dict[str, list[int]] = {}
    for s in summary(rows):
        t = totals.setdefault(s["planner"], [0, 0, 0])
        t[0] += s["solved"]
        t[1] += s["problems"]
        t[2] += s["verified"]
    for planner, (n_solved, n_problems, n_verified) in totals.items():
        lines.append(f"| **all** | {planner} | {n_solved}/{n_problems} | {n_verified}/{n_solved} | | |")
    return "\n".join(lines) + "\n"


def write(path: Path, rows: Sequence[dict[str, Any]]) -> None:
    """Replace ``path`` with the rows, atomically (an interrupted run keeps the last complete file)."""
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = path.with_name(path.name + ".tmp")
    tmp.write_text(json.dumps(list(rows), indent=1) + "\n")
    tmp.replace(path)


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


def parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(prog=PROG, description=__doc__, formatter_class=argparse.RawTextHelpFormatter)
    p.add_argument("--suite", type=Path, required=True, help="the folder of IPC domains (../shared/data/ipc)")
    p.add_argument("--timeout", type=positive, default=60.0, help="seconds a problem, each planner (60)")
    p.add_argument("--peers", action="store_true", help="also the Aries planner (the peers extra)")
    p.add_argument("--peers-only", action="store_true", help="only the peers (to refresh their figures)")
    p.add_argument("--domains", default=None, help="NAME,... (folder names; default all)")
    p.add_argument("--problems", type=at_least_one, default=None, help="the first N problems of each domain")
    p.add_argument("--search", default=None, help="our planner's search strategy (--search NAME)")
    p.add_argument(
        "--verifier",
        type=Path,
        default=None,
        help=f"hddl-verify (default $HDDL_VERIFY, else {DEFAULT_VERIFIER})",
    )
    p.add_argument("--out", type=Path, default=RESULTS / "ipc.json", help="the rows (bench/results/ipc.json)")
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


def main(argv: Sequence[str] | None = None) -> int:
    p = parser()
    args = p.parse_args(argv)
    try:
        domains = [d.strip() for d in args.domains.split(",") if d.strip()] if args.domains else None
        problems = find_problems(args.suite, domains, args.problems)
        with_peers = args.peers or args.peers_only
        if with_peers and args.peer_cmd is None:
            missing = [m for m in ("unified_planning", "up_aries") if importlib.util.find_spec(m) is None]
            if missing:
                raise UsageError(
                    f"--peers needs {', '.join(missing)}: pip install -e '.[peers]' (the peers extra)"
                )
    except UsageError as e:
        print(f"{PROG}: error: {e}", file=sys.stderr)
        return 2
    verifier = _verifier(args.verifier)
    ours_name = f"htnagent-{args.search}" if args.search else "htnagent"
    rows: list[dict[str, Any]] = []
    print(
        f"{len(problems)} problems, {args.timeout:g} s each"
        + (", with Aries" if with_peers else "")
        + f"; rows to {args.out}",
        file=sys.stderr,
    )
    write(args.out, rows)  # this run's file from the start, even if it is stopped before a row
    try:
        for i, problem in enumerate(problems, 1):
            for planner in ([] if args.peers_only else [ours_name]) + (["aries"] if with_peers else []):
                if planner == "aries":
                    argv_peer = peer_command(args.peer_cmd, problem, args.timeout, "aries")
                    row = peer(problem, planner, argv_peer, args.timeout, verifier, args.grace)
                else:
                    argv_ours = our_command(args.planner_cmd, problem, args.timeout, args.search)
                    row = ours(problem, planner, argv_ours, args.timeout, verifier, args.grace)
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
        args.out.with_suffix(".md").write_text(markdown(rows, args.timeout, machine_line()))
        return 130
    table = markdown(rows, args.timeout, machine_line())
    args.out.with_suffix(".md").write_text(table)
    print(table, file=sys.stderr)
    return 0
