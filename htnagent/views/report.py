"""A run as one self-contained HTML page (``report TRACE --html OUT``), drawn from its :class:`History`.

The page holds everything it shows: no network, no external script, style or
font.  It has the timeline (as inline SVG, drawn here), the map with the
robot's way (inline SVG, when the scenario is given: a trace carries no map),
a slider and a play button over simulated time, and for the slider's time each
agent's current goal, stack, selected plan and action.  ``#t=SECONDS`` in the
address opens the page at that time; moving the slider updates it.

The history's JSON form (:meth:`History.as_json`) is embedded as
``<script type="application/json" id="htn-data">``.  The page's logic script
(``id="htn-logic"``) computes the state at a time from that data alone, with
pure functions that mirror :meth:`History.at` (``stateAt``); a test runs it
under Node against the Python model.  The interface script (``id="htn-ui"``)
only draws what ``stateAt`` returns.
"""

from __future__ import annotations

import html
import json
import math
import os
import stat
from pathlib import Path

from htnagent.domains.maps import WorldMap
from htnagent.errors import PlotError
from htnagent.runtime.events import JSONValue
from htnagent.scenario import Scenario
from htnagent.views.history import GoalBar, History

GOAL_COLOUR = "#4c78a8"
EMERGENCY_COLOUR = "#e45756"
DOOR_COLOUR = "#7f7f7f"

_TL_WIDTH = 1000
_TL_LEFT = 90
_TL_RIGHT = 20
_ROW = 22
_BAR = 16
_LANE_GAP = 14
_TOP = 30
_MAP_WIDTH = 560
_MAX_TIERS = 6
"""Rows of mark labels above the timeline, at most."""


def check_report_target(file: str, source: str) -> None:
    """Fail early, before the trace is read, if the page could not be written to ``file``:
    no name, the trace itself (it would be overwritten), a folder, or a FIFO or socket
    (writing would wait for a reader for ever) other than this process's own stdout."""
    if not file:
        raise PlotError("--html: give the name of the page to write")
    try:
        info: os.stat_result | None = os.stat(file)
    except (OSError, ValueError):
        info = None  # not there (or no such name): writing says why if it cannot
    if info is None:
        return
    if stat.S_ISDIR(info.st_mode):
        raise PlotError(f"{file}: is a directory; give a file name for the page")
    if not (stat.S_ISREG(info.st_mode) or stat.S_ISCHR(info.st_mode) or _is_stdout(info)):
        # A FIFO nobody reads would make writing wait for ever (/dev/stdout into a pipe is fine).
        raise PlotError(f"{file}: is not a regular file; give a file name for the page")
    try:
        same = os.path.samefile(file, source)
    except (OSError, ValueError):
        same = False
    if same:
        raise PlotError(f"{file}: is the trace being read; give the page another name")


def _is_stdout(info: os.stat_result) -> bool:
    try:
        return os.path.samestat(info, os.fstat(1))
    except OSError:
        return False


def write_report(history: History, file: str, *, scenario: Scenario | None = None, source: str = "") -> None:
    """Write the page for ``history`` to ``file``; PlotError if the file cannot be written."""
    page = render(history, scenario=scenario, source=source)
    try:
        Path(file).write_text(page, encoding="utf-8")
    except OSError as e:
        raise PlotError(f"{file}: cannot write the report: {e.strerror or e}") from None
    except ValueError:
        raise PlotError(f"{file}: cannot write the report: the name holds a NUL character") from None


def page_data(history: History, scenario: Scenario | None = None, source: str = "") -> dict[str, JSONValue]:
    """What the page embeds: the history, the map (if known), a title."""
    world: JSONValue = None
    if scenario is not None and scenario.map is not None:  # an HDDL agent's world has no map (§7.1)
        w = scenario.world
        world = {
            "nodes": {n.name: [n.x, n.y] for n in w.nodes.values()},
            "arcs": {a_id: [a.a, a.b] for a_id, a in w.arcs.items()},
        }
    return {
        "title": page_title(history, scenario, source),
        "source": source,
        "history": history.as_json(),
        "map": world,
    }


def page_title(history: History, scenario: Scenario | None = None, source: str = "") -> str:
    """The scenario's name (given, or from the trace's header), else the trace file's name."""
    if scenario is not None:
        return scenario.name
    if history.scenario_name:
        return history.scenario_name
    return Path(source).name if source else "htnagent run"


def render(history: History, *, scenario: Scenario | None = None, source: str = "") -> str:
    """The whole page as text."""
    data = page_data(history, scenario, source)
    title = html.escape(str(data["title"]))
    blob = _script_json(data)
    return _PAGE.format(
        title=title,
        run=_run_line(history, source),
        summary=_summary(history),
        timeline=_timeline_svg(history),
        map=_map_part(scenario, history),
        agents=_agent_panels(history),
        end=_e(repr(float(history.end))),
        data=blob,
        logic=_LOGIC,
        ui=_UI,
        style=_STYLE,
    )


def _script_json(data: dict[str, JSONValue]) -> str:
    """JSON safe inside ``<script>``: no ``</script>``, no comment openers, no line separators."""
    text = json.dumps(data, ensure_ascii=False, allow_nan=False, separators=(",", ":"))
    for char, escaped in (("<", "\\u003c"), (">", "\\u003e"), ("&", "\\u0026")):
        text = text.replace(char, escaped)
    return text.replace("\u2028", "\\u2028").replace("\u2029", "\\u2029")


def _e(value: object) -> str:
    return html.escape(str(value), quote=True)


MODES = {
    "online": "on-line replanning: a suspended goal keeps its plans and resumes by repairing them",
    "naive": "naive replanning: a suspended goal is planned again from scratch when it resumes",
}
"""What each replanning mode means, in the words the page shows beside it."""


