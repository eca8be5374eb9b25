"""``report TRACE --html OUT``: one self-contained page, its data the history's, its logic the model's.

- The page is made for every shipped scenario and refers to nothing outside itself.
- Its embedded JSON is exactly :meth:`History.as_json` of the trace.
- Its logic script, run under Node on that JSON, gives the state :meth:`History.at`
  gives, at several times including the emergencies (skipped without ``node``).
- Headless Chromium opened at ``#t=<emergency>`` shows the trace's stack
  (skipped without ``/usr/bin/chromium``).
- The page's parts do not run into each other in a browser: the stack label clear of the
  depth axis's numbers, the map's legend outside the map.
- The slider's end is the run's end, reachable, and shows the final state.
- The run's header gives the mode shown and, without ``--scenario``, the title.
- While playing, the page scrolls so that the robot stays in view.
- A bad trace is one line on stderr and exit 2.
"""

from __future__ import annotations

import html
import html.parser
import json
import math
import os
import random
import re
import shutil
import subprocess
import sys
import tempfile
from pathlib import Path
from typing import Any

import pytest

from htnagent.cli.commands import main
from htnagent.views.history import History
from tests.support import SCENARIO_DIR, SHIPPED, shipped_run, write_trace

NESTED = "nested_emergencies.yaml"
FOUR = "four_emergencies.yaml"
CHROMIUM = "/usr/bin/chromium"


def report_of(name: str, tmp: Path, *, with_map: bool = True) -> tuple[str, History]:
    """Write the shipped scenario's trace and its page; the page's text and the trace's history."""
    scenario, events = shipped_run(name)
    trace = write_trace(events, tmp / f"{Path(name).stem}.jsonl")
    out = tmp / f"{Path(name).stem}.html"
    args = ["report", str(trace), "--html", str(out)]
    if with_map:
        args += ["--scenario", str(scenario.file)]
    assert main(args) == 0
    return out.read_text(encoding="utf-8"), History.from_events(events, scenario.agent_names)


class _Scripts(html.parser.HTMLParser):
    """The page's script blocks by id, and every attribute value that could load something."""

    def __init__(self) -> None:
        super().__init__()
        self.scripts: dict[str, str] = {}
        self.links: list[tuple[str, str, str]] = []
        self._in: str | None = None

    def handle_starttag(self, tag: str, attrs: list[tuple[str, str | None]]) -> None:
        for name, value in attrs:
            if name in ("src", "href", "xlink:href", "action", "data", "poster", "srcset"):
                self.links.append((tag, name, value or ""))
        if tag == "script":
            self._in = dict(attrs).get("id") or ""
            self.scripts[self._in] = ""

    def handle_endtag(self, tag: str) -> None:
        if tag == "script":
            self._in = None

    def handle_data(self, data: str) -> None:
        if self._in is not None:
            self.scripts[self._in] += data


def parsed(page: str) -> _Scripts:
    p = _Scripts()
    p.feed(page)
    return p


def embedded(page: str) -> dict[str, Any]:
    data: dict[str, Any] = json.loads(parsed(page).scripts["htn-data"])
    return data


def as_json(value: object) -> Any:
    return json.loads(json.dumps(value))


# -- every scenario ----------------------------------------------------------------------------------


@pytest.mark.parametrize("name", SHIPPED)
def test_the_page_is_made_self_contained_with_the_historys_data(name: str, tmp_path: Path) -> None:
    page, history = report_of(name, tmp_path)
    found = parsed(page)
    assert found.links == [], f"the page loads {found.links}"
    assert not re.search(r"""(?:src|href)\s*=\s*["']?\s*(?:https?:|file:|//|\.|/)""", page, re.I)
    assert "@import" not in page
    assert all(u.startswith("data:") for u in re.findall(r"url\(\s*['\"]?([^)'\"]*)", page))
    assert "<link" not in page and "<iframe" not in page
    assert set(found.scripts) == {"htn-data", "htn-logic", "htn-ui"}
    data = embedded(page)
    assert data["history"] == as_json(history.as_json())
    if shipped_run(name)[0].map is not None:
        assert data["map"] is not None and set(data["map"]["nodes"])
    else:  # an HDDL agent's world of facts (docs/design.md §7.1)
        assert data["map"] is None


