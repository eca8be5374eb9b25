"""A scenario naming Python code runs that code, and nothing else.

``domain: package.module:attribute`` once imported anything (a module's top
level runs on import) and called anything callable: ``check`` on a scenario
naming ``venv.__main__:x`` made a virtual environment, ``code:interact``
opened a prompt, ``sys:exit`` escaped as SystemExit, a module in the current
folder was imported from there.  Now only the user's own modules (next to the
scenario, or installed) are imported, and only a ``Domain`` or a function
marked ``@domain_factory`` is taken, before anything is called.
"""

from __future__ import annotations

import shutil
import subprocess
import sys
import uuid
from pathlib import Path

import pytest
import yaml

from htnagent.cli.commands import main
from htnagent.domains import domain_factory, is_domain_factory
from htnagent.domains.guide_talk import talk_domain

REPO = Path(__file__).resolve().parents[1]
SCENARIOS = REPO / "scenarios"


def write_scenario(folder: Path, domain: str) -> Path:
    folder.mkdir(parents=True, exist_ok=True)
    shutil.copy(SCENARIOS / "museum_map.yaml", folder)
    data = {
        "name": "user code",
        "map": "museum_map.yaml",
        "robot": {"start": "n1", "speed": 1.0},
        "agents": [{"name": "host", "domain": domain, "executor": "robot"}],
        "goals": [{"agent": "host", "task": "goto_node(n2)"}],
    }
    path = folder / "user.yaml"
    path.write_text(yaml.safe_dump(data))
    return path


def refused(path: Path, capsys: pytest.CaptureFixture[str]) -> str:
    assert main(["check", str(path)]) == 2
    out, err = capsys.readouterr()
    assert out == ""
    assert "Traceback" not in err
    lines = err.splitlines()
    assert len(lines) == 1, err
    assert lines[0].startswith(f"htnagent: error: {path}: agents[0].domain: ")
    return lines[0]


def module_name() -> str:
    return f"user_domain_{uuid.uuid4().hex[:8]}"


MODULE = """
import functools
from pathlib import Path

from htnagent.domains import domain_factory
from htnagent.domains.museum import nodes_domain

Path(__file__).with_name("imported.{name}").touch()


@domain_factory
def marked(world):
    print("hello from the factory")
    return nodes_domain(world)


def unmarked(world):
    Path(__file__).with_name("called.{name}").touch()
    return nodes_domain(world)


class Maker:
    def __call__(self, world):
        Path(__file__).with_name("called.{name}").touch()
        return nodes_domain(world)


maker = Maker()
later = functools.partial(unmarked)
"""


# -- the standard library is never imported ------------------------------------------------


@pytest.mark.parametrize(
    "domain",
    ["venv.__main__:x", "code:interact", "sys:exit", "this:x", "antigravity:x", "os:system", "builtins:exec"],
)
def test_a_standard_library_module_is_refused_before_import(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], monkeypatch: pytest.MonkeyPatch, domain: str
) -> None:
    monkeypatch.chdir(tmp_path)
    loaded = set(sys.modules)
    line = refused(write_scenario(tmp_path / "s", domain), capsys)
    top = domain.partition(".")[0].partition(":")[0]
    assert f"{top} is a standard-library module, not a domain" in line
    assert set(sys.modules) == loaded, "nothing was imported"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["s"], "nothing was made"


