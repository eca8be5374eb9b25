"""A run answers the paper's question: the summary gives each goal's times and, at each
resumption, what it cost (docs/contracts.md "Trace events", `summary`); ``compare`` runs
both modes side by side (docs/contracts.md "Command line").

The shipped runs come from ``tests.support.shipped_run`` (once per session); the naive
museum run, once per module.
"""

from __future__ import annotations

import functools
import io
import json
from pathlib import Path
from typing import Any

import anyio
import pytest
from rich.console import Console

from htnagent.cli.commands import main
from htnagent.runtime.events import Summary, TraceEvent
from htnagent.scenario import load_scenario
from htnagent.system.simulation import RunReport, run_scenario
from htnagent.views.console import print_summary
from tests.remote_support import remote_scenario
from tests.support import SCENARIO_DIR, as_dicts, inline, shipped_run, write_trace

MUSEUM = SCENARIO_DIR / "museum.yaml"


def summary_of_run(events: tuple[TraceEvent, ...]) -> Summary:
    last = events[-1]
    assert isinstance(last, Summary)
    return last


def of(
    events: tuple[TraceEvent, ...], kind: str, agent: str, goal: str | None = None
) -> list[dict[str, Any]]:
    return [
        e
        for e in as_dicts(events)
        if e["event"] == kind and e["agent"] == agent and (goal is None or e.get("goal") == goal)
    ]


@functools.cache
def naive_museum() -> RunReport:
    return anyio.run(functools.partial(run_scenario, load_scenario(MUSEUM), replanning="naive"))


# -- the summary's goals -------------------------------------------------------------------------


def test_the_museum_summary_gives_the_emergency_its_times_and_the_first_goal_its_wait_and_resume() -> None:
    _, events = shipped_run("museum.yaml")
    first, emergency = summary_of_run(events).goals
    # Expect: goto(n1) given at 0, suspended when goto(n28) came, resumed once when it ended.
    assert (first.goal, first.emergency, first.given, first.started) == ("goto(n1)", False, 0.0, 0.0)
    assert (emergency.goal, emergency.emergency) == ("goto(n28)", True)
    # The emergency is given at its trigger: half way along move(n40,n35,arc59).
    move = next(e for e in as_dicts(events) if e["event"] == "robot_moving" and e["arc"] == "arc59")
    assert emergency.given == pytest.approx(move["t"] + 0.5 * move["duration"], abs=1e-6)
    assert emergency.started == emergency.given  # it suspends the running goal at once
    assert emergency.ended == of(events, "goal_finished", "guide", "goto(n28)")[0]["t"]
    assert emergency.waited_s == 0.0 and emergency.resumes == ()
    suspended = of(events, "goal_suspended", "guide", "goto(n1)")
    resumed = of(events, "goal_resumed", "guide", "goto(n1)")
    assert len(suspended) == len(resumed) == 1
    assert first.waited_s > 0
    assert first.waited_s == pytest.approx(resumed[0]["t"] - suspended[0]["t"], abs=1e-6)
    assert first.ended == of(events, "goal_finished", "guide", "goto(n1)")[0]["t"] > emergency.ended
    (resume,) = first.resumes
    assert resume.t == resumed[0]["t"] == emergency.ended
    assert resume.replan_ms >= 0 and resume.window_ms is not None and resume.window_ms >= 0
    # The agents' replanning counts the guide's own (its goal_resumed's) and the navigator's.
    assert resume.replan_ms >= resumed[0]["replan_ms"] - 1e-3


def test_nested_emergencies_give_each_suspended_goal_its_own_resume_and_wait() -> None:
    _, events = shipped_run("nested_emergencies.yaml")
    first, n28, n38 = summary_of_run(events).goals
    assert [g.emergency for g in (first, n28, n38)] == [False, True, True]
    assert n38.given == 10.0 and n38.resumes == () and n38.waited_s == 0.0
    # Expect: goto(n28) waits under goto(n38), then goto(n1) under goto(n28): a resume each.
    for goal, above in ((n28, n38), (first, n28)):
        (resume,) = goal.resumes
        (suspended,) = of(events, "goal_suspended", "guide", goal.goal)
        assert resume.t == above.ended
        assert goal.waited_s == pytest.approx(resume.t - suspended["t"], abs=1e-6)
        assert resume.replan_ms >= 0 and resume.window_ms is not None and resume.window_ms >= 0
    assert n28.resumes[0].t < first.resumes[0].t


def test_each_resumption_counts_the_parent_and_the_child_and_the_window_holds_both() -> None:
    report = naive_museum()
    (resumption,) = report.resumptions("guide")
    # Expect: the guide's goal_resumed, then the navigator planning the guide's first order.
    assert list(resumption.replan_ms) == ["guide", "navigator"]
    assert resumption.replan_ms["navigator"] > 0
    assert resumption.order_ms is not None and resumption.window_ms is not None
    assert resumption.window_ms >= resumption.order_ms >= 0
    (row,) = report.summary.goals[0].resumes
    assert row.replan_ms == pytest.approx(resumption.total_ms, abs=1e-3)