def test_without_the_scenario_the_page_has_no_map_but_the_same_history(tmp_path: Path) -> None:
    page, history = report_of(NESTED, tmp_path, with_map=False)
    data = embedded(page)
    assert data["map"] is None
    assert data["history"] == as_json(history.as_json())
    assert 'id="map"' not in page and "--scenario" in page


def test_a_scenario_without_a_map_says_so_and_gives_the_robot_no_place(tmp_path: Path) -> None:
    page, history = report_of("courier_hddl.yaml", tmp_path)
    assert history.summary is not None and history.summary.robot == {}
    assert "world of facts" in page and "--scenario" not in page
    assert "robot ends ;" not in page and "robot ends" not in page
    museum, _ = report_of("museum.yaml", tmp_path)
    assert "robot ends at n1; travelled" in museum


def test_text_from_the_trace_cannot_close_the_script(tmp_path: Path) -> None:
    _, events = shipped_run(NESTED)
    hostile = [e.as_dict() for e in events]
    first = next(e for e in hostile if e["event"] == "goal_received")
    first["goal"] = "</script><script>alert(1)</script>"
    trace = tmp_path / "t.jsonl"
    trace.write_text("".join(json.dumps(e) + "\n" for e in hostile))
    assert main(["report", str(trace), "--html", str(tmp_path / "t.html")]) == 0
    page = (tmp_path / "t.html").read_text()
    assert page.count("<script") == 3
    assert embedded(page)["history"]["goals"][0]["goal"] == first["goal"]


# -- the page's logic under Node ----------------------------------------------------------------------------

NODE = shutil.which("node")


def _times(history: History) -> list[float]:
    """The emergencies' moments, a little after each, the middle of every third motion, the end."""
    times = [0.0, history.end]
    for mark in history.marks:
        times += [mark.t, mark.t + 0.5]
    times += [(m.start + m.end) / 2 for m in history.motions[::3]]
    times += [g.received for g in history.goals[::2]]
    return sorted(set(times))


def _close(a: Any, b: Any) -> bool:
    if isinstance(a, float | int) and isinstance(b, float | int) and not isinstance(a, bool):
        return math.isclose(a, b, abs_tol=2e-6)
    if isinstance(a, dict) and isinstance(b, dict):
        return a.keys() == b.keys() and all(_close(a[k], b[k]) for k in a)
    if isinstance(a, list) and isinstance(b, list):
        return len(a) == len(b) and all(_close(x, y) for x, y in zip(a, b, strict=True))
    return bool(a == b)


@pytest.mark.skipif(NODE is None, reason="node is not installed")
@pytest.mark.parametrize("name", [NESTED, FOUR, "explain_question.yaml", "door_shut.yaml"])
def test_the_pages_state_at_a_time_is_the_models(name: str, tmp_path: Path) -> None:
    assert NODE is not None
    page, history = report_of(name, tmp_path)
    scripts = parsed(page).scripts
    times = _times(history)
    (tmp_path / "data.json").write_text(scripts["htn-data"])
    program = tmp_path / "check.js"
    program.write_text(
        scripts["htn-logic"]
        + "\nconst fs = require('fs');\n"
        + f"const data = JSON.parse(fs.readFileSync({json.dumps(str(tmp_path / 'data.json'))}, 'utf8'));\n"
        + f"const times = {json.dumps(times)};\n"
        + "console.log(JSON.stringify(times.map(t => stateAt(data.history, t))));\n"
    )
    done = subprocess.run([NODE, str(program)], capture_output=True, text=True, timeout=30, check=False)
    assert done.returncode == 0, done.stderr
    from_js = json.loads(done.stdout)
    for t, got in zip(times, from_js, strict=True):
        want = as_json(history.at(t).as_json())
        assert _close(got, want), f"at {t}: the page says {got}, the model {want}"


# -- the page in a browser --------------------------------------------------------------------------------


def _chromium(url: str, *extra: str) -> str:
    with tempfile.TemporaryDirectory() as profile:
        done = subprocess.run(
            [
                CHROMIUM,
                "--headless",
                "--no-sandbox",
                "--disable-gpu",
                "--disable-quic",
                "--no-first-run",
                "--disable-background-networking",
                "--disable-component-update",
                "--disable-sync",
                f"--user-data-dir={profile}",
                "--virtual-time-budget=2000",
                *extra,
                url,
            ],
            capture_output=True,
            text=True,
            timeout=90,
            check=False,
            env={**os.environ, "HOME": profile},
        )
    assert done.returncode == 0, done.stderr[-2000:]
    return done.stdout


