"""Emergencies on the IPC domains (``python -m bench ipc-interrupt --suite DIR``).

For each problem of the suite (found as ``python -m bench ipc`` finds them:
:func:`htnagent.testing.hddl_inputs.find_problems`), one agent plans on the HDDL domain and executes
on the simulated HDDL robot (docs/design.md §7.1), in both replanning modes:

1. **Solved?** ``htnagent.planning.hddl_solving.solve`` on the whole problem within
   ``--timeout`` seconds (default 20).  A problem it does not solve is skipped, as is one
   whose plan has more than ``--max-actions`` actions (default 2,000): the most a run of
   this bench carries out within its limits (Towers' largest problems are a million).
2. **The goal** is the problem's own network, one goal (scenario ``tasks: problem``,
   docs/design.md §4): its tasks in order, its ``:goal`` checked at the end, planned as
   one by the search that solved it in step 1 (depth-first or greedy best-first), within
   ``max(1,000,000, 2 × its expansions)`` expansions.  Networks of one task are run too.
3. **The emergency**, chosen from the problem by
   :func:`htnagent.testing.emergencies.choose_interruption` (its docstring and
   docs/benchmarks.md say how; no list per domain): it arrives half way
   (``when: {action: A, progress: 0.5}``) through the action half way along the agent's
   plan; a task of the domain (a compound task, or one of its actions where none will
   do), grounded with the problem's objects, whose plan from there breaks what the
   agent keeps of the rest, after which the agent still has a plan for the network --
   or, where no candidate does, the one whose plan changes the most facts while it leaves
   the network finishable (``emergency_kind: most changes``; the table says so), or,
   where every candidate leaves it unfinishable, the one that changes the most
   (``not mended``: the network cannot be finished after it, and the table says so).
4. **Suspension.** Every action of the domain that
   :func:`htnagent.planning.hddl_translation.unsuspendable` accepts is declared suspendable
   (``agents[].suspendable``): the acting action is stopped half way, has had no
   effect, and the resumed goal may ``resume`` it (or drop it).
5. **Both modes**, in one process: a warm-up run of each, then ``--runs`` rounds
   (default 5; medians reported), on-line then naive in each, so that whatever else
   the machine does weighs on both alike; each run measured by
   :func:`bench.measure.measure_run` like the museum benchmark: ``replan_ms`` the agent's
   own replanning when the network resumes (its ``goal_resumed`` replan_ms, the paper's
   measure); ``resume_ms`` the window, the wall clock from the emergency goal's end to the
   agent's first order to the robot after it; ``planning_ms`` the agent's
   own count of planning and plan keeping over the whole run, ``planning_cpu_ms`` its
   CPU time (which the machine's other work does not add to); ``cost`` the
   actions carried out with success (``__done`` markers and ``rollback`` left
   out; a suspended action that is resumed counts once, by its ``resume``);
   ``success`` every goal succeeded; ``beliefs_match`` the agent's belief,
   without the translation's own facts, equalled the simulated world after
   every action (as ``tests/test_hddl_agents.py`` checks it).  Naive mode plans the
   whole network again from the belief at resumption: where the domain's methods cannot
   do again a task already done, it fails, and the row's reason says so.

Each step (1–3 together, then the runs of step 5) is one process, one at a time,
killed with its process group past its wall-clock limit: ``--timeout`` plus
``--run-timeout`` (default 60 s) for steps 1–3, ``--run-timeout`` a mode (twice it)
for the runs.  Cut short, the mode that took the time (its runs' seconds, and what was
left of the limit for the one going on) is a row with ``success: false`` and its
``reason``; the other keeps the runs it finished (``runs``).
Problems are taken round robin over the domains (each domain's first, then each one's
second, ...), so that a run stopped part way has rows of every domain; progress is one line
per problem on stderr.

Rows (``bench/results/ipc_interrupt.json``, rewritten after every problem; a run given
the same ``--out`` again keeps the rows of the problems already done there and goes on):
``{domain, problem, mode, resume_ms, replan_ms, planning_ms, cost, success}``
(docs/contracts.md) plus ``beliefs_match``, ``reason``, ``runs``, ``actions`` (the plan's),
``emergency``, ``emergency_kind`` (``breaks``, ``most changes`` or ``not mended``), ``changed`` (facts its
plan changes), ``trigger``, ``search``, ``timeout``.  A skipped problem is one row with
``mode: null``, ``success: null`` and its ``reason``.  ``ipc_interrupt.md``: per
domain, runs in each mode, successes, the medians of ``replan_ms``, the window and
``planning_ms`` and their naive / on-line ratios, and the costs compared.
"""

