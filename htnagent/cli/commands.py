"""The command line: ``python -m htnagent run|plan|check SCENARIO``, ``report TRACE``,
``check|verify --hddl`` (docs/contracts.md).

The CLI owns the console.  Exit codes: 0 success, 1 no plan / a goal failed,
2 invalid input or usage, 130 interrupted.  Every error of kind 2 is exactly one
line on stderr, ``htnagent: error: <file>: <key path or line>: <reason>`` (usage
errors have no file; HDDL files give ``FILE:LINE:COL: reason``), never a traceback.

Ctrl-C and SIGTERM: until a run starts there is nothing to save, and
``python -m htnagent`` ends at once with exit 130 (:mod:`htnagent.__main__`).
Once a run has started, :class:`_RunSignals` takes both signals over until
the command returns: the first stops the run, which still prints its summary;
any later one (while the run winds down, the summary or the picture is
written) is only noted.  Either way the exit code is 130 and stderr says
``htnagent: interrupted``, never a traceback.
"""

from __future__ import annotations

import argparse
import dataclasses
import functools
import io
import json
import os
import re
import signal
import sys
import textwrap
import threading
import time
from collections.abc import Awaitable, Callable, Sequence
from pathlib import Path
from types import FrameType, TracebackType
from typing import TYPE_CHECKING, Any, NoReturn, Self, TextIO

import anyio
from rich.console import Console
from rich.markup import escape as rich_escape
from rich.table import Table
from rich.text import Text
from rich_argparse import RawDescriptionRichHelpFormatter

from htnagent.cli.common import (
    EXIT_FAILED,
    EXIT_INTERRUPTED,
    EXIT_INVALID,
    EXIT_OK,
    PROG,
    guarded,
    is_terminal,
    one_line,
    reader_gone,
    seconds,
)
from htnagent.cli.common import fail as _fail
from htnagent.cli.hddl_plan import SEARCH_CHOICES, plan_hddl, read_hddl
from htnagent.errors import HtnAgentError, PlotError, ScenarioError, SettingsError, TextFormError
from htnagent.hddl.check import check_plan
from htnagent.hddl.model import Domain, Problem
from htnagent.hddl.plan_file import read_plan
from htnagent.limits import MAX_SPEED, MIN_SPEED
from htnagent.model.plans import Plan
from htnagent.model.terms import parse
from htnagent.planning.hddl_translation import translate
from htnagent.planning.planner import PlanStatus, Search, plan, stop_searches
from htnagent.runtime.events import Summary, TraceEvent
from htnagent.runtime.trace import Observer
from htnagent.scenario import Scenario, load_scenario
from htnagent.scenario.builtin import builtin_scenarios, scenario_file
from htnagent.scenario.checks import check_task
from htnagent.system.simulation import RunReport, run_scenario
from htnagent.version import VERSION
from htnagent.views.console import (
    KEY,
    RESUME_KEY,
    JsonLines,
    LiveTrace,
    OutputConsole,
    print_summary,
    print_whole,
    printable,
)
from htnagent.views.decomposition import plan_tree, tree_json, tree_lines
from htnagent.views.history import History
from htnagent.views.plot import check_plot_scenario, check_plot_target, draw_run
from htnagent.views.report import check_report_target, write_report
from htnagent.views.timeline import draw_timeline
from htnagent.views.trace_file import read_trace

if TYPE_CHECKING:
    from htnagent.remote.link import Security


class _UsageError(Exception):
    """A command line that argparse refused."""


class _HelpFormatter(RawDescriptionRichHelpFormatter):
    """rich-argparse's help, its epilog kept as written, made on a console of its own: the
    default one writes to standard output even while only building the parser, and a full
    disk or a closed standard output would then fail every command.  Colour when standard
    output is a terminal (or as NO_COLOR and FORCE_COLOR say)."""

    def __init__(self, prog: str, **kwargs: Any) -> None:
        kwargs.setdefault(
            "console", Console(file=io.StringIO(), force_terminal=is_terminal(sys.stdout) or None)
        )
        super().__init__(prog, **kwargs)


class _Parser(argparse.ArgumentParser):
    """argparse, but a usage error is one line and leaves the exiting to :func:`main`; the help
    is rich's, its epilog (examples, exit codes) printed as written."""

    def __init__(self, *args: Any, **kwargs: Any) -> None:
        kwargs.setdefault("formatter_class", _HelpFormatter)
        super().__init__(*args, **kwargs)

    def error(self, message: str) -> NoReturn:
        raise _UsageError(f"{message} (see {self.prog} --help)")


def _speed(text: str) -> float:
    """``--speed``: a finite pace a clock can keep (1e-320 would never advance, 1e300 is no pace)."""
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected a number, got {text!r}") from None
    if not MIN_SPEED <= value <= MAX_SPEED:  # also refuses nan
        raise argparse.ArgumentTypeError(
            f"expected a number from {MIN_SPEED:g} to {MAX_SPEED:g} (simulated seconds per real second), "
            f"got {text!r}"
        )
    return value