def _list_items(dom: str, element_id: str) -> list[str]:
    m = re.search(rf'<ol[^>]*id="{re.escape(element_id)}"[^>]*>(.*?)</ol>', dom, re.S)
    assert m is not None, f"no #{element_id} in the page"
    return [html.unescape(li) for li in re.findall(r"<li[^>]*>(.*?)</li>", m.group(1), re.S)]


def _text_of(dom: str, element_id: str) -> str:
    m = re.search(rf'<span[^>]*id="{re.escape(element_id)}"[^>]*>(.*?)</span>', dom, re.S)
    assert m is not None, f"no #{element_id} in the page"
    return html.unescape(m.group(1))


NO_CHROMIUM = f"{CHROMIUM} is not installed (apt-get install chromium)"


@pytest.mark.skipif(not Path(CHROMIUM).exists(), reason=NO_CHROMIUM)
@pytest.mark.parametrize(("name", "which"), [(NESTED, -1), (FOUR, -1)])
def test_a_browser_opened_at_the_last_emergency_shows_the_traces_stack(
    name: str, which: int, tmp_path: Path
) -> None:
    _, history = report_of(name, tmp_path)
    emergency = [m for m in history.marks if m.kind == "emergency"][which]
    page = tmp_path / f"{Path(name).stem}.html"
    dom = _chromium(f"{page.as_uri()}#t={emergency.t}", "--dump-dom")
    now = history.at(emergency.t)
    for i, agent in enumerate(history.agents):
        want = now.agents[agent]
        # The page lists a stack top first.
        assert _list_items(dom, f"agent-{i}-stack")[::-1] == list(want.stack), agent
        shown = _text_of(dom, f"agent-{i}-goal")
        assert shown.startswith(want.goal or "—"), (agent, shown)
    assert f"{emergency.t:.2f} s" in dom


@pytest.mark.skipif(not Path(CHROMIUM).exists(), reason=NO_CHROMIUM)
def test_a_browser_draws_the_page(tmp_path: Path) -> None:
    report_of(NESTED, tmp_path)
    shot = tmp_path / "shot.png"
    _chromium((tmp_path / "nested_emergencies.html").as_uri() + "#t=12", f"--screenshot={shot}")
    assert shot.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


# -- the header: title and mode ---------------------------------------------------------------------------


def _h1(page: str) -> str:
    m = re.search(r"<h1>(.*?)</h1>", page, re.S)
    assert m is not None
    return html.unescape(m.group(1))


def _report_lines(lines: list[str], tmp_path: Path, *extra: str) -> str:
    trace = tmp_path / "saved.jsonl"
    trace.write_text("\n".join(lines) + "\n")
    assert main(["report", str(trace), "--html", str(tmp_path / "saved.html"), *extra]) == 0
    return (tmp_path / "saved.html").read_text(encoding="utf-8")


def test_without_the_scenario_the_title_is_the_headers_scenario_name(tmp_path: Path) -> None:
    scenario, _ = shipped_run(NESTED)
    page = _report_lines(_good_lines(), tmp_path)
    assert _h1(page) == scenario.name
    assert f"<title>{html.escape(scenario.name)}</title>" in page
    assert embedded(page)["title"] == scenario.name


def test_a_trace_saved_without_the_header_loads_titled_by_its_file(tmp_path: Path) -> None:
    lines = [line for line in _good_lines() if json.loads(line)["event"] != "run_started"]
    assert len(lines) == len(_good_lines()) - 1
    page = _report_lines(lines, tmp_path)
    assert _h1(page) == "saved.jsonl"
    assert re.search(r'id="mode"[^>]*>not recorded<', page)
    assert embedded(page)["history"]["run"] is None


@pytest.mark.parametrize("mode", ["online", "naive"])
def test_the_page_shows_the_runs_mode(mode: str, tmp_path: Path) -> None:
    lines = _good_lines()
    header = json.loads(lines[0])
    assert header["event"] == "run_started" and header["mode"] == "online"
    lines[0] = json.dumps({**header, "mode": mode})
    page = _report_lines(lines, tmp_path, "--scenario", str(SCENARIO_DIR / NESTED))
    shown = re.search(r'<p class="run" id="run-info">(.*?)</p>', page, re.S)
    assert shown is not None
    text = html.unescape(re.sub(r"<[^>]+>", "", shown.group(1)))
    assert text.startswith(f"mode: {mode} (")
    assert ("from scratch" in text) == (mode == "naive")
    assert header["version"] in text and "saved.jsonl" in text
    assert embedded(page)["history"]["run"] == {
        "scenario": header["scenario"],
        "mode": mode,
        "version": header["version"],
    }


