"""Printing a run for people (rich) and for programs (JSON Lines).

:class:`LiveTrace` prints one readable line per trace event as the run goes:
the time, the agent (indented by its level), and what happened — the selected
plan, each action, suspensions and resumptions with the stack depth, the
replanning time.  :class:`JsonLines` writes each event as one JSON line.
"""

from __future__ import annotations

import json
from collections.abc import Sequence
from typing import IO

from rich.console import Console
from rich.table import Table
from rich.text import Text

from htnagent.runtime.events import (
    ActionFinished,
    ActionStarted,
    AgentCrashed,
    ArcClosed,
    ArcOpened,
    FactsChanged,
    GoalCleared,
    GoalFinished,
    GoalReceived,
    GoalResumed,
    GoalSuspended,
    MessageSent,
    PlanSelected,
    Summary,
    SuspendRefused,
    TraceEvent,
)

KEY = "◆ goal given  ▶ action  ⏸ suspended (on the stack)  ⏵ resumed  ✔ ✘ ended"
"""The marks of the live trace, printed under its title."""

_STYLES = ["bold cyan", "bold green", "bold magenta", "bold yellow", "bold blue"]


def printable(text: str) -> str:
    """``text`` with control characters written as escapes (``\\x1b``, ``\\n``): names come
    from the user's files, and the terminal must show them, not obey them."""
    if text.isprintable():
        return text
    return "".join(c if c.isprintable() else c.encode("unicode_escape").decode("ascii") for c in text)


class OutputConsole(Console):
    """A rich console whose closed pipe (``| head``) is a :class:`BrokenPipeError` for the
    command to handle, as any write error is: rich's own ends the process with exit 1."""

    def on_broken_pipe(self) -> None:
        self.quiet = True  # what is still to be printed goes nowhere
        raise BrokenPipeError(32, "Broken pipe")


def search_progress(search: str, expansions: int, seconds: float) -> str:
    """How far a search has got, in one line: ``searching (gbfs): 1,234,567 expansions, 12.3 s``."""
    return f"searching ({search}): {expansions:,} expansions, {seconds:.1f} s"


class SearchProgress:
    """Shows a long search's progress on one line of a terminal, rewritten in place
    (``plan --hddl``); :meth:`close` wipes it, so that the answer stands alone."""

    def __init__(self, out: IO[str]) -> None:
        self.out = out
        self.shown = False

    def __call__(self, search: object, expansions: int, seconds: float) -> None:
        name = getattr(search, "value", search)
        self.out.write(f"\r{search_progress(str(name), expansions, seconds)}\x1b[K")
        self.out.flush()
        self.shown = True

    def close(self) -> None:
        if self.shown:
            self.out.write("\r\x1b[K")
            self.out.flush()
            self.shown = False


class JsonLines:
    """Writes each event as one JSON line, the ``summary`` last (docs/contracts.md ``run --json``).

    When a run is interrupted, a reply already on its way (a robot's
    ``message``) can be traced after the summary; such stragglers are left out,
    so that the summary stays the last line.
    """

    def __init__(self, out: IO[str]) -> None:
        self.out = out
        self.done = False

    def __call__(self, event: TraceEvent) -> None:
        if self.done:
            return
        self.out.write(json.dumps(event.as_dict(), separators=(",", ":")) + "\n")
        self.out.flush()
        self.done = isinstance(event, Summary)


class LiveTrace:
    """A readable live trace; ``agents`` parent first (their order sets the indent)."""

    def __init__(self, console: Console, agents: Sequence[str]) -> None:
        self.console = console
        self.level = {name: i for i, name in enumerate(agents)}
        self.level.setdefault("robot", len(agents))

    def __call__(self, event: TraceEvent) -> None:
        text = _describe(event)
        if text is None:
            return
        agent = event.agent
        level = self.level.get(agent, 0)
        # The time alone is dim: a style given to Text() itself would dim the whole line.
        line = Text()
        line.append(f"{event.t:>9.2f}s ", style="dim")
        line.append("  " * level)
        line.append(
            f"{agent:<10} ", style=_STYLES[level % len(_STYLES)] if agent in self.level else "bold red"
        )
        line.append_text(text)
        if not line.plain.isprintable():  # a name with control characters: shown escaped, unstyled
            line = Text(printable(line.plain))
        self.console.print(line, soft_wrap=True, highlight=False)


