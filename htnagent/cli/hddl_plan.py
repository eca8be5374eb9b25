"""``plan --hddl``: an HDDL problem read, solved and printed -- and its fast start.

``python -m htnagent plan --hddl DOMAIN PROBLEM ...`` is what the IPC bench (and a user
timing a planner) runs once a problem, so its start counts: :func:`fast_main` parses that
one command line with a small parser of its own and runs it importing only what planning
needs (the HDDL reader, the translation, the planner) -- never the scenario code,
pydantic, rich, anyio or the drawing code the rest of the command line stands on.  Any
other command line, and any this parser does not take as it is (``--help``, a mistake:
the full parser words the error), goes to :func:`htnagent.cli.commands.main`, which runs
:func:`plan_hddl` the same way.
"""

from __future__ import annotations

import argparse
import functools
import json
import signal
import sys
import threading
from collections.abc import Sequence
from typing import Any, NoReturn

from htnagent.cli.common import EXIT_FAILED, EXIT_OK, PROG, fail, guarded, is_terminal, seconds
from htnagent.hddl.model import Domain, Problem
from htnagent.hddl.plan_file import format_plan, object_spellings, spellings
from htnagent.hddl.reader import read_domain, read_problem
from htnagent.model.plans import Plan
from htnagent.model.terms import Atom
from htnagent.planning.hddl_solving import Better, Solved, solve, solve_anytime
from htnagent.planning.ipc_output import actions_of, ipc_plan
from htnagent.planning.planner import PlanStatus, Search, stop_searches

SEARCH_CHOICES = (*(s.value for s in Search), "auto")
FORMATS = ("text", "json", "ipc")


def read_hddl(domain_file: str, problem_file: str) -> tuple[Domain, Problem]:
    domain = read_domain(domain_file)
    return domain, read_problem(problem_file, domain)


def plan_hddl(args: argparse.Namespace, domain_file: str, problem_file: str) -> int:
    """Solve and print (docs/contracts.md "Command line"): exit 0 with a plan, 1 without."""
    if args.json and args.format not in (None, "json"):
        return fail(f"--json and --format {args.format} disagree (see {PROG} plan --help)")
    form = "json" if args.json else args.format or "text"
    if args.tree and form == "ipc":
        return fail("--tree is for --format text or json: the ipc format lists the decomposition already")
    search = Search(args.search) if args.search not in (None, "auto") else None
    domain, problem = read_hddl(domain_file, problem_file)
    spelling = spellings(domain.source.text, problem.source.text)
    objects = object_spellings(domain, problem)
    anytime = bool(getattr(args, "anytime", False))
    watch = _Anytime()

    def print_ipc(plan: Plan) -> None:
        """Each better plan as the IPC's anytime track prints it, at once."""
        watch.found = True
        if form == "ipc":
            sys.stdout.write(format_plan(ipc_plan(plan), spelling, objects))
            sys.stdout.flush()

    with watch if anytime else _nothing():
        solved = _solve_showing_progress(
            domain, problem, search=search, timeout=args.timeout, better=print_ipc if anytime else None
        )
    result = solved.result
    best = result.best
    if best is None:
        if result.status is PlanStatus.TIMED_OUT:
            why = f"timeout (no plan within {args.timeout:g} s)"
        elif result.status is PlanStatus.BUDGET_EXHAUSTED:
            why = f"budget (no plan within {solved.settings.budget:,} expansions)"
        elif result.status is PlanStatus.UNSOLVABLE:
            why = "unsolvable (the whole search space holds no plan)"
        else:
            why = result.status.value
        print(f"{PROG}: no plan: {why}", file=sys.stderr)
        return EXIT_FAILED
    if form == "ipc":
        if not anytime:
            sys.stdout.write(format_plan(ipc_plan(best), spelling, objects))
        return EXIT_OK
    actions = [spelled(a, spelling, objects) for a in actions_of(best)]
    if args.tree:
        from htnagent.views.decomposition import hddl_tree, tree_json, tree_lines

        tree = hddl_tree(ipc_plan(best), functools.partial(spelled_words, spelling, objects))
    if form == "json":
        line: dict[str, object] = {
            "plan": actions,
            "cost": best.cost,
            "alternatives": len(result.plans),
            "search": solved.search.value,
            "expansions": result.expansions,
            "seconds": round(result.seconds, 3),
        }
        if anytime:
            line["cheapest"] = result.exhausted  # no cheaper plan exists
        if args.tree:
            line["tree"] = tree_json(tree)
        print(json.dumps(line))
        return EXIT_OK
    for action in tree_lines(tree) if args.tree else actions:
        print(action)
    return EXIT_OK


