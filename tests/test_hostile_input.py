"""Hostile scenario and map files: every one is one line on stderr and exit 2, quickly.

Each case here once gave a traceback, a hang or unbounded memory (found by
adversarial testing); now the loader refuses it with a reason naming the file
and the place (docs/contracts.md "Command line").
"""

from __future__ import annotations

import os
import re
import shutil
import threading
import time
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pytest
import yaml
from hypothesis import HealthCheck, assume, given, settings
from hypothesis import strategies as st
from yaml.nodes import ScalarNode
from yaml.resolver import Resolver

from htnagent import files, limits, reading
from htnagent.cli.commands import main
from htnagent.errors import ScenarioError, shown
from htnagent.model.terms import parse
from htnagent.reading import _plain_tag, load_yaml_text, read_text, read_yaml
from htnagent.scenario import load_scenario

REPO = Path(__file__).resolve().parents[1]
SCENARIOS = REPO / "scenarios"
MAP = yaml.safe_load((SCENARIOS / "museum_map.yaml").read_text())

SCENARIO = """\
name: hostile
map: {map}
robot: {{start: n40, speed: 1.0}}
agents:
  - {{name: guide, domain: museum.areas, executor: navigator}}
  - {{name: navigator, domain: museum.nodes, executor: robot}}
goals:
  - {{agent: guide, task: {task}}}
"""


def scenario(tmp_path: Path, map: str = "museum_map.yaml", task: str = "goto(n1)", extra: str = "") -> Path:
    if not (tmp_path / "museum_map.yaml").exists():
        shutil.copy(SCENARIOS / "museum_map.yaml", tmp_path)
    path = tmp_path / "scenario.yaml"
    path.write_text(SCENARIO.format(map=map, task=task) + extra)
    return path


def map_file(tmp_path: Path, data: Any, name: str = "bad_map.yaml") -> str:
    (tmp_path / name).write_text(yaml.safe_dump(data))
    return name


def refused(argv: list[str], capsys: pytest.CaptureFixture[str]) -> str:
    """Run the CLI; expect exit 2 and one error line; return it."""
    started = time.monotonic()
    code = main(argv)
    out, err = capsys.readouterr()
    assert code == 2, (code, err)
    assert out == ""
    assert "Traceback" not in err
    lines = err.splitlines()
    assert len(lines) == 1, err
    assert lines[0].startswith("htnagent: error: ")
    assert len(lines[0]) < 1500, "the error line must stay short"
    assert time.monotonic() - started < 5, "refusing must be quick"
    return lines[0]


# -- special files ---------------------------------------------------------------------


@pytest.fixture
def fifo(tmp_path: Path) -> Iterator[Path]:
    path = tmp_path / "pipe.yaml"
    os.mkfifo(path)
    yield path
    # If reading the FIFO did block, a writer lets the blocked reader go before the test fails.
    fd = os.open(path, os.O_WRONLY | os.O_NONBLOCK) if _has_reader(path) else None
    if fd is not None:
        os.close(fd)


def _has_reader(path: Path) -> bool:
    try:
        os.close(os.open(path, os.O_WRONLY | os.O_NONBLOCK))
        return True
    except OSError:
        return False


def _in_thread(argv: list[str]) -> int | None:
    """main(argv) in a thread, so that a test of a hang fails instead of hanging."""
    result: list[int] = []
    thread = threading.Thread(target=lambda: result.append(main(argv)), daemon=True)
    thread.start()
    thread.join(5)
    return result[0] if result else None


