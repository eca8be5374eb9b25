"""The command line against hostile names, streams, targets and sizes (each case was found by
an outside check: a traceback, a hang, or time growing as the square of the input).

- names from the user's files are shown, never obeyed: rich markup (``[/]``) and control
  characters (an escape sequence, a newline) in a scenario's or an agent's name;
- a terminal that cannot show a character gets an escape, not an encoding error;
- ``report --html`` refuses the trace itself, a FIFO, a folder and no name, before reading;
- a scenario's goals and events are bounded, and ending goals costs each one look;
- running out of memory is one line;
- ``import htnagent`` loads nothing heavy, so Ctrl-C is handled from the first moment.
"""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path
from typing import Any

import pytest
import yaml

import htnagent.cli.commands
from htnagent.cli.commands import main
from htnagent.scenario import parse_scenario
from htnagent.system.runtime import Runtime
from htnagent.system.simulation import run_scenario

REPO = Path(__file__).resolve().parents[1]
SCENARIOS = REPO / "scenarios"


def write(tmp_path: Path, data: dict[str, Any], name: str = "s.yaml") -> Path:
    path = tmp_path / name
    path.write_text(yaml.safe_dump(data, allow_unicode=True))
    return path


def refused(args: list[str], capsys: pytest.CaptureFixture[str]) -> str:
    """Run the command line: exit 2 and one line on stderr, which is returned."""
    assert main(args) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1, err
    return err


def small(name: str = "small", guide: str = "guide", navigator: str = "navigator") -> dict[str, Any]:
    return {
        "name": name,
        "map": str(SCENARIOS / "museum_map.yaml"),
        "robot": {"start": "n40", "speed": 1.0},
        "agents": [
            {"name": guide, "domain": "museum.areas", "executor": navigator},
            {"name": navigator, "domain": "museum.nodes", "executor": "robot"},
        ],
        "goals": [{"agent": guide, "task": "goto(n38)"}],
    }


@pytest.mark.parametrize(
    ("name", "guide", "navigator"),
    [("[/]", "guide", "navigator"), ("a[/b]", "[/]", "navigator"), ("[bold]x", "guide", "[red]n")],
)
def test_markup_in_names_is_shown_as_written(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], name: str, guide: str, navigator: str
) -> None:
    assert main(["run", str(write(tmp_path, small(name, guide, navigator)))]) == 0
    out = capsys.readouterr().out
    assert name in out and guide in out and navigator in out


