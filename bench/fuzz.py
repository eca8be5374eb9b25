"""Hostile inputs through the command line (``python -m bench fuzz [--runs N]``).

Each run makes one bad input -- text forms and YAML nested deep, files over
the size limit, special files (FIFOs, /dev/zero, directories, sockets, symlink
loops), alias bombs, odd encodings (UTF-16/32, BOMs, NUL bytes, latin-1),
scenario and map files mutated at random, domains naming code that must not
run, random bytes -- and runs it through ``check`` and ``run`` (and ``plan``
for the nested tasks).  What counts as a failure:

- a traceback (``Traceback`` on stderr, or an exception escaping ``main``);
- an exit code other than 0, 1 or 2 (a crash, a death by signal);
- no answer within 5 s (a hang, or unbounded work);
- running out of the 1 GB of address space (``RLIMIT_AS``): a MemoryError,
  "ran out of memory", or a kill;
- code that must not run having run (a module in the current folder imported).

Two paths, reported apart in ``bench/results/fuzz.json``:

- ``subprocess``: ``python -m htnagent ...`` in a real process per command,
  with a 5 s timeout and ``RLIMIT_AS`` of 1 GB -- the user's path exactly.
  Every tenth input goes this way, and every input that uses a special file.
- ``in_process``: the other inputs, through :func:`htnagent.cli.commands.main` inside
  long-lived worker processes (also limited to 1 GB, a 5 s alarm per command,
  restarted after a timeout or a memory error).  This is about fifty times
  cheaper than a new interpreter per command, which is what makes 10,000
  inputs affordable on two cores; it exercises the same code minus interpreter
  start-up and signal handling (which ``tests/test_signals.py`` covers).
"""

from __future__ import annotations

import argparse
import contextlib
import io
import json
import os
import resource
import signal
import subprocess
import sys
import tempfile
import threading
import time
import traceback
from collections import Counter
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from htnagent.testing.hostile_inputs import (
    Case,
    Result,
    commands,
    make_case,
    materialized,
    problems,
)

ROOT = Path(__file__).resolve().parent.parent
RESULTS = ROOT / "bench" / "results"

TIMEOUT_S = 5.0
MEMORY_BYTES = 1 << 30
SUBPROCESS_EVERY = 10
WORKERS = 2


# -- running ---------------------------------------------------------------------------------


def _limit_memory() -> None:
    resource.setrlimit(resource.RLIMIT_AS, (MEMORY_BYTES, MEMORY_BYTES))


def run_process(argv: list[str], cwd: Path, env: dict[str, str]) -> Result:
    """``python -m htnagent argv`` in a new process, 5 s and 1 GB at most."""
    with tempfile.TemporaryFile() as out, tempfile.TemporaryFile() as err:
        started = time.monotonic()
        proc = subprocess.Popen(
            [sys.executable, "-m", "htnagent", *argv],
            cwd=cwd,
            stdin=subprocess.DEVNULL,
            stdout=out,
            stderr=err,
            env={**os.environ, **env, "PYTHONPATH": str(ROOT)},
            preexec_fn=_limit_memory,
        )
        timed_out = False
        status, usage = 0, None
        while True:
            pid, status, usage = os.wait4(proc.pid, os.WNOHANG)
            if pid:
                break
            if time.monotonic() - started > TIMEOUT_S:
                timed_out = True
                proc.kill()
                _, status, usage = os.wait4(proc.pid, 0)
                break
            time.sleep(0.005)
        proc.returncode = os.waitstatus_to_exitcode(status)  # reaped here, not by Popen
        seconds = time.monotonic() - started
        out.seek(0)
        err.seek(0)
        stdout = out.read()[-2000:].decode("utf-8", "replace")
        stderr = err.read()[-4000:].decode("utf-8", "replace")
    code = None if timed_out else proc.returncode
    maxrss = usage.ru_maxrss * 1024 if usage is not None else 0
    memory = "MemoryError" in stderr or "ran out of memory" in stderr or maxrss > 0.9 * MEMORY_BYTES
    return Result(code, seconds, stderr, stdout, None, timed_out, memory)


