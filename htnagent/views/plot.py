"""A picture of a run: the map, the robot's path, the emergency detours marked (``--plot``).

Needs matplotlib (``pip install 'htnagent[plot]'``); without it ``--plot`` is a
clear usage error.  Whether the picture can be written is checked before the
run (:func:`check_plot_target`), so that a run is not wasted on a file name
that was wrong from the start; a failure that still comes after the run is
reported by the CLI without hiding the run's own result.
"""

from __future__ import annotations

import os
import stat
from pathlib import Path
from typing import TYPE_CHECKING

from htnagent.errors import PlotError, drawing
from htnagent.runtime.events import ArcClosed, GoalFinished, GoalReceived, RobotMoving, Summary, TraceEvent
from htnagent.scenario import Scenario

if TYPE_CHECKING:
    from matplotlib.axes import Axes
    from matplotlib.figure import Figure


def check_plot_target(file: str, option: str = "--plot") -> None:
    """Fail early, before the run, if the picture could not be saved.

    The file is opened for writing as the picture will be: an existing file
    without truncating it, a new one by creating it and removing it again.
    ``option`` names the command-line option in the messages (``--plot``, ``--timeline``).
    """
    try:
        import matplotlib  # noqa: F401
    except ImportError:
        raise PlotError(f"{file}: {option} needs matplotlib: pip install 'htnagent[plot]'") from None
    if not file:
        raise PlotError(f"{option}: give the name of the picture to write (ending in {_ENDINGS})")
    path = Path(file)
    if path.suffix.lower() not in PICTURE_FORMATS:
        raise PlotError(
            f"{file}: {option} writes PNG, SVG or PDF, by the name's ending: give one of {_ENDINGS}"
        )
    try:
        try:
            info: os.stat_result | None = os.stat(file)
        except FileNotFoundError:
            info = None
        if info is None:
            # A link to a file not yet there: the picture is written where it points.
            new = os.path.realpath(file) if os.path.islink(file) else file
            folder = Path(new).parent
            if not folder.is_dir():
                raise PlotError(f"{file}: the folder {folder} does not exist")
            # O_NONBLOCK: a FIFO made meanwhile must not block the check.
            fd = os.open(new, os.O_WRONLY | os.O_CREAT | os.O_EXCL | _NONBLOCK, 0o666)
            os.close(fd)
            os.unlink(new)
        elif stat.S_ISDIR(info.st_mode):
            raise PlotError(f"{file}: is a directory; give a file name ending in {_ENDINGS}")
        elif not stat.S_ISREG(info.st_mode):
            raise PlotError(f"{file}: is not a regular file; give a file name ending in {_ENDINGS}")
        else:
            os.close(os.open(file, os.O_WRONLY | os.O_APPEND | _NONBLOCK))
    except OSError as e:  # no permission, a read-only file system, a name too long, ...
        raise PlotError(f"{file}: cannot write the picture there: {e.strerror or e}") from None
    except ValueError:  # a NUL in the name
        raise PlotError(f"{file}: cannot write the picture there: the name holds a NUL character") from None


_NONBLOCK = getattr(os, "O_NONBLOCK", 0)
PICTURE_FORMATS = (".png", ".svg", ".pdf")
"""The endings a picture may have; the format follows the ending."""
_ENDINGS = ", ".join(PICTURE_FORMATS)


def check_plot_scenario(scenario: Scenario, where: str) -> None:
    """Refuse, before the run, a map picture of a scenario without a map (an HDDL agent's world).

    ``where`` names the scenario file in the message.
    """
    if not scenario.world.nodes or scenario.robot.start is None:
        raise PlotError(f"{where}: --plot draws the robot on its map, and this scenario has no map")


def draw_run(scenario: Scenario, events: list[TraceEvent], file: str) -> None:
    """Draw the map and the path the robot travelled, emergency legs in red; PlotError if it cannot."""
    with drawing(file, "the picture"):
        _draw(scenario, events, file)


def _draw(scenario: Scenario, events: list[TraceEvent], file: str) -> None:
    import matplotlib.pyplot as plt

    fig = run_figure(scenario, events)
    try:
        fig.savefig(file, dpi=120, bbox_inches="tight")
    except OSError as exc:
        raise PlotError(f"{file}: cannot write the picture: {exc.strerror or exc}") from None
    finally:
        plt.close(fig)


_FIRST, _EMERGENCY, _DOOR = "#1f77b4", "#d62728", "#222222"