_SCENARIO_HELP = "the scenario file (YAML), or a built-in scenario's name (museum)"


def build_parser() -> argparse.ArgumentParser:
    """The argument parser of the ``htnagent`` command."""
    parser = _Parser(
        prog=PROG,
        description="On-line HTN planning agents that handle emergency goals.",
        epilog=_epilog(),
    )
    parser.add_argument("--version", action="version", version=f"{PROG} {VERSION}")
    sub = parser.add_subparsers(
        dest="command", metavar="{run,compare,plan,check,verify,report,serve,certs}", required=True
    )

    run = sub.add_parser("run", help="execute the scenario to the end")
    run.add_argument("scenario", metavar="SCENARIO", help=_SCENARIO_HELP)
    run.add_argument(
        "--replanning", choices=("online", "naive"), help="override the scenario's replanning mode"
    )
    run.add_argument("--json", action="store_true", help="JSON Lines on stdout, the last line a summary")
    run.add_argument(
        "--speed",
        type=_speed,
        metavar="X",
        help="simulated seconds per real second (default: as fast as possible)",
    )
    run.add_argument("--plot", metavar="FILE", help="draw the robot's path into FILE")
    run.add_argument(
        "--timeline", metavar="FILE", help="draw goals, suspensions and the stack depth over time into FILE"
    )

    pl = sub.add_parser(
        "plan",
        help="print the plan an agent would make (or solve an HDDL problem), without executing it",
        usage=(
            f"{PROG} plan SCENARIO --agent NAME --task TASK [--json] [--tree] [--search NAME] | "
            f"{PROG} plan --hddl DOMAIN PROBLEM [--format text|json|ipc] [--tree] [--timeout S] "
            "[--search NAME]"
        ),
    )
    pl.add_argument("files", nargs="+", metavar="FILE", help="SCENARIO, or with --hddl DOMAIN PROBLEM")
    pl.add_argument("--hddl", action="store_true", help="solve an HDDL domain and problem")
    pl.add_argument("--agent", metavar="NAME", help="the agent that plans (a scenario)")
    pl.add_argument("--task", metavar="TASK", help='the task, e.g. "goto(n1)" (a scenario)')
    pl.add_argument("--json", action="store_true", help='one JSON line: {"plan", "cost", "alternatives"}')
    pl.add_argument(
        "--tree",
        action="store_true",
        help="the decomposition tree: each compound task, its method, its subtasks indented, the actions "
        'as leaves (with --json: a "tree" key)',
    )
    pl.add_argument(
        "--format",
        choices=("text", "json", "ipc"),
        default=None,
        help="with --hddl: the actions (text), one JSON line, or the IPC plan format (default text)",
    )
    pl.add_argument("--timeout", type=seconds, metavar="S", help="give up after S seconds (exit 1, timeout)")
    pl.add_argument(
        "--search",
        choices=SEARCH_CHOICES,
        help="the search order: astar (cost-optimal; a scenario's default), gbfs (greedy), dfs "
        "(depth-first in method order), or with --hddl auto (its default: dfs, then gbfs "
        "and a grounded gbfs beside it)",
    )
    pl.add_argument(
        "--anytime",
        action="store_true",
        help="with --hddl: after the first plan, search for cheaper ones until --timeout (or Ctrl-C); "
        "--format ipc prints each as it is found, text and json the last",
    )

    check = sub.add_parser(
        "check",
        help="validate the scenario (print ok), or with --hddl an HDDL domain and problem (print sizes)",
        usage=f"{PROG} check SCENARIO | {PROG} check --hddl DOMAIN PROBLEM",
    )
    check.add_argument("files", nargs="+", metavar="FILE", help="SCENARIO, or with --hddl DOMAIN PROBLEM")
    check.add_argument("--hddl", action="store_true", help="the files are an HDDL domain and problem")

    verify = sub.add_parser(
        "verify",
        help="check a plan in the IPC format against an HDDL domain and problem",
        usage=f"{PROG} verify --hddl DOMAIN PROBLEM PLAN",
    )
    verify.add_argument("domain", metavar="DOMAIN", help="the HDDL domain file")
    verify.add_argument("problem", metavar="PROBLEM", help="the HDDL problem file")
    verify.add_argument("plan", metavar="PLAN", help="the plan, in the IPC output format (==> ... <==)")
    verify.add_argument(
        "--hddl", action="store_true", required=True, help="the files are HDDL (the one kind verify reads)"
    )

    report = sub.add_parser("report", help="a saved trace (run --json) as one self-contained HTML page")
    report.add_argument("trace", metavar="TRACE", help="the output of run --json (JSON Lines)")
    report.add_argument("--html", required=True, metavar="FILE", help="the HTML page to write")
    report.add_argument(
        "--scenario",
        metavar="SCENARIO",
        help="the scenario the trace ran (for the map and the agents' order)",
    )
    _add_serve(sub)
    _add_certs(sub)
    _add_compare(sub)
    return parser


