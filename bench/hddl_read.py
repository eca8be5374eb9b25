"""How fast HDDL is read (``python -m bench hddl-read [--suite DIR]``).

Reads every problem of an IPC-style suite -- each folder's ``domain.hddl``
with its other ``.hddl`` files (in subfolders too), and feature tests named
``X.hddl`` beside ``X-domain.hddl`` -- each time domain and problem, parsed
and checked, and a generated problem of about 4 MB (:func:`synthetic`).
Writes ``bench/results/hddl_read.json``, one object: ``files``, ``bytes``,
``total_s``, ``max`` (the slowest file), ``synthetic`` (its ``bytes`` and
``read_ms``), ``refused`` (files that did not read, with the message) and
``rows``, ``{suite, file, bytes, read_ms}`` per problem.  Timings are the best
of three reads.
"""

from __future__ import annotations

import json
import sys
import time
from pathlib import Path
from typing import Any

from bench.machine import machine_line
from htnagent.errors import HddlError
from htnagent.hddl import parse_domain, parse_problem, read_domain, read_problem
from htnagent.testing.hddl_inputs import suite_pairs, synthetic

RESULTS = Path(__file__).resolve().parent / "results"
DEFAULT_SUITE = Path(__file__).resolve().parent.parent.parent / "shared" / "data" / "ipc"


def _best_of(n: int, read: Any) -> float:
    best = float("inf")
    for _ in range(n):
        start = time.perf_counter()
        read()
        best = min(best, time.perf_counter() - start)
    return best


def main(suite: Path | None = None) -> int:
    """Read every problem of the suite and the synthetic one; print and write the figures."""
    root = suite or DEFAULT_SUITE
    rows: list[dict[str, Any]] = []
    refused: list[dict[str, str]] = []
    if root.is_dir():
        for name, domain_file, problem_file in suite_pairs(root):

            def read(d: Path = domain_file, p: Path = problem_file) -> None:
                read_problem(p, read_domain(d))

            try:
                seconds = _best_of(3, read)
            except HddlError as e:
                refused.append({"suite": name, "file": str(problem_file), "error": str(e)})
                continue
            rows.append(
                {
                    "suite": name,
                    "file": str(problem_file.relative_to(root)),
                    "bytes": problem_file.stat().st_size,
                    "read_ms": round(seconds * 1000, 2),
                }
            )
            print(f"{name}/{problem_file.name}: {seconds * 1000:.1f} ms", file=sys.stderr)
    else:
        print(f"no suite at {root}; only the synthetic problem is read", file=sys.stderr)
    domain_text, problem_text = synthetic()

    def read_synthetic() -> None:
        parse_problem(problem_text, parse_domain(domain_text, "<grid>"), "<grid-big>")

    synthetic_s = _best_of(3, read_synthetic)
    slowest = max(rows, key=lambda r: r["read_ms"], default=None)
    result = {
        "machine": machine_line(),
        "suite": str(root),
        "files": len(rows),
        "bytes": sum(r["bytes"] for r in rows),
        "total_s": round(sum(r["read_ms"] for r in rows) / 1000, 3),
        "max": slowest,
        "synthetic": {"bytes": len(problem_text.encode()), "read_ms": round(synthetic_s * 1000, 1)},
        "refused": refused,
        "rows": rows,
    }
    RESULTS.mkdir(exist_ok=True)
    (RESULTS / "hddl_read.json").write_text(json.dumps(result, indent=1) + "\n")
    print(
        f"{len(rows)} problems ({result['bytes']:,} bytes) in {result['total_s']} s, slowest "
        f"{slowest['file'] if slowest else '-'} ({slowest['read_ms'] if slowest else 0} ms); "
        f"synthetic {result['synthetic']['bytes']:,} bytes in {synthetic_s:.2f} s; {len(refused)} refused",
        file=sys.stderr,
    )
    return 0