from __future__ import annotations

import argparse
import functools
import itertools
import json
import statistics
import sys
import time
from collections.abc import Sequence
from pathlib import Path
from typing import Any

from bench.ipc import GRACE_S, UsageError, at_least_one, positive, run_process, suite_problems, write
from bench.machine import machine_line
from htnagent.planning.hddl_solving import HDDL_BUDGET
from htnagent.testing.hddl_inputs import SuiteProblem as Problem

ROOT = Path(__file__).resolve().parent.parent
RESULTS = ROOT / "bench" / "results"
PROG = "python -m bench ipc-interrupt"
MAX_ACTIONS = 2_000
"""The most actions a problem's plan may have to be run (``--max-actions``)."""
AGENT_BUDGET = 1_000_000
"""The fewest expansions the agent's planner is given (twice what the solve took, if more)."""
MODES = ("online", "naive")
AGENT = "agent"


# -- one problem, in the worker process ------------------------------------------------------------


def scenario_data(
    problem: Problem,
    suspendable: Sequence[str],
    search: str,
    budget: int,
    emergency: str | None = None,
    trigger: str | None = None,
) -> dict[str, Any]:
    """The scenario (as parsed YAML): one agent on the problem's HDDL files, by absolute path,
    whose goal is the problem's network; the emergency at ``trigger`` if given."""
    data: dict[str, Any] = {
        "name": f"ipc-interrupt {problem.domain} {problem.name}",
        "robot": {},
        "planner": {"search": search, "budget": budget},
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
        "goals": [{"agent": AGENT, "tasks": "problem"}],
    }
    if emergency is not None:
        goal: dict[str, Any] = {"agent": AGENT, "task": emergency, "emergency": True}
        if trigger is not None:
            goal["when"] = {"action": trigger, "progress": 0.5}
        data["goals"].append(goal)
    return data


def prepare(problem: Problem, timeout: float, max_actions: int = MAX_ACTIONS) -> dict[str, Any]:
    """Steps 1–3: ``{skip: reason}`` or ``{emergency, emergency_kind, changed, trigger,
    suspendable, search, budget, actions}``."""
    from htnagent.errors import HtnAgentError
    from htnagent.hddl.reader import read_domain, read_problem
    from htnagent.planning.hddl_solving import solve
    from htnagent.planning.hddl_translation import unsuspendable
    from htnagent.planning.planner import plan
    from htnagent.scenario import parse_scenario
    from htnagent.testing.emergencies import choose_interruption, is_marker
    from htnagent.upkeep.repair import one_plan

    try:
        domain = read_domain(problem.domain_file)
        hddl = read_problem(problem.problem_file, domain)
    except HtnAgentError as e:
        return {"skip": f"not read: {e}"}
    solved = solve(domain, hddl, timeout=timeout)
    best = solved.result.best
    if best is None:
        return {"skip": f"not solved as a network by hddl_solving.solve in {timeout:g} s"}
    length = sum(1 for s in best.steps if not is_marker(s.action))
    if length > max_actions:
        return {
            "skip": f"its plan has {length:,} actions, more than the {max_actions:,} a run of this bench "
            "carries out (--max-actions)"
        }
    suspendable = [name for name in domain.actions if unsuspendable(domain, name) is None]
    # The search that answered, the grounded one told by its guide: the agent plans the same way.
    search = "grounded" if solved.settings.guide is not None else solved.search.value
    budget = min(HDDL_BUDGET, max(AGENT_BUDGET, 2 * solved.result.expansions))
    scenario = parse_scenario(
        scenario_data(problem, suspendable, search, budget),
        str(problem.problem_file),
        problem.problem_file.parent,
    )
    agent_domain = scenario.domain_for(AGENT)
    state = scenario.initial_state(AGENT)
    goal = scenario.goal_task(0)
    # The agent's first plan, as it makes it (one plan, its search and budget).
    settings = scenario.settings_for(AGENT)
    first = plan(agent_domain, state, [goal], one_plan(settings))
    if first.best is None:
        return {"skip": f"the agent's {search} search finds no plan for the network: {first.status.value}"}
    actions = sum(1 for s in first.best.steps if not is_marker(s.action))
    if actions < 1:
        return {"skip": "the agent's plan has no action: nothing to interrupt"}
    chosen = choose_interruption(agent_domain, state, goal, first.best, domain, hddl, settings)
    if chosen.emergency is None:
        return {
            "skip": f"no task of the domain ({chosen.tried} tried) has a plan that changes a fact half way"
        }
    return {
        "emergency": str(chosen.emergency),
        "emergency_kind": "breaks" if chosen.breaks else "most changes" if chosen.solvable else "not mended",
        "changed": chosen.changed,
        "tried": chosen.tried,
        "trigger": str(chosen.trigger),
        "suspendable": suspendable,
        "search": search,
        "budget": budget,
        "actions": actions,
    }


