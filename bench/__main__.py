"""``python -m bench`` (the six published cases), or a study: ``python -m bench STUDY`` (see --help)."""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from bench.machine import recording_machine


def _robots(text: str) -> tuple[int, ...]:
    """``--robots 1,10,100``: fleet sizes, each at least 1."""
    try:
        sizes = tuple(int(part) for part in text.split(","))
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected sizes like 1,4,8, got {text!r}") from None
    if not sizes or min(sizes) < 1:
        raise argparse.ArgumentTypeError(f"every size must be at least 1, got {text!r}")
    return sizes


def main() -> int:
    if sys.argv[1:2] == ["ipc"]:  # its own options: python -m bench ipc --help
        from bench import ipc

        return ipc.main(sys.argv[2:])
    if sys.argv[1:2] == ["fuzz"]:  # its own options: python -m bench fuzz --help
        from bench import fuzz

        return fuzz.cli(sys.argv[2:])
    if sys.argv[1:2] == ["ipc-interrupt"]:  # its own options: python -m bench ipc-interrupt --help
        from bench import ipc_interrupt

        return ipc_interrupt.main(sys.argv[2:])
    # The studies imported only now: ``ipc`` and the others above start without them.
    from bench import differential, fleet, hddl_read, reaction, reliability, replanning, scaling, step

    parser = argparse.ArgumentParser(prog="python -m bench", description=__doc__)
    parser.add_argument(
        "study",
        nargs="?",
        default="replanning",
        choices=(
            "replanning",
            "scaling",
            "reliability",
            "differential",
            "fleet",
            "reaction",
            "fuzz",
            "step",
            "hddl-read",
            "remote",
            "ipc",
            "ipc-interrupt",
            "plan-start",
        ),
        help="a study (ipc, ipc-interrupt: python -m bench ipc --help, ... ipc-interrupt --help)",
    )
    parser.add_argument("--runs", type=int, default=None, help="measured runs per cell (fuzz: inputs)")
    parser.add_argument("--quick", action="store_true", help="scaling: stop at 100 areas (for a smoke test)")
    parser.add_argument(
        "--suite",
        type=Path,
        default=None,
        help="hddl-read: the folder of HDDL domains (default ../shared/data/ipc)",
    )
    parser.add_argument(
        "--robots",
        type=_robots,
        default=None,
        metavar="N,N,...",
        help="remote: the fleet sizes, robots (default 1,10,100; up to 10 robots a serving process)",
    )
    args = parser.parse_args()
    if args.study in ("ipc", "ipc-interrupt"):
        parser.error(
            f"{args.study} takes its options after it: python -m bench {args.study} --suite DIR (see --help)"
        )
    if args.study == "plan-start":
        from bench import plan_start

        return plan_start.main(args.suite / "Transport" if args.suite else None, runs=args.runs or 5)
    if args.study == "hddl-read":
        return hddl_read.main(args.suite)
    if args.study == "step":
        return step.main()
    if args.study == "remote":
        from bench import remote  # needs the zenoh extra

        return remote.main() if args.robots is None else remote.main(args.robots)
    if args.study == "reaction":
        return reaction.main(runs=args.runs or 300)
    if args.study == "fleet":
        return fleet.main()
    if args.study == "differential":
        return differential.main(runs=args.runs or 1000)
    if args.study == "reliability":
        return reliability.main(runs=args.runs or 300)
    if args.study == "scaling":
        return scaling.main(runs=args.runs, quick=args.quick)
    return replanning.main(runs=args.runs or 25)


raise SystemExit(recording_machine(main))