def _run_line(history: History, source: str) -> str:
    """The mode (from the trace's header), the version that ran, the trace's file."""
    parts = []
    if history.mode is None:
        parts.append('mode: <b id="mode">not recorded</b> (the trace has no run_started header)')
    else:
        meaning = MODES.get(history.mode, "")
        parts.append(
            f'mode: <b id="mode" class="mode-{_e(history.mode)}">{_e(history.mode)}</b>'
            + (f' <span class="meaning">({_e(meaning)})</span>' if meaning else "")
        )
    if history.run is not None and history.run.version:
        parts.append(f"htnagent {_e(history.run.version)}")
    if source:
        parts.append(f"trace {_e(Path(source).name)}")
    return f'<p class="run" id="run-info">{" · ".join(parts)}</p>'


def _summary(history: History) -> str:
    summary = history.summary
    if summary is None:
        return ""
    rows = []
    for g in summary.goals:
        mark = "ok" if g.status == "success" else "failed"
        reason = f" — {_e(g.reason)}" if g.reason else ""
        rows.append(f'<li class="{mark}"><b>{_e(g.agent)}</b> {_e(g.goal)}: {_e(g.status)}{reason}</li>')
    where = ", ".join(f"{_e(k)} {_e(v)}" for k, v in summary.robot.items())
    # An HDDL agent's robot is on no map: no place, no distance.
    robot = f"robot ends {where}; travelled {summary.distance:.2f} m; " if where else ""
    return (
        f'<ul class="goals">{"".join(rows)}</ul><p class="facts">{robot}run ends at {history.end:.2f} s</p>'
    )


# -- the timeline --------------------------------------------------------------------------------