EXAMPLES = (
    ("htnagent run museum", "run a built-in scenario, its trace live"),
    ("htnagent run museum --json > trace.jsonl", "the trace as JSON Lines, the summary last"),
    ("htnagent run my.yaml --replanning naive", "your own scenario, in the naive mode"),
    ("htnagent compare museum", "on-line against naive, side by side (replanning at each resumption)"),
    ("htnagent report trace.jsonl --html run.html --scenario museum", "a saved run as an HTML page"),
    ('htnagent plan museum --agent guide --task "goto(n28)" --tree', "a plan and its decomposition"),
    ("htnagent plan --hddl domain.hddl problem.hddl --format ipc", "solve an HDDL problem"),
    ("htnagent check my.yaml", "validate a scenario"),
)
"""The examples ``htnagent --help`` shows."""

EXIT_CODES = (
    (EXIT_OK, "success"),
    (EXIT_FAILED, "no plan, or a goal did not succeed"),
    (EXIT_INVALID, "invalid input or usage: one line on stderr, htnagent: error: FILE: place: reason"),
    (EXIT_INTERRUPTED, "interrupted (Ctrl-C, SIGTERM); a run still prints its summary"),
)
"""The exit codes ``htnagent --help`` lists."""


def _epilog() -> str:
    """Examples, the built-in scenarios and the exit codes, for ``--help`` (rich markup)."""

    def heading(text: str) -> str:
        return f"[argparse.groups]{text}[/]"

    lines = [heading("Examples:")]
    for command, what in EXAMPLES:
        lines += [f"  [dim]# {rich_escape(what)}[/]", f"  {rich_escape(command)}"]
    lines += ["", heading("Built-in scenarios") + " (a SCENARIO that is no file):"]
    names = ", ".join(builtin_scenarios()) or "none installed"
    lines += textwrap.wrap(names, 76, initial_indent="  ", subsequent_indent="  ")
    lines += ["", heading("Exit codes:")]
    lines += [f"  {code:<3}  {rich_escape(what)}" for code, what in EXIT_CODES]
    return "\n".join(lines)


def main(argv: Sequence[str] | None = None, *, owns_process: bool = False) -> int:
    """Run the command line with ``argv`` (default: ``sys.argv[1:]``); return the exit code.

    ``owns_process``: the caller exits right after (``python -m htnagent``), so
    the signal handlers a run installs stay until then instead of being put
    back -- a late Ctrl-C is then noted, never a traceback.
    """
    return guarded(functools.partial(_main, argv, owns_process), owns_process)


def _main(argv: Sequence[str] | None, owns_process: bool) -> int:
    parser = build_parser()
    try:
        args = parser.parse_args(argv)
    except _UsageError as e:
        return _fail(str(e))
    except SystemExit as e:  # --help and --version exit through argparse
        return e.code if isinstance(e.code, int) else EXIT_OK
    if args.command == "check":
        return _check(args)
    if args.command == "verify":
        return _verify(args)
    if args.command == "plan":
        return _plan(args)
    if args.command == "report":
        return _report(args)
    if args.command == "serve":
        return _serve(args, restore_signals=not owns_process)
    if args.command == "certs":
        return _certs(args)
    if args.command == "compare":
        return _compare(args, restore_signals=not owns_process)
    return _run(args, restore_signals=not owns_process)


def _check(args: argparse.Namespace) -> int:
    files: list[str] = args.files
    if args.hddl:
        if len(files) != 2:
            return _fail(
                f"check --hddl takes DOMAIN PROBLEM, not {len(files)} files (see {PROG} check --help)"
            )
        domain, problem = read_hddl(files[0], files[1])
        # What plan --hddl (and a scenario agent) refuses beyond the files' own checks, the
        # translation refuses (a formula that multiplies out too far): check runs it too.
        translate(domain, problem)
        print(_hddl_summary(domain, problem))
        return EXIT_OK
    if len(files) != 1:
        return _fail(f"check takes one SCENARIO (or --hddl DOMAIN PROBLEM) (see {PROG} check --help)")
    load_scenario(scenario_file(files[0]))
    print("ok")
    return EXIT_OK


def _hddl_summary(domain: Domain, problem: Problem) -> str:
    def n(count: int, noun: str) -> str:
        return f"{count} {noun}" if count == 1 else f"{count} {noun}s"

    objects = {o.name for o in (*domain.constants, *problem.objects)}
    types = len(domain.types) - 1  # object, always there, is not counted
    return (
        f"ok: domain {domain.name}: {n(types, 'type')}, {n(len(domain.predicates), 'predicate')}, "
        f"{n(len(domain.tasks), 'task')}, {n(len(domain.methods), 'method')}, "
        f"{n(len(domain.actions), 'action')}; problem {problem.name}: {n(len(objects), 'object')}, "
        f"{n(len(problem.init), 'initial fact')}, {n(len(problem.htn), 'initial task')}"
    )


