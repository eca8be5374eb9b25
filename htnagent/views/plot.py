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

from htnagent.errors import PlotError, drawing
from htnagent.runtime.events import GoalFinished, GoalReceived, RobotMoving, TraceEvent
from htnagent.scenario import Scenario


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
        raise PlotError(f"{option}: give the name of the picture to write (ending in .png)")
    path = Path(file)
    if path.suffix.lower() != ".png":
        raise PlotError(f"{file}: {option} writes PNG; give a file name ending in .png")
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
            raise PlotError(f"{file}: is a directory; give a file name ending in .png")
        elif not stat.S_ISREG(info.st_mode):
            raise PlotError(f"{file}: is not a regular file; give a file name ending in .png")
        else:
            os.close(os.open(file, os.O_WRONLY | os.O_APPEND | _NONBLOCK))
    except OSError as e:  # no permission, a read-only file system, a name too long, ...
        raise PlotError(f"{file}: cannot write the picture there: {e.strerror or e}") from None
    except ValueError:  # a NUL in the name
        raise PlotError(f"{file}: cannot write the picture there: the name holds a NUL character") from None


_NONBLOCK = getattr(os, "O_NONBLOCK", 0)


def draw_run(scenario: Scenario, events: list[TraceEvent], file: str) -> None:
    """Draw the map and the path the robot travelled, emergency legs in red; PlotError if it cannot."""
    with drawing(file, "the picture"):
        _draw(scenario, events, file)


def _draw(scenario: Scenario, events: list[TraceEvent], file: str) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    world = scenario.world
    top = scenario.agent_names[0]
    fig, ax = plt.subplots(figsize=(7, 9))
    for arc in world.arcs.values():
        a, b = world.nodes[arc.a], world.nodes[arc.b]
        ax.plot([a.x, b.x], [a.y, b.y], color="#cccccc", linewidth=1, zorder=1)
    for area, names in world.area_nodes.items():
        xs = [world.nodes[n].x for n in names]
        ys = [world.nodes[n].y for n in names]
        if xs:
            ax.text(sum(xs) / len(xs), max(ys) + 0.6, area, ha="center", fontsize=8, color="#888888")
    for node in world.nodes.values():
        ax.plot(node.x, node.y, "o", color="#999999", markersize=3, zorder=2)
        ax.text(node.x + 0.2, node.y + 0.2, node.name, fontsize=6, color="#666666")
    depth = 0
    normal_drawn = emergency_drawn = False
    for e in events:
        if isinstance(e, GoalReceived) and e.agent == top and e.emergency:
            depth += 1
        elif isinstance(e, GoalFinished) and e.agent == top and depth and _is_emergency(events, e):
            depth -= 1
        elif isinstance(e, RobotMoving) and e.arc is not None and e.arc in world.arcs:
            arc = world.arcs[e.arc]
            a, b = world.nodes[arc.a], world.nodes[arc.b]
            red = depth > 0
            ax.plot(
                [a.x, b.x],
                [a.y, b.y],
                color="#d62728" if red else "#1f77b4",
                linewidth=3 if red else 2.5,
                alpha=0.8,
                zorder=3 if red else 2,
                label=None
                if (red and emergency_drawn) or (not red and normal_drawn)
                else ("emergency" if red else "first goal"),
            )
            emergency_drawn |= red
            normal_drawn |= not red
    start = world.nodes.get(scenario.robot.start or "")
    if start is not None:  # an HDDL agent's robot has no map (docs/design.md §7.1)
        ax.plot(start.x, start.y, "s", color="black", markersize=8, zorder=4, label="start")
    ax.set_aspect("equal")
    ax.invert_yaxis()
    ax.set_title(scenario.name)
    if ax.get_legend_handles_labels()[0]:  # nothing to label on an HDDL agent's world (§7.1)
        ax.legend(loc="lower right", fontsize=8)
    try:
        fig.savefig(file, dpi=120, bbox_inches="tight")
    except OSError as exc:
        raise PlotError(f"{file}: cannot write the picture: {exc.strerror or exc}") from None
    finally:
        plt.close(fig)


def _is_emergency(events: list[TraceEvent], finished: GoalFinished) -> bool:
    return any(
        isinstance(e, GoalReceived) and e.agent == finished.agent and e.goal == finished.goal and e.emergency
        for e in events
    )
