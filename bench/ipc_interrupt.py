"""Emergencies on the IPC domains (``python -m bench ipc-interrupt --suite DIR``).

For each problem of the suite (found as ``python -m bench ipc`` finds them:
:func:`bench.ipc.find_problems`), one agent plans on the HDDL domain and executes
on the simulated HDDL robot (docs/design.md §7.1), in both replanning modes:

1. **Solved?** ``htnagent.planning.hddl_solving.solve`` on the whole problem within
   ``--timeout`` seconds (default 20).  A problem it does not solve is skipped.
2. **The goals.** The problem's initial task network ``t1 … tn`` (in its order)
   is split: ``t1 … tn-1`` are the agent's normal goals, each one scenario goal,
   given at time 0 in that order (the agent's FIFO list of waiting goals carries
   them out one after the other, Algorithm 4 -- the scenario format has one task
   per goal, and no HDDL task of the domain stands for several); ``tn`` is the
   emergency.  A network of one task, or one whose tasks are not ground (it
   names ``:htn :parameters``), is skipped (looked at before step 1: no solve
   is spent on it).  The problem's ``:goal`` is not
   checked (the scenario's goals are tasks; the IPC validity of plans is
   ``python -m bench ipc``'s business).
3. **Where it strikes.** A dry run of the agent on ``t1 … tn-1`` alone (on-line
   mode, no emergency) gives the plan of the others as executed: its actions
   (the translation's ``__done`` markers left out).  Fewer than 4 actions: the
   problem is skipped.  Otherwise the emergency arrives half way through the
   action at index ``len // 2`` (``when: {action: A, progress: 0.5}``, as in
   ``scenarios/courier_hddl.yaml``) -- the first action from there on that
   does not occur earlier in the plan, since a trigger fires on the first
   occurrence of its action.  Both modes get this one trigger (the same point
   of interruption); should a mode's run not do that action, the emergency is
   never given and the row fails with that reason.
4. **Suspension.** Every action of the domain that
   :func:`htnagent.planning.hddl_translation.unsuspendable` accepts is declared suspendable
   (``agents[].suspendable``): the acting action is stopped half way, has had no
   effect, and the resumed goal may ``resume`` it (or drop it).
5. **Both modes**, on-line then naive, each one warm-up run and ``--runs``
   measured runs (default 5; medians reported), each run measured by
   :func:`bench.measure.measure_run` like the museum benchmark: ``resume_ms`` is
   the wall clock from the emergency goal's end to the agent's first order to
   the robot after it (the resumed goal's first action: re-using or re-making
   its plans, clearing what will not be resumed); ``planning_ms`` the agent's
   own count of planning and plan keeping over the whole run; ``cost`` the
   actions carried out with success (``__done`` markers and ``rollback`` left
   out; a suspended action that is resumed counts once, by its ``resume``);
   ``success`` every goal succeeded; ``beliefs_match`` the agent's belief,
   without the translation's own facts, equalled the simulated world after
   every action (as ``tests/test_hddl_agents.py`` checks it).

Each step (1–3 together, then each mode) is one process, one at a time, killed
with its process group past its wall-clock limit: ``--timeout`` plus
``--run-timeout`` (default 60 s) for steps 1–3, ``--run-timeout`` for each mode
(all its runs).
A killed or failed run is a row with ``success: false`` and its ``reason``.
Progress is one line per problem on stderr.

Rows (``bench/results/ipc_interrupt.json``, rewritten after every problem):
``{domain, problem, mode, resume_ms, planning_ms, cost, success}`` (docs/contracts.md)
plus ``beliefs_match``, ``reason``, ``runs``, ``actions`` (the plan of the others' length),
``emergency``, ``trigger``, ``timeout``.  A skipped problem is one row with
``mode: null``, ``success: null`` and its ``reason``.  ``ipc_interrupt.md``: per
domain, runs in each mode, successes, the medians of ``resume_ms`` and
``planning_ms`` and their naive / on-line ratios, and the costs compared.
"""

from __future__ import annotations

import argparse
import functools
import json
import statistics
import sys
from collections.abc import Sequence
from pathlib import Path
from typing import Any