def _timeline_svg(history: History) -> str:
    end = max(history.end, 1e-6)
    scale = (_TL_WIDTH - _TL_LEFT - _TL_RIGHT) / end
    out: list[str] = []
    on_top: list[str] = []  # labels across hatching, failures' crosses and reasons: over the rest
    labels, tiers = _mark_labels(history, scale)
    first = _TOP + 12 * tiers
    y = float(first)
    for agent in history.agents:
        rows = history.goal_rows(agent)
        n = max((r for _, r in rows), default=0) + 1
        height = n * _ROW
        out.append(
            f'<rect class="lane" x="{_TL_LEFT - 4}" y="{y - 3:.1f}" '
            f'width="{_TL_WIDTH - _TL_LEFT - _TL_RIGHT + 8}" '
            f'height="{height + 6:.1f}"/>'
            f'<text class="lane-name" x="{_TL_LEFT - 10}" y="{y + height / 2 + 4:.1f}">'
            f"<title>{_e(agent)}</title>{_e(_lane_name(agent))}</text>"
        )
        for goal, row in rows:
            bar, over = _goal_bar(goal, y + row * _ROW, scale, history.end)
            out.append(bar)
            on_top.append(over)
        y += height + _LANE_GAP
    lanes_bottom = y - _LANE_GAP + 3
    depth_top = lanes_bottom + 14
    most = max((d for steps in history.depth.values() for _, d in steps), default=0)
    depth_height = 18 * (most + 1)
    # The label ends left of the depth axis's widest number (6.5 px a digit at 10 px), with a gap.
    label_end = _TL_LEFT - 4 - 6.5 * len(str(most)) - 6
    out.append(
        f'<text class="lane-name depth-name" x="{label_end:.1f}" '
        f'y="{depth_top + depth_height / 2 + 4:.1f}">stack</text>'
    )
    colours = ("#1b9e77", "#d95f02", "#7570b3", "#e7298a", "#66a61e")
    keys: list[str] = []  # each agent's name in its line's colour, over the cursor (drawn last)
    key_end = _TL_WIDTH - _TL_RIGHT - 6.0
    for i, agent in enumerate(history.agents):
        points = []
        last = 0
        for t, d in history.depth[agent]:
            x = _TL_LEFT + t * scale
            points.append(f"{x:.1f},{_depth_y(last, depth_top, depth_height, most, i):.1f}")
            points.append(f"{x:.1f},{_depth_y(d, depth_top, depth_height, most, i):.1f}")
            last = d
        points.append(f"{_TL_LEFT + end * scale:.1f},{_depth_y(last, depth_top, depth_height, most, i):.1f}")
        colour = colours[i % len(colours)]
        out.append(f'<polyline class="depth" stroke="{colour}" points="{" ".join(points)}"/>')
        keys.append(
            f'<text class="depth-key" fill="{colour}" x="{key_end:.1f}" '
            f'y="{depth_top - 3:.1f}" text-anchor="end">{_e(agent)}</text>'
        )
        key_end -= 6.5 * len(agent) + 14  # 11 px letters, then a gap
    for k in sorted({0, most // 2, most}):
        out.append(
            f'<text class="tick depth-tick" x="{_TL_LEFT - 4}" '
            f'y="{_depth_y(k, depth_top, depth_height, most, 0) + 3:.1f}" '
            f'text-anchor="end">{k}</text>'
        )
    bottom = depth_top + depth_height + 4
    for mark in history.marks:
        x = _TL_LEFT + mark.t * scale
        cls = "emergency" if mark.kind == "emergency" else ("crash" if mark.kind == "crash" else "door")
        out.append(
            f'<line class="mark {cls}" x1="{x:.1f}" x2="{x:.1f}" y1="{first - 8}" y2="{bottom:.1f}">'
            f"<title>{_e(mark.label)} at {mark.t:.2f} s</title></line>"
        )
    step = _tick_step(end)
    k = 0
    while k * step <= end + 1e-9:
        x = _TL_LEFT + k * step * scale
        out.append(
            f'<line class="grid" x1="{x:.1f}" x2="{x:.1f}" y1="{bottom:.1f}" y2="{bottom + 4:.1f}"/>'
            f'<text class="tick" x="{x:.1f}" y="{bottom + 15:.1f}" text-anchor="middle">{k * step:g}</text>'
        )
        k += 1
    total = bottom + 22
    # Long agent names widen the drawing to the left rather than run off its edge.
    longest = max((len(_lane_name(a)) for a in history.agents), default=0)
    extra = max(0.0, _NAME_PX * longest + 16 - _TL_LEFT)
    out += on_top
    out += labels
    out.append(f'<line id="tl-cursor" x1="{_TL_LEFT}" x2="{_TL_LEFT}" y1="{first - 12}" y2="{bottom:.1f}"/>')
    out += keys
    return (
        f'<svg id="timeline" viewBox="{-extra:.0f} 0 {_TL_WIDTH + extra:.0f} {total:.0f}" width="100%" '
        f'data-left="{_TL_LEFT}" data-scale="{scale:.9g}" role="img" '
        f'aria-label="timeline of goals and stacks">{"".join(out)}</svg>'
    )


_NAME_PX = 7.5
"""The width of a letter of a lane's name (12 px, bold), at most."""


def _lane_name(agent: str) -> str:
    return agent if len(agent) <= 32 else agent[:31] + "…"


def _mark_labels(history: History, scale: float) -> tuple[list[str], int]:
    """The marks' labels above the lanes, in as many tiers as keep them apart; and how many."""
    ends: list[float] = []  # where each tier's last label ends, in pixels
    out = []
    for mark in history.marks:
        x = _TL_LEFT + mark.t * scale
        text = mark.label if len(mark.label) <= 50 else mark.label[:47] + "..."
        tier = next((i for i, e in enumerate(ends) if e < x), len(ends))
        if tier == _MAX_TIERS:
            continue  # a crowd of marks: the lines stay (with their tooltips), the labels would overlap
        if tier == len(ends):
            ends.append(0.0)
        ends[tier] = x + 6.0 * len(text) + 8
        cls = "emergency" if mark.kind == "emergency" else ("crash" if mark.kind == "crash" else "door")
        out.append((tier, x, cls, text))
    tiers = len(ends)
    labels = [
        f'<text class="mark-label {cls}" x="{x + 3:.1f}" y="{_TOP + 12 * (tiers - tier) - 10:.1f}">'
        f"{_e(text)}</text>"
        for tier, x, cls, text in out
    ]
    return labels, tiers


def _depth_y(d: int, top: float, height: float, most: int, i: int) -> float:
    return top + height - 4 - (height - 10) * (d / max(most, 1)) - 1.5 * i


def _tick_step(end: float) -> float:
    raw = end / 10
    base = 10 ** math.floor(math.log10(raw)) if raw > 0 else 1
    return next((base * m for m in (1, 2, 5, 10) if base * m >= raw), base * 10)


def _goal_bar(goal: GoalBar, y: float, scale: float, end_of_run: float) -> tuple[str, str]:
    """The goal's bar, and what is drawn over everything (over the marks' lines too): its
    label where it crosses the hatching, and its failure, if it failed."""
    end = end_of_run if goal.end is None else goal.end
    x0 = _TL_LEFT + goal.received * scale
    width = max((end - goal.received) * scale, 1.5)
    top = y + (_ROW - _BAR) / 2
    kind = "emergency" if goal.emergency else "goal"
    colour = EMERGENCY_COLOUR if goal.emergency else GOAL_COLOUR
    tip = f"{goal.agent}: {goal.goal}, {goal.received:.2f}–{end:.2f} s, {goal.status}"
    if goal.reason:
        tip += f" ({goal.reason})"
    parts = [
        f'<g class="bar {kind} {goal.status}"><title>{_e(tip)}</title>',
        f'<rect x="{x0:.1f}" y="{top:.1f}" width="{width:.1f}" height="{_BAR}" fill="{colour}"/>',
    ]
    started = goal.plans[0].t if goal.plans else goal.received
    if started > goal.received:  # waiting behind the running goal: paler
        wait = (started - goal.received) * scale
        parts.append(f'<rect class="waiting" x="{x0:.1f}" y="{top:.1f}" width="{wait:.1f}" height="{_BAR}"/>')
    for span in goal.suspended:
        stop = end if span.end is None else span.end
        if stop <= span.start:
            continue
        sx0 = _TL_LEFT + span.start * scale
        sx1 = _TL_LEFT + stop * scale
        parts.append(
            f'<rect class="suspended" x="{sx0:.1f}" y="{top:.1f}" width="{sx1 - sx0:.1f}" height="{_BAR}" '
            f'stroke="{colour}"/>'
        )
        parts.append(f'<path class="hatch" stroke="{colour}" d="{_hatch(sx0, sx1, top, top + _BAR)}"/>')
    # The whole name, else the task's name alone (GoalBar.labels), if either fits.
    name = next((label for label in goal.labels if len(label) * 6.2 < width - 6), None)
    over = ""
    if name is not None:
        label_width = len(name) * 6.2
        # White on the bar's colour; across hatching, dark with a white halo, over the
        # line of the emergency that suspended it.
        first_stop = goal.first_stop(end)
        label = f'<text class="bar-label{{}}" x="{x0 + 3:.1f}" y="{top + 12:.1f}">{_e(name)}</text>'
        if label_width < (first_stop - goal.received) * scale - 6:
            parts.append(label.format(""))
        else:
            over = label.format(" dark")
    parts.append("</g>")
    if goal.status == "failure":
        x1 = x0 + width
        cy = top + _BAR / 2
        over += (
            f'<path class="fail" d="M{x1 - 5:.1f},{cy - 5:.1f}L{x1 + 5:.1f},{cy + 5:.1f}'
            f'M{x1 - 5:.1f},{cy + 5:.1f}L{x1 + 5:.1f},{cy - 5:.1f}"/>'
            f'<text class="fail-label" x="{x1 + 8:.1f}" y="{cy + 4:.1f}">'
            f"failed: {_e(goal.reason[:60])}</text>"
        )
    return "".join(parts), over


def _hatch(x0: float, x1: float, y0: float, y1: float, step: float = 6.0) -> str:
    """Diagonal strokes filling the box, clipped by hand (the page refers to nothing, not even a pattern)."""
    h = y1 - y0
    out = []
    a = x0 - h
    while a < x1:
        xs, xe = max(a, x0), min(a + h, x1)
        if xs < xe:
            out.append(f"M{xs:.1f},{y1 - (xs - a):.1f}L{xe:.1f},{y1 - (xe - a):.1f}")
        a += step
    return "".join(out)


# -- the map --------------------------------------------------------------------------------------

_NO_MAP_IN_WORLD = (
    '<p class="nomap">No map: this scenario\'s agent works on a world of facts (HDDL), not on a map. '
    'The robot is at: <b id="robot-text"></b></p>'
)


def _map_part(scenario: Scenario | None, history: History) -> str:
    if scenario is None:
        return _NO_MAP
    if scenario.map is None:  # an HDDL agent's world has no map (§7.1)
        return _NO_MAP_IN_WORLD
    return _map_svg(scenario, history)


_NO_MAP = (
    '<p class="nomap">No map: a trace does not carry one. Give <code>--scenario SCENARIO.yaml</code> '
    'to draw it. The robot is at: <b id="robot-text"></b></p>'
)


_AREA_FONT = 3.2
"""An area's name's font size, in hundredths of the map's span (a node's name: 1.7)."""


def _area_name_spots(world: WorldMap, unit: float) -> dict[str, tuple[float, float]]:
    """Where each area's name is written: in the area's box, on as little of the nodes
    and their names as can be (a name at the centroid of its nodes sat on a node or on
    its name), clear of the names written before, then of the arcs and of a margin
    round it, then as near that centroid as can be.

    A name is a box its glyphs fill (about 0.6 of the font size wide each); what the map
    draws is counted in cells of one unit (:class:`_Crowding`), so that any box is
    counted at once."""
    font = unit * _AREA_FONT
    node_font = unit * 1.7
    crowd = _Crowding(world, unit)
    for node in world.nodes.values():
        crowd.cover(node.x - unit, node.x + unit, node.y - unit, node.y + unit, weight=3)
        # A node's name: to its upper right, as _map_svg writes it.
        width = 0.6 * node_font * len(node.name)
        crowd.cover(node.x + unit, node.x + unit + width, node.y - unit - node_font, node.y - unit, weight=3)
    for arc in world.arcs.values():
        a, b = world.nodes[arc.a], world.nodes[arc.b]
        crowd.line(a.x, a.y, b.x, b.y, weight=1)
    crowd.count_up()
    margin = font * 0.6
    written: list[tuple[float, float, float, float]] = []
    spots: dict[str, tuple[float, float]] = {}
    for area, names in world.area_nodes.items():
        xs = [world.nodes[n].x for n in names]
        ys = [world.nodes[n].y for n in names]
        if not xs:
            continue
        cx, cy = sum(xs) / len(xs), sum(ys) / len(ys)
        half = 0.3 * font * len(area)
        best: tuple[float, int, float] | None = None
        spot = (cx, cy)
        for i in range(9):
            for j in range(9):
                x = min(xs) + (max(xs) - min(xs)) * i / 8
                y = min(ys) + (max(ys) - min(ys)) * j / 8
                box = (x - half, x + half, y - font / 2, y + font / 2)
                under = crowd.weight(*box) + 3 * sum(_meet(box, other) for other in written)
                round_it = (box[0] - margin, box[1] + margin, box[2] - margin, box[3] + margin)
                crowded = crowd.weight(*round_it) + 3 * sum(_meet(round_it, other) for other in written)
                key = (under, int(crowded > under), math.dist((x, y), (cx, cy)))
                if best is None or key < best:
                    best, spot = key, (x, y)
        spots[area] = spot
        written.append((spot[0] - half, spot[0] + half, spot[1] - font / 2, spot[1] + font / 2))
    return spots


def _meet(a: tuple[float, float, float, float], b: tuple[float, float, float, float]) -> bool:
    """Whether two boxes (x0, x1, y0, y1) overlap."""
    return a[0] < b[1] and b[0] < a[1] and a[2] < b[3] and b[2] < a[3]


class _Crowding:
    """What the map draws, counted in square cells of ``unit``: each thing adds its weight
    to the cells it covers; :meth:`weight` sums a box's cells at once (a summed-area table,
    made by :meth:`count_up` once everything is covered)."""

    def __init__(self, world: WorldMap, unit: float) -> None:
        xs = [n.x for n in world.nodes.values()] or [0.0]
        ys = [n.y for n in world.nodes.values()] or [0.0]
        self.unit = max(unit, 1e-9)
        # Room round the nodes for the names written beside them and across the edges.
        self.x0, self.y0 = min(xs) - 20 * self.unit, min(ys) - 20 * self.unit
        self.cols = math.ceil((max(xs) - min(xs)) / self.unit) + 41
        self.rows = math.ceil((max(ys) - min(ys)) / self.unit) + 41
        self.cells = [[0] * self.cols for _ in range(self.rows)]
        self.sums: list[list[int]] = []

    def _col(self, x: float) -> int:
        return min(max(math.floor((x - self.x0) / self.unit), 0), self.cols - 1)

    def _row(self, y: float) -> int:
        return min(max(math.floor((y - self.y0) / self.unit), 0), self.rows - 1)

    def cover(self, x0: float, x1: float, y0: float, y1: float, *, weight: int) -> None:
        for r in range(self._row(y0), self._row(y1) + 1):
            row = self.cells[r]
            for c in range(self._col(x0), self._col(x1) + 1):
                row[c] += weight

    def line(self, ax: float, ay: float, bx: float, by: float, *, weight: int) -> None:
        steps = max(1, math.ceil(2 * math.dist((ax, ay), (bx, by)) / self.unit))
        cells = {
            (self._row(ay + (by - ay) * k / steps), self._col(ax + (bx - ax) * k / steps))
            for k in range(steps + 1)
        }
        for r, c in cells:
            self.cells[r][c] += weight

    def count_up(self) -> None:
        sums = [[0] * (self.cols + 1) for _ in range(self.rows + 1)]
        for r in range(self.rows):
            above, here, row = sums[r], sums[r + 1], self.cells[r]
            running = 0
            for c in range(self.cols):
                running += row[c]
                here[c + 1] = above[c + 1] + running
        self.sums = sums

    def weight(self, x0: float, x1: float, y0: float, y1: float) -> int:
        """The weight of what covers the box's cells."""
        r0, r1, c0, c1 = self._row(y0), self._row(y1) + 1, self._col(x0), self._col(x1) + 1
        s = self.sums
        return s[r1][c1] - s[r0][c1] - s[r1][c0] + s[r0][c0]


def _map_svg(scenario: Scenario, history: History) -> str:
    world = scenario.world
    xs = [n.x for n in world.nodes.values()] or [0.0]
    ys = [n.y for n in world.nodes.values()] or [0.0]
    span = max(max(xs) - min(xs), max(ys) - min(ys), 1e-9)
    pad = span * 0.06
    x0, y0 = min(xs) - pad, min(ys) - pad
    w, h = max(xs) - min(xs) + 2 * pad, max(ys) - min(ys) + 2 * pad
    unit = span / 100  # sizes in map units, so that any map's scale looks alike
    parts = []
    for arc_id, arc in world.arcs.items():
        a, b = world.nodes[arc.a], world.nodes[arc.b]
        parts.append(
            f'<line class="arc" data-arc="{_e(arc_id)}" x1="{a.x:g}" y1="{a.y:g}" x2="{b.x:g}" y2="{b.y:g}" '
            f'stroke-width="{unit * 0.4:.4g}"><title>{_e(arc_id)}</title></line>'
        )
    small = len(world.nodes) <= 400
    if small:
        for area, (x, y) in _area_name_spots(world, unit).items():
            size = unit * _AREA_FONT
            parts.append(f'<text class="area" x="{x:g}" y="{y:g}" font-size="{size:.4g}">{_e(area)}</text>')
    # The way under the nodes and their names, so that it hides neither.
    parts.append(f'<g id="trail" stroke-width="{unit * 1.0:.4g}"></g>')
    for node in world.nodes.values():
        parts.append(f'<circle class="node" cx="{node.x:g}" cy="{node.y:g}" r="{unit * 0.7:.4g}"/>')
        if small:
            parts.append(
                f'<text class="node-name" x="{node.x + unit:g}" y="{node.y - unit:g}" '
                f'font-size="{unit * 1.7:.4g}">{_e(node.name)}</text>'
            )
    start = world.nodes.get(scenario.robot.start or "")
    if start is not None:
        parts.append(
            f'<rect class="start" x="{start.x - unit * 1.2:g}" y="{start.y - unit * 1.2:g}" '
            f'width="{unit * 2.4:.4g}" height="{unit * 2.4:.4g}">'
            f"<title>start: {_e(start.name)}</title></rect>"
        )
    end = world.nodes.get(_end_node(history) or "")
    if end is not None:
        parts.append(
            f'<circle class="end" cx="{end.x:g}" cy="{end.y:g}" r="{unit * 2.6:.4g}" '
            f'stroke-width="{unit * 0.6:.4g}"><title>end: {_e(end.name)}</title></circle>'
        )
    parts.append(f'<circle id="robot" cx="0" cy="0" r="{unit * 1.8:.4g}" stroke-width="{unit * 0.5:.4g}"/>')
    # The longer side gets _MAP_WIDTH pixels.
    width, height = (_MAP_WIDTH, _MAP_WIDTH * h / w) if w >= h else (_MAP_WIDTH * w / h, _MAP_WIDTH)
    # One column as wide as the map (or the legend's least): what is written under it wraps
    # instead of widening the column and moving the agents' panels as the slider moves.
    column = max(width, 300.0)
    return (
        f'<div class="mapcol" style="width:{column:.0f}px">'
        f'<svg id="map" viewBox="{x0:g} {y0:g} {w:g} {h:g}" width="{width:.0f}" height="{height:.0f}" '
        f'role="img" aria-label="map">{"".join(parts)}</svg>'
        + _legend(history, start is not None, end is not None)
        + '<p class="where">robot: <b id="robot-text"></b></p></div>'
    )


def _end_node(history: History) -> str | None:
    """Where the robot ends: the summary's node, else where its last motion arrived."""
    if history.summary is not None and history.summary.robot.get("at"):
        return history.summary.robot["at"]
    place = history.robot_at(history.end)
    node = None if place is None else place.get("node")
    return node if isinstance(node, str) else None


def _swatch(inner: str) -> str:
    return f'<svg class="swatch" viewBox="0 0 28 14" width="28" height="14" aria-hidden="true">{inner}</svg>'


def _legend(history: History, start: bool, end: bool) -> str:
    """What the map's colours and marks mean, below the map (never over it)."""
    items = [("way", '<line x1="2" y1="7" x2="26" y2="7" class="lg-way"/>', "the robot's way so far")]
    if any(m.kind == "emergency" for m in history.marks):
        items.append(
            (
                "emergency",
                '<line x1="2" y1="7" x2="26" y2="7" class="lg-emergency"/>',
                "legs driven during an emergency",
            )
        )
    items.append(("robot", '<circle cx="14" cy="7" r="5" class="lg-robot"/>', "the robot"))
    if start:
        items.append(("start", '<rect x="9" y="2" width="10" height="10" class="start"/>', "start"))
    if end:
        items.append(("end", '<circle cx="14" cy="7" r="5" class="end lg-end"/>', "where the run ends"))
    if any(m.kind == "arc_closed" for m in history.marks):
        items.append(
            (
                "door",
                '<line x1="2" y1="7" x2="26" y2="7" class="lg-door"/>',
                "a shut door",
            )
        )
    rows = "".join(
        f'<li data-key="{key}">{_swatch(inner)}<span>{_e(text)}</span></li>' for key, inner, text in items
    )
    return f'<ul id="map-legend" class="legend" aria-label="map legend">{rows}</ul>'


# -- the agents ------------------------------------------------------------------------------------


def _agent_panels(history: History) -> str:
    out = []
    for i, agent in enumerate(history.agents):
        out.append(
            f'<section class="agent" id="agent-{i}" data-agent="{_e(agent)}">'
            f"<h3>{_e(agent)}</h3>"
            f'<div class="row"><span class="k">goal</span> '
            f'<span class="goal" id="agent-{i}-goal"></span></div>'
            f'<div class="row done"><span class="k">done</span> '
            f'<span class="last" id="agent-{i}-last"></span></div>'
            f'<div class="row"><span class="k">doing</span> '
            f'<span class="action" id="agent-{i}-action"></span></div>'
            f'<div class="row"><span class="k">stack</span> '
            f'<span class="hint" id="agent-{i}-stack-hint"></span>'
            f'<ol class="stack" id="agent-{i}-stack"></ol></div>'
            f'<div class="row"><span class="k">plan</span> '
            f'<span class="hint" id="agent-{i}-plan-hint"></span>'
            f'<ol class="plan" id="agent-{i}-plan"></ol></div>'
            "</section>"
        )
    return "".join(out)


_STYLE = """
body{font:14px/1.4 system-ui,-apple-system,"Segoe UI",Roboto,sans-serif;margin:16px 24px;
color:#222;background:#fff}
h1{font-size:20px;margin:0 0 6px}
h3{margin:0 0 4px;font-size:15px}
.goals{margin:4px 0;padding-left:18px}.goals .failed{color:#b00020}
.facts{color:#555;margin:2px 0 10px}
#controls{display:flex;gap:12px;align-items:center;margin:8px 0;position:sticky;top:0;background:#fff;
padding:6px 0;z-index:2;border-bottom:1px solid #eee}
#slider{flex:1}
#time{font-variant-numeric:tabular-nums;min-width:90px;font-weight:bold}
button{font:inherit;padding:3px 12px}
#timeline{display:block;max-width:1100px;cursor:crosshair}
.lane{fill:#f4f4f4}.lane-name{font-size:12px;font-weight:bold;text-anchor:end}
.bar-label{font-size:10.5px;fill:#fff;pointer-events:none}
.bar-label.dark{fill:#111;stroke:#fff;stroke-width:3px;paint-order:stroke}
.suspended{fill:#fff;stroke-width:1}.waiting{fill:#fff;opacity:.6}.hatch{stroke-width:1;fill:none}
.fail{stroke:#222;stroke-width:2.2}
.fail-label{font-size:10px;fill:#222;stroke:#fff3c4;stroke-width:4px;paint-order:stroke}
.mark-label{font-size:10px}.mark-label.emergency{fill:#c62828}.mark-label.door{fill:#666}
.depth{fill:none;stroke-width:2}.depth-key{font-size:11px;stroke:#fff;stroke-width:3px;paint-order:stroke}
.tick{font-size:10px;fill:#555}.grid{stroke:#999}
.mark{stroke-width:1.2}.mark.emergency{stroke:#e45756;stroke-dasharray:5 3}
.mark.door{stroke:#7f7f7f;stroke-dasharray:2 3}.mark.crash{stroke:#222}
#tl-cursor{stroke:#111;stroke-width:1.5}
#main{display:flex;gap:20px;flex-wrap:wrap;align-items:flex-start;margin-top:10px}
#map{border:1px solid #ddd;background:#fcfcfc;max-width:100%;height:auto}
.arc{stroke:#c8c8c8}
.arc.closed{stroke:#b00020;stroke-width:3.5px;stroke-dasharray:4 3;vector-effect:non-scaling-stroke}
.node{fill:#999}.node-name{fill:#666}.area{fill:#bbb;opacity:.45;text-anchor:middle;dominant-baseline:middle;font-weight:bold}
.start{fill:#222}.end{fill:none;stroke:#222}
#trail line{stroke-linecap:round}#trail .n{stroke:#1f77b4}#trail .e{stroke:#d62728}
#robot{fill:#ffbf00;stroke:#222}
.legend{list-style:none;margin:6px 0 0;padding:0;display:flex;flex-wrap:wrap;gap:4px 16px;font-size:12px;
color:#444}
.legend li{display:flex;align-items:center;gap:5px}
.lg-way{stroke:#1f77b4;stroke-width:4;stroke-linecap:round}.lg-emergency{stroke:#d62728;stroke-width:4;
stroke-linecap:round}.lg-robot{fill:#ffbf00;stroke:#222;stroke-width:1.5}.lg-end{stroke-width:1.5}
.lg-door{stroke:#b00020;stroke-width:3.5;stroke-dasharray:4 3}
.run{color:#444;margin:0 0 4px}.run .meaning{color:#666}
#agents{flex:1;min-width:320px}
.agent{border:1px solid #ddd;border-radius:6px;padding:8px 12px;margin-bottom:10px}
.k{display:inline-block;min-width:46px;color:#666}
.agent .goal{font-weight:bold}.agent .goal.emergency{color:#c62828}
.last{color:#555}.last.failure{color:#b00020}
ol{margin:2px 0 2px 0;padding-left:26px}
.plan li.now{font-weight:bold;background:#fff3c4}
.stack li{color:#444}.hint{color:#666}
.nomap{color:#555;max-width:420px}
"""

_LOGIC = r"""
"use strict";
// Pure functions of the embedded history: the page's state at time t.
// They mirror htnagent.views.history.History.at (a test runs them under Node against it).
function holds(span, t) {
  return span[0] <= t && (span[1] === null || t < span[1]);
}
function lastStart(goal, t) {
  let best = -Infinity;
  for (const s of goal.suspended) if (holds(s, t) && s[0] > best) best = s[0];
  return best;
}
function agentAt(h, name, t) {
  const live = h.goals.filter(g => g.agent === name && g.received <= t && (g.end === null || t < g.end));
  const isStacked = g => g.suspended.some(s => holds(s, t));
  const stacked = live.filter(isStacked);
  stacked.sort((a, b) => lastStart(a, t) - lastStart(b, t));
  let current = null;
  let currentT = -Infinity;
  for (const g of live.filter(g => !isStacked(g))) {
    let when = -Infinity;
    for (const p of g.plans) if (p.t <= t) when = p.t;
    if (current === null || when > currentT) { current = g; currentT = when; }
  }
  let plan = null;
  if (current !== null) for (const p of current.plans) if (p.t <= t) plan = p.plan;
  let action = null;
  for (const s of (h.actions[name] || [])) {
    if (s.start <= t && (s.end === null || t < s.end)) action = s.action;
  }
  return {
    goal: current === null ? null : current.goal,
    emergency: current === null ? false : current.emergency,
    stack: stacked.map(g => g.goal),
    plan: plan,
    action: action,
  };
}
function lastFinished(h, name, t) {
  // The agent's goal that ended last by t (its status), for an agent with nothing to do.
  let last = null;
  for (const g of h.goals) {
    if (g.agent === name && g.end !== null && g.end <= t && (last === null || g.end >= last.end)) last = g;
  }
  return last;
}
function round6(x) { return Math.round(x * 1e6) / 1e6; }
function fractionAt(m, t) {
  if (m.end <= m.start) return m.f1;
  const share = Math.min(1, Math.max(0, (t - m.start) / (m.end - m.start)));
  return m.f0 + (m.f1 - m.f0) * share;
}
function placeOn(m, fraction) {
  fraction = round6(fraction);
  if (fraction >= 1) return {node: m.to};
  if (fraction <= 0) return {node: m.from};
  return {arc: m.arc, from: m.from, to: m.to, fraction: fraction};
}
function robotAt(h, t) {
  let last = null;
  for (const m of h.motions) { if (m.start > t) break; last = m; }
  if (last === null) return h.start === null ? null : {node: h.start};
  return placeOn(last, t < last.end ? fractionAt(last, t) : last.f1);
}
function activityAt(h, t) {
  for (const a of h.activities) if (a.start <= t && t < a.end) return a.action;
  return null;
}
function stateAt(h, t) {
  const agents = {};
  for (const name of h.agents) agents[name] = agentAt(h, name, t);
  return {t: t, agents: agents, robot: robotAt(h, t), activity: activityAt(h, t)};
}
function robotXY(world, place) {
  if (world === null || place === null) return null;
  if (place.node !== undefined) {
    const p = world.nodes[place.node];
    return p === undefined ? null : p;
  }
  const a = world.nodes[place.from], b = world.nodes[place.to];
  if (a === undefined || b === undefined) return null;
  return [a[0] + (b[0] - a[0]) * place.fraction, a[1] + (b[1] - a[1]) * place.fraction];
}
function depthAt(h, agent, t) {
  let d = 0;
  for (const step of (h.depth[agent] || [])) { if (step[0] > t) break; d = step[1]; }
  return d;
}
function timeFromHash(hash, end) {
  const m = /^#t=([0-9]*\.?[0-9]+(?:e[+-]?[0-9]+)?)$/i.exec(hash || "");
  if (m === null) return null;
  const t = Number(m[1]);
  return Number.isFinite(t) ? Math.min(Math.max(t, 0), end) : null;
}
if (typeof module !== "undefined") {
  module.exports = {stateAt, robotXY, depthAt, timeFromHash, lastFinished};
}
"""

_UI = r"""
"use strict";
(function () {
  const data = JSON.parse(document.getElementById("htn-data").textContent);
  const h = data.history;
  const world = data.map;
  const end = h.end;
  const slider = document.getElementById("slider");
  const timeText = document.getElementById("time");
  const play = document.getElementById("play");
  const speed = document.getElementById("speed");
  const cursor = document.getElementById("tl-cursor");
  const timeline = document.getElementById("timeline");
  const left = Number(timeline.dataset.left), scale = Number(timeline.dataset.scale);
  const svgNS = "http://www.w3.org" + "/2000/svg";
  let now = 0;
  let playing = null;

  function fill(list, items, current) {
    while (list.firstChild) list.removeChild(list.firstChild);
    for (const item of items) {
      const li = document.createElement("li");
      li.textContent = item;
      if (item === current) li.className = "now";
      list.appendChild(li);
    }
  }
  function drawTrail(t) {
    const trail = document.getElementById("trail");
    if (trail === null || world === null) return;
    while (trail.firstChild) trail.removeChild(trail.firstChild);
    const top = h.agents.length ? h.agents[0] : null;
    for (const m of h.motions) {
      if (m.start > t) break;
      const stop = Math.min(t, m.end);
      const a = robotXY(world, {node: m.from}), b = robotXY(world, {node: m.to});
      if (a === null || b === null) continue;
      const share = m.end <= m.start ? 1 : Math.min(1, Math.max(0, (stop - m.start) / (m.end - m.start)));
      const f1 = m.f0 + (m.f1 - m.f0) * share;
      const line = document.createElementNS(svgNS, "line");
      line.setAttribute("x1", a[0] + (b[0] - a[0]) * m.f0);
      line.setAttribute("y1", a[1] + (b[1] - a[1]) * m.f0);
      line.setAttribute("x2", a[0] + (b[0] - a[0]) * f1);
      line.setAttribute("y2", a[1] + (b[1] - a[1]) * f1);
      line.setAttribute("class", top !== null && depthAt(h, top, m.start) > 0 ? "e" : "n");
      trail.appendChild(line);
    }
  }
  function drawDoors(t) {
    const closed = new Set();
    for (const mark of h.marks) {
      if (mark.t > t) break;
      if (mark.kind === "arc_closed") closed.add(mark.subject);
      if (mark.kind === "arc_opened") closed.delete(mark.subject);
    }
    for (const line of document.querySelectorAll("line.arc")) {
      line.classList.toggle("closed", closed.has(line.dataset.arc));
    }
  }
  function show(t) {
    now = t;
    const state = stateAt(h, t);
    slider.value = String(t);
    timeText.textContent = t.toFixed(2) + " s";
    cursor.setAttribute("x1", left + t * scale);
    cursor.setAttribute("x2", left + t * scale);
    h.agents.forEach(function (name, i) {
      const a = state.agents[name];
      const goal = document.getElementById("agent-" + i + "-goal");
      goal.textContent = a.goal === null ? "—" : a.goal + (a.emergency ? " (emergency)" : "");
      goal.classList.toggle("emergency", a.emergency);
      const last = lastFinished(h, name, t);
      const done = document.getElementById("agent-" + i + "-last");
      done.textContent = last === null ? "—"
        : last.goal + ": " + last.status + (last.reason ? " (" + last.reason + ")" : "")
          + " at " + last.end.toFixed(2) + " s";
      done.className = "last " + (last === null ? "" : last.status);
      document.getElementById("agent-" + i + "-action").textContent = a.action === null ? "—" : a.action;
      fill(document.getElementById("agent-" + i + "-stack"), a.stack.slice().reverse(), null);
      const hint = a.stack.length ? "(top first)" : "empty";
      document.getElementById("agent-" + i + "-stack-hint").textContent = hint;
      document.getElementById("agent-" + i + "-plan-hint").textContent = a.plan === null ? "none" : "";
      fill(document.getElementById("agent-" + i + "-plan"), a.plan === null ? [] : a.plan, a.action);
    });
    const place = state.robot;
    let where = "unknown";
    if (place !== null) {
      where = place.node !== undefined ? "at " + place.node
        : "on " + place.arc + ", " + Math.round(place.fraction * 100) + "% of the way "
          + place.from + " → " + place.to;
    }
    if (state.activity !== null) where += ", doing " + state.activity;
    document.getElementById("robot-text").textContent = where;
    const robot = document.getElementById("robot");
    const xy = robotXY(world, place);
    if (robot !== null) {
      robot.style.display = xy === null ? "none" : "";
      if (xy !== null) { robot.setAttribute("cx", xy[0]); robot.setAttribute("cy", xy[1]); }
    }
    drawTrail(t);
    drawDoors(t);
    if (playing !== null && robot !== null && xy !== null) keepInView(robot);
  }
  function keepInView(el) {
    // While playing, scroll the page so that the robot stays in sight below the sticky controls.
    const box = el.getBoundingClientRect();
    const top = document.getElementById("controls").getBoundingClientRect().bottom + 12;
    const bottom = window.innerHeight - 12;
    let dy = 0;
    if (box.bottom > bottom) dy = box.bottom - bottom + Math.min(120, (bottom - top) / 3);
    else if (box.top < top) dy = box.top - top - Math.min(120, (bottom - top) / 3);
    let dx = 0;
    if (box.right > window.innerWidth - 12) dx = box.right - window.innerWidth + 60;
    else if (box.left < 12) dx = box.left - 60;
    if (dx !== 0 || dy !== 0) window.scrollBy(dx, dy);
  }
  function remember(t) {
    try {
      history.replaceState(null, "", "#t=" + t.toFixed(2));
    } catch (e) { /* a page opened from a file may refuse */ }
  }
  slider.addEventListener("input", function () { stop(); show(Number(slider.value)); remember(now); });
  timeline.addEventListener("click", function (ev) {
    const box = timeline.getBoundingClientRect();
    const view = timeline.viewBox.baseVal;
    const x = view.x + (ev.clientX - box.left) * (view.width / box.width);
    show(Math.min(Math.max((x - left) / scale, 0), end));
    remember(now);
  });
  function stop() {
    if (playing !== null) { cancelAnimationFrame(playing); playing = null; play.textContent = "▶ play"; }
  }
  function frame(last) {
    return function (stamp) {
      const dt = last === null ? 0 : (stamp - last) / 1000;
      const t = Math.min(end, now + dt * Number(speed.value));
      show(t);
      if (t >= end) { stop(); remember(now); return; }
      playing = requestAnimationFrame(frame(stamp));
    };
  }
  play.addEventListener("click", function () {
    if (playing !== null) { stop(); remember(now); return; }
    if (now >= end) show(0);
    play.textContent = "❚❚ pause";
    playing = requestAnimationFrame(frame(null));
  });
  window.addEventListener("hashchange", function () {
    const t = timeFromHash(location.hash, end);
    if (t !== null) { stop(); show(t); }
  });
  const first = timeFromHash(location.hash, end);
  show(first === null ? 0 : first);
})();
"""

_PAGE = """<!DOCTYPE html>
<html lang="en">
<head>
<meta charset="utf-8">
<meta name="viewport" content="width=device-width, initial-scale=1">
<title>{title}</title>
<style>{style}</style>
</head>
<body>
<h1>{title}</h1>
{run}
{summary}
<div id="controls">
<button id="play" type="button">▶ play</button>
<input id="slider" type="range" min="0" max="{end}" step="any" value="0" aria-label="simulated time">
<span id="time">0.00 s</span>
<label>speed <select id="speed"><option value="1">1×</option><option value="2">2×</option>
<option value="5" selected>5×</option><option value="10">10×</option>
<option value="25">25×</option></select></label>
</div>
{timeline}
<div id="main">
<div id="mapbox">{map}</div>
<div id="agents">{agents}</div>
</div>
<script type="application/json" id="htn-data">{data}</script>
<script id="htn-logic">{logic}</script>
<script id="htn-ui">{ui}</script>
</body>
</html>
"""
