"""The package's public names: one list, each name importable, every error an HtnAgentError."""

from __future__ import annotations

import inspect
import subprocess
import sys

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
