"""A run as a timeline picture (``run --timeline FILE.png``), drawn from its :class:`History`.

One lane per agent, parent on top.  Each goal is a bar from received to
finished; goals that overlap in time (an emergency over the goal it suspended)
stack in rows of the lane.  A bar is hatched while its goal is suspended on the
stack and paler while it waits behind another goal for its first plan;
emergencies have their own colour; a failure is a cross at its end with the
reason beside it.  Below the lanes, each agent's stack depth over time.
Emergencies arriving and doors shutting or opening are vertical lines across
both.  Needs matplotlib (the ``plot`` extra), like :mod:`htnagent.views.plot`.
"""

from __future__ import annotations

from typing import Any

from htnagent.errors import PlotError, drawing
from htnagent.views.history import GoalBar, History

GOAL_COLOUR = "#4c78a8"
EMERGENCY_COLOUR = "#e45756"
FAILURE_COLOUR = "#222222"
DOOR_COLOUR = "#7f7f7f"
AGENT_COLOURS = ("#1b9e77", "#d95f02", "#7570b3", "#e7298a", "#66a61e")

_ROW = 1.0
_BAR = 0.72
_GAP = 0.7
"""Between two lanes, in rows."""
_WIDTH_IN = 13.0
_FONT = 7.5
_MAX_HEIGHT_IN = 40.0
_MAX_TIERS = 6
"""Rows of mark labels above the lanes, at most."""


def draw_timeline(history: History, file: str, title: str = "") -> None:
    """Draw ``history`` as a timeline PNG into ``file``; PlotError if it cannot."""
    with drawing(file, "the timeline"):
        _draw(history, file, title)


def _draw(history: History, file: str, title: str) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from matplotlib.lines import Line2D
    from matplotlib.patches import Patch
    from matplotlib.ticker import MaxNLocator

    lanes = _lanes(history)
    total_rows = sum(rows for _, _, rows in lanes) + _GAP * max(0, len(lanes) - 1)
    # Rows of 0.42 in, the whole at most _MAX_HEIGHT_IN (a storm of nested goals still draws).
    lane_height = min(max(1.6, 0.42 * total_rows + 0.6), _MAX_HEIGHT_IN)
    fig, (ax, depth_ax) = plt.subplots(
        2,
        1,
        figsize=(_WIDTH_IN, lane_height + 2.4),
        sharex=True,
        gridspec_kw={"height_ratios": [lane_height, 1.5], "hspace": 0.08},
    )
    end = max(history.end, 1e-6)
    ax.set_xlim(-0.01 * end, end * 1.01)
    ax.set_ylim(total_rows + 0.2, -0.2)
    seconds_per_inch = end * 1.02 / (_WIDTH_IN * 0.8)

    ticks, names = [], []
    for agent, top, rows in lanes:
        ticks.append(top + rows / 2)
        names.append(agent)
        ax.axhspan(top - 0.12, top + rows + 0.12, color="#f4f4f4", zorder=0)
        for goal, row in history.goal_rows(agent):
            _bar(ax, goal, top + row * _ROW, history.end, seconds_per_inch)
    ax.set_yticks(ticks, names, fontsize=9, fontweight="bold")
    ax.tick_params(axis="y", length=0)
    for side in ("top", "right", "left"):
        ax.spines[side].set_visible(False)

    for i, agent in enumerate(history.agents):
        steps = history.depth[agent]
        xs = [t for t, _ in steps] + [history.end]
        # Agents' lines a little apart, so that equal depths do not hide each other.
        ys = [d - 0.06 * i for _, d in steps] + [steps[-1][1] - 0.06 * i]
        depth_ax.step(
            xs,
            ys,
            where="post",
            color=AGENT_COLOURS[i % len(AGENT_COLOURS)],
            linewidth=2.0 - 0.3 * min(i, 3),
            label=agent,
            alpha=0.9,
        )
    most = max((d for steps in history.depth.values() for _, d in steps), default=0)
    depth_ax.set_ylim(-0.3, most + 0.6)
    depth_ax.yaxis.set_major_locator(MaxNLocator(nbins=5, integer=True))
    depth_ax.set_ylabel("stack depth", fontsize=8)
    depth_ax.set_xlabel("simulated time (s)", fontsize=8)
    agents_legend = depth_ax.legend(loc="upper right", fontsize=7, ncol=len(history.agents), frameon=False)
    for side in ("top", "right"):
        depth_ax.spines[side].set_visible(False)

    tiers = _marks(history, ax, depth_ax, seconds_per_inch)

    legend = [
        Patch(facecolor=GOAL_COLOUR, label="goal"),
        Patch(facecolor=EMERGENCY_COLOUR, label="emergency goal"),
        Patch(facecolor="white", edgecolor=GOAL_COLOUR, hatch="////", label="suspended (on the stack)"),
        Patch(facecolor="#b7c9dc", label="waiting to start"),
        Line2D([], [], color=FAILURE_COLOUR, marker="x", linestyle="", label="failed"),
        Line2D([], [], color=EMERGENCY_COLOUR, linestyle="--", label="emergency arrives"),
        Line2D([], [], color=DOOR_COLOUR, linestyle=":", label="door shut / opened"),
    ]
    depth_ax.legend(
        handles=legend, loc="upper center", bbox_to_anchor=(0.5, -0.32), ncol=7, fontsize=7.5, frameon=False
    )
    depth_ax.add_artist(agents_legend)
    if title:
        ax.set_title(title, fontsize=11, pad=14 + 10 * tiers, loc="left")
    try:
        fig.savefig(file, dpi=110, bbox_inches="tight", pad_inches=0.15)
    except OSError as exc:
        raise PlotError(f"{file}: cannot write the timeline: {exc.strerror or exc}") from None
    finally:
        plt.close(fig)


