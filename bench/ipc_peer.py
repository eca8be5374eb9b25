"""One attempt of a peer planner on one HDDL problem, in its own process (``bench/ipc.py`` runs it).

``python -m bench.ipc_peer DOMAIN PROBLEM --timeout S [--planner aries]`` reads the
files with unified-planning (its ``PDDLReader`` reads HDDL too: the ``:htn`` section
makes a ``HierarchicalProblem``) and solves with ``OneshotPlanner(name=...)``, giving
the planner what is left of ``S`` once the files are read.  It prints ``read
SECONDS`` as soon as the files are read (so that the parent, if it has to kill this
process, knows whether it was still reading), then one JSON line: ``status``
(``solved``, ``timeout``, ``unsolvable``, ``refused``, ``unsupported``, ``error``,
...), ``plan_length`` (primitive actions), ``read_s``, ``solve_s``, ``reason`` and
``plan``: the plan in the IPC format (docs/contracts.md "Command line"), written here
from unified-planning's ``HierarchicalPlan`` (by
:func:`htnagent.testing.peer_plans.ipc_plan`), so that the bench verifies it as it
verifies ours.  unified-planning lower-cases what it reads; the names are written
back as the HDDL files spell them.  Exit 0 when a plan was found, 1 otherwise.

Needs the ``peers`` extra (``unified-planning``, ``up-aries``); nothing else in the
project imports it.
"""

from __future__ import annotations

import argparse
import json
import os
import sys
import time
import warnings
from pathlib import Path
from typing import Any

from htnagent.hddl import plan_file
from htnagent.testing.peer_plans import flat_actions, ipc_plan

START = time.perf_counter()


def _emit(**fields: Any) -> None:
    print(json.dumps(fields), flush=True)


def _first_line(e: BaseException) -> str:
    text = str(e).strip().splitlines()
    return f"{type(e).__name__}: {text[0] if text else ''}"[:300]


def spellings(*files: str) -> dict[str, str]:
    """Each name of the files, lower-cased, to its first spelling there."""
    return plan_file.spellings(*(Path(f).read_text(encoding="utf-8-sig") for f in files))


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python -m bench.ipc_peer", description=__doc__)
    parser.add_argument("domain")
    parser.add_argument("problem")
    parser.add_argument("--timeout", type=float, required=True, help="seconds for reading and solving")
    parser.add_argument("--planner", default="aries", help="the unified-planning engine name")
    args = parser.parse_args(argv)
    try:
        from unified_planning.io import PDDLReader
        from unified_planning.shortcuts import OneshotPlanner, get_environment
    except ImportError as e:
        _emit(status="error", reason=f"the peers extra is not installed ({e})")
        return 1
    env = get_environment()
    env.credits_stream = None
    # Barman-BDI names a type and a predicate alike ("ingredient"), which HDDL allows and
    # unified-planning refuses unless told to let different kinds of element share a name.
    env.error_used_name = False
    warnings.simplefilter("ignore")  # (it still warns, on stderr)
    try:
        problem = PDDLReader().parse_problem(args.domain, args.problem)
    except Exception as e:  # unified-planning refuses some IPC files: a row, not a crash
        _emit(status="refused", read_s=round(time.perf_counter() - START, 3), reason=_first_line(e))
        return 1
    read_s = time.perf_counter() - START
    print(f"read {read_s:.3f}", flush=True)
    left = args.timeout - read_s
    if left <= 0:
        _emit(status="timeout", read_s=round(read_s, 3), reason="timeout while reading")
        return 1
    solve_start = time.perf_counter()
    try:
        with open(os.devnull, "w") as quiet, OneshotPlanner(name=args.planner) as planner:
            result = planner.solve(problem, timeout=left, output_stream=quiet)
    except Exception as e:
        _emit(status="error", read_s=round(read_s, 3), reason=_first_line(e))
        return 1
    solve_s = time.perf_counter() - solve_start
    status = result.status.name.lower()
    plan = result.plan
    if plan is not None and status.startswith("solved"):
        actions = flat_actions(plan)
        try:
            text: str | None = ipc_plan(problem, plan, spellings(args.domain, args.problem))
            why = None
        except Exception as e:  # a plan unified-planning gives in a shape not foreseen here
            text, why = None, f"no IPC plan written: {_first_line(e)}"
        _emit(
            status="solved",
            plan_length=len(actions),
            read_s=round(read_s, 3),
            solve_s=round(solve_s, 3),
            reason=why,
            plan=text,
        )
        return 0
    kind = "unsolvable" if status.startswith("unsolvable") else status
    said = [m.message for m in result.log_messages or () if m.message.strip()]
    why = said[0].strip().splitlines()[0][:200] if said else status
    _emit(status=kind, read_s=round(read_s, 3), solve_s=round(solve_s, 3), reason=why)
    return 1


if __name__ == "__main__":
    sys.exit(main())
