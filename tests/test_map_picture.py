"""The map picture (``run --plot``) and the live trace's colours: what a person sees is readable."""

from __future__ import annotations

from collections.abc import Iterator
from pathlib import Path

import pytest
from matplotlib.figure import Figure
from matplotlib.text import Text as MplText
from rich.console import Console

from htnagent.cli.commands import main
from htnagent.runtime.events import GoalReceived
from htnagent.views.console import LiveTrace
from htnagent.views.plot import check_plot_target, draw_run, run_figure
from tests.support import SCENARIO_DIR, shipped_run


@pytest.fixture
def figure(request: pytest.FixtureRequest) -> Iterator[Figure]:
    import matplotlib.pyplot as plt

    scenario, events = shipped_run(request.param)
    fig = run_figure(scenario, list(events))
    fig.canvas.draw()
    yield fig
    plt.close(fig)


def legend_labels(fig: Figure) -> list[str]:
    legend = fig.axes[0].get_legend()
    assert legend is not None
    return [t.get_text() for t in legend.get_texts()]


def texts(fig: Figure) -> list[MplText]:
    return [t for t in fig.axes[0].texts if t.get_text()]


@pytest.mark.parametrize("figure", ["museum.yaml", "nested_emergencies.yaml"], indirect=True)
def test_the_legend_lies_outside_the_map(figure: Figure) -> None:
    renderer = figure.canvas.get_renderer()  # type: ignore[attr-defined]
    axes = figure.axes[0]
    legend = axes.get_legend()
    assert legend is not None
    box, frame = legend.get_window_extent(renderer), axes.get_window_extent(renderer)
    assert not box.overlaps(frame), (box, frame)


@pytest.mark.parametrize("figure", ["museum.yaml", "door_shut.yaml"], indirect=True)
def test_every_node_name_lies_inside_the_map_and_the_figure(figure: Figure) -> None:
    renderer = figure.canvas.get_renderer()  # type: ignore[attr-defined]
    frame = figure.axes[0].get_window_extent(renderer)
    page = figure.bbox
    names = [t for t in texts(figure) if t.get_text().startswith("n")]
    assert len(names) == 40
    for t in names:
        box = t.get_window_extent(renderer)
        for outer in (frame, page):
            assert outer.x0 <= box.x0 and box.x1 <= outer.x1, t.get_text()
            assert outer.y0 <= box.y0 and box.y1 <= outer.y1, t.get_text()


@pytest.mark.parametrize("figure", ["museum.yaml"], indirect=True)
def test_start_and_end_are_marked(figure: Figure) -> None:
    assert {"start", "end"} <= set(legend_labels(figure))


@pytest.mark.parametrize("figure", ["nested_emergencies.yaml"], indirect=True)
def test_the_emergency_legs_are_numbered_in_the_order_the_emergencies_came(figure: Figure) -> None:
    _, events = shipped_run("nested_emergencies.yaml")
    came = [e for e in events if isinstance(e, GoalReceived) and e.emergency and e.agent == "guide"]
    numbers = sorted(t.get_text() for t in texts(figure) if t.get_text().isdigit())
    assert numbers == [str(i) for i in range(1, len(came) + 1)] and len(came) == 2


@pytest.mark.parametrize("figure", ["door_shut.yaml"], indirect=True)
def test_a_door_shut_during_the_run_is_drawn(figure: Figure) -> None:
    assert "door shut during the run" in legend_labels(figure)


@pytest.mark.parametrize(("ending", "starts"), [(".svg", b"<?xml"), (".pdf", b"%PDF")])
def test_the_picture_format_follows_the_file_name(tmp_path: Path, ending: str, starts: bytes) -> None:
    picture = tmp_path / f"run{ending}"
    check_plot_target(str(picture))  # accepted before the run
    scenario, events = shipped_run("museum.yaml")
    draw_run(scenario, list(events), str(picture))
    assert picture.read_bytes().startswith(starts)


def refusal(argv: list[str], capsys: pytest.CaptureFixture[str]) -> str:
    assert main(argv) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1, err
    return err


def test_a_map_picture_of_a_scenario_without_a_map_is_refused(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    picture = tmp_path / "run.png"
    err = refusal(["run", str(SCENARIO_DIR / "courier_hddl.yaml"), "--plot", str(picture)], capsys)
    assert "has no map" in err and not picture.exists()


def test_one_file_for_the_map_and_the_timeline_is_refused(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    picture = tmp_path / "run.png"
    argv = ["run", str(SCENARIO_DIR / "museum.yaml"), "--plot", str(picture), "--timeline", str(picture)]
    assert "name the same file" in refusal(argv, capsys)


def test_the_live_trace_dims_the_time_only() -> None:
    _, events = shipped_run("museum.yaml")
    console = Console(record=True, force_terminal=True, width=200, color_system="truecolor")
    LiveTrace(console, ["guide", "navigator"])(
        next(e for e in events if isinstance(e, GoalReceived) and e.emergency)
    )
    segments = [s for s in console._record_buffer if s.text.strip()]  # what was printed, with styles
    emergency = next(s for s in segments if "EMERGENCY" in s.text)
    time = segments[0]
    assert time.style is not None and time.style.dim
    assert emergency.style is not None and not emergency.style.dim and emergency.style.bold