def _lanes(history: History) -> list[tuple[str, float, int]]:
    """Each agent's lane: (agent, top row, number of rows)."""
    out: list[tuple[str, float, int]] = []
    top = 0.0
    for agent in history.agents:
        rows = max((row for _, row in history.goal_rows(agent)), default=0) + 1
        out.append((agent, top, rows))
        top += rows + _GAP
    return out


def _bar(ax: Any, goal: GoalBar, y: float, end_of_run: float, seconds_per_inch: float) -> None:
    end = end_of_run if goal.end is None else goal.end
    colour = EMERGENCY_COLOUR if goal.emergency else GOAL_COLOUR
    y0 = y + (_ROW - _BAR) / 2
    width = max(end - goal.received, seconds_per_inch * 0.02)
    ax.broken_barh([(goal.received, width)], (y0, _BAR), facecolors=colour, edgecolor="white", linewidth=0.6)
    started = goal.plans[0].t if goal.plans else goal.received
    if started > goal.received:  # waiting behind the running goal: paler
        ax.broken_barh([(goal.received, started - goal.received)], (y0, _BAR), facecolors="white", alpha=0.6)
    for span in goal.suspended:
        stop = end if span.end is None else span.end
        if stop > span.start:
            ax.broken_barh(
                [(span.start, stop - span.start)],
                (y0, _BAR),
                facecolors="white",
                edgecolor=colour,
                hatch="////",
                linewidth=0.6,
            )
    _label(ax, goal, y, end)
    if goal.status == "failure":
        ax.plot(
            end, y + _ROW / 2, marker="x", color=FAILURE_COLOUR, markersize=8, markeredgewidth=2, zorder=5
        )
        reason = goal.reason if len(goal.reason) <= 60 else goal.reason[:57] + "..."
        ax.annotate(
            f"failed: {reason}" if reason else "failed",
            (end, y + _ROW / 2),
            xytext=(6, 0),
            textcoords="offset points",
            va="center",
            ha="left",
            fontsize=_FONT - 0.5,
            color=FAILURE_COLOUR,
            bbox={"facecolor": "#fff3c4", "edgecolor": "#c9a400", "pad": 1.5, "linewidth": 0.5},
            zorder=6,
        )
    elif goal.status == "cleared":
        ax.plot(end, y + _ROW / 2, marker="|", color="#555555", markersize=9, zorder=5)


def _label(ax: Any, goal: GoalBar, y: float, end: float) -> None:
    """The goal's name in its bar, measured: smaller if it must, the task's name alone if the
    bar is short (:attr:`GoalBar.labels`), left out if even that does not fit.

    White over the part where the goal ran first; dark on a white box where it
    has to cross the hatching.
    """
    renderer = ax.figure.canvas.get_renderer()

    def px(t: float) -> float:
        return float(ax.transData.transform((t, 0))[0])

    text = ax.annotate(
        goal.goal,
        (goal.received, y + _ROW / 2),
        xytext=(3, 0),
        textcoords="offset points",
        va="center",
        ha="left",
        fontsize=_FONT,
        color="white",
        clip_on=True,
    )
    room = px(end) - px(goal.received) - 8
    fitting = (
        (label, font) for label in goal.labels for font in (_FONT, _FONT - 1.5)
    )  # the whole name first, at the smaller font if it must, then the task's name alone
    for label, font in fitting:
        text.set_text(label)
        text.set_fontsize(font)
        width = text.get_window_extent(renderer).width
        if width < room:
            break
    else:
        text.remove()
        return
    first_stop = goal.first_stop(end)
    if width >= px(first_stop) - px(goal.received) - 8:
        text.set_color("#111111")
        text.set_bbox({"facecolor": "white", "edgecolor": "none", "pad": 0.5})
        text.set_zorder(4)  # over the line of the emergency that suspended it


def _marks(history: History, ax: Any, depth_ax: Any, seconds_per_inch: float) -> int:
    """Vertical lines for emergencies and doors, their labels above the lanes in staggered tiers.

    Returns the number of tiers the labels took.
    """
    tiers: list[float] = []  # where each tier's last label ends, in seconds
    for mark in history.marks:
        text = mark.label if len(mark.label) <= 50 else mark.label[:47] + "..."
        if mark.kind == "emergency":
            colour, style = EMERGENCY_COLOUR, "--"
        elif mark.kind == "crash":
            colour, style = FAILURE_COLOUR, "-"
        else:
            colour, style = DOOR_COLOUR, ":"
        for axis in (ax, depth_ax):
            axis.axvline(mark.t, color=colour, linestyle=style, linewidth=1.0, alpha=0.8, zorder=1)
        width = len(text) * 7 * 0.55 / 72 * seconds_per_inch
        tier = next((i for i, last in enumerate(tiers) if last < mark.t), len(tiers))
        if tier == _MAX_TIERS:
            continue  # a crowd of marks: the lines stay, the labels would only cover each other
        if tier == len(tiers):
            tiers.append(0.0)
        tiers[tier] = mark.t + width + seconds_per_inch * 0.1
        ax.annotate(
            text,
            (mark.t, 1),
            xycoords=("data", "axes fraction"),
            xytext=(2, 3 + 10 * tier),
            textcoords="offset points",
            fontsize=7,
            color=colour,
            ha="left",
            va="bottom",
            annotation_clip=False,
        )
    return len(tiers)