# -- the slider's end, the stack label, the legend ---------------------------------------------------


def _slider(page: str) -> dict[str, str]:
    m = re.search(r'<input id="slider"([^>]*)>', page)
    assert m is not None
    return {k: html.unescape(v) for k, v in re.findall(r'(\w+)="([^"]*)"', m.group(1))}


@pytest.mark.parametrize("name", [NESTED, FOUR, "museum.yaml"])
def test_the_sliders_end_is_the_runs_end_and_its_final_state(name: str, tmp_path: Path) -> None:
    page, history = report_of(name, tmp_path)
    summary = history.summary
    assert summary is not None
    final = history.at(history.end)
    assert final.robot == {"node": summary.robot["at"]}
    # Every agent is done: no goal, no stack; each goal ended as the summary says.
    assert all(a.goal is None and a.stack == () and a.action is None for a in final.agents.values())
    ended = {(g.agent, g.goal): g.status for g in history.goals if g.end is not None and g.end <= history.end}
    assert all(ended[(g.agent, g.goal)] == g.status for g in summary.goals)
    slider = _slider(page)
    assert float(slider["min"]) == 0.0 and float(slider["max"]) == history.end
    step = slider["step"]
    if step != "any":  # the end must be a whole number of steps from the start
        assert float(slider["max"]) / float(step) == round(float(slider["max"]) / float(step))


def _svg_texts(page: str, cls: str) -> list[tuple[float, str]]:
    found = re.findall(
        rf'<text class="[^"]*\b{cls}\b[^"]*" x="([-0-9.]+)"[^>]*>(?:<title>[^<]*</title>)?([^<]*)</text>',
        page,
    )
    return [(float(x), text) for x, text in found]


def test_a_bar_too_short_for_its_goal_shows_the_task_name(tmp_path: Path) -> None:
    """The museum's navigator first moves to area7 for 6 s, too short for
    ``move_area(area8,area7)``: the bar says ``move_area(…)``, on its own colour (its
    suspension was resumed in the same instant: nothing is hatched)."""
    page, history = report_of("museum.yaml", tmp_path)
    first = next(g for g in history.goals if g.agent == "navigator")
    assert first.goal == "move_area(area8,area7)"
    labels = [text for _, text in _svg_texts(page, "bar-label")]
    assert "move_area(…)" in labels and first.goal not in labels
    assert 'class="bar-label dark"' not in page.split("move_area(…)")[0].rsplit("<text", 1)[-1]
    # The width a label is given assumes the regular weight: the panels' bold goal must not
    # reach the bars (whose group is of class "goal" too).
    assert not re.search(r"(^|})\.goal[{.]", page, re.MULTILINE)


@pytest.mark.parametrize("name", [NESTED, FOUR])
def test_the_stack_label_ends_before_the_depth_axis_numbers_begin(name: str, tmp_path: Path) -> None:
    page, _ = report_of(name, tmp_path)
    [(label_end, label)] = _svg_texts(page, "depth-name")
    ticks = _svg_texts(page, "depth-tick")
    assert label == "stack" and ticks
    # Both end-anchored; a digit of the 10 px numbers is at most 6.5 px wide.
    assert all(label_end + 3 <= x - 6.5 * len(text) for x, text in ticks)


def test_a_long_agent_name_widens_the_timeline_to_its_left(tmp_path: Path) -> None:
    long = "reception_desk_coordinator"
    lines = [line.replace('"guide"', json.dumps(long)) for line in _good_lines()]
    page = _report_lines(lines, tmp_path)
    m = re.search(r'<svg id="timeline" viewBox="([-0-9.]+) 0 ([0-9.]+) ', page)
    assert m is not None
    left_edge = float(m.group(1))
    [name_end] = [x for x, t in _svg_texts(page, "lane-name") if t == long]
    assert left_edge <= name_end - 7.5 * len(long)  # the whole name inside the drawing
    plain = re.search(r'<svg id="timeline" viewBox="([-0-9.]+) ', report_of(NESTED, tmp_path)[0])
    assert plain is not None and float(plain.group(1)) == 0


