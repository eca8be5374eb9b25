"""How fast ``plan --hddl`` starts and answers (``python -m bench plan-start``).

A planner is timed from its start: the IPC bench runs ``python -m htnagent plan --hddl``
once a problem, so Python starting and importing is part of every figure.  This runs it
on one small problem (Transport pfile01 of ``../shared/data/ipc`` by default) ``--runs``
times, one at a time, and writes ``bench/results/plan_start.json``: one object,
``{problem, runs, wall_s: {median, min, max}, cpu_s: {median, ...}, loaded, machine,
load}`` -- ``wall_s`` each run's wall clock (start to exit), ``cpu_s`` its user plus
system time (what the run itself cost, whatever else the machine was doing), ``loaded``
which of the heavy modules (pydantic, rich, anyio, matplotlib, yaml, the scenario code)
the command imported (none), ``load`` the machine's one-minute load average before the
runs (the wall clock on a busy machine says more about the others than about us).
"""

from __future__ import annotations

import json
import os
import statistics
import subprocess
import sys
import time
from pathlib import Path
from typing import Any

from bench.ipc import RESULTS, ROOT, compiled, write
from bench.machine import machine_line

DEFAULT = ROOT.parent / "shared" / "data" / "ipc" / "Transport"
HEAVY = ("pydantic", "rich", "anyio", "matplotlib", "yaml", "htnagent.scenario")

_PROBE = """\
import atexit, json, sys
watched = json.loads(sys.argv[1])
loaded = lambda: [m for m in watched if m in sys.modules]
atexit.register(lambda: sys.stderr.write("LOADED " + json.dumps(loaded()) + "\\n"))
sys.argv = ["htnagent", *sys.argv[2:]]
from htnagent.cli.launch import run
run()
"""


def _once(argv: list[str]) -> tuple[float, float]:
    """One run: its wall clock and its CPU time (user plus system, from the kernel)."""
    start = time.perf_counter()
    proc = subprocess.Popen(argv, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, cwd=ROOT)
    _, status, usage = os.wait4(proc.pid, 0)
    wall = time.perf_counter() - start
    proc.returncode = os.waitstatus_to_exitcode(status)
    if proc.returncode != 0:
        raise SystemExit(f"python -m bench plan-start: {' '.join(argv)} exited {proc.returncode}")
    return wall, usage.ru_utime + usage.ru_stime


def _spread(values: list[float]) -> dict[str, float]:
    return {
        "median": round(statistics.median(values), 3),
        "min": round(min(values), 3),
        "max": round(max(values), 3),
    }


def main(folder: Path | None = None, runs: int = 5) -> int:
    folder = folder or DEFAULT
    domain, problem = folder / "domain.hddl", folder / "pfile01.hddl"
    compiled()  # as an installed wheel has it
    plan = ["plan", "--hddl", str(domain), str(problem), "--format", "ipc"]
    load = os.getloadavg()[0]
    times = [_once([sys.executable, "-m", "htnagent", *plan]) for _ in range(runs)]
    probe = subprocess.run(
        [sys.executable, "-c", _PROBE, json.dumps(HEAVY), *plan],
        capture_output=True,
        text=True,
        cwd=ROOT,
        check=True,
    )
    said = [line for line in probe.stderr.splitlines() if line.startswith("LOADED ")]
    result: dict[str, Any] = {
        "problem": f"{folder.name}/{problem.name}",
        "runs": runs,
        "wall_s": _spread([w for w, _ in times]),
        "cpu_s": _spread([c for _, c in times]),
        "loaded": json.loads(said[-1].removeprefix("LOADED ")) if said else None,
        "machine": machine_line(),
        "load": round(load, 2),
    }
    write(RESULTS / "plan_start.json", [result])
    print(json.dumps(result, indent=1), file=sys.stderr)
    return 0