def _verify(args: argparse.Namespace) -> int:
    domain, problem = read_hddl(args.domain, args.problem)
    plan = read_plan(args.plan)
    problems = check_plan(domain, problem, plan)
    actions = f"{len(plan.steps)} action{'s' * (len(plan.steps) != 1)}"
    if not problems:
        print(f"valid: {actions}, {len(plan.decompositions)} decomposed tasks")
        return EXIT_OK
    noun = "problem" if len(problems) == 1 else "problems"
    print(f"invalid: {len(problems)} {noun} ({actions})")
    for p in problems:
        place = f"{args.plan}:{p.line}" if p.line else args.plan
        print(f"  {place}: {one_line(p.reason)}")
    return EXIT_FAILED


def _plan(args: argparse.Namespace) -> int:
    files: list[str] = args.files
    if args.hddl:
        if len(files) != 2:
            given = f"{len(files)} file{'s' * (len(files) != 1)}"
            return _fail(f"plan --hddl takes DOMAIN PROBLEM, not {given} (see {PROG} plan --help)")
        if args.agent is not None or args.task is not None:
            return _fail("plan --hddl takes no --agent or --task: the problem gives the tasks")
        return plan_hddl(args, files[0], files[1])
    if len(files) != 1:
        return _fail(f"plan takes one SCENARIO (or --hddl DOMAIN PROBLEM) (see {PROG} plan --help)")
    if args.anytime:
        return _fail(f"--anytime is for plan --hddl (see {PROG} plan --help)")
    for option in ("format", "timeout"):
        if getattr(args, option) is not None:
            return _fail(f"--{option} is for plan --hddl (see {PROG} plan --help)")
    for option in ("agent", "task"):
        if getattr(args, option) is None:
            return _fail(f"plan SCENARIO needs --{option} (see {PROG} plan --help)")
    scenario = load_scenario(scenario_file(files[0]))
    file = scenario.file
    if args.agent not in scenario.agent_names:
        raise ScenarioError(
            file,
            "--agent",
            f"no agent named {args.agent!r}; the agents are {', '.join(scenario.agent_names)}",
        )
    try:
        task = parse(args.task)
    except TextFormError as e:
        raise ScenarioError(file, "--task", str(e)) from None
    check_task(scenario, args.agent, task, "--task")
    domain = scenario.domain_for(args.agent)
    settings = scenario.settings_for(args.agent)
    if args.search == "auto":
        return _fail(f"--search auto is for plan --hddl (see {PROG} plan --help)")
    if args.search is not None:
        settings = dataclasses.replace(settings, search=Search(args.search), guide=None)
    try:
        result = plan(domain, scenario.initial_state(args.agent), [task], settings)
    except HtnAgentError:
        raise
    except Exception as e:  # a user's domain code failed while planning
        raise ScenarioError(
            file, "--task", f"planning failed in domain {domain.name}: {type(e).__name__}: {e}"
        ) from None
    best = result.best
    if best is None:
        why = {
            PlanStatus.UNSOLVABLE: "no plan exists",
            PlanStatus.BUDGET_EXHAUSTED: f"the budget of {scenario.settings.budget} expansions ran out",
        }.get(result.status, result.status.value)
        print(
            f"{PROG}: no plan: {args.agent} cannot do {task} from {_start_of(scenario)} ({why})",
            file=sys.stderr,
        )
        return EXIT_FAILED
    if args.json:
        line: dict[str, object] = {"plan": best.text(), "cost": best.cost, "alternatives": len(result.plans)}
        if args.tree:
            line["tree"] = tree_json(plan_tree(best))
        print(json.dumps(line))
        return EXIT_OK
    _print_plan(sys.stdout, scenario, args.agent, str(task), result.plans, tree=args.tree)
    return EXIT_OK


def _report(args: argparse.Namespace) -> int:
    check_report_target(args.html, args.trace)
    events = read_trace(args.trace)
    scenario = load_scenario(scenario_file(args.scenario)) if args.scenario else None
    agents = scenario.agent_names if scenario is not None else ()
    if scenario is not None:
        # The map and the lanes come from the scenario: it must be the one the trace ran.
        traced = {e.agent for e in events} - {"runtime", "world", "robot"}
        strangers = sorted(traced - set(agents))
        if strangers:
            raise ScenarioError(
                args.scenario,
                "agents",
                f"the trace's agent {strangers[0]!r} is not in this scenario "
                f"(its agents: {', '.join(agents)}); give the scenario the trace ran",
            )
    history = History.from_events(events, agents)
    write_report(history, args.html, scenario=scenario, source=args.trace)
    return EXIT_OK


def _start_of(scenario: Scenario) -> str:
    """Where the plans start: the robot's node, or an HDDL agent's problem (docs/design.md §7.1)."""
    hddl = scenario.hddl_robot
    if hddl is not None:
        return f"the :init of {hddl.problem.name}"
    return str(scenario.robot.start)