from bench.ipc import GRACE_S, Problem, UsageError, at_least_one, find_problems, positive, run_process, write
from bench.machine import machine_line

ROOT = Path(__file__).resolve().parent.parent
RESULTS = ROOT / "bench" / "results"
PROG = "python -m bench ipc-interrupt"
MIN_ACTIONS = 4
"""The plan of the others must have at least this many actions for an emergency half way."""
MODES = ("online", "naive")
AGENT = "agent"


# -- one problem, in the worker process ------------------------------------------------------------


def scenario_data(
    problem: Problem,
    goals: Sequence[str],
    suspendable: Sequence[str],
    emergency: str | None = None,
    trigger: str | None = None,
) -> dict[str, Any]:
    """The scenario (as parsed YAML): one agent on the problem's HDDL files, by absolute path."""
    data: dict[str, Any] = {
        "name": f"ipc-interrupt {problem.domain} {problem.name}",
        "robot": {},
        "agents": [
            {
                "name": AGENT,
                "domain": {
                    "hddl": str(problem.domain_file.resolve()),
                    "problem": str(problem.problem_file.resolve()),
                },
                "executor": "robot",
                "suspendable": list(suspendable),
            }
        ],
        "goals": [{"agent": AGENT, "task": g} for g in goals],
    }
    if emergency is not None:
        goal: dict[str, Any] = {"agent": AGENT, "task": emergency, "emergency": True}
        if trigger is not None:
            goal["when"] = {"action": trigger, "progress": 0.5}
        data["goals"].append(goal)
    return data


def prepare(problem: Problem, timeout: float) -> dict[str, Any]:
    """Steps 1–3: ``{skip: reason}`` or ``{goals, emergency, trigger, suspendable, actions}``."""
    from htnagent.errors import HtnAgentError
    from htnagent.hddl.reader import read_domain, read_problem
    from htnagent.planning.hddl_solving import solve
    from htnagent.planning.hddl_translation import unsuspendable

    try:
        domain = read_domain(problem.domain_file)
        hddl = read_problem(problem.problem_file, domain)
    except HtnAgentError as e:
        return {"skip": f"not read: {e}"}
    # The network's shape first: it costs nothing to look at, a solve up to ``timeout``.
    tasks = [s.call for s in hddl.htn]
    if len(tasks) < 2:
        return {"skip": f"the initial task network has {len(tasks)} task(s): no other goal to interrupt"}
    if not all(t.is_ground for t in tasks):
        return {"skip": "the initial task network's tasks are not ground (:htn :parameters)"}
    solved = solve(domain, hddl, timeout=timeout)
    if solved.result.best is None:
        return {"skip": f"not solved by hddl_domain.solve in {timeout:g} s"}
    suspendable = [name for name in domain.actions if unsuspendable(domain, name) is None]
    goals = [str(t) for t in tasks[:-1]]
    dry = run_agent(problem, scenario_data(problem, goals, suspendable), "online")
    if not dry["success"]:
        return {"skip": f"the agent fails the other tasks without an emergency: {dry['reason']}"}
    actions: list[str] = dry["executed"]
    if len(actions) < MIN_ACTIONS:
        return {"skip": f"the plan of the others has {len(actions)} action(s), fewer than {MIN_ACTIONS}"}
    half = len(actions) // 2
    trigger = next((a for i, a in enumerate(actions) if i >= half and a not in actions[:i]), actions[half])
    return {
        "goals": goals,
        "emergency": str(tasks[-1]),
        "trigger": trigger,
        "suspendable": suspendable,
        "actions": len(actions),
    }


