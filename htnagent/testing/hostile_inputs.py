"""Hostile inputs for the command line, and the judge of what they did.

Each input is one bad file set -- text forms and YAML nested deep, files over the
size limit, special files (FIFOs, /dev/zero, directories, sockets, symlink loops),
alias bombs, odd encodings (UTF-16/32, BOMs, NUL bytes, latin-1), scenario and map
files mutated at random, domains naming code that must not run, random bytes --
made the same way every time from its number and a seed (:func:`make_case`), put
in a fresh folder (:func:`materialized`), and run through the commands
:func:`commands` lists.  :func:`problems` says what a command's :class:`Result`
shows wrong: a traceback, a hang, running out of memory, a crash.

``python -m bench fuzz`` runs thousands of them; the tests run a few.
"""

from __future__ import annotations

import codecs
import contextlib
import os
import random
import shutil
import socket
import tempfile
from collections.abc import Callable, Iterator
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import yaml

SCENARIOS = Path(__file__).resolve().parent.parent / "scenarios"
SMALL_LIMIT = 1_000_000  # HTNAGENT_MAX_FILE_BYTES for the "huge file" inputs: cheap to exceed


@dataclass
class Case:
    """One bad input: files to make in a fresh folder, and the scenario to name on the command line."""

    kind: str
    files: dict[str, bytes] = field(default_factory=dict)
    specials: dict[str, str] = field(default_factory=dict)  # name -> fifo, dir, socket, loop
    scenario: str = "scenario.yaml"  # relative to the case folder, or absolute
    env: dict[str, str] = field(default_factory=dict)
    task: str | None = None  # plan --task, for the nested text forms
    marker: str | None = None  # a file whose existence means code ran that must not have
    special: bool = False  # uses a special file: always through real processes


def _sources() -> list[str]:
    return [p.read_text() for p in sorted(SCENARIOS.glob("*.yaml")) if not p.name.endswith("_map.yaml")]


SOURCES = _sources()
MAP_TEXT = (SCENARIOS / "museum_map.yaml").read_text()
BASE = next(t for t in SOURCES if "emergency to n28" in t)

# fmt: off
SPECIAL_VALUES = [
    "1e400", "-1e400", ".nan", ".inf", "-0", "0x7fffffffffffffff", "9" * 5001, "1_0", "0o777", "~", "null",
    "yes", "''", '""', "[]", "{}", "!!binary aGk=", "!!set {a}", "!!python/object:os.system x", "!foo bar",
    "&x", "*x", "*nope", "<<", "2001-13-45", "1:30", "\\x00", "'\\u0000'", "[[[[[[[[", "{{{{", "- - - -",
    "goto(" * 50, "move(n40,n35,arc59)", "a" * 10_000, "n" * 300 + "(", ":", "? x", "|\n  text", ">-\n  t",
]

DOMAINS = [
    "os:system", "venv.__main__:x", "code:interact", "sys:exit", "this:x", "antigravity:x", "subprocess:run",
    "builtins:exec", "__main__:x", "htnagent.__main__:main", "htnagent.cli.commands:main", "pip:main",
    "htnagent.domains:BUILTIN", "htnagent.domains.museum:nodes_domain",
    "htnagent.domains.guide_talk:talk_domain", "sneaky:make", "local_mod:make", "local_mod:unmarked",
    "local_mod:boom", "x" * 300 + ":y", "a.b.c:d.e.f",
]
# fmt: on

LOCAL_MODULE = b"""
import sys
from htnagent.domains import domain_factory
from htnagent.domains.museum import nodes_domain
print("local module imported")

@domain_factory
def make(world):
    return nodes_domain(world)

def unmarked(world):
    open("RAN", "w").close()
    return nodes_domain(world)

@domain_factory
def boom(world):
    raise SystemExit(7)
"""

SNEAKY_MODULE = b'open("RAN", "w").close()\ndef make(world):\n    return None\n'


def _scenario_text(rng: random.Random) -> str:
    return rng.choice(SOURCES)


def _nested(depth: int, name: str = "f") -> str:
    return f"{name}(" * depth + "x" + ")" * depth


