"""Ctrl-C during ``run``: a quick, clean stop with the summary and exit code 130."""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent


@pytest.mark.parametrize("json_output", [True, False])
def test_ctrl_c_stops_the_run_with_a_summary_and_exit_130(json_output: bool) -> None:
    args = [sys.executable, "-m", "htnagent", "run", str(ROOT / "scenarios" / "museum.yaml"), "--speed", "10"]
    if json_output:
        args.append("--json")
    proc = subprocess.Popen(
        args, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, env={**os.environ, "COLUMNS": "200"}
    )
    assert proc.stdout is not None
    first = proc.stdout.readline()  # the run has started
    assert first
    time.sleep(0.5)
    sent = time.monotonic()
    proc.send_signal(signal.SIGINT)
    out, err = proc.communicate(timeout=10)
    # Expect: stopped within a second or two, exit 130, no traceback, the summary last.
    assert time.monotonic() - sent < 2.0
    assert proc.returncode == 130
    assert "Traceback" not in err
    assert err.strip() == "htnagent: interrupted"
    if json_output:
        lines = (first + out).strip().splitlines()
        assert all(json.loads(line) for line in lines)
        summary = json.loads(lines[-1])
        assert summary["event"] == "summary"
        assert any(g["reason"] == "interrupted before it ended" for g in summary["goals"])
        # The robot never stands still in this scenario (1 m/s): the distance so far,
        # the part of the arc it was on included, is the time so far.
        assert summary["distance"] == pytest.approx(summary["t"], abs=1e-6)
    else:
        assert "goals" in out and "interrupted before it ended" in out