def run_agent(problem: Problem, data: dict[str, Any], mode: str) -> dict[str, Any]:
    """One run of the scenario in ``mode``: ``{resume_ms, planning_ms, cost, success, beliefs_match,
    reason, executed}``."""
    import anyio

    from bench.measure import RunFigures, measure_run
    from htnagent.executors.hddl_robot import HddlRobot
    from htnagent.model.actions import ROLLBACK, action_recovered_by
    from htnagent.model.terms import parse
    from htnagent.runtime.events import ActionFinished, Summary, TraceEvent
    from htnagent.scenario import parse_scenario
    from htnagent.system.runtime import Runtime
    from htnagent.system.simulation import run_scenario

    scenario = parse_scenario(data, str(problem.problem_file), problem.problem_file.parent)
    runtimes: list[Runtime] = []
    executed: list[str] = []
    mismatches: list[str] = []
    failures: list[str] = []

    def observe(event: TraceEvent) -> None:
        if isinstance(event, Summary):  # every goal's end, one never given too
            failures.extend(f"{g.goal}: {g.reason}"[:300] for g in event.goals if g.status != "success")
        if not isinstance(event, ActionFinished) or event.result != "success":
            return
        action = parse(event.action)
        if action.name == ROLLBACK or action.name.startswith("__"):
            return
        done = action_recovered_by(action)
        executed.append(str(done if done is not None else action))
        robot = runtimes[0].bottom_executor
        if isinstance(robot, HddlRobot) and not mismatches:
            world = robot.world.facts()
            for name, agent in runtimes[0].agents.items():
                belief = frozenset(f for f in agent.belief.facts() if not f.name.startswith("__"))
                if belief != world:
                    mismatches.append(f"{name} after {event.action}: {sorted(map(str, belief ^ world))[:5]}")

    if any(g.emergency for g in scenario.goals):
        figures = anyio.run(
            functools.partial(measure_run, scenario, mode, observers=[observe], on_start=runtimes.append)
        )
    else:  # the dry run of the others: nothing to resume
        report = anyio.run(
            functools.partial(
                run_scenario, scenario, replanning=mode, observers=[observe], on_start=runtimes.append
            )
        )
        figures = RunFigures(planning_ms=sum(report.summary.planning_ms.values()), succeeded=report.succeeded)
    reason = "; ".join(failures) or (mismatches[0] if mismatches else None)
    return {
        "resume_ms": None if figures.parent_ms is None else round(figures.parent_ms, 4),
        "planning_ms": round(figures.planning_ms, 4),
        "cost": len(executed),
        "success": figures.succeeded,
        "beliefs_match": not mismatches,
        "reason": reason,
        "executed": executed,
    }


def combine(runs: Sequence[dict[str, Any]]) -> dict[str, Any]:
    """One warm-up run (``runs[0]``, like the museum benchmark's) and the measured ones: the
    medians of ``resume_ms`` and ``planning_ms``, the measured runs' largest ``cost``; success
    and matching beliefs only if every run, the warm-up too, had them."""
    measured = runs[1:] or runs
    resumes = [r["resume_ms"] for r in measured if r["resume_ms"] is not None]
    return {
        "resume_ms": round(statistics.median(resumes), 4) if resumes else None,
        "planning_ms": round(statistics.median(r["planning_ms"] for r in measured), 4),
        "cost": max(r["cost"] for r in measured),
        "success": all(r["success"] for r in runs),
        "beliefs_match": all(r["beliefs_match"] for r in runs),
        "reason": next((r["reason"] for r in runs if r["reason"]), None),
        "runs": len(measured),
    }


def worker(argv: Sequence[str]) -> int:
    """``--worker prepare D P TIMEOUT`` or ``--worker MODE D P PLAN.json``: one JSON line on stdout."""
    stage, domain_file, problem_file, extra = argv
    problem = Problem(Path(problem_file).parent.name, Path(domain_file), Path(problem_file))
    if stage == "prepare":
        out = prepare(problem, float(extra))
    else:
        plan = json.loads(extra)
        data = scenario_data(problem, plan["goals"], plan["suspendable"], plan["emergency"], plan["trigger"])
        out = combine([run_agent(problem, data, stage) for _ in range(plan["runs"] + 1)])
    print(json.dumps(out))
    return 0


# -- the benchmark, in the parent process ----------------------------------------------------------