def _describe(e: TraceEvent) -> Text | None:
    """One readable line for the events a person wants to follow (None: not shown)."""
    match e:
        case GoalReceived():
            flag = Text(" EMERGENCY", style="bold red") if e.emergency else Text("")
            return Text.assemble("◆ goal ", (e.goal, "bold"), flag)
        case PlanSelected():
            return Text.assemble(
                "  plan ", (" → ".join(e.plan) or "(nothing to do)", "italic"), f"  cost {e.cost:.2f}"
            )
        case ActionStarted():
            return Text.assemble("  ▶ ", e.action)
        case ActionFinished():
            style = {"success": "green", "failure": "red", "suspended": "yellow"}[e.result]
            reason = f" ({e.reason})" if e.reason else ""
            return Text.assemble("  ", (e.result, style), f" {e.action}{reason}")
        case GoalSuspended():
            return Text.assemble(("⏸ suspended ", "yellow"), e.goal, f"  stack depth {e.stack_depth}")
        case GoalResumed():
            return Text.assemble(
                ("⏵ resumed ", "yellow"), e.goal, f"  {e.replanning} replanning {e.replan_ms:.3f} ms"
            )
        case GoalCleared():
            return Text.assemble(("✕ cleared ", "yellow"), e.goal)
        case GoalFinished():
            ok = e.status == "success"
            reason = f" ({e.reason})" if e.reason else ""
            return Text.assemble(
                ("✔ " if ok else "✘ ", "green" if ok else "red"), f"{e.goal} {e.status}{reason}"
            )
        case ArcClosed():
            return Text(f"closed {e.arc}", style="bold red")
        case ArcOpened():
            return Text(f"opened {e.arc}", style="bold red")
        case FactsChanged():
            changes = [*(f"+{f}" for f in e.add), *(f"-{f}" for f in e.delete)]
            return Text(f"world: {' '.join(changes)}", style="bold red")
        case SuspendRefused():
            return Text(f"  cannot suspend {e.action}: it goes on", style="yellow")
        case MessageSent() if e.kind in ("suspend", "resume", "clear", "suspended", "refused"):
            return Text(f"  ✉ {e.kind} {e.action} → {e.to}", style="dim")
        case AgentCrashed():
            return Text(f"crashed: {e.error}", style="bold red")
    return None


def print_summary(console: Console, summary: Summary) -> None:
    """The summary as a small table and a few lines: each goal's times (simulated seconds),
    then each resumption with the agents' replanning and the window (wall clock)."""
    table = Table(title="goals (times in simulated seconds)", show_edge=False)
    # On a narrow terminal a cell is folded, never cut short.
    table.add_column("agent", overflow="fold")
    table.add_column("goal", overflow="fold")
    table.add_column("", overflow="fold")  # the emergency mark
    for name in ("given", "started", "ended", "waited"):
        table.add_column(name, justify="right", overflow="fold")
    table.add_column("status", overflow="fold")
    for g in summary.goals:
        status = g.status + (f" ({g.reason})" if g.reason else "")
        style = "green" if g.status == "success" else "red"
        table.add_row(
            Text(printable(g.agent)),
            Text(printable(g.goal)),
            Text("emergency" if g.emergency else "", style="bold red"),
            _seconds(g.given),
            _seconds(g.started),
            _seconds(g.ended),
            _seconds(g.waited_s) if g.waited_s else "",
            Text(printable(status), style=style),
        )
    print_whole(console, table)
    resumes = sorted(((r, g) for g in summary.goals for r in g.resumes), key=lambda rg: rg[0].t)
    for r, g in resumes:
        window = "" if r.window_ms is None else f", window {r.window_ms:.3f} ms"
        line = f"⏵ {g.goal} resumed at {r.t:.2f} s: replanning {r.replan_ms:.3f} ms{window}"
        console.print(Text(printable(line)))
    if resumes:
        console.print(Text(RESUME_KEY, style="dim"), soft_wrap=True)
    where = summary.robot
    if where:  # a robot on a map (an HDDL agent's robot is on none)
        place = f"at {where['at']}" if "at" in where else f"on {where.get('on')}"
        travelled = f"robot {place}; travelled {summary.distance:.2f} m through {' '.join(summary.visited)}"
        console.print(Text(printable(travelled)))
    planning = ", ".join(f"{k} {v:.1f} ms" for k, v in summary.planning_ms.items())
    console.print(Text(printable(f"planning time: {planning}")))


RESUME_KEY = (
    "  replanning: the agents' own work as the goal resumed; window: from the emergency's end "
    "to the resumed goal's first order at the robot (wall clock: they differ from run to run)"
)
"""What the summary's resumption figures mean, printed under them."""


def print_whole(console: Console, table: Table) -> None:
    """Print the table; into a file or a pipe no screen is in the way, so it keeps its
    natural width rather than the 80 columns rich assumes there."""
    if console.is_terminal:
        console.print(table)
        return
    narrow = console.width
    whole = console.measure(table, options=console.options.update(max_width=10_000)).maximum
    console.width = max(narrow, whole)
    try:
        console.print(table)
    finally:
        console.width = narrow


def _seconds(t: float | None) -> str:
    return "" if t is None else f"{t:.2f}"