def test_the_map_has_a_legend_outside_its_drawing(tmp_path: Path) -> None:
    page, _ = report_of(NESTED, tmp_path)
    drawing = page[page.index('<svg id="map"') : page.index("</svg>", page.index('<svg id="map"'))]
    assert "map-legend" not in drawing
    legend = re.search(r'<ul id="map-legend".*?</ul>', page, re.S)
    assert legend is not None and legend.start() > page.index('<svg id="map"')
    keys = re.findall(r'data-key="(\w+)"', legend.group(0))
    assert keys == ["way", "emergency", "robot", "start", "end"]  # no door shuts in this run
    assert '<circle class="end"' in drawing and '<rect class="start"' in drawing
    door_page, history = report_of("door_shut.yaml", tmp_path)
    assert any(m.kind == "arc_closed" for m in history.marks)
    door_keys = re.findall(r'data-key="(\w+)"', door_page)
    assert "door" in door_keys
    # The red legs are listed only when an emergency came.
    assert ("emergency" in door_keys) == any(m.kind == "emergency" for m in history.marks)


_FRAME_CLOCK = (
    "<script>window.requestAnimationFrame = function (cb) {"
    " return setTimeout(function () { cb(performance.now()); }, 16); };"
    " window.cancelAnimationFrame = clearTimeout;</script>"
)
"""Headless Chromium's virtual time runs timers but paints no frames: frames as timers."""


def _probe(page: Path, script: str, *extra: str) -> Any:
    """Open a copy of the page in Chromium with ``script`` run after it; what it reported."""
    text = page.read_text(encoding="utf-8")
    text = text.replace('<script id="htn-ui">', _FRAME_CLOCK + '<script id="htn-ui">')
    report = (
        'function report(x) { const p = document.createElement("pre"); p.id = "probe";'
        " p.textContent = JSON.stringify(x); document.body.appendChild(p); }\n"
    )
    text = text.replace("</body>", f"<script>{report}{script}</script></body>")
    probe = page.with_name("probe.html")
    probe.write_text(text, encoding="utf-8")
    dom = _chromium(probe.as_uri(), "--dump-dom", "--virtual-time-budget=5000", *extra)
    m = re.search(r'<pre id="probe">(.*?)</pre>', dom, re.S)
    assert m is not None, "the probe did not report"
    return json.loads(html.unescape(m.group(1)))


_MEASURE = """
function box(el) { const r = el.getBoundingClientRect(); return [r.left, r.top, r.right, r.bottom]; }
function bbox(el) { const b = el.getBBox(); return [b.x, b.y, b.x + b.width, b.y + b.height]; }
const out = {
  label: bbox(document.querySelector("text.depth-name")),
  ticks: Array.from(document.querySelectorAll("text.depth-tick")).map(bbox),
  map: box(document.getElementById("map")),
  legend: box(document.getElementById("map-legend")),
};
const slider = document.getElementById("slider");
slider.value = slider.max;
slider.dispatchEvent(new Event("input"));
out.value = Number(slider.value);
out.time = document.getElementById("time").textContent;
out.robot = document.getElementById("robot-text").textContent;
out.goals = Array.from(document.querySelectorAll("span.goal")).map(e => e.textContent);
out.last = Array.from(document.querySelectorAll("span.last")).map(e => e.textContent);
report(out);
"""


@pytest.mark.skipif(not Path(CHROMIUM).exists(), reason=NO_CHROMIUM)
def test_in_a_browser_nothing_overlaps_and_the_sliders_end_shows_the_final_state(tmp_path: Path) -> None:
    _, history = report_of(NESTED, tmp_path)
    got = _probe(tmp_path / "nested_emergencies.html", _MEASURE, "--window-size=1300,1100")
    label_right = got["label"][2]
    assert all(label_right <= tick[0] - 2 for tick in got["ticks"]), got
    m, lg = got["map"], got["legend"]
    assert lg[1] >= m[3] or lg[0] >= m[2] or lg[3] <= m[1] or lg[2] <= m[0], got  # apart
    assert got["value"] == history.end
    assert got["time"] == f"{history.end:.2f} s"
    assert history.summary is not None
    assert got["robot"] == f"at {history.summary.robot['at']}"
    assert got["goals"] == ["—"] * len(history.agents)
    for agent, shown in zip(history.agents, got["last"], strict=True):
        last = max((g for g in history.goals_of(agent) if g.end is not None), key=lambda g: g.end or 0.0)
        assert shown == f"{last.goal}: {last.status} at {last.end:.2f} s"