def gen_nested_terms(rng: random.Random) -> Case:
    depth = rng.choice([20, 33, 100, 250, 1000, 10_000, 200_000])
    name = rng.choice(["f", "goto", "resume", "move"])
    where = rng.choice(["task", "trigger", "plan"])
    if where == "plan":  # a command-line argument may be at most 128 KiB (MAX_ARG_STRLEN)
        depth = min(depth, 100_000 // (len(name) + 2))
    term = _nested(depth, name)
    text = BASE
    if where == "task":
        text = text.replace("task: goto(n1)", f"task: goto({term})")
    elif where == "trigger":
        text = text.replace("move(n40,n35,arc59)", f"'move({term},n35,arc59)'")
    files = {"scenario.yaml": text.encode(), "museum_map.yaml": MAP_TEXT.encode()}
    return Case("nested_terms", files, task=f"goto({term})" if where == "plan" else None)


def gen_nested_yaml(rng: random.Random) -> Case:
    depth = rng.choice([99, 100, 101, 150, 1000, 20_000, 300_000])
    style = rng.choice(["seq", "map", "block", "mixed"])
    if style == "seq":
        value = "[" * depth + "]" * depth
    elif style == "map":
        value = "{a: " * depth + "b" + "}" * depth
    elif style == "mixed":
        value = "[{a: " * (depth // 2) + "x" + "}]" * (depth // 2)
    else:
        depth = min(depth, 400)
        value = "\n" + "".join(" " * (i + 2) + f"k{i}:\n" for i in range(depth)) + " " * (depth + 2) + "v"
    key = rng.choice(["name", "goals", "events", "map", "robot"])
    text = BASE.replace(f"\n{key}:", f"\n{key}_old:", 1) + f"{key}: {value}\n"
    if rng.random() < 0.3:  # in the map file instead
        return Case(
            "nested_yaml", {"scenario.yaml": BASE.encode(), "museum_map.yaml": f"areas: {value}\n".encode()}
        )
    return Case("nested_yaml", {"scenario.yaml": text.encode(), "museum_map.yaml": MAP_TEXT.encode()})


def gen_huge(rng: random.Random) -> Case:
    choice = rng.random()
    if choice < 0.1:
        # A sparse file past the default 64 MiB: refused by its size, never read.
        return Case(
            "huge", {"scenario.yaml": BASE.encode()}, specials={"museum_map.yaml": "sparse"}, special=True
        )
    size = rng.randint(SMALL_LIMIT // 2, 3 * SMALL_LIMIT)
    unit = rng.choice([b"- {}\n", b"a: b\n", b"[" * 1000, b"x" * 1000 + b"\n", b"- &a [1]\n", b"\x00" * 64])
    blob = (unit * (size // len(unit) + 1))[:size]
    if choice < 0.5:
        return Case("huge", {"scenario.yaml": blob}, env={"HTNAGENT_MAX_FILE_BYTES": str(SMALL_LIMIT)})
    return Case(
        "huge",
        {"scenario.yaml": BASE.encode(), "museum_map.yaml": blob},
        env={"HTNAGENT_MAX_FILE_BYTES": str(SMALL_LIMIT)},
    )


def gen_special(rng: random.Random) -> Case:
    kind = rng.choice(
        ["fifo", "dir", "socket", "loop", "/dev/zero", "/dev/urandom", "/dev/null", "missing", "long"]
    )
    as_map = rng.random() < 0.6
    files: dict[str, bytes] = {}
    specials: dict[str, str] = {}
    name = "museum_map.yaml" if as_map else "scenario.yaml"
    scenario = "scenario.yaml"
    if kind.startswith("/dev/"):
        if as_map:
            files["scenario.yaml"] = BASE.replace("museum_map.yaml", kind).encode()
        else:
            scenario = kind
    elif kind == "missing":
        files["scenario.yaml"] = BASE.replace("museum_map.yaml", "nowhere/none.yaml").encode()
    elif kind == "long":
        long_name = "m" * rng.choice([255, 256, 5000])
        if as_map:
            files["scenario.yaml"] = BASE.replace("museum_map.yaml", long_name).encode()
        else:
            scenario = long_name
    else:
        specials[name] = kind
        if as_map:
            files["scenario.yaml"] = BASE.encode()
    return Case("special", files, specials, scenario=scenario, special=True)


def gen_alias_bomb(rng: random.Random) -> Case:
    levels, fanout = rng.randint(4, 12), rng.randint(2, 10)
    lines = ["a0: &a0 [" + ", ".join(["lol"] * fanout) + "]"]
    for i in range(1, levels):
        lines.append(f"a{i}: &a{i} [" + ", ".join([f"*a{i - 1}"] * fanout) + "]")
    bomb = "\n".join(lines) + "\n"
    if rng.random() < 0.2:  # merges instead of lists
        bomb = "b0: &b0 {x: 1, y: 2}\n" + "".join(
            f"b{i}: &b{i} {{<<: [{', '.join([f'*b{i - 1}'] * fanout)}], k{i}: 1}}\n" for i in range(1, levels)
        )
        last = f"*b{levels - 1}"
    else:
        last = f"*a{levels - 1}"
    where = rng.choice(["name", "goals", "map", "mapfile", "recursive"])
    map_file = {"museum_map.yaml": MAP_TEXT.encode()}
    if where == "recursive":
        return Case("alias_bomb", {"scenario.yaml": (BASE + "events: &e [*e]\n").encode(), **map_file})
    if where == "mapfile":
        return Case(
            "alias_bomb", {"scenario.yaml": BASE.encode(), "museum_map.yaml": (bomb + MAP_TEXT).encode()}
        )
    text = BASE.replace(f"\n{where}:", f"\n{where}_old:", 1)
    return Case("alias_bomb", {"scenario.yaml": (bomb + text + f"{where}: {last}\n").encode(), **map_file})


def gen_encoding(rng: random.Random) -> Case:
    text = _scenario_text(rng).replace("museum", rng.choice(["musée", "мuseum", "博物館", "museum"]))
    encoding = rng.choice(
        ["utf-16", "utf-16-le", "utf-16-be", "utf-32", "utf-8-sig", "latin-1", "cp1252", "utf-8"]
    )
    try:
        raw = text.encode(encoding)
    except UnicodeEncodeError:
        raw = text.encode(encoding, "replace")
    mutation = rng.random()
    if mutation < 0.3:
        pos = rng.randrange(len(raw) + 1)
        raw = raw[:pos] + b"\x00" * rng.randint(1, 4) + raw[pos:]
    elif mutation < 0.45:
        raw = raw.replace(b"\n", b"\r\n") if encoding.startswith("utf-8") else raw
    elif mutation < 0.55:
        raw = codecs.BOM_UTF8 + codecs.BOM_UTF16_LE + raw
    elif mutation < 0.65:
        pos = rng.randrange(len(raw) + 1)
        raw = raw[:pos] + bytes([rng.choice([0x80, 0xC3, 0xED, 0xF4, 0xFF, 0x1B, 0x7F])]) + raw[pos:]
    return Case("encoding", {"scenario.yaml": raw, "museum_map.yaml": MAP_TEXT.encode()})


def _mutate_text(text: str, rng: random.Random) -> str:
    for _ in range(rng.randint(1, 4)):
        op = rng.random()
        lines = text.split("\n")
        if op < 0.25 and len(text) > 1:  # replace a token by a special value
            tokens = [t for t in text.replace("{", " ").replace("}", " ").replace(",", " ").split() if t]
            token = rng.choice(tokens)
            text = text.replace(token, rng.choice(SPECIAL_VALUES), 1)
        elif op < 0.4:  # delete a character
            i = rng.randrange(len(text))
            text = text[:i] + text[i + 1 :]
        elif op < 0.55:  # insert a special character
            i = rng.randrange(len(text) + 1)
            text = text[:i] + rng.choice(list("{}[]:,-&*!|>'\"#%@`\t\n ()?<=~")) + text[i:]
        elif op < 0.7:  # duplicate a line
            i = rng.randrange(len(lines))
            lines.insert(i, lines[i])
            text = "\n".join(lines)
        elif op < 0.8:  # swap two lines
            i, j = rng.randrange(len(lines)), rng.randrange(len(lines))
            lines[i], lines[j] = lines[j], lines[i]
            text = "\n".join(lines)
        elif op < 0.9:  # change an indentation
            i = rng.randrange(len(lines))
            lines[i] = " " * rng.randint(0, 6) + lines[i].lstrip()
            text = "\n".join(lines)
        else:  # flip a byte's worth of character
            i = rng.randrange(len(text))
            text = text[:i] + chr(rng.randrange(0x20, 0x2FF)) + text[i + 1 :]
    return text


def _mutate_data(data: Any, rng: random.Random) -> Any:
    paths: list[tuple[Any, Any]] = []

    def walk(node: Any) -> None:
        if isinstance(node, dict):
            for k in list(node):
                paths.append((node, k))
                walk(node[k])
        elif isinstance(node, list):
            for i in range(len(node)):
                paths.append((node, i))
                walk(node[i])

    walk(data)
    for _ in range(rng.randint(1, 3)):
        if not paths:
            break
        parent, key = rng.choice(paths)
        choice = rng.random()
        try:
            if choice < 0.4:
                parent[key] = rng.choice(
                    [None, True, -1, 0, 2**70, 1e308, float("nan"), "", "x" * 500, [], {}, ["a"], {"k": "v"}]
                )
            elif choice < 0.6:
                del parent[key]
            else:
                parent[key] = rng.choice(
                    ["n99", "arc999", "goto(n1)", "area9", "robot", "guide", "?x", "a,b"]
                )
        except (IndexError, KeyError, TypeError):
            pass
    return data


def gen_mutated_scenario(rng: random.Random) -> Case:
    text = _scenario_text(rng)
    if rng.random() < 0.1:
        pass  # a shipped scenario as it is: the runs must still work (exit 0 or 1)
    elif rng.random() < 0.5:
        text = _mutate_text(text, rng)
    else:
        data = yaml.safe_load(text)
        text = yaml.safe_dump(_mutate_data(data, rng), allow_unicode=True)
    return Case("mutated_scenario", {"scenario.yaml": text.encode(), "museum_map.yaml": MAP_TEXT.encode()})


def gen_mutated_map(rng: random.Random) -> Case:
    if rng.random() < 0.5:
        text = _mutate_text(MAP_TEXT, rng)
    else:
        text = yaml.safe_dump(_mutate_data(yaml.safe_load(MAP_TEXT), rng), allow_unicode=True)
    return Case(
        "mutated_map", {"scenario.yaml": _scenario_text(rng).encode(), "museum_map.yaml": text.encode()}
    )


def gen_domain(rng: random.Random) -> Case:
    domain = rng.choice(DOMAINS)
    text = BASE.replace("domain: museum.nodes", f'domain: "{domain}"')
    # The scenario sits in a subfolder; the current folder holds a module that must not be imported.
    files = {
        "sub/scenario.yaml": text.encode(),
        "sub/museum_map.yaml": MAP_TEXT.encode(),
        "sneaky.py": SNEAKY_MODULE,
        "sub/local_mod.py": LOCAL_MODULE,
    }
    return Case("domain", files, scenario="sub/scenario.yaml", marker="RAN")


def gen_random_bytes(rng: random.Random) -> Case:
    raw = rng.randbytes(rng.choice([0, 1, 16, 200, 4096]))
    if rng.random() < 0.3:  # printable garbage parses further
        raw = bytes(rng.choice(b"{}[]:,-&*!|> \n\tabcn0123456789()'\"") for _ in range(rng.randint(1, 2000)))
    return Case("random_bytes", {"scenario.yaml": raw})


GENERATORS: list[tuple[str, Callable[[random.Random], Case], float]] = [
    ("nested_terms", gen_nested_terms, 0.08),
    ("nested_yaml", gen_nested_yaml, 0.08),
    ("huge", gen_huge, 0.04),
    ("special", gen_special, 0.05),
    ("alias_bomb", gen_alias_bomb, 0.07),
    ("encoding", gen_encoding, 0.10),
    ("mutated_scenario", gen_mutated_scenario, 0.30),
    ("mutated_map", gen_mutated_map, 0.12),
    ("domain", gen_domain, 0.06),
    ("random_bytes", gen_random_bytes, 0.10),
]


def make_case(index: int, seed: int = 0) -> Case:
    """The input number ``index`` (the same every time for the same seed)."""
    rng = random.Random(seed * 1_000_003 + index)
    generators = [g for _, g, _ in GENERATORS]
    weights = [w for _, _, w in GENERATORS]
    return rng.choices(generators, weights)[0](rng)


@contextlib.contextmanager
def materialized(case: Case, parent: Path) -> Iterator[Path]:
    """The case's files in a fresh folder (removed afterwards)."""
    folder = Path(tempfile.mkdtemp(dir=parent))
    sock: socket.socket | None = None
    try:
        for name, content in case.files.items():
            (folder / name).parent.mkdir(parents=True, exist_ok=True)
            (folder / name).write_bytes(content)
        for name, kind in case.specials.items():
            path = folder / name
            if kind == "fifo":
                os.mkfifo(path)
            elif kind == "dir":
                path.mkdir()
            elif kind == "socket":
                sock = socket.socket(socket.AF_UNIX, socket.SOCK_STREAM)
                sock.bind(str(path))
            elif kind == "loop":
                os.symlink(path.name, path)
            elif kind == "sparse":
                with open(path, "wb") as f:
                    f.truncate(65 * 1024 * 1024)
        yield folder
    finally:
        if sock is not None:
            sock.close()
        shutil.rmtree(folder, ignore_errors=True)


def commands(case: Case, folder: Path) -> list[list[str]]:
    scenario = case.scenario if case.scenario.startswith("/") else str(folder / case.scenario)
    out = [["check", scenario], ["run", scenario, "--json"]]
    if case.task is not None:
        out.append(["plan", scenario, "--agent", "guide", "--task", case.task])
    return out


@dataclass
class Result:
    """What one command did."""

    code: int | None
    seconds: float
    stderr: str
    stdout_tail: str = ""
    traceback: str | None = None
    timeout: bool = False
    memory: bool = False


def problems(result: Result) -> list[str]:
    """What is wrong with a command's result (nothing, for a clean refusal or a clean run)."""
    found = []
    if result.timeout:
        found.append("timeout")
    if result.memory:
        found.append("over_memory")
    if result.traceback is not None or "Traceback" in result.stderr:
        found.append("traceback")
    if result.code is not None and result.code not in (0, 1, 2):  # None: timed out, or an exception escaped
        found.append("bad_exit")
    return found