def _solve_showing_progress(
    domain: Domain,
    problem: Problem,
    *,
    search: Search | None,
    timeout: float | None,
    better: Better | None = None,
) -> Solved:
    """:func:`solve` (:func:`solve_anytime` when told of ``better`` plans), its progress
    shown on stderr when stderr is a terminal (nothing otherwise)."""
    if not is_terminal(sys.stderr):
        if better is not None:
            return solve_anytime(domain, problem, better, search=search, timeout=timeout)
        return solve(domain, problem, search=search, timeout=timeout)
    from htnagent.views.console import SearchProgress  # rich: only for a person watching

    shown = SearchProgress(sys.stderr)
    try:
        if better is not None:
            return solve_anytime(domain, problem, better, search=search, timeout=timeout, progress=shown)
        return solve(domain, problem, search=search, timeout=timeout, progress=shown)
    finally:
        shown.close()


class _nothing:
    def __enter__(self) -> None:
        return None

    def __exit__(self, *exc: object) -> None:
        return None


class _Anytime:
    """Ctrl-C and SIGTERM while ``plan --anytime`` searches: before the first plan as
    always (the process ends, exit 130); once a plan is found, the search stops at its
    next look at the clock and the best plan stands (exit 0), nothing half printed."""

    def __init__(self) -> None:
        self.found = False
        self.saved: dict[int, Any] = {}

    def _signalled(self, signum: int, frame: Any) -> None:
        if not self.found:
            previous = self.saved.get(signum)
            if callable(previous):
                previous(signum, frame)
            raise KeyboardInterrupt
        stop_searches()

    def __enter__(self) -> None:
        if threading.current_thread() is threading.main_thread():
            for sig in (signal.SIGINT, signal.SIGTERM):
                previous = signal.getsignal(sig)
                if previous is not signal.SIG_IGN:
                    self.saved[sig] = previous
                    signal.signal(sig, self._signalled)

    def __exit__(self, *exc: object) -> None:
        for sig, previous in self.saved.items():
            signal.signal(sig, previous)
        stop_searches(False)


def spelled(action: Atom, spelling: dict[str, str], objects: dict[str, str]) -> str:
    """``name(arg,...)``, each name as the HDDL files spell it."""
    return spelled_words(spelling, objects, action.name, action.args)


def spelled_words(
    spelling: dict[str, str], objects: dict[str, str], name: str, args: Sequence[object]
) -> str:
    words = [objects.get(str(a)) or spelling.get(str(a), str(a)) for a in args]
    name = spelling.get(name, name)
    return f"{name}({','.join(words)})" if words else name


class _NotMine(Exception):
    """A command line the fast parser does not take as it is: the full one will."""


class _FastParser(argparse.ArgumentParser):
    def error(self, message: str) -> NoReturn:
        raise _NotMine(message)


def _fast_parser() -> argparse.ArgumentParser:
    """``plan --hddl``'s options, as the full parser has them (help and wording are its)."""
    p = _FastParser(prog=f"{PROG} plan", add_help=False, exit_on_error=False)
    p.add_argument("files", nargs="+")
    p.add_argument("--hddl", action="store_true")
    p.add_argument("--json", action="store_true")
    p.add_argument("--tree", action="store_true")
    p.add_argument("--format", choices=FORMATS, default=None)
    p.add_argument("--timeout", type=seconds)
    p.add_argument("--search", choices=SEARCH_CHOICES)
    p.add_argument("--anytime", action="store_true")
    return p


def fast_main(argv: Sequence[str], *, owns_process: bool = False) -> int | None:
    """Run ``plan --hddl DOMAIN PROBLEM [options]`` and return its exit code, or None when
    ``argv`` is any other command line (or one this parser does not take as it is)."""
    if argv[:1] != ["plan"] or "--hddl" not in argv or any(a in ("-h", "--help") for a in argv):
        return None
    try:
        args = _fast_parser().parse_args(list(argv[1:]))
    except (_NotMine, argparse.ArgumentError):
        return None
    if not args.hddl or len(args.files) != 2:
        return None
    files: list[Any] = args.files
    return guarded(lambda: plan_hddl(args, files[0], files[1]), owns_process)


__all__ = ["fast_main", "plan_hddl", "read_hddl", "spelled", "spelled_words"]