class _Worker:
    """A long-lived process running :func:`htnagent.cli.commands.main` on the commands it is sent."""

    def __init__(self) -> None:
        jobs_r, self._jobs_w = os.pipe()
        self._results_r, results_w = os.pipe()
        self.proc = subprocess.Popen(
            [sys.executable, "-m", "bench.fuzz", "--worker", str(jobs_r), str(results_w)],
            cwd=ROOT,
            stdin=subprocess.DEVNULL,
            stdout=subprocess.DEVNULL,
            stderr=subprocess.DEVNULL,
            pass_fds=(jobs_r, results_w),
            preexec_fn=_limit_memory,
            env={**os.environ, "PYTHONPATH": str(ROOT)},
        )
        os.close(jobs_r)
        os.close(results_w)
        self._jobs = os.fdopen(self._jobs_w, "w", buffering=1)
        self._results = os.fdopen(self._results_r, "r")
        self.jobs = 0

    def ask(self, argv: list[str], cwd: Path, env: dict[str, str]) -> tuple[Result, bool]:
        """The result, and whether the worker must be replaced."""
        started = time.monotonic()
        self.jobs += 1
        answer: list[str] = []
        try:
            self._jobs.write(json.dumps({"argv": argv, "cwd": str(cwd), "env": env}) + "\n")
            reader = threading.Thread(target=lambda: answer.append(self._results.readline()), daemon=True)
            reader.start()
            reader.join(TIMEOUT_S + 10)
        except OSError:
            pass
        seconds = time.monotonic() - started
        if not answer or not answer[0]:
            self.proc.kill()
            self.proc.wait()
            code = self.proc.returncode
            timed_out = not answer
            memory = code in (-signal.SIGKILL, -signal.SIGSEGV) and not timed_out
            return Result(
                None if timed_out else code, seconds, "(worker died)", "", None, timed_out, memory
            ), True
        data = json.loads(answer[0])
        result = Result(**data)
        return result, result.timeout or result.memory

    def close(self) -> None:
        with contextlib.suppress(OSError):
            self._jobs.close()
        try:
            self.proc.wait(10)
        except subprocess.TimeoutExpired:
            self.proc.kill()
            self.proc.wait()
        with contextlib.suppress(OSError):
            self._results.close()


_JOBS_PER_WORKER = 400  # a fresh worker now and then: no heap left fragmented by a big input


class _Timeout(BaseException):
    """The alarm of an in-process command went off."""


def _worker(jobs_fd: int, results_fd: int) -> None:
    from htnagent.cli.commands import main

    jobs = os.fdopen(jobs_fd, "r")
    results = os.fdopen(results_fd, "w", buffering=1)

    def alarm(signum: int, frame: object) -> None:
        raise _Timeout

    signal.signal(signal.SIGALRM, alarm)
    for line in jobs:
        job = json.loads(line)
        out, err = io.StringIO(), io.StringIO()
        saved_env = {k: os.environ.get(k) for k in job["env"]}
        os.environ.update(job["env"])
        cwd = os.getcwd()
        os.chdir(job["cwd"])
        code: int | None = None
        tb: str | None = None
        timed_out = memory = False
        started = time.monotonic()
        signal.setitimer(signal.ITIMER_REAL, TIMEOUT_S)
        try:
            with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
                code = main(job["argv"])
        except _Timeout:
            timed_out = True
        except BaseException as e:  # whatever escapes main is a failure to report
            tb = "".join(traceback.format_exception(e))
            memory = isinstance(e, MemoryError) or "MemoryError" in tb
            timed_out = "_Timeout" in tb
        finally:
            signal.setitimer(signal.ITIMER_REAL, 0)
            os.chdir(cwd)
            for k, v in saved_env.items():
                if v is None:
                    os.environ.pop(k, None)
                else:
                    os.environ[k] = v
        stderr = err.getvalue()[-4000:]
        memory = memory or "MemoryError" in stderr or "ran out of memory" in stderr
        # User code turns even the alarm into an error line: look for it there too.
        timed_out = timed_out or "_Timeout" in stderr
        result = Result(
            code, time.monotonic() - started, stderr, out.getvalue()[-2000:], tb, timed_out, memory
        )
        results.write(json.dumps(result.__dict__) + "\n")