def test_a_main_module_is_refused(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    line = refused(write_scenario(tmp_path, "htnagent.__main__:main"), capsys)
    assert "a __main__ module is a program, not a domain" in line


@pytest.mark.parametrize("domain", ["os.path:join:x", ".relative:x", "pkg-name:x", "mod:", ":attr", "a..b:c"])
def test_a_malformed_name_is_refused(tmp_path: Path, capsys: pytest.CaptureFixture[str], domain: str) -> None:
    assert "expected package.module:attribute" in refused(write_scenario(tmp_path, domain), capsys)


# -- the scenario's folder, not the current one ---------------------------------------------------


def test_a_module_next_to_the_scenario_is_found_without_touching_sys_path(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    name = module_name()
    (tmp_path / f"{name}.py").write_text(
        MODULE.replace("{name}", name) + 'print("hello from the top level")\n'
    )
    path = write_scenario(tmp_path, f"{name}:marked")
    before = list(sys.path)
    assert main(["check", str(path)]) == 0
    out, err = capsys.readouterr()
    assert out == "ok\n"
    # What the user's code prints goes to stderr: stdout may be carrying JSON Lines.
    assert err == "hello from the top level\nhello from the factory\n"
    assert sys.path == before
    assert (tmp_path / f"imported.{name}").exists()


def test_a_module_in_the_current_folder_is_not_imported_by_accident(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], monkeypatch: pytest.MonkeyPatch
) -> None:
    here = tmp_path / "here"
    here.mkdir()
    name = module_name()
    (here / f"{name}.py").write_text(MODULE.replace("{name}", name))
    monkeypatch.chdir(here)
    # As under python -m, and an interactive '': the current folder is on sys.path.
    monkeypatch.syspath_prepend(str(here))
    monkeypatch.setattr(sys, "path", ["", *sys.path])
    line = refused(write_scenario(tmp_path / "elsewhere", f"{name}:marked"), capsys)
    assert f"cannot import module {name!r}" in line
    assert "and the installed packages" in line
    assert not (here / f"imported.{name}").exists()


def test_python_m_htnagent_does_not_import_from_the_current_folder(tmp_path: Path) -> None:
    here = tmp_path / "here"
    here.mkdir()
    name = module_name()
    (here / f"{name}.py").write_text(MODULE.replace("{name}", name))
    path = write_scenario(tmp_path / "elsewhere", f"{name}:marked")
    done = subprocess.run(
        [sys.executable, "-m", "htnagent", "check", str(path)],
        cwd=here,
        capture_output=True,
        text=True,
        timeout=60,
        check=False,
    )
    assert done.returncode == 2
    assert f"cannot import module {name!r}" in done.stderr
    assert not (here / f"imported.{name}").exists()


# -- only a Domain or a marked factory, checked before calling -------------------------------------


@pytest.mark.parametrize("attribute", ["unmarked", "maker", "later", "Maker"])
def test_anything_but_a_domain_or_a_marked_factory_is_refused_before_it_is_called(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], attribute: str
) -> None:
    name = module_name()
    (tmp_path / f"{name}.py").write_text(MODULE.replace("{name}", name))
    line = refused(write_scenario(tmp_path, f"{name}:{attribute}"), capsys)
    assert "not a Domain nor a function marked @htnagent.domains.domain_factory" in line
    assert not (tmp_path / f"called.{name}").exists()


def test_the_decorator_marks_the_function_itself() -> None:
    def make(world: object) -> object:
        return world

    assert not is_domain_factory(make)
    assert domain_factory(make) is make  # type: ignore[type-var]
    assert is_domain_factory(make)
    assert is_domain_factory(talk_domain)
    assert not is_domain_factory(lambda world: world)
    assert not is_domain_factory(print)


# -- whatever the user's code raises is one line ---------------------------------------------------

RAISING = """
from htnagent.domains import domain_factory
{top}

@domain_factory
def make(world):
    {call}
"""


@pytest.mark.parametrize(
    ("top", "call", "reason"),
    [
        ("raise SystemExit(3)", "pass", "importing {name!r} failed: SystemExit: 3"),
        ("raise KeyboardInterrupt", "pass", "importing {name!r} failed: KeyboardInterrupt"),
        ("import sys; sys.exit('bye')", "pass", "importing {name!r} failed: SystemExit: bye"),
        ("class Odd(BaseException): pass\nraise Odd('odd')", "pass", "importing {name!r} failed: Odd: odd"),
        ("import no_such_module_xyz", "pass", "importing {name!r} failed: ModuleNotFoundError"),
        ("", "raise SystemExit(0)", "calling {name}:make(map) failed: SystemExit: 0"),
        ("", "raise KeyboardInterrupt", "calling {name}:make(map) failed: KeyboardInterrupt"),
        ("", "raise GeneratorExit('x' * 10_000)", "calling {name}:make(map) failed: GeneratorExit: xxx"),
        ("", "return 42", "{name}:make(map) returned a int, not a Domain"),
    ],
)
def test_whatever_user_code_raises_is_one_line(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], top: str, call: str, reason: str
) -> None:
    name = module_name()
    (tmp_path / f"{name}.py").write_text(RAISING.format(top=top, call=call))
    line = refused(write_scenario(tmp_path, f"{name}:make"), capsys)
    assert reason.format(name=name) in line


def test_a_module_getattr_that_raises_is_one_line(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    name = module_name()
    (tmp_path / f"{name}.py").write_text("def __getattr__(name):\n    raise SystemExit('no')\n")
    line = refused(write_scenario(tmp_path, f"{name}:anything"), capsys)
    assert f"looking up {name}:anything failed: SystemExit: no" in line


def test_the_guide_talk_domain_is_marked_and_loads(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["check", str(SCENARIOS / "explain_question.yaml")]) == 0
    assert capsys.readouterr().out == "ok\n"
