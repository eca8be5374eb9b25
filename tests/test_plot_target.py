"""``run --plot FILE``: a bad place is refused before the run; a late failure keeps the run's result.

The picture is written only after the whole run: a place found bad only then must not
hide the run's real result behind the picture's failure (exit 2).
"""

from __future__ import annotations

import os
from pathlib import Path
from typing import Any

import pytest

from htnagent.cli import commands as cli
from htnagent.views import plot
from htnagent.views.plot import check_plot_target

REPO = Path(__file__).resolve().parents[1]
MUSEUM = str(REPO / "scenarios" / "museum.yaml")
UNREACHABLE = str(REPO / "scenarios" / "unreachable_goal.yaml")


def refused_before_the_run(target: str, capsys: pytest.CaptureFixture[str]) -> str:
    assert cli.main(["run", MUSEUM, "--plot", target]) == 2
    out, err = capsys.readouterr()
    assert out == ""  # nothing ran
    lines = err.splitlines()
    assert len(lines) == 1 and "Traceback" not in err, err
    assert lines[0].startswith(f"htnagent: error: {target[:200]}")
    return lines[0]


def test_a_folder_that_refuses_writing_is_found_before_the_run(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], monkeypatch: pytest.MonkeyPatch
) -> None:
    target = str(tmp_path / "run.png")
    real_open = os.open

    def refuse(name: str, *args: Any, **kwargs: Any) -> int:
        if name == target:
            raise PermissionError(13, "Permission denied", name)
        return real_open(name, *args, **kwargs)

    # Tests may run as root, for whom no folder refuses writing: refuse it here.
    monkeypatch.setattr(os, "open", refuse)
    line = refused_before_the_run(target, capsys)
    assert line.endswith("cannot write the picture there: Permission denied")


@pytest.mark.parametrize(
    ("make", "reason"),
    [
        (lambda p: p.mkdir(), "is a directory"),
        (lambda p: os.mkfifo(p), "is not a regular file"),
        (lambda p: p.symlink_to(p.parent / "gone" / "x.png"), "the folder"),
    ],
)
def test_a_target_that_is_not_a_file_is_refused_before_the_run(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], make: Any, reason: str
) -> None:
    target = tmp_path / "run.png"
    make(target)
    assert reason in refused_before_the_run(str(target), capsys)


def test_a_name_too_long_is_refused_before_the_run(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    line = refused_before_the_run(str(tmp_path / ("p" * 5000 + ".png")), capsys)
    assert "File name too long" in line


def test_a_folder_that_is_a_file_is_refused_before_the_run(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    (tmp_path / "file").write_text("")
    assert "Not a directory" in refused_before_the_run(str(tmp_path / "file" / "run.png"), capsys)


def test_a_link_to_a_picture_not_yet_made_is_followed(tmp_path: Path) -> None:
    # The check once tried to create the link itself, and said "File exists".
    link = tmp_path / "latest.png"
    link.symlink_to(tmp_path / "run-42.png")
    check_plot_target(str(link))
    assert link.is_symlink() and not (tmp_path / "run-42.png").exists()


def test_the_check_leaves_no_file_behind_and_an_existing_file_untouched(tmp_path: Path) -> None:
    new = tmp_path / "new.png"
    check_plot_target(str(new))
    assert not new.exists()
    old = tmp_path / "old.png"
    old.write_bytes(b"previous picture")
    check_plot_target(str(old))
    assert old.read_bytes() == b"previous picture"


@pytest.mark.parametrize(("scenario", "code"), [(MUSEUM, 0), (UNREACHABLE, 1)])
def test_a_picture_failing_after_the_run_keeps_the_runs_exit_code(
    tmp_path: Path,
    capsys: pytest.CaptureFixture[str],
    monkeypatch: pytest.MonkeyPatch,
    scenario: str,
    code: int,
) -> None:
    target = tmp_path / "run.png"

    def fail(*args: object) -> None:
        raise OSError(28, "No space left on device")

    monkeypatch.setattr(plot, "_draw", fail)
    assert cli.main(["run", scenario, "--json", "--plot", str(target)]) == code
    out, err = capsys.readouterr()
    assert out.splitlines()[-1].startswith('{"t":')  # the trace and its summary were printed
    assert '"event":"summary"' in out.splitlines()[-1]
    reason = "drawing the picture failed: OSError: [Errno 28] No space left on device"
    assert err == f"htnagent: error: {target}: {reason}\n"


def test_a_folder_removed_during_the_run_is_reported_after_it(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], monkeypatch: pytest.MonkeyPatch
) -> None:
    folder = tmp_path / "pictures"
    folder.mkdir()
    target = folder / "run.png"
    real_draw = plot._draw

    def remove_then_draw(*args: Any) -> None:
        folder.rmdir()
        real_draw(*args)

    monkeypatch.setattr(plot, "_draw", remove_then_draw)
    assert cli.main(["run", MUSEUM, "--plot", str(target)]) == 0
    out, err = capsys.readouterr()
    assert "picture saved" not in out
    assert err.startswith(f"htnagent: error: {target}: cannot write the picture: ")
    assert err.count("\n") == 1