def _print_plan(
    out: TextIO, scenario: Scenario, agent: str, task: str, found: Sequence[Plan], *, tree: bool = False
) -> None:
    best = found[0]
    domain = scenario.domain_for(agent).name
    print(f"{agent} ({domain}) plans {task} from {_start_of(scenario)}:", file=out)
    if tree:
        for line in tree_lines(plan_tree(best)):
            print(f"  {line}", file=out)
    else:
        width = len(str(len(best)))
        for i, action in enumerate(best.text(), start=1):
            print(f"  {i:>{width}}. {action}", file=out)
    print(f"cost {best.cost:.2f}", file=out)
    costs = ", ".join(f"{p.cost:.2f}" for p in found)
    noun = "plan" if len(found) == 1 else "plans"
    print(f"{len(found)} {noun} found (the best first), costs {costs}", file=out)


def _run(args: argparse.Namespace, restore_signals: bool = True) -> int:
    scenario = load_scenario(scenario_file(args.scenario))
    if scenario.remote:
        import htnagent.remote  # noqa: F401  (the zenoh extra, or one line naming it)
    if args.plot is not None:
        check_plot_target(args.plot)
        check_plot_scenario(scenario, args.scenario)
    if args.timeline is not None:
        check_plot_target(args.timeline, "--timeline")
    if args.plot and args.timeline and _same_file(args.plot, args.timeline):
        raise PlotError(f"{args.plot}: --plot and --timeline name the same file; give each its own")
    with _RunSignals(restore=restore_signals) as signals:
        console = OutputConsole(highlight=False)
        if args.json:
            printer = _Printer(JsonLines(sys.stdout))
        else:
            mode = args.replanning or scenario.replanning
            printer = _Printer(LiveTrace(console, scenario.agent_names))
            title = Text.assemble((printable(scenario.name), "bold"), f"  ({mode} replanning)")
            printer.write(console.print, title)
            printer.write(console.print, Text(KEY, style="dim"))
        run = functools.partial(
            run_scenario,
            scenario,
            replanning=args.replanning,
            speed=args.speed,
            observers=[printer],
            keep_events=bool(args.plot or args.timeline),
        )
        report = anyio.run(_until_interrupted, run, signals)
        if isinstance(printer.error, BrokenPipeError):
            reader_gone()  # the run went on without a reader: its exit code stands
        elif printer.error is not None:
            raise printer.error  # the run went on without its trace: say so (main)
        if not args.json:
            try:
                print_summary(console, report.summary)
            except BrokenPipeError:
                reader_gone()
        if args.plot:
            _save(
                "picture", args.plot, lambda: draw_run(scenario, report.events, args.plot), console, args.json
            )
        if args.timeline:

            def timeline() -> None:
                history = History.from_events(report.events, scenario.agent_names)
                draw_timeline(history, args.timeline, scenario.name)

            _save("timeline", args.timeline, timeline, console, args.json)
        if report.interrupted or signals.received:
            print(f"{PROG}: interrupted", file=sys.stderr)
            return EXIT_INTERRUPTED
    return EXIT_OK if report.succeeded else EXIT_FAILED


def _same_file(a: str, b: str) -> bool:
    """Whether two names lead to one file (the same path, or a link to it)."""
    return os.path.realpath(a) == os.path.realpath(b)


class _Printer:
    """Prints the trace as the run goes; output that cannot be written (a full disk, a
    reader gone) ends the printing, not the run, and is reported after it."""

    def __init__(self, printer: Observer) -> None:
        self.printer = printer
        self.error: OSError | None = None

    def __call__(self, event: TraceEvent) -> None:
        self.write(self.printer, event)

    def write(self, write: Callable[..., object], *what: object) -> None:
        """``write(*what)``, unless the output has failed already; a failure is kept."""
        if self.error is None:
            try:
                write(*what)
            except OSError as e:
                self.error = e


def _save(what: str, file: str, draw: Callable[[], None], console: Console, quiet: bool) -> None:
    """Draw a picture of the run that has ended.  The file was checked before the run; if
    drawing fails after all, say so in one line — the run's result stands."""
    try:
        draw()
    except HtnAgentError as e:
        print(f"{PROG}: error: {one_line(str(e))}", file=sys.stderr)
    else:
        if not quiet:
            console.print(Text(printable(f"{what} saved to {file}")))


class _RunSignals:
    """SIGINT and SIGTERM while a run is under way: noted, never raised.

    The handler only counts; the run looks at the count (see
    :func:`_until_interrupted`) and stops itself, so no exception can land in
    the middle of the runtime or of printing the summary, and a second signal
    during shutdown changes nothing.  The handlers in place before are put back
    on exit if ``restore``.  Only the main thread can take signals over;
    elsewhere this does nothing (and a run there is stopped by its caller).  A
    signal ignored when the run starts (``trap '' INT``) stays ignored.
    """

    SIGNALS = (signal.SIGINT, signal.SIGTERM)

    def __init__(self, restore: bool = True) -> None:
        self.received = 0
        self._restore = restore
        self._saved: list[tuple[int, object]] = []

    def _note(self, signum: int, frame: FrameType | None) -> None:
        self.received += 1
        stop_searches()  # a search under way ends now: the run then sees the signal

    def __enter__(self) -> Self:
        if threading.current_thread() is threading.main_thread():
            for sig in self.SIGNALS:
                if signal.getsignal(sig) is not signal.SIG_IGN:
                    self._saved.append((sig, signal.signal(sig, self._note)))
        return self

    def __exit__(
        self, kind: type[BaseException] | None, error: BaseException | None, tb: TracebackType | None
    ) -> None:
        stop_searches(False)
        if self._restore:
            for sig, handler in reversed(self._saved):
                signal.signal(sig, handler)  # type: ignore[arg-type]  # as getsignal gave it
        self._saved.clear()


