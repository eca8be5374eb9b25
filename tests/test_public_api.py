"""The package's public names: one list, each name importable, every error an HtnAgentError."""

from __future__ import annotations

import ast
import inspect
import subprocess
import sys
from pathlib import Path

import htnagent
from htnagent import errors


def test_every_public_name_is_listed_once_and_resolves() -> None:
    listed = htnagent.__all__
    assert len(listed) == len(set(listed))
    for name in listed:
        assert getattr(htnagent, name) is not None, name


def test_every_error_class_is_public_and_an_htnagent_error() -> None:
    classes = [c for _, c in inspect.getmembers(errors, inspect.isclass) if c.__module__ == errors.__name__]
    raised = [c for c in classes if issubclass(c, Exception) and not c.__name__.startswith("_")]
    assert raised
    for cls in raised:
        assert issubclass(cls, htnagent.HtnAgentError), cls
        assert cls.__name__ in htnagent.__all__, cls
        # The hierarchy drawn in the module docstring names every class.
        assert cls.__name__ in (errors.__doc__ or ""), cls


def test_importing_the_package_loads_no_runtime() -> None:
    # The command line installs its signal handlers before anything heavy is imported.
    heavy = "('anyio', 'pydantic', 'networkx')"
    code = f"import sys, htnagent; print(sorted(m for m in {heavy} if m in sys.modules))"
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout
    assert out.strip() == "[]"


def test_no_public_name_shadows_a_module_of_the_package() -> None:
    # ``import htnagent.X`` binds X in the package: a public name X would then change meaning.
    root = Path(htnagent.__file__).parent
    for name in htnagent.__all__:
        assert not (root / f"{name}.py").exists(), name
        assert not (root / name).is_dir(), name


def test_the_planning_function_stays_after_its_neighbours_are_imported() -> None:
    probe = (
        "import htnagent, htnagent.model.plans, htnagent.planning.planner;"
        " from htnagent import plan, Plan; print(callable(plan), Plan.__name__)"
    )
    done = subprocess.run([sys.executable, "-c", probe], capture_output=True, text=True, timeout=60)
    assert done.stdout.split() == ["True", "Plan"], done.stderr


def test_the_type_checkers_names_are_the_exported_names() -> None:
    # The TYPE_CHECKING block re-exports for mypy/pyright what __getattr__ gives at run time.
    tree = ast.parse(Path(htnagent.__file__).read_text())
    block = next(n for n in tree.body if isinstance(n, ast.If) and ast.unparse(n.test) == "TYPE_CHECKING")
    imported = {
        alias.name: (node.module or "").removeprefix("htnagent.")
        for node in block.body
        if isinstance(node, ast.ImportFrom)
        for alias in node.names
    }
    assert imported == htnagent._EXPORTS