def test_a_goal_never_given_has_no_times() -> None:
    scenario = inline(
        {
            "robot": {"start": "n40", "speed": 1.0},
            "agents": [{"name": "navigator", "domain": "museum.nodes", "executor": "robot"}],
            "goals": [
                {"agent": "navigator", "task": "goto_node(n35)"},
                {
                    "agent": "navigator",
                    "task": "goto_node(n1)",
                    "when": {"action": "move(n1,n2,arc1)", "progress": 0.5},  # never happens
                },
            ],
        }
    )
    report = anyio.run(run_scenario, scenario)
    done, never = report.summary.goals
    assert done.status == "success" and done.ended is not None and done.ended > 0
    assert (never.given, never.started, never.ended, never.waited_s, never.resumes) == (
        None,
        None,
        None,
        0.0,
        (),
    )


def test_the_text_summary_shows_the_emergency_the_times_and_each_resumption() -> None:
    _, events = shipped_run("nested_emergencies.yaml")
    summary = summary_of_run(events)
    out = io.StringIO()
    print_summary(Console(file=out, width=120), summary)
    text = out.getvalue()
    assert text.count("emergency") >= 2
    for word in ("given", "started", "ended", "waited"):
        assert word in text
    lines = [line for line in text.splitlines() if "resumed at" in line]
    # In time order: goto(n28) first (under goto(n38)), then goto(n1).
    assert [line.split()[1] for line in lines] == ["goto(n28)", "goto(n1)"]
    assert all("replanning" in line and "ms" in line and "window" in line for line in lines)


def test_a_trace_saved_before_the_goals_had_times_still_makes_a_report(tmp_path: Path) -> None:
    _, events = shipped_run("museum.yaml")
    trace = write_trace(events, tmp_path / "old.jsonl")
    lines = trace.read_text().splitlines()
    old = json.loads(lines[-1])
    old["goals"] = [{k: g[k] for k in ("agent", "goal", "status")} for g in old["goals"]]
    trace.write_text("\n".join([*lines[:-1], json.dumps(old)]) + "\n")
    assert main(["report", str(trace), "--html", str(tmp_path / "old.html")]) == 0


# -- compare ---------------------------------------------------------------------------------------


def test_compare_json_gives_both_modes_as_separate_runs_give_them(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["compare", str(MUSEUM), "--json"]) == 0
    out = capsys.readouterr().out
    assert len(out.splitlines()) == 1
    both = json.loads(out)
    assert list(both) == ["online", "naive"]
    _, events = shipped_run("museum.yaml")  # the museum's own mode is online
    alone = {"online": summary_of_run(events), "naive": naive_museum().summary}
    for mode, data in both.items():
        assert data["succeeded"] is True and data["wall_s"] > 0
        assert set(data) >= {"goals", "robot", "visited", "distance", "planning_ms"}
        rows = [(g["agent"], g["goal"], g["status"], g.get("reason", "")) for g in data["goals"]]
        assert tuple(rows) == alone[mode].outcomes
        assert data["distance"] == pytest.approx(alone[mode].distance, abs=1e-6)
        assert data["visited"] == list(alone[mode].visited)
        (resume,) = data["goals"][0]["resumes"]
        assert set(resume) == {"t", "replan_ms", "window_ms"} and resume["replan_ms"] >= 0
        assert set(data["planning_ms"]) == {"guide", "navigator"}


def test_compare_prints_both_modes_side_by_side(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["compare", str(SCENARIO_DIR / "nested_emergencies.yaml")]) == 0
    out = capsys.readouterr().out
    assert "on-line" in out and "naive" in out
    assert out.count("replanning ms") == 2 and out.count("window ms") == 2
    for row in ("distance m", "planning ms (whole run)", "wall time s"):
        assert row in out


def test_compare_exits_1_when_a_goal_fails_in_a_mode(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["compare", str(SCENARIO_DIR / "unreachable_goal.yaml")]) == 1
    out = capsys.readouterr().out
    assert "online: goto(n40) failed" in out and "naive: goto(n40) failed" in out


def test_compare_refuses_bad_input_in_one_line(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["compare", str(tmp_path / "missing.yaml")]) == 2
    err = capsys.readouterr().err
    assert err.startswith("htnagent: error: ") and len(err.splitlines()) == 1
    remote = remote_scenario(tmp_path, 7999)
    assert main(["compare", str(remote)]) == 2
    err = capsys.readouterr().err
    assert len(err.splitlines()) == 1 and "agents[1].remote" in err and "Traceback" not in err
