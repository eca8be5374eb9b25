"""On-line against naive on random scenarios (``python -m bench differential``).

Runs :func:`htnagent.testing.differential.compare` on seeds ``0 .. runs-1`` (in
as many processes as there are cores), sums what the runs gave, and writes
``bench/results/differential.json``: one row for the runs without door events,
one for those with, one for all —
``{doors, runs, goals, emergencies, door_events, violations, online_m, naive_m}``
— plus the first violations seen.  Besides each run's own checks, the runs
with doors must together travel no more than
:data:`~htnagent.testing.differential.DOORS_TOTAL_SLACK` farther on-line.
"""

from __future__ import annotations

import json
import os
import sys
import time
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path
from typing import Any

import anyio

from htnagent.testing.differential import DOORS_TOTAL_SLACK, Comparison, compare

RESULTS = Path(__file__).resolve().parent / "results"


def _one(seed: int) -> Comparison:
    return anyio.run(compare, seed)


def _row(doors: str, runs: list[Comparison]) -> dict[str, Any]:
    return {
        "doors": doors,
        "runs": len(runs),
        "goals": sum(r.goals for r in runs),
        "emergencies": sum(r.emergencies for r in runs),
        "door_events": sum(r.door_events for r in runs),
        "violations": sum(len(r.violations) for r in runs),
        "online_m": round(sum(r.online.distance for r in runs), 2),
        "naive_m": round(sum(r.naive.distance for r in runs), 2),
    }


def main(runs: int = 1000) -> int:
    """Run ``runs`` random scenarios in both modes; print and write the figures."""
    started = time.perf_counter()
    results: list[Comparison] = []
    workers = max(os.cpu_count() or 1, 1)
    with ProcessPoolExecutor(workers) as pool:
        for result in pool.map(_one, range(runs), chunksize=10):
            results.append(result)
            if len(results) % 100 == 0:
                bad = sum(1 for r in results if r.violations)
                elapsed = time.perf_counter() - started
                print(f"{len(results)}/{runs} runs, {bad} with violations, {elapsed:.0f} s", file=sys.stderr)
    without = [r for r in results if not r.doors]
    with_doors = [r for r in results if r.doors]
    rows = [_row("no", without), _row("yes", with_doors), _row("all", results)]
    examples = [f"seed {r.seed}: {v}" for r in results for v in r.violations]
    door_rows = rows[1]
    if door_rows["online_m"] > door_rows["naive_m"] * (1 + DOORS_TOTAL_SLACK):
        line = (
            f"runs with doors: on-line travelled {door_rows['online_m']} m in all, naive "
            f"{door_rows['naive_m']} m (allowed +{DOORS_TOTAL_SLACK:.0%})"
        )
        examples.append(line)
        door_rows["violations"] += 1
        rows[2]["violations"] += 1
    RESULTS.mkdir(parents=True, exist_ok=True)
    (RESULTS / "differential.json").write_text(json.dumps(rows, indent=2) + "\n")
    (RESULTS / "differential_violations.json").write_text(json.dumps(examples[:50], indent=2) + "\n")
    print(
        f"{'doors':>5} {'runs':>5} {'goals':>6} {'emerg.':>6} {'door ev.':>8} {'viol.':>5} "
        f"{'on-line m':>10} {'naive m':>10}"
    )
    for row in rows:
        print(
            f"{row['doors']:>5} {row['runs']:>5} {row['goals']:>6} {row['emergencies']:>6} "
            f"{row['door_events']:>8} {row['violations']:>5} {row['online_m']:>10} {row['naive_m']:>10}"
        )
    for line in examples[:20]:
        print("  " + line)
    print(f"{time.perf_counter() - started:.0f} s; wrote bench/results/differential.json", file=sys.stderr)
    return 1 if examples else 0