@dataclass
class Tally:
    inputs: int = 0
    executions: int = 0
    tracebacks: int = 0
    timeouts: int = 0
    over_memory: int = 0
    bad_exit: int = 0
    code_ran: int = 0
    max_seconds: float = 0.0
    exit_codes: Counter[str] = field(default_factory=Counter)

    def add(self, result: Result) -> list[str]:
        self.executions += 1
        self.max_seconds = max(self.max_seconds, result.seconds)
        self.exit_codes[str(result.code)] += 1
        found = problems(result)
        self.tracebacks += "traceback" in found
        self.timeouts += "timeout" in found
        self.over_memory += "over_memory" in found
        self.bad_exit += "bad_exit" in found
        return found

    def as_dict(self) -> dict[str, Any]:
        out = {k: v for k, v in self.__dict__.items() if k != "exit_codes"}
        out["max_seconds"] = round(self.max_seconds, 3)
        out["exit_codes"] = dict(sorted(self.exit_codes.items()))
        return out


def run_cases(
    runs: int, *, seed: int = 0, subprocess_every: int = SUBPROCESS_EVERY, progress: bool = True
) -> dict[str, Any]:
    """Make and run ``runs`` inputs; return the report written to fuzz.json."""
    tallies = {"subprocess": Tally(), "in_process": Tally()}
    kinds: Counter[str] = Counter()
    examples: list[dict[str, Any]] = []
    samples: dict[str, dict[str, Any]] = {}
    lock = threading.Lock()
    workers: list[_Worker | None] = [None] * WORKERS
    started = time.monotonic()
    done = 0

    def one(index: int) -> None:
        nonlocal done
        case = make_case(index, seed)
        slot = index % WORKERS
        path = "subprocess" if case.special or index % subprocess_every == 0 else "in_process"
        with (
            tempfile.TemporaryDirectory(prefix="htnagent-fuzz-") as parent,
            materialized(case, Path(parent)) as folder,
        ):
            outcomes = []
            for argv in commands(case, folder):
                if path == "subprocess":
                    result = run_process(argv, folder, case.env)
                else:
                    worker = workers[slot] or _Worker()
                    workers[slot] = worker
                    result, replace = worker.ask(argv, folder, case.env)
                    if replace or worker.jobs >= _JOBS_PER_WORKER:
                        worker.close()
                        workers[slot] = None
                outcomes.append((argv, result))
            ran = case.marker is not None and (folder / case.marker).exists()
        with lock:
            kinds[case.kind] += 1
            tally = tallies[path]
            tally.inputs += 1
            tally.code_ran += ran
            for argv, result in outcomes:
                found = tally.add(result) + (["code_ran"] if ran else [])
                if found and len(examples) < 30:
                    examples.append(_example(index, case, path, argv, result, found))
                if case.kind not in samples and not found:
                    samples[case.kind] = _example(index, case, path, argv, result, found)
            done += 1
            if progress and (done % max(20, runs // 50) == 0 or done == runs):
                bad = sum(
                    t.tracebacks + t.timeouts + t.over_memory + t.bad_exit + t.code_ran
                    for t in tallies.values()
                )
                rate = done / (time.monotonic() - started)
                print(
                    f"fuzz: {done}/{runs} inputs, {bad} problems, {rate:.1f} inputs/s",
                    file=sys.stderr,
                    flush=True,
                )

    # Inputs go two at a time, one per worker slot, so that a slot's worker is never shared.
    with ThreadPoolExecutor(WORKERS) as pool:
        for batch in range(0, runs, WORKERS):
            list(pool.map(one, range(batch, min(runs, batch + WORKERS))))
    for worker in workers:
        if worker is not None:
            worker.close()
    total = Tally()
    for t in tallies.values():
        for key in ("inputs", "executions", "tracebacks", "timeouts", "over_memory", "bad_exit", "code_ran"):
            setattr(total, key, getattr(total, key) + getattr(t, key))
        total.max_seconds = max(total.max_seconds, t.max_seconds)
        total.exit_codes.update(t.exit_codes)
    headline = total.as_dict()
    return {
        "runs": runs,
        "tracebacks": headline["tracebacks"],
        "timeouts": headline["timeouts"],
        "over_memory": headline["over_memory"],
        "bad_exit": headline["bad_exit"],
        "max_seconds": headline["max_seconds"],
        "code_ran": headline["code_ran"],
        "executions": headline["executions"],
        "exit_codes": headline["exit_codes"],
        "through": {name: t.as_dict() for name, t in tallies.items()},
        "how": (
            f"each input through check and run --json (and plan --task for nested tasks); "
            f"'subprocess': python -m htnagent in a new process per command (every {subprocess_every}th "
            "input and every special file); 'in_process': htnagent.cli.commands.main in long-lived worker "
            "processes; both with a 5 s timeout and RLIMIT_AS of 1 GB"
        ),
        "limits": {"timeout_s": TIMEOUT_S, "memory_bytes": MEMORY_BYTES, "seed": seed},
        "kinds": dict(sorted(kinds.items())),
        "seconds": round(time.monotonic() - started, 1),
        "examples": examples,
        "samples": [samples[k] for k in sorted(samples)],
    }


def _example(
    index: int, case: Case, path: str, argv: list[str], result: Result, found: list[str]
) -> dict[str, Any]:
    preview = {name: content[:120].decode("utf-8", "replace") for name, content in case.files.items()}
    return {
        "input": index,
        "kind": case.kind,
        "through": path,
        "command": [argv[0], Path(argv[1]).name[:60], *(a[:60] for a in argv[2:])],
        "code": result.code,
        "seconds": round(result.seconds, 3),
        "problems": found,
        "stderr": (result.traceback or result.stderr)[-600:],
        "files": preview,
        "specials": case.specials,
    }


def main(
    runs: int, *, results: Path = RESULTS, seed: int = 0, subprocess_every: int = SUBPROCESS_EVERY
) -> int:
    """Run ``runs`` hostile inputs; write ``results``/fuzz.json; 0 if none went wrong, else 1."""
    report = run_cases(runs, seed=seed, subprocess_every=subprocess_every)
    results.mkdir(parents=True, exist_ok=True)
    (results / "fuzz.json").write_text(json.dumps(report, indent=2, ensure_ascii=False) + "\n")
    bad = sum(report[k] for k in ("tracebacks", "timeouts", "over_memory", "bad_exit", "code_ran"))
    print(
        f"fuzz: {runs} inputs, {report['executions']} commands: {report['tracebacks']} tracebacks, "
        f"{report['timeouts']} timeouts, {report['over_memory']} over memory, "
        f"{report['bad_exit']} bad exits, "
        f"{report['code_ran']} with code run that must not; slowest {report['max_seconds']} s",
        file=sys.stderr,
    )
    return 0 if bad == 0 else 1


def cli(argv: list[str]) -> int:
    """``python -m bench fuzz [--runs N] [--seed S] [--subprocess-every K] [--out DIR]``."""
    parser = argparse.ArgumentParser(prog="python -m bench fuzz", description=__doc__.split("\n\n")[0])
    parser.add_argument("--runs", type=int, default=1000, help="hostile inputs to make and run (1000)")
    parser.add_argument("--seed", type=int, default=0, help="the same seed, the same inputs (0)")
    parser.add_argument(
        "--subprocess-every",
        type=int,
        default=SUBPROCESS_EVERY,
        help=f"every K-th input through a new process, the rest through workers ({SUBPROCESS_EVERY})",
    )
    parser.add_argument("--out", type=Path, default=RESULTS, help="fuzz.json's folder (bench/results)")
    args = parser.parse_args(argv)
    if args.runs < 1 or args.subprocess_every < 1:
        parser.error("--runs and --subprocess-every must be at least 1")
    return main(args.runs, results=args.out, seed=args.seed, subprocess_every=args.subprocess_every)


if __name__ == "__main__" and len(sys.argv) == 4 and sys.argv[1] == "--worker":
    _worker(int(sys.argv[2]), int(sys.argv[3]))