def run_agent(problem: Problem, data: dict[str, Any], mode: str) -> dict[str, Any]:
    """One run of the scenario in ``mode``: ``{resume_ms, replan_ms, planning_ms, cost, success,
    beliefs_match, reason, executed}``."""
    import anyio

    from bench.measure import measure_run
    from htnagent.model.actions import ROLLBACK, action_recovered_by
    from htnagent.model.terms import parse
    from htnagent.runtime.events import ActionFinished, Summary, TraceEvent
    from htnagent.scenario import parse_scenario
    from htnagent.system.runtime import Runtime
    from htnagent.testing.invariants import hddl_belief_differences

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
        if not mismatches:
            mismatches.extend(
                f"after {event.action}, {d[:200]}" for d in hddl_belief_differences(runtimes[0])
            )

    figures = anyio.run(
        functools.partial(measure_run, scenario, mode, observers=[observe], on_start=runtimes.append)
    )
    reason = "; ".join(failures) or (mismatches[0] if mismatches else None)
    if reason is not None and mode == "naive" and figures.parent_replan_ms is not None:
        reason = f"{reason} (naive plans the whole network again from the belief at resumption)"
    return {
        "resume_ms": None if figures.parent_ms is None else round(figures.parent_ms, 4),
        "replan_ms": None if figures.replan_ms is None else round(figures.replan_ms, 4),
        "planning_ms": round(figures.planning_ms, 4),
        "planning_cpu_ms": round(figures.planning_cpu_ms, 4),
        "cost": len(executed),
        "success": figures.succeeded,
        "beliefs_match": not mismatches,
        "reason": reason,
        "executed": executed,
    }


def combine(runs: Sequence[dict[str, Any]]) -> dict[str, Any]:
    """One warm-up run (``runs[0]``, like the museum benchmark's) and the measured ones: the
    medians of ``replan_ms``, ``resume_ms``, ``planning_ms`` and ``planning_cpu_ms``, the
    measured runs' largest ``cost``; success and matching beliefs only if every run, the
    warm-up too, had them."""
    measured = runs[1:] or runs

    def median(key: str) -> float | None:
        values = [r[key] for r in measured if r[key] is not None]
        return round(statistics.median(values), 4) if values else None

    return {
        "resume_ms": median("resume_ms"),
        "replan_ms": median("replan_ms"),
        "planning_ms": median("planning_ms"),
        "planning_cpu_ms": median("planning_cpu_ms"),
        "cost": max(r["cost"] for r in measured),
        "success": all(r["success"] for r in runs),
        "beliefs_match": all(r["beliefs_match"] for r in runs),
        "reason": next((r["reason"] for r in runs if r["reason"]), None),
        "runs": len(measured),
    }