# How often a run looks for a signal: a handler cannot wake an event loop on every
# backend, so the run polls; 50 ms is quick for a person and costs nothing.
_SIGNAL_POLL_S = 0.05
# A serving process polls less often: it runs for as long as its robots do, and a fleet
# runs several on one host (ten for a hundred robots), each waking its event loop for
# nothing at every poll.  A quarter second is still quick to stop.
_SERVE_POLL_S = 0.25


async def _until_interrupted(run: Callable[..., Awaitable[RunReport]], signals: _RunSignals) -> RunReport:
    """Run; the first SIGINT or SIGTERM (noted by ``signals``) stops the run cleanly with its summary."""
    stop = anyio.Event()

    async def watch() -> None:
        while not signals.received:  # noqa: ASYNC110  (a signal handler cannot set an anyio.Event)
            await anyio.sleep(_SIGNAL_POLL_S)
        stop.set()

    async with anyio.create_task_group() as tg:
        tg.start_soon(watch)
        report = await run(stop=stop)
        tg.cancel_scope.cancel()
    return report


# -- serve: one agent for a parent in another process (docs/contracts.md "Agents in other processes")


def _endpoint(text: str) -> str:
    """``--listen``: ``tcp/HOST:PORT`` or ``tls/HOST:PORT``."""
    from htnagent.scenario.wording import ENDPOINT_PATTERN

    if re.fullmatch(ENDPOINT_PATTERN, text) is None:
        raise argparse.ArgumentTypeError(f"expected tcp/HOST:PORT or tls/HOST:PORT, got {text!r}")
    return text


def _add_serve(sub: argparse._SubParsersAction[_Parser]) -> None:
    serve = sub.add_parser(
        "serve",
        help="serve one agent (and the agents below it) to its parent in another process",
        description="Serve AGENT of each scenario (a robot each, one Zenoh session for all) at "
        "ENDPOINT. Off the loopback the link must be TLS: tls/HOST:PORT with --certificate and "
        "--key, and --root-ca (mutual TLS: the parent shows a certificate signed by it) or "
        "--users (Zenoh's user/password).",
    )
    serve.add_argument("scenario", nargs="+", metavar="SCENARIO", help=_SCENARIO_HELP)
    serve.add_argument("--agent", required=True, metavar="NAME", help="the agent to serve")
    serve.add_argument(
        "--listen",
        type=_endpoint,
        default="tcp/127.0.0.1:7447",
        metavar="ENDPOINT",
        help="where the parent connects, tcp/HOST:PORT or tls/HOST:PORT "
        "(default: tcp/127.0.0.1:7447, loopback only)",
    )
    serve.add_argument(
        "--speed", type=_speed, metavar="X", help="simulated seconds per real second (default 1)"
    )
    serve.add_argument(
        "--root-ca", metavar="FILE", help="TLS: the root certificate parents' must be signed by"
    )
    serve.add_argument("--certificate", metavar="FILE", help="TLS: this process's certificate")
    serve.add_argument("--key", metavar="FILE", help="TLS: the private key of --certificate")
    serve.add_argument(
        "--users", metavar="FILE", help="Zenoh's user/password authentication: lines user:password"
    )
    serve.add_argument(
        "--allow",
        action="append",
        metavar="NAME",
        help="only this parent may use the link (repeatable): its certificate's common name with "
        "--root-ca, its user name with --users; Zenoh's access control denies everyone else",
    )
    serve.add_argument(
        "--insecure",
        action="store_true",
        help="allow a plain tcp/ endpoint off the loopback: anyone who reaches it can order the robot",
    )


