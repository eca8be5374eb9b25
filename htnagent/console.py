"""Printing a run for people (rich) and for programs (JSON Lines).

:class:`LiveTrace` prints one readable line per trace event as the run goes:
the time, the agent (indented by its level), and what happened — the selected
plan, each action, suspensions and resumptions with the stack depth, the
replanning time.  :class:`JsonLines` writes each event as one JSON line.
"""

from __future__ import annotations

import json
from collections.abc import Sequence
from typing import IO, Any

from rich.console import Console
from rich.table import Table
from rich.text import Text

from htnagent.trace import Event

_STYLES = ["bold cyan", "bold green", "bold magenta", "bold yellow", "bold blue"]


class JsonLines:
    """Writes each event as one JSON line, the ``summary`` last (CONTRACTS.md ``run --json``).

    When a run is interrupted, a reply already on its way (a robot's
    ``message``) can be traced after the summary; such stragglers are left out,
    so that the summary stays the last line.
    """

    def __init__(self, out: IO[str]) -> None:
        self.out = out
        self.done = False

    def __call__(self, event: Event) -> None:
        if self.done:
            return
        self.out.write(json.dumps(event, separators=(",", ":")) + "\n")
        self.out.flush()
        self.done = event.get("event") == "summary"


class LiveTrace:
    """A readable live trace; ``agents`` parent first (their order sets the indent)."""

    def __init__(self, console: Console, agents: Sequence[str]) -> None:
        self.console = console
        self.level = {name: i for i, name in enumerate(agents)}
        self.level.setdefault("robot", len(agents))

    def __call__(self, event: Event) -> None:
        text = self._describe(event)
        if text is None:
            return
        agent = event["agent"]
        level = self.level.get(agent, 0)
        line = Text(f"{event['t']:>9.2f}s ", style="dim")
        line.append("  " * level)
        line.append(
            f"{agent:<10} ", style=_STYLES[level % len(_STYLES)] if agent in self.level else "bold red"
        )
        line.append_text(text)
        self.console.print(line, soft_wrap=True, highlight=False)

    def _describe(self, e: Event) -> Text | None:
        kind = e["event"]
        if kind == "goal_received":
            flag = Text(" EMERGENCY", style="bold red") if e.get("emergency") else Text("")
            return Text.assemble("◆ goal ", (e["goal"], "bold"), flag)
        if kind == "plan_selected":
            return Text.assemble(
                "  plan ", (" → ".join(e["plan"]) or "(nothing to do)", "italic"), f"  cost {e['cost']:.2f}"
            )
        if kind == "action_started":
            return Text.assemble("  ▶ ", e["action"])
        if kind == "action_finished":
            style = {"success": "green", "failure": "red", "suspended": "yellow"}.get(e["result"], "")
            reason = f" ({e['reason']})" if e.get("reason") else ""
            return Text.assemble("  ", (f"{e['result']}", style), f" {e['action']}{reason}")
        if kind == "goal_suspended":
            return Text.assemble(("⏸ suspended ", "yellow"), e["goal"], f"  stack depth {e['stack_depth']}")
        if kind == "goal_resumed":
            return Text.assemble(
                ("⏵ resumed ", "yellow"), e["goal"], f"  {e['replanning']} replanning {e['replan_ms']:.3f} ms"
            )
        if kind == "goal_cleared":
            return Text.assemble(("✕ cleared ", "yellow"), e["goal"])
        if kind == "goal_finished":
            ok = e["status"] == "success"
            reason = f" ({e['reason']})" if e.get("reason") else ""
            return Text.assemble(
                ("✔ " if ok else "✘ ", "green" if ok else "red"), f"{e['goal']} {e['status']}{reason}"
            )
        if kind in ("arc_closed", "arc_opened"):
            return Text(f"{'closed' if kind == 'arc_closed' else 'opened'} {e['arc']}", style="bold red")
        if kind == "suspend_refused":
            return Text(f"  cannot suspend {e['action']}: it goes on", style="yellow")
        if kind == "message" and e["kind"] in ("suspend", "resume", "clear", "suspended", "refused"):
            return Text(f"  ✉ {e['kind']} {e['action']} → {e['to']}", style="dim")
        if kind == "agent_crashed":
            return Text(f"crashed: {e['error']}", style="bold red")
        return None


def print_summary(console: Console, summary: dict[str, Any]) -> None:
    """The summary as a small table and a few lines."""
    table = Table(title="goals", show_edge=False)
    table.add_column("agent")
    table.add_column("goal")
    table.add_column("status")
    for g in summary["goals"]:
        status = g["status"] + (f" ({g['reason']})" if g.get("reason") else "")
        table.add_row(
            g["agent"], g["goal"], Text(status, style="green" if g["status"] == "success" else "red")
        )
    console.print(table)
    where = summary["robot"]
    place = f"at {where['at']}" if "at" in where else f"on {where.get('on')}"
    console.print(
        f"robot {place}; travelled {summary['distance']:.2f} m through {' '.join(summary['visited'])}"
    )
    planning = ", ".join(f"{k} {v:.1f} ms" for k, v in summary["planning_ms"].items())
    console.print(f"planning time: {planning}")