def test_control_characters_in_names_are_escaped(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    data = small("\x1b[31mRED\x1b[0m\r\nINJECTED", "guide", "nav\x1b[2J")
    assert main(["run", str(write(tmp_path, data))]) == 0
    out = capsys.readouterr().out
    assert "\x1b" not in out and "\r" not in out
    assert "\\x1b[31mRED" in out and "nav\\x1b[2J" in out


def test_a_terminal_that_cannot_show_a_character_gets_an_escape() -> None:
    env = {**os.environ, "PYTHONIOENCODING": "ascii"}
    done = subprocess.run(
        [sys.executable, "-m", "htnagent", "run", str(SCENARIOS / "museum.yaml")],
        capture_output=True,
        env=env,
        timeout=120,
    )
    assert done.returncode == 0, done.stderr.decode(errors="replace")[-500:]
    assert b"Traceback" not in done.stderr
    assert b"\\u25c6 goal" in done.stdout  # the goal's mark, escaped


@pytest.fixture
def trace(tmp_path: Path) -> Path:
    path = tmp_path / "run.jsonl"
    with path.open("w") as out:
        done = subprocess.run(
            [sys.executable, "-m", "htnagent", "run", str(SCENARIOS / "museum.yaml"), "--json"],
            stdout=out,
            timeout=120,
        )
    assert done.returncode == 0
    return path


def test_report_refuses_to_overwrite_its_trace(trace: Path, capsys: pytest.CaptureFixture[str]) -> None:
    before = trace.read_bytes()
    assert main(["report", str(trace), "--html", str(trace)]) == 2
    assert "is the trace being read" in capsys.readouterr().err
    assert trace.read_bytes() == before


@pytest.mark.skipif(not hasattr(os, "mkfifo"), reason="no FIFOs here")
def test_report_to_a_fifo_is_refused_without_blocking(
    trace: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    fifo = tmp_path / "page.html"
    os.mkfifo(fifo)
    assert main(["report", str(trace), "--html", str(fifo)]) == 2
    assert "not a regular file" in capsys.readouterr().err


@pytest.mark.parametrize("target", ["", "."])
def test_report_needs_a_file_name(trace: Path, capsys: pytest.CaptureFixture[str], target: str) -> None:
    err = refused(["report", str(trace), "--html", target], capsys)
    assert "give the name" in err or "is a directory" in err


@pytest.mark.parametrize("key", ["goals", "events"])
def test_goals_and_events_are_bounded(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], monkeypatch: pytest.MonkeyPatch, key: str
) -> None:
    monkeypatch.setattr(htnagent.scenario.loader, f"MAX_{key.upper()}", 10)
    data = small()
    data["goals"] = [{"agent": "guide", "task": "goto(n38)"}] * 11 if key == "goals" else data["goals"]
    if key == "events":
        data["events"] = [{"when": {"time": i}, "close": "arc1"} for i in range(11)]
    err = refused(["check", str(write(tmp_path, data))], capsys)
    assert f"11 {key}; a scenario may give at most 10" in err


class _Counting(dict[int, Any]):
    looks = 0

    def __getitem__(self, key: int) -> Any:
        _Counting.looks += 1
        return super().__getitem__(key)


async def test_ending_goals_looks_at_each_once() -> None:
    # Whether every goal has ended was asked by scanning every ticket at each goal's end:
    # 50,000 goals took 9 minutes.  Each ticket is now looked at once after it ends.
    n = 2_000
    data = small()
    data["agents"] = [{"name": "navigator", "domain": "museum.nodes", "executor": "robot"}]
    data["goals"] = [{"agent": "navigator", "task": "goto_node(n40)"}] * n  # there already

    runtimes: list[Runtime] = []
    held: list[int] = []

    def counting(runtime: Runtime) -> None:
        runtime.outcomes = _Counting(runtime.outcomes)
        runtimes.append(runtime)

    def spent(event: object) -> None:
        # Ended goals are let go of after the next order, or at the latest 64 ends later.
        held.append(runtimes[0].agents["navigator"].upkeep.kept)

    _Counting.looks = 0
    scenario = parse_scenario(data, "<many>", SCENARIOS)
    report = await run_scenario(scenario, on_start=counting, observers=[spent])
    assert report.succeeded and len(report.summary.goals) == n
    assert _Counting.looks <= 3 * n
    assert max(held) <= 64


def test_running_out_of_memory_is_one_line(
    capsys: pytest.CaptureFixture[str], monkeypatch: pytest.MonkeyPatch
) -> None:
    def exhausted(*args: object, **kwargs: object) -> None:
        raise MemoryError

    monkeypatch.setattr(htnagent.cli.commands, "load_scenario", exhausted)
    err = refused(["check", str(SCENARIOS / "museum.yaml")], capsys)
    assert "out of memory" in err


def test_importing_the_package_loads_nothing_heavy() -> None:
    # python -m htnagent imports the package before its signal handlers can be set: the
    # longer that takes, the longer Ctrl-C meets Python's own handling (a traceback).
    probe = (
        "import sys, htnagent; heavy = [m for m in ('htnagent.planning.planner', 'pydantic', 'anyio', 'rich')"
        " if m in sys.modules]; print(heavy)"
    )
    done = subprocess.run([sys.executable, "-c", probe], capture_output=True, text=True, timeout=60)
    assert done.stdout.strip() == "[]", done.stderr


@pytest.mark.parametrize("option", ["--plot", "--timeline"])
def test_an_empty_picture_name_is_refused(capsys: pytest.CaptureFixture[str], option: str) -> None:
    pytest.importorskip("matplotlib")
    err = refused(["run", str(SCENARIOS / "museum.yaml"), option, ""], capsys)
    assert "give the name of the picture" in err


def test_base_60_through_an_explicit_tag_is_refused_at_once(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    data = small()
    path = write(tmp_path, data)
    path.write_text(path.read_text() + "planner: {budget: !!int 1:" + "59:" * 200_000 + "5}\n")
    err = refused(["check", str(path)], capsys)
    assert "base-60 numbers are not read" in err


def test_a_name_yaml_reads_as_a_number_says_to_quote_it(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    data = small()
    data["robot"]["start"] = 1e1
    assert main(["check", str(write(tmp_path, data))]) == 2
    assert "robot.start: expected text, got 10.0 (a number: put a name in quotes" in capsys.readouterr().err


def test_report_may_write_to_its_own_stdout(trace: Path) -> None:
    # /dev/stdout into a pipe is a FIFO, but it is this process's own output: no one waits.
    done = subprocess.run(
        [sys.executable, "-m", "htnagent", "report", str(trace), "--html", "/dev/stdout"],
        capture_output=True,
        timeout=120,
    )
    assert done.returncode == 0, done.stderr
    assert done.stdout.startswith(b"<!DOCTYPE html>")


def test_report_refuses_a_scenario_the_trace_did_not_run(
    trace: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    page = tmp_path / "page.html"
    other = SCENARIOS / "courier_hddl.yaml"
    err = refused(["report", str(trace), "--html", str(page), "--scenario", str(other)], capsys)
    assert "the trace's agent 'guide' is not in this scenario" in err
    assert not page.exists()
    assert (
        main(["report", str(trace), "--html", str(page), "--scenario", str(SCENARIOS / "museum.yaml")]) == 0
    )


@pytest.mark.skipif(not Path("/dev/full").exists(), reason="needs /dev/full")
@pytest.mark.parametrize("output", ["full", "closed"])
@pytest.mark.parametrize(
    "args",
    [
        ["run", "museum.yaml", "--json"],
        ["run", "museum.yaml"],
        ["check", "museum.yaml"],
        ["plan", "--hddl", "courier_hddl_domain.hddl", "courier_hddl_problem.hddl", "--format", "ipc"],
    ],
)
def test_output_that_cannot_be_written_is_an_error_not_a_success(args: list[str], output: str) -> None:
    # A full disk, or no standard output at all: the trace or the answer is lost, and the
    # command must say so -- not exit 0 (the trace printer's failure was swallowed as a
    # broken observer's), and not with a traceback.
    argv = [
        sys.executable,
        "-m",
        "htnagent",
        *[str(SCENARIOS / a) if a.endswith((".yaml", ".hddl")) else a for a in args],
    ]
    with open("/dev/full", "w") as full:
        done = subprocess.run(
            argv,
            stdout=full if output == "full" else subprocess.DEVNULL,
            stderr=subprocess.PIPE,
            text=True,
            timeout=120,
            # >&-: the command starts with no standard output.
            preexec_fn=None if output == "full" else lambda: os.close(1),
        )
    lines = done.stderr.splitlines()
    assert done.returncode == 2 and len(lines) == 1, done.stderr
    reason = "No space left on device" if output == "full" else "standard output is closed"
    assert lines[0] == f"htnagent: error: cannot write the output: {reason}"