def _call(
    problem: Problem, stage: str, extra: str, limit: float, grace: float
) -> tuple[dict[str, Any] | None, str]:
    argv = [sys.executable, "-m", "bench.ipc_interrupt", "--worker", stage]
    argv += [str(problem.domain_file), str(problem.problem_file), extra]
    outcome = run_process(argv, limit, grace)
    if outcome.code is None:
        return None, f"killed at the wall-clock limit of {limit:g} s"
    lines = [line for line in outcome.stdout.splitlines() if line.startswith("{")]
    if outcome.code != 0 or not lines:
        tail = [line for line in outcome.stderr.splitlines() if line.strip()]
        return None, f"exit {outcome.code}: {tail[-1][:300] if tail else 'no output'}"
    result: dict[str, Any] = json.loads(lines[-1])
    return result, ""


def _row(problem: Problem, mode: str | None, timeout: float, **fields: Any) -> dict[str, Any]:
    row: dict[str, Any] = {
        "domain": problem.domain,
        "problem": problem.name,
        "mode": mode,
        "resume_ms": None,
        "planning_ms": None,
        "cost": None,
        "success": None if mode is None else False,
        "beliefs_match": None,
        "reason": None,
        "timeout": timeout,
    }
    row.update(fields)
    return row


def bench_problem(
    problem: Problem, timeout: float, run_timeout: float, grace: float = GRACE_S, runs: int = 5
) -> list[dict[str, Any]]:
    """The rows of one problem: one skipped row, or one per mode."""
    plan, why = _call(problem, "prepare", f"{timeout:g}", timeout + run_timeout, grace)
    if plan is None:
        return [_row(problem, None, timeout, reason=f"preparing: {why}")]
    if "skip" in plan:
        return [_row(problem, None, timeout, reason=plan["skip"])]
    about = {"actions": plan["actions"], "emergency": plan["emergency"], "trigger": plan["trigger"]}
    rows = []
    for mode in MODES:
        got, why = _call(problem, mode, json.dumps({**plan, "runs": runs}), run_timeout, grace)
        rows.append(_row(problem, mode, timeout, **about, **(got or {"reason": why})))
    return rows


def _median(values: Sequence[float]) -> float | None:
    return statistics.median(values) if values else None


def _ms(value: float | None) -> str:
    return "—" if value is None else f"{value:.2f}"


def markdown(rows: Sequence[dict[str, Any]], timeout: float, run_timeout: float, machine: str) -> str:
    """Per domain: runs, successes, medians of resume and planning time, costs compared."""
    out = [
        "# Emergencies on the IPC domains (`python -m bench ipc-interrupt`)",
        "",
        "The last task of each problem's network arrives as an emergency half way through the plan of "
        f"the others; solve limit {timeout:g} s, {run_timeout:g} s a mode. Resume and planning ms (wall "
        "clock; each a problem's median of its measured runs) are medians over the problems where "
        "both modes succeeded, as is the cost comparison; beliefs are counted over the runs that "
        f"ended (one killed at its limit compared nothing). Machine: {machine}.",
        "",
        "| domain | problems | skipped | succeeded on-line | succeeded naive | on-line resume ms "
        "| naive resume ms | naive / on-line | on-line planning ms | naive planning ms "
        "| cost on-line ≤ naive | beliefs match |",
        "|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---|",
    ]
    domains: dict[str, list[dict[str, Any]]] = {}
    for row in rows:
        domains.setdefault(row["domain"], []).append(row)
    for domain, found in domains.items():
        problems = sorted({r["problem"] for r in found})
        skipped = sum(1 for r in found if r["mode"] is None)
        pairs = []
        for name in problems:
            by_mode = {r["mode"]: r for r in found if r["problem"] == name and r["mode"] is not None}
            if all(m in by_mode and by_mode[m]["success"] for m in MODES):
                pairs.append(by_mode)
        on = _median([p["online"]["resume_ms"] for p in pairs if p["online"]["resume_ms"] is not None])
        nv = _median([p["naive"]["resume_ms"] for p in pairs if p["naive"]["resume_ms"] is not None])
        ratio = f"{nv / on:.1f}×" if on and nv is not None else "—"
        plan_on = _median([p["online"]["planning_ms"] for p in pairs])
        plan_nv = _median([p["naive"]["planning_ms"] for p in pairs])
        cheaper = sum(1 for p in pairs if p["online"]["cost"] <= p["naive"]["cost"])
        runs = [r for r in found if r["mode"] is not None]
        # A run killed at its time limit compared nothing: it is not counted here.
        checked = [r for r in runs if r["beliefs_match"] is not None]
        matched = sum(1 for r in checked if r["beliefs_match"])
        ran = len(problems) - skipped
        won = {m: sum(1 for r in runs if r["mode"] == m and r["success"]) for m in MODES}
        out.append(
            f"| {domain} | {len(problems)} | {skipped} | {won['online']}/{ran} | {won['naive']}/{ran} "
            f"| {_ms(on)} | {_ms(nv)} | {ratio} "
            f"| {_ms(plan_on)} | {_ms(plan_nv)} | {cheaper}/{len(pairs)} | {matched}/{len(checked)} runs |"
        )
    out += ["", "Skipped problems and failed runs:", ""]
    for row in rows:
        if row["mode"] is None or not row["success"]:
            mode = row["mode"] or "skipped"
            out.append(f"- {row['domain']}/{row['problem']} ({mode}): {row['reason']}")
    out.append("")
    return "\n".join(out)


def parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(prog=PROG, description=__doc__, formatter_class=argparse.RawTextHelpFormatter)
    p.add_argument("--suite", type=Path, required=True, help="the folder of IPC domains (../shared/data/ipc)")
    p.add_argument("--timeout", type=positive, default=20.0, help="seconds to solve a problem (20)")
    p.add_argument(
        "--run-timeout", type=positive, default=60.0, help="wall-clock seconds an agent's run (60)"
    )
    p.add_argument(
        "--runs",
        type=at_least_one,
        default=5,
        help="measured runs a mode, after one warm-up run (5; medians)",
    )
    p.add_argument("--domains", default=None, help="NAME,... (folder names; default all)")
    p.add_argument("--problems", type=at_least_one, default=None, help="the first N problems of each domain")
    p.add_argument(
        "--out",
        type=Path,
        default=RESULTS / "ipc_interrupt.json",
        help="the rows (bench/results/ipc_interrupt.json)",
    )
    p.add_argument("--grace", type=float, default=GRACE_S, help=argparse.SUPPRESS)
    return p


def _status(rows: Sequence[dict[str, Any]]) -> str:
    if rows[0]["mode"] is None:
        return f"skipped: {rows[0]['reason']}"
    parts = []
    for r in rows:
        if r["success"]:
            parts.append(f"{r['mode']} resume {_ms(r['resume_ms'])} ms, cost {r['cost']}")
        else:
            parts.append(f"{r['mode']} FAILED ({r['reason']})")
    return f"{rows[0]['actions']} actions, emergency {rows[0]['emergency']}: " + "; ".join(parts)


def main(argv: Sequence[str] | None = None) -> int:
    args_in = list(sys.argv[1:] if argv is None else argv)
    if args_in[:1] == ["--worker"]:
        return worker(args_in[1:])
    args = parser().parse_args(args_in)
    try:
        domains = [d.strip() for d in args.domains.split(",") if d.strip()] if args.domains else None
        problems = find_problems(args.suite, domains, args.problems)
    except UsageError as e:
        print(f"{PROG}: error: {e}", file=sys.stderr)
        return 2
    rows: list[dict[str, Any]] = []
    print(f"{len(problems)} problems; rows to {args.out}", file=sys.stderr)
    write(args.out, rows)
    md = args.out.with_suffix(".md")
    try:
        for i, problem in enumerate(problems, 1):
            found = bench_problem(problem, args.timeout, args.run_timeout, args.grace, args.runs)
            rows += found
            write(args.out, rows)
            print(f"[{i}/{len(problems)}] {problem.domain}/{problem.name}: {_status(found)}", file=sys.stderr)
    except KeyboardInterrupt:
        print(f"{PROG}: interrupted; {len(rows)} rows kept in {args.out}", file=sys.stderr)
        md.write_text(markdown(rows, args.timeout, args.run_timeout, machine_line()))
        return 130
    table = markdown(rows, args.timeout, args.run_timeout, machine_line())
    md.write_text(table)
    print(table, file=sys.stderr)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