def run_figure(scenario: Scenario, events: list[TraceEvent]) -> Figure:
    """The picture of a run as a matplotlib figure (not saved; the caller closes it).

    The map in grey with every node named; the robot's path over it, the legs travelled for
    an emergency in red and numbered in the order the emergencies came; arcs shut during
    the run dashed; start and end marked.  The legend sits below the map, never over it.
    """
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    world = scenario.world
    xs = [n.x for n in world.nodes.values()]
    ys = [n.y for n in world.nodes.values()]
    width, height = max(xs) - min(xs) + 4, max(ys) - min(ys) + 4
    scale = 9 / max(width, height)
    fig, ax = plt.subplots(figsize=(max(4.0, width * scale + 1), max(4.0, height * scale + 1.5)))
    for arc in world.arcs.values():
        a, b = world.nodes[arc.a], world.nodes[arc.b]
        ax.plot([a.x, b.x], [a.y, b.y], color="#cccccc", linewidth=1, zorder=1)
    for area, names in world.area_nodes.items():
        area_x = [world.nodes[n].x for n in names]
        area_y = [world.nodes[n].y for n in names]
        if area_x:
            ax.text(
                sum(area_x) / len(area_x), max(area_y) + 0.6, area, ha="center", fontsize=8, color="#888888"
            )
    for node in world.nodes.values():
        ax.plot(node.x, node.y, "o", color="#999999", markersize=3, zorder=2)
        # Above the path, on a light ground: the path never hides a node's name.
        ax.text(
            node.x + 0.2,
            node.y + 0.2,
            node.name,
            fontsize=6,
            color="#444444",
            zorder=9,
            bbox={"boxstyle": "square,pad=0.05", "facecolor": "white", "edgecolor": "none", "alpha": 0.7},
        )
    _draw_path(ax, scenario, events)
    start = world.nodes.get(scenario.robot.start or "")
    if start is not None:
        ax.plot(start.x, start.y, "s", color="black", markersize=9, zorder=7, label="start")
    end = world.nodes.get(_end_node(events) or "")
    if end is not None:
        ax.plot(
            end.x, end.y, "*", color="#ffbf00", markeredgecolor="black", markersize=14, zorder=7, label="end"
        )
    # Room for the names right of the nodes and the area names above them: nothing is cut.
    ax.set_xlim(min(xs) - 1, max(xs) + 2)
    ax.set_ylim(max(ys) + 1, min(ys) - 1.5)  # y grows downwards, as on the museum's plan
    ax.set_aspect("equal")
    ax.set_title(scenario.name)
    handles, _ = ax.get_legend_handles_labels()
    if handles:
        ax.legend(loc="upper center", bbox_to_anchor=(0.5, -0.07), ncols=min(len(handles), 3), fontsize=8)
    return fig


def _draw_path(ax: Axes, scenario: Scenario, events: list[TraceEvent]) -> None:
    """The robot's legs (emergency legs red and numbered), and the arcs shut during the run."""
    world = scenario.world
    top = scenario.agent_names[0]
    emergencies = {(e.goal) for e in events if isinstance(e, GoalReceived) and e.agent == top and e.emergency}
    running: list[int] = []  # the emergencies under way, innermost last (their numbers)
    count = 0
    numbered: set[int] = set()
    drawn: set[str] = set()
    shut: list[str] = []
    for e in events:
        if isinstance(e, GoalReceived) and e.agent == top and e.emergency:
            count += 1
            running.append(count)
        elif isinstance(e, GoalFinished) and e.agent == top and running and e.goal in emergencies:
            running.pop()
        elif isinstance(e, ArcClosed) and e.arc in world.arcs and e.arc not in shut:
            shut.append(e.arc)
        elif isinstance(e, RobotMoving) and e.arc is not None and e.arc in world.arcs:
            arc = world.arcs[e.arc]
            a, b = world.nodes[arc.a], world.nodes[arc.b]
            kind = "emergency" if running else "other goals"
            ax.plot(
                [a.x, b.x],
                [a.y, b.y],
                color=_EMERGENCY if running else _FIRST,
                linewidth=3 if running else 2.5,
                alpha=0.8,
                zorder=4 if running else 3,
                label=None if kind in drawn else kind,
            )
            drawn.add(kind)
            if running and running[-1] not in numbered:
                numbered.add(running[-1])
                ax.text(
                    (a.x + b.x) / 2,
                    (a.y + b.y) / 2,
                    str(running[-1]),
                    fontsize=8,
                    color="white",
                    ha="center",
                    va="center",
                    zorder=8,
                    fontweight="bold",
                    bbox={"boxstyle": "circle,pad=0.2", "facecolor": _EMERGENCY, "edgecolor": "white"},
                )
    for name in shut:
        arc = world.arcs[name]
        a, b = world.nodes[arc.a], world.nodes[arc.b]
        label = None if "shut" in drawn else "door shut during the run"
        ax.plot(
            [a.x, b.x], [a.y, b.y], color=_DOOR, linewidth=2, linestyle=(0, (2, 2)), zorder=5, label=label
        )
        ax.plot((a.x + b.x) / 2, (a.y + b.y) / 2, "x", color=_DOOR, markersize=8, markeredgewidth=2, zorder=5)
        drawn.add("shut")


def _end_node(events: list[TraceEvent]) -> str | None:
    """Where the robot ended: the summary's node, else the last node reached."""
    for e in reversed(events):
        if isinstance(e, Summary):
            return e.robot.get("at") or (e.visited[-1] if e.visited else None)
    return None