_PLAY = """
document.getElementById("speed").value = "25";
document.getElementById("play").click();
setTimeout(function () {
  const r = document.getElementById("robot").getBoundingClientRect();
  const controls = document.getElementById("controls").getBoundingClientRect();
  report({robot: [r.top, r.bottom], view: window.innerHeight, controls: controls.bottom,
          scrolled: window.scrollY, time: document.getElementById("time").textContent});
}, 1500);
"""


@pytest.mark.skipif(not Path(CHROMIUM).exists(), reason=NO_CHROMIUM)
def test_while_playing_the_page_keeps_the_robot_in_view(tmp_path: Path) -> None:
    report_of("museum.yaml", tmp_path)
    # A low window: the map starts near the bottom and the robot (at n40, the map's bottom) out of view.
    got = _probe(tmp_path / "museum.html", _PLAY, "--window-size=1300,600")
    assert got["time"] != "0.00 s", got
    assert got["scrolled"] > 0, got
    assert got["controls"] <= got["robot"][0] and got["robot"][1] <= got["view"], got


# -- bad input ----------------------------------------------------------------------------------------------


def _bad(tmp_path: Path, content: str | None, capsys: pytest.CaptureFixture[str]) -> str:
    trace = tmp_path / "trace.jsonl"
    if content is not None:
        trace.write_text(content)
    code = main(["report", str(trace), "--html", str(tmp_path / "out.html")])
    err = capsys.readouterr().err
    assert code == 2
    assert err.count("\n") == 1 and err.startswith("htnagent: error: ") and "Traceback" not in err
    assert not (tmp_path / "out.html").exists()
    return err


def _good_lines() -> list[str]:
    _, events = shipped_run(NESTED)
    return [json.dumps(e.as_dict()) for e in events]


