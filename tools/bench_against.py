"""Time two checkouts against each other, runs interleaved: ``python tools/bench_against.py OTHER``.

Each round runs a study (``python -m bench STUDY``) in this checkout, then in OTHER (another
worktree, e.g. ``git worktree add ../base <commit>`` with its own venv), and reads the figures
the study wrote to ``bench/results/``; the results files are put back as they were after each
run.  Interleaving spreads the machine's drift over both sides.  Prints, per figure, the median
over the rounds on each side and their ratio (this / other; above 1.0 is slower here).

    python tools/bench_against.py ../base --python ../base/.venv/bin/python \
        --studies replanning,reaction,step --rounds 3
"""

from __future__ import annotations

import argparse
import json
import statistics
import subprocess
import sys
from collections.abc import Callable
from pathlib import Path

HERE = Path(__file__).resolve().parent.parent

Key = tuple[object, ...]

# study -> (results file, the row's key, the figures compared)
STUDIES: dict[str, tuple[str, Callable[[dict[str, object]], Key], tuple[str, ...]]] = {
    "replanning": (
        "replanning.json",
        lambda r: (r["case"], r["level"], r["mode"], r.get("look_ahead", True)),
        ("median_ms", "replan_ms"),
    ),
    "reaction": ("reaction.json", lambda r: (r["levels"], r["mode"]), ("median_ms", "p99_ms")),
    "step": ("step.json", lambda r: (r["nodes"], r["pair"]), ("planner_us_per_step",)),
}


def run_once(checkout: Path, python: str, study: str) -> dict[Key, dict[str, float]]:
    """The figures of one run of ``study`` in ``checkout``; its results file left as it was."""
    name, key, figures = STUDIES[study]
    results = checkout / "bench" / "results" / name
    kept = results.read_bytes() if results.exists() else None
    argv = [python, "-m", "bench"] + ([] if study == "replanning" else [study])
    try:
        subprocess.run(argv, cwd=checkout, check=True, stdout=subprocess.DEVNULL)
        rows = json.loads(results.read_text())
    finally:
        if kept is not None:
            results.write_bytes(kept)
    return {key(r): {f: float(r[f]) for f in figures if f in r} for r in rows}


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    parser.add_argument("other", type=Path, help="the other checkout")
    parser.add_argument("--python", default=sys.executable, help="the other checkout's Python")
    parser.add_argument("--studies", default="replanning,reaction,step")
    parser.add_argument("--rounds", type=int, default=3)
    args = parser.parse_args(argv)
    for study in args.studies.split(","):
        here: dict[Key, dict[str, list[float]]] = {}
        there: dict[Key, dict[str, list[float]]] = {}
        for n in range(args.rounds):
            for side, checkout, python in ((here, HERE, sys.executable), (there, args.other, args.python)):
                for k, figures in run_once(checkout.resolve(), python, study).items():
                    for f, v in figures.items():
                        side.setdefault(k, {}).setdefault(f, []).append(v)
            print(f"{study}: round {n + 1} of {args.rounds} done", file=sys.stderr)
        print(f"\n## {study} ({args.rounds} rounds, interleaved; ratio = this / other)")
        ratios: list[float] = []
        for k in sorted(here, key=str):
            for f, values in here[k].items():
                other = there.get(k, {}).get(f)
                if not other:
                    continue
                a, b = statistics.median(values), statistics.median(other)
                ratio = a / b if b else float("nan")
                ratios.append(ratio)
                print(f"{' / '.join(map(str, k)):40} {f:20} {a:10.4f} {b:10.4f} {ratio:6.3f}")
        if ratios:
            print(f"median ratio {statistics.median(ratios):.3f}, worst {max(ratios):.3f}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