def worker(argv: Sequence[str]) -> int:
    """``--worker prepare D P TIMEOUT MAX_ACTIONS``: one JSON line on stdout.
    ``--worker runs D P PLAN.json``: one JSON line a run, as it ends: a warm-up run of
    each mode, then ``runs`` rounds, the modes in turn within each (whatever else the
    machine does then weighs on both alike)."""
    stage, domain_file, problem_file, *extra = argv
    problem = Problem(Path(problem_file).parent.name, Path(domain_file), Path(problem_file))
    if stage == "prepare":
        print(json.dumps(prepare(problem, float(extra[0]), int(extra[1]))))
        return 0
    plan = json.loads(extra[0])
    data = scenario_data(
        problem, plan["suspendable"], plan["search"], plan["budget"], plan["emergency"], plan["trigger"]
    )
    for run in range(plan["runs"] + 1):
        for mode in MODES:
            started = time.perf_counter()
            got = run_agent(problem, data, mode)
            seconds = round(time.perf_counter() - started, 3)
            print(json.dumps({"mode": mode, "run": run, "seconds": seconds, **got}), flush=True)
    return 0


# -- the benchmark, in the parent process ----------------------------------------------------------


def _call(
    problem: Problem, stage: str, extra: Sequence[str], limit: float, grace: float
) -> tuple[list[dict[str, Any]], str]:
    """The worker's JSON lines (those printed before a kill too), and why it stopped short
    ("" if it ended well)."""
    argv = [sys.executable, "-m", "bench.ipc_interrupt", "--worker", stage]
    argv += [str(problem.domain_file), str(problem.problem_file), *extra]
    outcome = run_process(argv, limit, grace)
    got = [json.loads(line) for line in outcome.stdout.splitlines() if line.startswith("{")]
    if outcome.code is None:
        return got, f"killed at the wall-clock limit of {limit:g} s"
    if outcome.code != 0 or not got:
        tail = [line for line in outcome.stderr.splitlines() if line.strip()]
        return got, f"exit {outcome.code}: {tail[-1][:300] if tail else 'no output'}"
    return got, ""


def _row(problem: Problem, mode: str | None, timeout: float, **fields: Any) -> dict[str, Any]:
    row: dict[str, Any] = {
        "domain": problem.domain,
        "problem": problem.name,
        "mode": mode,
        "resume_ms": None,
        "replan_ms": None,
        "planning_ms": None,
        "planning_cpu_ms": None,
        "cost": None,
        "success": None if mode is None else False,
        "beliefs_match": None,
        "reason": None,
        "timeout": timeout,
    }
    row.update(fields)
    return row


def bench_problem(
    problem: Problem,
    timeout: float,
    run_timeout: float,
    grace: float = GRACE_S,
    runs: int = 5,
    max_actions: int = MAX_ACTIONS,
) -> list[dict[str, Any]]:
    """The rows of one problem: one skipped row, or one per mode."""
    extra = [f"{timeout:g}", str(max_actions)]
    prepared, why = _call(problem, "prepare", extra, timeout + run_timeout, grace)
    if why:
        return [_row(problem, None, timeout, reason=f"preparing: {why}")]
    plan = prepared[-1]
    if "skip" in plan:
        return [_row(problem, None, timeout, reason=plan["skip"])]
    keys = ("actions", "emergency", "emergency_kind", "changed", "trigger", "search")
    about = {k: plan[k] for k in keys}
    limit = run_timeout * len(MODES)
    got, why = _call(problem, "runs", [json.dumps({**plan, "runs": runs})], limit, grace)
    # Stopped short, the mode that took the time failed -- its finished runs plus the one
    # going on (what was left of the limit) -- not merely the one whose run was going on;
    # the other keeps the runs it finished (``runs`` says how many were measured).
    spent = {m: sum(g.get("seconds", 0.0) for g in got if g["mode"] == m) for m in MODES}
    running = MODES[len(got) % len(MODES)]
    spent[running] += max(0.0, limit - sum(spent.values()))
    slow = max(MODES, key=lambda m: spent[m])
    rows = []
    for mode in MODES:
        mine = [g for g in got if g["mode"] == mode]
        if mine and (not why or mode != slow):
            rows.append(_row(problem, mode, timeout, **about, **combine(mine)))
        else:
            rows.append(_row(problem, mode, timeout, **about, reason=why or "no run ended"))
    return rows


def _median(values: Sequence[float]) -> float | None:
    return statistics.median(values) if values else None