def test_a_trace_that_is_not_json_lines_is_refused(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    lines = _good_lines()
    lines[3] = "this is no JSON"
    err = _bad(tmp_path, "\n".join(lines), capsys)
    assert "trace.jsonl: line 4: not JSON" in err


def test_a_trace_without_a_summary_is_refused(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    lines = _good_lines()[:-1]
    err = _bad(tmp_path, "\n".join(lines), capsys)
    assert f"line {len(lines)}: the trace ends without a summary event" in err


def test_an_unknown_event_kind_is_refused(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    lines = _good_lines()
    lines[1] = '{"t": 0.0, "agent": "guide", "event": "teleported"}'
    err = _bad(tmp_path, "\n".join(lines), capsys)
    assert "line 2: unknown event 'teleported'" in err


@pytest.mark.parametrize(
    ("content", "reason"),
    [
        ("", "the file is empty"),
        ("\n\n", "the file is empty"),
        ("[1, 2]\n", "line 1: expected an event object"),
        ('{"t": NaN, "agent": "a", "event": "summary"}\n', "line 1: not JSON"),
        ('{"t": 1e999, "agent": "a", "event": "arc_closed", "arc": "x"}\n', "line 1: t: expected a time"),
        ('{"t": 0, "agent": "guide", "event": "goal_received"}\n', "line 1: goal_received: goal"),
        (b"\xff\xfe\x00bad".decode("latin-1"), "line 1"),
    ],
)
def test_malformed_traces_are_one_line(
    content: str, reason: str, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    assert reason in _bad(tmp_path, content, capsys)


def test_a_directory_or_missing_file_is_refused(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    assert "no such file" in _bad(tmp_path, None, capsys)
    (tmp_path / "trace.jsonl").mkdir()
    assert "is a directory" in _bad(tmp_path, None, capsys)


@pytest.mark.skipif(not hasattr(os, "mkfifo"), reason="no FIFOs here")
def test_a_fifo_is_refused_at_once(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    os.mkfifo(tmp_path / "trace.jsonl")
    assert "FIFO" in _bad(tmp_path, None, capsys)


def test_a_bad_trace_in_a_new_process_has_no_traceback(tmp_path: Path) -> None:
    trace = tmp_path / "t.jsonl"
    trace.write_text('{"t": 0, "agent": "x", "event": "nope"}\n')
    done = subprocess.run(
        [sys.executable, "-m", "htnagent", "report", str(trace), "--html", str(tmp_path / "o.html")],
        capture_output=True,
        text=True,
        timeout=60,
        check=False,
    )
    assert done.returncode == 2
    assert done.stderr.count("\n") == 1 and "Traceback" not in done.stderr
    assert done.stdout == ""


def test_an_unwritable_page_is_one_line(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    trace = write_trace(shipped_run(NESTED)[1], tmp_path / "t.jsonl")
    code = main(["report", str(trace), "--html", str(tmp_path / "no" / "such" / "o.html")])
    err = capsys.readouterr().err
    assert code == 2 and err.count("\n") == 1 and "cannot write the report" in err


def test_time_running_backwards_is_refused_with_its_line(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    lines = _good_lines()
    later = next(i for i, line in enumerate(lines) if json.loads(line)["t"] > 0)
    lines.insert(later + 1, lines[0])  # an event at 0 s after one later
    assert f"line {later + 2}: t: 0 is before the line above" in _bad(tmp_path, "\n".join(lines), capsys)


def test_mangled_traces_give_a_page_or_one_line(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    rng = random.Random(17)
    good = _good_lines()
    scenario = str(SCENARIO_DIR / NESTED)
    for _ in range(60):
        lines = list(good)
        for _ in range(rng.randint(1, 4)):
            j = rng.randrange(len(lines))
            what = rng.random()
            if what < 0.4:
                del lines[j]
            elif what < 0.6:
                lines.insert(rng.randrange(len(lines)), lines[j])
            else:
                event = json.loads(lines[j])
                key = rng.choice([k for k in event if k != "event"])
                event[key] = rng.choice([None, -1, "x", [], {}, "rollback(move(n1,n2,arc1))", True, 1e308])
                lines[j] = json.dumps(event)
        trace = tmp_path / "m.jsonl"
        trace.write_text("\n".join(lines) + "\n")
        code = main(["report", str(trace), "--html", str(tmp_path / "m.html"), "--scenario", scenario])
        err = capsys.readouterr().err
        assert code == 0 or (code == 2 and err.count("\n") == 1), err


def _boxes(
    page: str, cls: str, width: float, height: float, *, middle: bool
) -> list[tuple[str, float, float, float, float]]:
    """The texts of class ``cls`` as boxes (name, x0, x1, y0, y1): glyphs ``width`` of the font
    size wide and ``height`` of it tall; centred on (x, y) if ``middle``, else from x rightward
    with y the baseline."""
    found = re.findall(
        rf'<text class="{cls}" x="([-0-9.e]+)" y="([-0-9.e]+)" font-size="([0-9.e]+)">([^<]*)</text>', page
    )
    boxes = []
    for x, y, size, text in found:
        x0, y0, f = float(x), float(y), float(size)
        w = width * f * len(text)
        if middle:
            boxes.append((text, x0 - w / 2, x0 + w / 2, y0 - height * f / 2, y0 + height * f / 2))
        else:
            boxes.append((text, x0, x0 + w, y0 - height * f, y0))
    return boxes


def _meet(a: tuple[str, float, float, float, float], b: tuple[str, float, float, float, float]) -> bool:
    return a[1] < b[2] and b[1] < a[2] and a[3] < b[4] and b[3] < a[4]


def test_the_areas_names_sit_on_no_node_no_node_name_and_no_other_area_name(tmp_path: Path) -> None:
    """Written at the centroid of its nodes, "area1" sat on node n4 of the museum map (the
    map of every shipped scenario) and "area4" on n25."""
    page, _ = report_of("museum.yaml", tmp_path)
    areas = _boxes(page, "area", 0.6, 0.7, middle=True)
    assert len(areas) == 8
    nodes = [
        ("node", float(x) - float(r), float(x) + float(r), float(y) - float(r), float(y) + float(r))
        for x, y, r in re.findall(
            r'<circle class="node" cx="([-0-9.e]+)" cy="([-0-9.e]+)" r="([0-9.e]+)"/>', page
        )
    ]
    names = _boxes(page, "node-name", 0.55, 0.7, middle=False)
    assert nodes and names
    for i, area in enumerate(areas):
        hits = [other[0] for other in [*nodes, *names, *areas[i + 1 :]] if _meet(area, other)]
        assert not hits, f"{area[0]} meets {hits}"
