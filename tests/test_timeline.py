"""``run --timeline FILE.png``: a timeline picture of every shipped scenario, from its history."""

from __future__ import annotations

from pathlib import Path

import pytest

from htnagent.cli.commands import main
from htnagent.views.history import History
from htnagent.views.timeline import draw_timeline
from tests.support import SCENARIO_DIR, SHIPPED, shipped_run

PNG = b"\x89PNG\r\n\x1a\n"


@pytest.mark.parametrize("name", SHIPPED)
def test_every_shipped_scenario_has_a_timeline(name: str, tmp_path: Path) -> None:
    scenario, events = shipped_run(name)
    out = tmp_path / "timeline.png"
    draw_timeline(History.from_events(events, scenario.agent_names), str(out), scenario.name)
    assert out.read_bytes()[:8] == PNG


def test_run_draws_the_timeline_beside_the_json_trace(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    out = tmp_path / "t.png"
    code = main(["run", str(SCENARIO_DIR / "nested_emergencies.yaml"), "--json", "--timeline", str(out)])
    captured = capsys.readouterr()
    assert code == 0 and captured.err == ""
    assert captured.out.splitlines()[-1].startswith('{"t":')  # stdout stays JSON Lines only
    assert out.read_bytes()[:8] == PNG


def test_a_failed_run_still_draws_and_keeps_its_exit_code(tmp_path: Path) -> None:
    out = tmp_path / "t.png"
    assert main(["run", str(SCENARIO_DIR / "unreachable_goal.yaml"), "--timeline", str(out)]) == 1
    assert out.read_bytes()[:8] == PNG


@pytest.mark.parametrize(("target", "reason"), [("t.jpg", "writes PNG, SVG or PDF"), (".", "is a directory")])
def test_a_bad_target_is_refused_before_the_run(
    target: str, reason: str, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    path = tmp_path / target if target != "." else tmp_path / "dir.png"
    if target == ".":
        path.mkdir()
    code = main(["run", str(SCENARIO_DIR / "museum.yaml"), "--timeline", str(path)])
    err = capsys.readouterr().err
    assert code == 2 and reason in err and err.count("\n") == 1