@pytest.mark.timeout(20)
def test_a_fifo_as_the_scenario_is_refused_without_blocking(
    fifo: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    assert _in_thread(["check", str(fifo)]) == 2
    err = capsys.readouterr().err
    reason = "is a FIFO (named pipe), not a scenario file; only regular files are read"
    assert err == f"htnagent: error: {fifo}: {reason}\n"


@pytest.mark.timeout(20)
def test_a_fifo_as_the_map_is_refused_without_blocking(
    tmp_path: Path, fifo: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    path = scenario(tmp_path, map=fifo.name)
    assert _in_thread(["check", str(path)]) == 2
    assert "is a FIFO (named pipe), not a map file" in capsys.readouterr().err


@pytest.mark.skipif(not Path("/dev/zero").exists(), reason="no /dev/zero")
def test_dev_zero_as_the_map_is_refused_at_once(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    line = refused(["check", str(scenario(tmp_path, map="/dev/zero"))], capsys)
    assert (
        line
        == "htnagent: error: /dev/zero: is a character device, not a map file; only regular files are read"
    )


def test_a_directory_as_the_map_is_one_line(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    (tmp_path / "maps").mkdir()
    line = refused(["check", str(scenario(tmp_path, map="maps"))], capsys)
    assert line.endswith("maps: is a directory, not a map file")


def test_an_empty_scenario_name_says_so(capsys: pytest.CaptureFixture[str]) -> None:
    line = refused(["check", ""], capsys)
    assert line == "htnagent: error: '': no scenario file named '' (the file name is empty)"


# -- sizes -------------------------------------------------------------------------------


def test_a_file_over_the_size_limit_is_refused(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], monkeypatch: pytest.MonkeyPatch
) -> None:
    path = scenario(tmp_path)
    monkeypatch.setenv(limits.MAX_FILE_BYTES_ENV, "100")
    line = refused(["check", str(path)], capsys)
    assert line.startswith(f"htnagent: error: {path}: the file is too big (")
    assert "at most 100 bytes are read, see HTNAGENT_MAX_FILE_BYTES" in line
    # The map file is held to the same limit.
    monkeypatch.setenv(limits.MAX_FILE_BYTES_ENV, str(path.stat().st_size))
    line = refused(["check", str(path)], capsys)
    assert line.startswith(f"htnagent: error: {tmp_path / 'museum_map.yaml'}: the file is too big")


def test_the_size_limit_is_a_keyword_of_load_scenario(tmp_path: Path) -> None:
    path = scenario(tmp_path)
    with pytest.raises(ScenarioError, match="too big"):
        load_scenario(path, max_file_bytes=50)
    assert load_scenario(path, max_file_bytes=1_000_000).world.nodes
    with pytest.raises(ValueError, match="positive whole number"):
        load_scenario(path, max_file_bytes=0)


@pytest.mark.parametrize("value", ["lots", "-5", "0", "1e6", "²"])
def test_a_bad_size_limit_in_the_environment_is_one_line(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], monkeypatch: pytest.MonkeyPatch, value: str
) -> None:
    monkeypatch.setenv(limits.MAX_FILE_BYTES_ENV, value)
    line = refused(["check", str(scenario(tmp_path))], capsys)
    assert line.startswith("htnagent: error: HTNAGENT_MAX_FILE_BYTES: expected a positive whole number")


def test_a_file_growing_past_the_limit_while_read_is_refused(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    # stat() said small enough, the read finds more: the limit holds on what is read too.
    path = tmp_path / "growing.yaml"
    path.write_text("a: " + "x" * 500 + "\n")
    monkeypatch.setattr(files, "_check_kind", lambda *args: None)
    with pytest.raises(ScenarioError, match="too big"):
        read_text(path, "scenario", max_bytes=100)


# -- names the system refuses ----------------------------------------------------------


def test_a_map_name_of_5000_characters_is_one_short_line(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    path = scenario(tmp_path, map="a" * 5000)
    line = refused(["check", str(path)], capsys)
    assert line.startswith(f"htnagent: error: {path}: map: cannot read map file ")
    assert "File name too long" in line


def test_a_scenario_name_of_5000_characters_is_one_short_line(capsys: pytest.CaptureFixture[str]) -> None:
    line = refused(["check", "b" * 5000 + ".yaml"], capsys)
    assert "File name too long" in line


def test_a_map_name_through_a_file_is_one_line(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    line = refused(["check", str(scenario(tmp_path, map="museum_map.yaml/inner.yaml"))], capsys)
    assert "Not a directory" in line


# -- nesting -------------------------------------------------------------------------------


def nested(depth: int, name: str = "f") -> str:
    return f"{name}(" * depth + "x" + ")" * depth


@pytest.mark.parametrize("depth", [250, 1000, 100_000])
def test_a_task_nested_deep_is_one_line(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], depth: int
) -> None:
    line = refused(["check", str(scenario(tmp_path, task=f"goto({nested(depth)})"))], capsys)
    assert "goals[0].task: 'goto(f(f(f(" in line
    assert f"nested more than {limits.MAX_TERM_DEPTH} deep" in line


def test_a_trigger_nested_deep_is_one_line(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    action = f"move({nested(300)},n35,arc59)"
    when = f"  - {{agent: guide, task: goto(n2), when: {{action: '{action}', progress: 1}}}}\n"
    line = refused(["check", str(scenario(tmp_path, extra=when))], capsys)
    assert "goals[1].when.action: " in line and "nested more than" in line


def test_plan_with_a_task_nested_deep_is_one_line(capsys: pytest.CaptureFixture[str]) -> None:
    argv = ["plan", str(SCENARIOS / "museum.yaml"), "--agent", "guide", "--task", f"goto({nested(250)})"]
    line = refused(argv, capsys)
    assert line.startswith(f"htnagent: error: {SCENARIOS / 'museum.yaml'}: --task: ")
    assert "nested more than" in line


def test_text_forms_up_to_the_depth_limit_parse() -> None:
    assert str(parse(nested(limits.MAX_TERM_DEPTH))) == nested(limits.MAX_TERM_DEPTH)
    with pytest.raises(ValueError, match="nested more than"):
        parse(nested(limits.MAX_TERM_DEPTH + 1))


@pytest.mark.parametrize("depth", [101, 20_000, 1_000_000])
@pytest.mark.parametrize("kind", ["[]", "{}", "block"])
def test_yaml_nested_deep_is_one_line_with_its_line(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], depth: int, kind: str
) -> None:
    if kind == "block":
        depth = min(depth, 200)  # indentation grows as the square of the depth
        text = "".join(" " * i + f"k{i}:\n" for i in range(depth)) + " " * depth + "v\n"
    else:
        text = "a: " + kind[0] * depth + kind[1] * depth + "\n"
    path = tmp_path / "deep.yaml"
    path.write_text(text)
    line = refused(["check", str(path)], capsys)
    assert f"{path}: line " in line
    assert f"nested more than {limits.MAX_YAML_DEPTH} levels deep" in line


def test_yaml_nested_to_the_limit_loads() -> None:
    depth = limits.MAX_YAML_DEPTH
    data = load_yaml_text("[" * depth + "]" * depth, "deep.yaml")
    for _ in range(depth - 1):
        data = data[0]
    assert data == []


# -- odd values ------------------------------------------------------------------------------


@pytest.mark.parametrize("area", [["area1"], {"name": "area1"}, 5, None])
def test_a_node_whose_area_is_not_a_name_is_one_line(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], area: Any
) -> None:
    data = yaml.safe_load((SCENARIOS / "museum_map.yaml").read_text())
    data["nodes"]["n3"]["area"] = area
    path = scenario(tmp_path, map=map_file(tmp_path, data))
    line = refused(["check", str(path)], capsys)
    assert line.startswith(
        f"htnagent: error: {tmp_path / 'bad_map.yaml'}: nodes.n3.area: expected text, got {shown(area)}"
    )


def test_an_integer_of_5001_digits_is_one_line(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    path = scenario(tmp_path, extra="planner: {budget: " + "9" * 5001 + "}\n")
    line = refused(["check", str(path)], capsys)
    assert line == f"htnagent: error: {path}: line 9, column 19: a whole number of 5,001 digits is too long"


def test_a_huge_value_in_the_wrong_place_gives_a_short_message(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    path = scenario(tmp_path).with_name("big_name.yaml")
    path.write_text(
        scenario(tmp_path).read_text().replace("name: hostile", "name: [" + "x, " * 100_000 + "y]")
    )
    line = refused(["check", str(path)], capsys)
    assert "name: expected text, got ['x', 'x', 'x'" in line


def test_errors_quote_values_briefly() -> None:
    assert shown(10**5000) == "<a whole number of about 5001 digits>"
    assert len(shown("x" * 10**6)) < 80
    assert len(shown([[1] * 1000] * 1000)) < 80
    assert shown("goto(n1)") == "'goto(n1)'"


# -- aliases ------------------------------------------------------------------------------------

BILLION_LAUGHS = "a0: &a0 [lol, lol, lol, lol, lol, lol, lol, lol, lol, lol]\n" + "".join(
    f"a{i}: &a{i} [{', '.join([f'*a{i - 1}'] * 10)}]\n" for i in range(1, 10)
)


def test_an_alias_bomb_is_refused_at_once(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    path = tmp_path / "bomb.yaml"
    path.write_text(BILLION_LAUGHS + scenario(tmp_path).read_text().replace("name: hostile", "name: *a9"))
    line = refused(["check", str(path)], capsys)
    # a3 would repeat 11,110 values: refused there, long before the 10^10 of a9.
    assert line.startswith(f"htnagent: error: {path}: line 4, column ")
    assert line.endswith(
        "aliases repeat more than 10,000 values (an alias bomb?); write the values out instead"
    )


def test_an_alias_bomb_in_the_map_is_refused_at_once(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    (tmp_path / "bomb_map.yaml").write_text(BILLION_LAUGHS)
    line = refused(["check", str(scenario(tmp_path, map="bomb_map.yaml"))], capsys)
    assert line.startswith(f"htnagent: error: {tmp_path / 'bomb_map.yaml'}: line 4, column ")
    assert "aliases repeat more than" in line


def test_aliases_for_reuse_are_fine(tmp_path: Path) -> None:
    text = scenario(tmp_path).read_text()
    text = text.replace("robot: {start: n40, speed: 1.0}", "robot: &r {start: n40, speed: 1.0}")
    path = tmp_path / "aliases.yaml"
    path.write_text(
        text + "events:\n" + "".join(f"  - {{when: {{time: {t}}}, close: arc51}}\n" for t in (1, 2))
    )
    assert load_scenario(path).events[1].arc == "arc51"


def test_a_recursive_alias_is_refused() -> None:
    with pytest.raises(ScenarioError, match=r"line 1, column 8: the alias \*a is inside the value it names"):
        load_yaml_text("a: &a [*a]\n", "r.yaml")


# -- encodings -----------------------------------------------------------------------------------


@pytest.mark.parametrize("encoding", ["utf-8-sig", "utf-16", "utf-16-be", "utf-32"])
def test_unicode_files_with_a_byte_order_mark_load(tmp_path: Path, encoding: str) -> None:
    text = scenario(tmp_path).read_text().replace("hostile", "hostile — ünïcode")
    raw = text.encode(encoding)
    if encoding == "utf-16-be":
        raw = b"\xfe\xff" + raw
    path = tmp_path / "bom.yaml"
    path.write_bytes(raw)
    assert load_scenario(path).name == "hostile — ünïcode"


@pytest.mark.parametrize(
    ("raw", "where", "reason"),
    [
        ("name: café\n".encode("latin-1"), "line 1", "not UTF-8 text (byte 0xe9 at byte 9)"),
        (b"a: 1\nname: x\x00y\n", "line 2", "unacceptable character #x0000"),
        (b"a: 1\nb: \x1b[31m\n", "line 2", "unacceptable character #x001b"),
        (b"\xff\xfe\x00", "line 1", "not valid UTF-16-LE text"),
    ],
)
def test_bytes_that_are_not_text_are_one_line_with_the_line(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], raw: bytes, where: str, reason: str
) -> None:
    path = tmp_path / "odd.yaml"
    path.write_bytes(raw)
    line = refused(["check", str(path)], capsys)
    assert line.startswith(f"htnagent: error: {path}: {where}")
    assert reason in line


# -- names, coordinates and speeds ----------------------------------------------------------------


@pytest.mark.parametrize("name", ["ar,ea8", "area 8", "area(8)", "'area8'", "?area8", "area\t8"])
def test_area_names_are_checked_like_node_names(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], name: str
) -> None:
    data = yaml.safe_load((SCENARIOS / "museum_map.yaml").read_text())
    data["areas"][name] = None
    line = refused(["check", str(scenario(tmp_path, map=map_file(tmp_path, data)))], capsys)
    assert "is not a valid name (no spaces, parentheses, commas, quotes or '?')" in line


@pytest.mark.parametrize(
    ("x", "reason"),
    [
        (1e308, "must be at most 1e+09, got 1e+308"),
        (-1e308, "must be at least -1e+09, got -1e+308"),
        (1e9 + 1, "must be at most 1e+09, got 1000000001.0"),
        (float("inf"), "expected a finite number, got inf"),
        (float("nan"), "expected a finite number, got nan"),
    ],
)
def test_coordinates_must_be_finite_and_bounded(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], x: float, reason: str
) -> None:
    data = yaml.safe_load((SCENARIOS / "museum_map.yaml").read_text())
    data["nodes"]["n1"]["x"] = x
    line = refused(["check", str(scenario(tmp_path, map=map_file(tmp_path, data)))], capsys)
    assert line.endswith(f"bad_map.yaml: nodes.n1.x: {reason}")


def test_coordinates_up_to_the_bound_are_fine(tmp_path: Path) -> None:
    data = yaml.safe_load((SCENARIOS / "museum_map.yaml").read_text())
    data["nodes"]["n1"]["x"] = -limits.MAX_COORDINATE
    data["nodes"]["n2"]["y"] = limits.MAX_COORDINATE
    world = load_scenario(scenario(tmp_path, map=map_file(tmp_path, data))).world
    assert world.arcs["arc1"].length == pytest.approx(limits.MAX_COORDINATE * 2**0.5, rel=1e-6)


@pytest.mark.parametrize(
    ("length", "reason"),
    [
        (float("inf"), "expected a finite number, got inf"),
        (1e300, "must be at most 1e+10, got 1e+300"),
        (0, "must be greater than 0, got 0"),
        (-1, "must be greater than 0, got -1"),
    ],
)
def test_arc_lengths_must_be_positive_and_bounded(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], length: float, reason: str
) -> None:
    data = yaml.safe_load((SCENARIOS / "museum_map.yaml").read_text())
    data["arcs"]["arc1"] = {"ends": ["n1", "n2"], "length": length}
    line = refused(["check", str(scenario(tmp_path, map=map_file(tmp_path, data)))], capsys)
    assert line.endswith(f"bad_map.yaml: arcs.arc1.length: {reason}")


@pytest.mark.parametrize("speed", ["1.0e-320", "1.0e-7", "1.0e+300", ".inf"])
def test_robot_speeds_must_be_sane(tmp_path: Path, capsys: pytest.CaptureFixture[str], speed: str) -> None:
    path = scenario(tmp_path)
    path.write_text(path.read_text().replace("speed: 1.0", f"speed: {speed}"))
    line = refused(["check", str(path)], capsys)
    assert "robot.speed: " in line


@pytest.mark.parametrize("speed", ["1e-320", "0", "-1", "nan", "inf", "1e-7", "1e300", "fast"])
def test_run_speed_must_be_sane(capsys: pytest.CaptureFixture[str], speed: str) -> None:
    line = refused(["run", str(SCENARIOS / "museum.yaml"), "--speed", speed], capsys)
    assert "--speed" in line


# -- the loader reads YAML as PyYAML does -------------------------------------------------------

yaml_data = st.recursive(
    st.one_of(
        st.none(),
        st.booleans(),
        st.integers(-(10**30), 10**30),
        st.floats(allow_nan=False),
        st.text(max_size=10),
        st.sampled_from(
            ["yes", "No", "~", "null", "0x1F", "012", "1_000", "1:30", ".inf", "2001-12-14", "<<"]
        ),
    ),
    lambda inner: st.one_of(
        st.lists(inner, max_size=4), st.dictionaries(st.text(max_size=6), inner, max_size=4)
    ),
    max_leaves=25,
)


@settings(max_examples=200, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(data=yaml_data, flow=st.booleans())
def test_the_loader_reads_what_pyyaml_reads(data: Any, flow: bool) -> None:
    text = yaml.safe_dump(data, default_flow_style=flow, allow_unicode=True)
    if flow and "(" in text:
        return  # in flow collections text forms are mended on purpose
    # PyYAML writes the text "1e9" unquoted (YAML 1.1 reads it as text); here it is a number.
    assume(not any(EXPONENT.fullmatch(t) for t in texts_in(data)))
    assert repr(load_yaml_text(text, "t.yaml")) == repr(yaml.safe_load(text))


EXPONENT = re.compile(r"[-+]?(\.[0-9]+|[0-9]+(\.[0-9]*)?)[eE][-+]?[0-9]+")


def texts_in(data: Any) -> list[str]:
    if isinstance(data, str):
        return [data]
    if isinstance(data, list):
        return [t for item in data for t in texts_in(item)]
    if isinstance(data, dict):
        return [t for k, v in data.items() for t in (*texts_in(k), *texts_in(v))]
    return []


@settings(max_examples=300, deadline=None)
@given(st.text(alphabet=st.sampled_from("0123456789+-._:eEoOxXbBnNyYtTfFlLuUsS~<=aI "), max_size=12))
def test_plain_scalars_get_the_tags_pyyaml_gives(value: str) -> None:
    pyyaml = Resolver().resolve(ScalarNode, value, (True, False))  # type: ignore[no-untyped-call]
    # Two departures, as in YAML 1.2: base 60 is a string, and 1e9 (no dot) a float.
    if pyyaml in (INT, FLOAT) and ":" in value:
        pyyaml = STR
    elif pyyaml == STR and EXPONENT.fullmatch(value):
        pyyaml = FLOAT
    assert _plain_tag(value) == pyyaml


INT, FLOAT, STR = "tag:yaml.org,2002:int", "tag:yaml.org,2002:float", "tag:yaml.org,2002:str"


@pytest.mark.parametrize(
    ("text", "value"),
    [("1e9", 1e9), ("1e-6", 1e-6), ("-2E+3", -2000.0), ("1:30", "1:30"), ("1:30.5", "1:30.5")],
)
def test_exponents_are_numbers_and_base_60_is_text(text: str, value: Any) -> None:
    assert load_yaml_text(f"a: {text}", "t.yaml") == {"a": value}


def test_a_base_60_number_is_read_at_once_and_never_overflows(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    # YAML 1.1 reads 1:59:59:... group by group (time growing as the square of its length),
    # and a long one overflows a float: it is text here, and the field says what it wants.
    started = time.monotonic()
    for value in ("1:" + "59:" * 300_000 + "5", "1:" + "59:" * 180 + ".5"):
        path = scenario(tmp_path, extra=f"planner: {{budget: {value}}}\n")
        assert main(["check", str(path)]) == 2
        err = capsys.readouterr().err
        assert err.count("\n") == 1 and "budget" in err
    assert time.monotonic() - started < 10


def test_big_files_are_read_with_libyaml_when_present() -> None:
    assert reading._Parser is getattr(yaml, "CSafeLoader", yaml.SafeLoader)
    assert getattr(yaml, "__with_libyaml__", False) == (reading._Parser is not yaml.SafeLoader)


def test_read_yaml_refuses_a_second_document(tmp_path: Path) -> None:
    path = tmp_path / "two.yaml"
    path.write_text("a: 1\n---\nb: 2\n")
    with pytest.raises(ScenarioError, match="line 2, column 1: a second YAML document"):
        read_yaml(path, "scenario")


@pytest.mark.parametrize(
    ("text", "expected"),
    [
        ("[f(x,y), z]", ["f(x,y)", "z"]),
        ("{a: f(x,y,z), b: 1}", {"a": "f(x,y,z)", "b": 1}),
        ("{a: resume(move(n40,n35,arc59))}", {"a": "resume(move(n40,n35,arc59))"}),
        # Parentheses that never close leave the pieces as YAML read them.
        ("[f(x, g(y), z]", ["f(x", "g(y)", "z"]),
        ("{a: f(x, b: 2}", {"a": "f(x", "b": 2}),
        # A text form is read whole, so what follows its parentheses is not silently dropped.
        ("[f(a)g(b,c)]", ["f(a)g(b,c)"]),
    ],
)
def test_text_forms_split_by_flow_commas_are_mended(text: str, expected: Any) -> None:
    assert load_yaml_text(text, "t.yaml") == expected


def test_mending_is_linear(tmp_path: Path) -> None:
    # Thousands of parentheses that never close: each piece is looked at once, not once per piece.
    text = "[" + "f(, " * 200_000 + "x]\n"
    started = time.monotonic()
    assert len(load_yaml_text(text, "t.yaml")) == 200_001
    assert time.monotonic() - started < 10