def _listen_security(args: argparse.Namespace) -> Security | None:
    """How ``serve`` secures its endpoint, from its options; SettingsError unless it is safe
    (off the loopback: TLS with mutual authentication or user/password) or ``--insecure``."""
    from htnagent.remote.link import Security
    from htnagent.scenario.schema import on_loopback

    listen: str = args.listen
    tls = listen.startswith("tls/")
    for option in ("root_ca", "certificate", "key", "users"):
        name = getattr(args, option)
        if name is not None and not Path(name).is_file():
            raise SettingsError(f"--{option.replace('_', '-')} {name}: no such file")
    if tls:
        if args.certificate is None or args.key is None:
            raise SettingsError(f"--listen {listen}: TLS needs this process's --certificate and --key")
        if args.root_ca is None and args.users is None:
            raise SettingsError(
                f"--listen {listen}: TLS needs --root-ca (mutual TLS: parents show a certificate "
                "signed by it) or --users (Zenoh's user/password), else anyone could connect"
            )
    elif args.root_ca is not None or args.certificate is not None or args.key is not None:
        raise SettingsError(f"--listen {listen}: certificates need a tls/ endpoint")
    elif not on_loopback(listen):
        if not args.insecure:
            raise SettingsError(
                f"--listen {listen} is off the loopback: anyone who reaches it could order the robot; "
                "use tls/HOST:PORT with --certificate, --key and --root-ca or --users "
                "(or --insecure to allow it anyway)"
            )
        print(
            f"{PROG}: WARNING: --insecure: {listen} is plain TCP off the loopback: anyone who reaches "
            "it can read every message and order the robot",
            file=sys.stderr,
            flush=True,
        )
    allow = tuple(args.allow or ())
    if allow and args.root_ca is None and args.users is None:
        raise SettingsError("--allow names a parent by its certificate (--root-ca) or user name (--users)")
    if tls and not allow and not on_loopback(listen) and not args.insecure:
        # A certificate of the same root (or another user of --users) gets onto the link; only
        # Zenoh's access control, by name, keeps it off the robot's keys (the payloads' session
        # id is only a claim).
        raise SettingsError(
            f"--listen {listen} is off the loopback: name the parent that may command the robot "
            "(--allow NAME: its certificate's common name, or its user name), else anyone with a "
            "certificate of the same root could (or --insecure to allow it anyway)"
        )
    if not tls and args.users is None:
        return None
    return Security(
        root_ca=args.root_ca,
        certificate=args.certificate,
        key=args.key,
        mutual=args.root_ca is not None,
        users_file=args.users,
        allow=allow,
    )


def _serve(args: argparse.Namespace, restore_signals: bool = True) -> int:
    scenarios = [load_scenario(scenario_file(name)) for name in args.scenario]
    import htnagent.remote  # noqa: F401  (the zenoh extra, or one line naming it)
    from htnagent.remote.link import sessions_open
    from htnagent.system.fleet import check_fleet
    from htnagent.system.serving import check_served, serve

    security = _listen_security(args)
    for scenario in scenarios:
        check_served(scenario, args.agent)
    check_fleet(scenarios)

    def ready() -> None:
        spaces = ", ".join(s.key_space for s in scenarios)
        label = "namespace" if len(scenarios) == 1 else f"{len(scenarios)} robots, namespaces"
        sessions = sessions_open()
        print(
            f"serving {args.agent} at {args.listen} ({label} {spaces}; "
            f"{sessions} Zenoh session{'s' if sessions != 1 else ''})",
            flush=True,
        )

    async def until_interrupted(signals: _RunSignals) -> None:
        stop = anyio.Event()

        async def watch() -> None:
            while not signals.received:  # noqa: ASYNC110  (a signal handler cannot set an anyio.Event)
                await anyio.sleep(_SERVE_POLL_S)
            stop.set()

        async with anyio.create_task_group() as tg:
            tg.start_soon(watch)
            await serve(
                scenarios,
                args.agent,
                args.listen,
                speed=args.speed,
                ready=ready,
                stop=stop,
                security=security,
            )
            tg.cancel_scope.cancel()

    with _RunSignals(restore=restore_signals) as signals:
        anyio.run(until_interrupted, signals)
    print(f"{PROG}: interrupted", file=sys.stderr)
    return EXIT_INTERRUPTED


def _add_certs(sub: argparse._SubParsersAction[_Parser]) -> None:
    certs = sub.add_parser(
        "certs",
        help="make a self-signed root and peer certificates for a TEST fleet (mutual TLS)",
        description="Write DIR/root.pem, DIR/root.key and, per peer, DIR/NAME.pem and DIR/NAME.key "
        "(unencrypted keys, readable by their owner only), for trying remote agents over mutual "
        "TLS. For tests and trials only: a real fleet's certificates come from its own authority.",
    )
    certs.add_argument("folder", metavar="DIR", help="the folder to write into (made if need be)")
    certs.add_argument(
        "--peer",
        action="append",
        metavar="NAME",
        help="a peer to make a certificate for (repeatable; default: serve and parent)",
    )
    certs.add_argument(
        "--host",
        action="append",
        metavar="NAME",
        help="a host name or address the certificates are for (repeatable; default: "
        "localhost, 127.0.0.1, ::1)",
    )


def _certs(args: argparse.Namespace) -> int:
    import htnagent.remote  # noqa: F401  (the zenoh extra, or one line naming it)
    from htnagent.remote.certs import DEFAULT_HOSTS, DEFAULT_PEERS, make_certificates

    written = make_certificates(
        Path(args.folder), peers=args.peer or DEFAULT_PEERS, hosts=args.host or DEFAULT_HOSTS
    )
    for path in written:
        print(path)
    return EXIT_OK


# -- compare: the scenario on-line and naive, side by side (docs/contracts.md "Command line")

_MODES = ("online", "naive")


