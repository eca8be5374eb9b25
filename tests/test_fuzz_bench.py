"""The fuzz bench in small (`python -m bench fuzz` runs 10,000): a few dozen hostile inputs, no failure."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from bench import fuzz


@pytest.mark.timeout(120)
def test_hostile_inputs_give_no_traceback_hang_or_crash(tmp_path: Path) -> None:
    # Every fourth input (and every special file) through real processes, the rest in workers.
    assert fuzz.main(16, results=tmp_path, seed=2024, subprocess_every=4) == 0
    report = json.loads((tmp_path / "fuzz.json").read_text())
    assert report["runs"] == 16
    for key in ("tracebacks", "timeouts", "over_memory", "bad_exit", "code_ran"):
        assert report[key] == 0, report["examples"]
    assert report["max_seconds"] < fuzz.TIMEOUT_S
    through = report["through"]
    assert through["subprocess"]["inputs"] >= 4
    assert through["subprocess"]["inputs"] + through["in_process"]["inputs"] == 16
    assert report["executions"] >= 32


def test_every_kind_of_input_is_made() -> None:
    kinds = {fuzz.make_case(i).kind for i in range(300)}
    assert kinds == {name for name, _, _ in fuzz.GENERATORS}


def test_the_bench_sees_a_traceback_a_hang_and_a_crash() -> None:
    # The judge itself: what would count as a failure does.
    assert fuzz.problems(fuzz.Result(1, 0.1, "Traceback (most recent call last):\n")) == ["traceback"]
    assert fuzz.problems(fuzz.Result(None, 5.0, "", timeout=True)) == ["timeout"]
    assert fuzz.problems(fuzz.Result(-11, 0.1, "")) == ["bad_exit"]
    assert fuzz.problems(fuzz.Result(2, 0.1, "htnagent: error: f: ran out of memory", memory=True)) == [
        "over_memory"
    ]
    assert fuzz.problems(fuzz.Result(2, 0.1, "htnagent: error: f: line 1: bad\n")) == []