def _ms(value: float | None) -> str:
    return "—" if value is None else f"{value:.2f}"


def _ratio(naive: float | None, online: float | None) -> float | None:
    if naive is None or online is None:
        return None
    return naive / online if online > 0 else float("inf")


TARGET = 10.0
"""The median naive / on-line ``replan_ms`` asked for in every domain."""


def markdown(
    rows: Sequence[dict[str, Any]],
    timeout: float,
    run_timeout: float,
    machine: str,
    max_actions: int = MAX_ACTIONS,
    not_run: int = 0,
) -> str:
    """Per domain: runs, successes, medians of replanning, window and planning time, costs compared."""
    out = [
        "# Emergencies on the IPC domains (`python -m bench ipc-interrupt`)",
        "",
        "Each problem's own task network is one goal (`tasks: problem`); an emergency task of the "
        "domain, chosen from the problem (docs/benchmarks.md), arrives half way through its plan. "
        f"Limits: solve {timeout:g} s, {run_timeout:g} s a mode's runs (both modes in one process, "
        "in turn), plans of at most "
        f"{max_actions:,} actions. `replan_ms` is the agent's own replanning when the network "
        "resumes (the paper's measure), the window the wall clock from the emergency's end to the "
        "resumed goal's first order; each a problem's median of its measured runs, then the median "
        "over the problems where both modes resumed the network (replan; naive's counts a resumption "
        "where it found no plan for the network too; window where an order followed) or both "
        "succeeded (planning, cost). Planning CPU: each problem's on-line / naive CPU time of the "
        "whole run's planning and plan keeping, the median over the problems both modes solved, "
        "and the largest. "
        f"Target: naive / on-line `replan_ms` ≥ {TARGET:g}× in every domain. "
        "Beliefs are counted over the runs that ended (one killed at its limit compared nothing). "
        f"Machine: {machine}.",
        "",
        "| domain | problems | skipped | emergency breaks the rest | succeeded on-line "
        "| succeeded naive | on-line replan ms | naive replan ms | naive / on-line | target "
        "| on-line window ms | naive window ms | on-line planning ms | naive planning ms "
        "| planning CPU on-line / naive | largest (problem) | cost on-line ≤ naive "
        "| total cost on-line / naive | beliefs match |",
        "|---|---:|---:|---:|---:|---:|---:|---:|---:|---|---:|---:|---:|---:|---:|---|---:|---:|---|",
    ]
    counts = sorted({r["runs"] for r in rows if r.get("runs")})
    if counts:
        measured = ", ".join(map(str, counts))
        out[2] += f" Measured runs a mode, after a warm-up run of each, the modes in turn: {measured}."
    if not_run:
        out[2] += (
            f" **{not_run} problems of the suite were not run** (the run was stopped part way; "
            "problems are taken round robin over the domains)."
        )
    domains: dict[str, list[dict[str, Any]]] = {}
    for row in rows:
        domains.setdefault(row["domain"], []).append(row)
    for domain, found in domains.items():
        problems = sorted({r["problem"] for r in found})
        skipped = sum(1 for r in found if r["mode"] is None)
        both_ok, resumed = [], []
        for name in problems:
            by_mode = {r["mode"]: r for r in found if r["problem"] == name and r["mode"] is not None}
            if all(m in by_mode and by_mode[m]["success"] for m in MODES):
                both_ok.append(by_mode)
            if all(m in by_mode and by_mode[m].get("replan_ms") is not None for m in MODES):
                resumed.append(by_mode)
        on = _median([p["online"]["replan_ms"] for p in resumed])
        nv = _median([p["naive"]["replan_ms"] for p in resumed])
        ratio = _ratio(nv, on)
        shown = "—" if ratio is None else f"{ratio:.1f}×"
        target = "—" if ratio is None else ("met" if ratio >= TARGET else "**missed**")
        win_on = _median([p["online"]["resume_ms"] for p in resumed if p["online"]["resume_ms"] is not None])
        win_nv = _median([p["naive"]["resume_ms"] for p in resumed if p["naive"]["resume_ms"] is not None])
        plan_on = _median([p["online"]["planning_ms"] for p in both_ok])
        plan_nv = _median([p["naive"]["planning_ms"] for p in both_ok])
        # The whole run's planning compared by CPU time: the wall clock of many small pieces
        # of work is what another process on a shared machine inflates most.  Compared problem
        # by problem: a ratio of the two modes' medians over problems of many sizes compares
        # whichever problems happen to sit in the middle of each.
        cpu_ratios = sorted(
            (p["online"]["planning_cpu_ms"] / p["naive"]["planning_cpu_ms"], p["online"]["problem"])
            for p in both_ok
            if p["online"].get("planning_cpu_ms") is not None and p["naive"].get("planning_cpu_ms")
        )
        cpu_median = _median([r for r, _ in cpu_ratios])
        cpu_shown = "—" if cpu_median is None else f"{cpu_median:.2f}"
        if cpu_ratios and len(cpu_ratios) < len(both_ok):
            cpu_shown += f" ({len(cpu_ratios)} of {len(both_ok)})"  # rows from before the CPU clock
        largest = f"{cpu_ratios[-1][0]:.2f} ({cpu_ratios[-1][1]})" if cpu_ratios else "—"
        cheaper = sum(1 for p in both_ok if p["online"]["cost"] <= p["naive"]["cost"])
        total = {m: sum(p[m]["cost"] for p in both_ok) for m in MODES}
        runs = [r for r in found if r["mode"] is not None]
        # A run killed at its time limit compared nothing: it is not counted here.
        checked = [r for r in runs if r["beliefs_match"] is not None]
        matched = sum(1 for r in checked if r["beliefs_match"])
        ran = len(problems) - skipped
        breaks = sum(1 for r in runs if r["mode"] == "online" and r.get("emergency_kind") == "breaks")
        won = {m: sum(1 for r in runs if r["mode"] == m and r["success"]) for m in MODES}
        out.append(
            f"| {domain} | {len(problems)} | {skipped} | {breaks}/{ran} | {won['online']}/{ran} "
            f"| {won['naive']}/{ran} | {_ms(on)} | {_ms(nv)} | {shown} | {target} "
            f"| {_ms(win_on)} | {_ms(win_nv)} "
            f"| {_ms(plan_on)} | {_ms(plan_nv)} | {cpu_shown} | {largest} | {cheaper}/{len(both_ok)} "
            f"| {total['online']} / {total['naive']} | {matched}/{len(checked)} runs |"
        )
    fallback = [r for r in rows if r["mode"] == "online" and r.get("emergency_kind") == "most changes"]
    if fallback:
        out += [
            "",
            "Where no candidate task broke the rest of the plan and left it solvable, the emergency "
            "is the one whose plan changes the most facts (beyond what the rest does next) while the "
            "rest stays solvable; 0 facts: every other candidate left the network unfinishable, and "
            "this one only does what the rest does next:",
            "",
        ]
        out += [f"- {r['domain']}/{r['problem']}: {r['emergency']} ({r['changed']} facts)" for r in fallback]
    unmendable = [r for r in rows if r["mode"] == "online" and r.get("emergency_kind") == "not mended"]
    if unmendable:
        out += [
            "",
            "Where every candidate task left the network with no plan within the check's bounds "
            "(it may not be finishable after it), the one that changes the most facts:",
            "",
        ]
        out += [
            f"- {r['domain']}/{r['problem']}: {r['emergency']} ({r['changed']} facts)" for r in unmendable
        ]
    naive_only = []
    for r in rows:
        if r["mode"] == "naive" and r["success"]:
            online = next(
                (
                    o
                    for o in rows
                    if o["mode"] == "online" and o["problem"] == r["problem"] and o["domain"] == r["domain"]
                ),
                None,
            )
            if online is not None and not online["success"]:
                naive_only.append(f"- {r['domain']}/{r['problem']}: {online['reason']}")
    if naive_only:
        out += ["", "**Naive succeeded where on-line failed:**", "", *naive_only]
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
    p.add_argument("--run-timeout", type=positive, default=60.0, help="wall-clock seconds a mode's runs (60)")
    p.add_argument(
        "--runs",
        type=at_least_one,
        default=5,
        help="measured runs a mode, after one warm-up run; the modes in turn (5; medians)",
    )
    p.add_argument(
        "--max-actions",
        type=at_least_one,
        default=MAX_ACTIONS,
        help=f"skip a problem whose plan has more actions ({MAX_ACTIONS:,})",
    )
    p.add_argument("--domains", default=None, help="NAME,... (folder names; default all)")
    p.add_argument("--problems", type=at_least_one, default=None, help="the first N problems of each domain")
    p.add_argument(
        "--out",
        type=Path,
        default=RESULTS / "ipc_interrupt.json",
        help="the rows (bench/results/ipc_interrupt.json)",
    )
    p.add_argument(
        "--resume",
        action="store_true",
        help="keep the rows --out already holds and run only the problems not in it",
    )
    p.add_argument(
        "--table", action="store_true", help="only write the .md table of the rows --out holds (run nothing)"
    )
    p.add_argument("--grace", type=float, default=GRACE_S, help=argparse.SUPPRESS)
    return p