def _add_compare(sub: argparse._SubParsersAction[_Parser]) -> None:
    compare = sub.add_parser(
        "compare",
        help="run the scenario in both replanning modes and print them side by side",
        description="Run the scenario on-line, then naive, and print per mode the goals' outcomes, "
        "the distance, the whole-run planning time, the agents' replanning and the window at "
        "each resumption, and the wall time. Exit 0 if every goal succeeded in both modes, 1 if not.",
    )
    compare.add_argument("scenario", metavar="SCENARIO", help="the scenario file (YAML)")
    compare.add_argument(
        "--json", action="store_true", help='one JSON object: {"online": {...}, "naive": {...}}'
    )


def _compare(args: argparse.Namespace, restore_signals: bool = True) -> int:
    scenario = load_scenario(scenario_file(args.scenario))
    for i, agent in enumerate(scenario.agents):
        if agent.remote:
            raise ScenarioError(
                scenario.file,
                f"agents[{i}].remote",
                "compare runs every agent in this process, in each mode; "
                "run each mode with run --replanning instead",
            )
    summaries: dict[str, Summary] = {}
    walls: dict[str, float] = {}
    with _RunSignals(restore=restore_signals) as signals:
        # One run first, unmeasured: neither mode pays the process's start-up (imports, caches).
        warm_up = anyio.run(_until_interrupted, functools.partial(run_scenario, scenario), signals)
        if warm_up.interrupted or signals.received:
            print(f"{PROG}: interrupted", file=sys.stderr)
            return EXIT_INTERRUPTED
        for mode in _MODES:
            started = time.perf_counter()
            report = anyio.run(
                _until_interrupted, functools.partial(run_scenario, scenario, replanning=mode), signals
            )
            walls[mode] = time.perf_counter() - started
            if report.interrupted or signals.received:
                print(f"{PROG}: interrupted", file=sys.stderr)
                return EXIT_INTERRUPTED
            summaries[mode] = report.summary
    if args.json:
        both = {mode: _compared(summary, walls[mode]) for mode, summary in summaries.items()}
        print(json.dumps(both, separators=(",", ":")))
    else:
        _print_comparison(Console(highlight=False), scenario, summaries, walls)
    return EXIT_OK if all(s.succeeded for s in summaries.values()) else EXIT_FAILED


def _compared(summary: Summary, wall_s: float) -> dict[str, object]:
    """One mode's object of ``compare --json``: the summary's fields, whether every goal
    succeeded, and the run's wall time."""
    data = summary.as_dict()
    return {
        "succeeded": summary.succeeded,
        **{k: v for k, v in data.items() if k not in ("t", "agent", "event")},
        "wall_s": round(wall_s, 4),
    }


def _print_comparison(
    console: Console, scenario: Scenario, summaries: dict[str, Summary], walls: dict[str, float]
) -> None:
    online, naive = summaries["online"], summaries["naive"]
    table = Table(title=Text(printable(scenario.name), style="bold"), show_edge=False)
    for name in ("", "on-line", "naive", "naive/on-line"):
        table.add_column(name, justify="right" if name else "left")

    def ratio(a: float | None, b: float | None) -> str:
        return f"{b / a:.1f}×" if a and b is not None else ""

    def figures(label: str, a: float | None = None, b: float | None = None) -> None:
        table.add_row(label, _ms(a), _ms(b), ratio(a, b))

    for i, (on, na) in enumerate(zip(online.goals, naive.goals, strict=True)):
        mark = Text(" emergency", style="bold red") if on.emergency else ""
        table.add_row(
            Text.assemble(printable(f"{i + 1}. {on.goal} ({on.agent})"), mark),
            _status(on.status),
            _status(na.status),
            "",
        )
        for k in range(max(len(on.resumes), len(na.resumes))):
            a = on.resumes[k] if k < len(on.resumes) else None
            b = na.resumes[k] if k < len(na.resumes) else None
            when = a.t if a is not None else b.t if b is not None else 0.0
            replans = [None if r is None else r.replan_ms for r in (a, b)]
            windows = [None if r is None else r.window_ms for r in (a, b)]
            figures(f"   resumed at {when:.2f} s: replanning ms", *replans)
            figures("   window ms", *windows)
    planning = sum(online.planning_ms.values()), sum(naive.planning_ms.values())
    table.add_row("distance m", f"{online.distance:.2f}", f"{naive.distance:.2f}", "")
    figures("planning ms (whole run)", *planning)
    table.add_row("run ends at s (simulated)", f"{online.t:.2f}", f"{naive.t:.2f}", "")
    table.add_row("wall time s", f"{walls['online']:.3f}", f"{walls['naive']:.3f}", "")
    print_whole(console, table)
    for mode, summary in summaries.items():
        for g in summary.goals:
            if g.reason:
                console.print(
                    Text(printable(f"{mode}: {g.goal} failed: {g.reason}"), style="red"), soft_wrap=True
                )
    if any(g.resumes for summary in summaries.values() for g in summary.goals):
        console.print(Text(RESUME_KEY, style="dim"), soft_wrap=True)


def _status(status: str) -> Text:
    return Text(status, style="green" if status == "success" else "red")


def _ms(value: float | None) -> str:
    return "" if value is None else f"{value:.3f}"
