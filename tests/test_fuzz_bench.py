"""Hostile inputs through the command line: the fuzz bench in small (`python -m bench fuzz` runs
thousands), the kinds of input it makes, and the judge of what counts as going wrong."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import pytest

from htnagent.testing import hostile_inputs
from htnagent.testing.hostile_inputs import Result, make_case, problems

ROOT = Path(__file__).resolve().parent.parent


@pytest.mark.timeout(120)
def test_hostile_inputs_give_no_traceback_hang_or_crash(tmp_path: Path) -> None:
    # Every fourth input (and every special file) through real processes, the rest in workers.
    command = [sys.executable, "-m", "bench", "fuzz", "--runs", "12", "--seed", "2024"]
    command += ["--subprocess-every", "4", "--out", str(tmp_path)]
    done = subprocess.run(command, cwd=ROOT, capture_output=True, text=True, timeout=110)
    report = json.loads((tmp_path / "fuzz.json").read_text())
    assert done.returncode == 0, report["examples"]
    assert report["runs"] == 12
    for key in ("tracebacks", "timeouts", "over_memory", "bad_exit", "code_ran"):
        assert report[key] == 0, report["examples"]
    assert report["max_seconds"] < report["limits"]["timeout_s"]
    through = report["through"]
    assert through["subprocess"]["inputs"] >= 3
    assert through["subprocess"]["inputs"] + through["in_process"]["inputs"] == 12
    assert report["executions"] >= 24


def test_every_kind_of_input_is_made() -> None:
    kinds = {make_case(i).kind for i in range(300)}
    assert kinds == {name for name, _, _ in hostile_inputs.GENERATORS}


def test_the_same_seed_makes_the_same_inputs() -> None:
    assert [make_case(i, seed=7) for i in range(20)] == [make_case(i, seed=7) for i in range(20)]
    assert [make_case(i, seed=7) for i in range(20)] != [make_case(i, seed=8) for i in range(20)]


def test_the_judge_sees_a_traceback_a_hang_and_a_crash() -> None:
    # The judge itself: what would count as a failure does.
    assert problems(Result(1, 0.1, "Traceback (most recent call last):\n")) == ["traceback"]
    assert problems(Result(None, 5.0, "", timeout=True)) == ["timeout"]
    assert problems(Result(-11, 0.1, "")) == ["bad_exit"]
    assert problems(Result(2, 0.1, "htnagent: error: f: ran out of memory", memory=True)) == ["over_memory"]
    assert problems(Result(2, 0.1, "htnagent: error: f: line 1: bad\n")) == []