def _status(rows: Sequence[dict[str, Any]]) -> str:
    if rows[0]["mode"] is None:
        return f"skipped: {rows[0]['reason']}"
    parts = []
    for r in rows:
        if r["success"]:
            parts.append(f"{r['mode']} replan {_ms(r['replan_ms'])} ms, cost {r['cost']}")
        else:
            parts.append(f"{r['mode']} FAILED ({r['reason']})")
    about = f"{rows[0]['actions']} actions, emergency {rows[0]['emergency']} ({rows[0]['emergency_kind']})"
    return f"{about}: " + "; ".join(parts)


def main(argv: Sequence[str] | None = None) -> int:
    args_in = list(sys.argv[1:] if argv is None else argv)
    if args_in[:1] == ["--worker"]:
        return worker(args_in[1:])
    args = parser().parse_args(args_in)
    try:
        domains = [d.strip() for d in args.domains.split(",") if d.strip()] if args.domains else None
        problems = suite_problems(args.suite, domains, args.problems)
    except UsageError as e:
        print(f"{PROG}: error: {e}", file=sys.stderr)
        return 2
    # Round robin over the domains (each one's first problem, then each one's second, ...): a
    # run stopped part way has rows of every domain.
    by_domain: dict[str, list[Problem]] = {}
    for problem in problems:
        by_domain.setdefault(problem.domain, []).append(problem)
    problems = [p for batch in itertools.zip_longest(*by_domain.values()) for p in batch if p is not None]
    rows = _kept(args.out) if args.resume or args.table else []
    done = {(r["domain"], r["problem"]) for r in rows}
    print(
        f"{len(problems)} problems ({len(done)} done before, kept); rows to {args.out}",
        file=sys.stderr,
        flush=True,
    )
    md = args.out.with_suffix(".md")
    if not args.table:
        write(args.out, rows)

    def table() -> str:
        left = len({(p.domain, p.name) for p in problems} - {(r["domain"], r["problem"]) for r in rows})
        return markdown(rows, args.timeout, args.run_timeout, machine_line(), args.max_actions, left)

    if args.table:
        md.write_text(table())
        return 0

    try:
        for i, problem in enumerate(problems, 1):
            if (problem.domain, problem.name) in done:
                continue
            found = bench_problem(
                problem, args.timeout, args.run_timeout, args.grace, args.runs, args.max_actions
            )
            rows += found
            write(args.out, rows)
            print(
                f"[{i}/{len(problems)}] {problem.domain}/{problem.name}: {_status(found)}",
                file=sys.stderr,
                flush=True,
            )
    except KeyboardInterrupt:
        print(f"{PROG}: interrupted; {len(rows)} rows kept in {args.out} (--resume goes on)", file=sys.stderr)
        md.write_text(table())
        return 130
    text = table()
    md.write_text(text)
    print(text, file=sys.stderr)
    return 0


def _kept(out: Path) -> list[dict[str, Any]]:
    """The rows of an earlier run in ``out`` (none if it is missing or not rows of this bench)."""
    try:
        rows = json.loads(out.read_text())
    except (OSError, ValueError):
        return []
    if not isinstance(rows, list) or not all(isinstance(r, dict) and "problem" in r for r in rows):
        return []
    return rows


if __name__ == "__main__":
    raise SystemExit(main())
