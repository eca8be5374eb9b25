"""The scenarios that ship with htnagent, found by name (``python -m htnagent run museum``).

The repository's top-level ``scenarios/`` folder is the package's ``htnagent/scenarios``
(a link in the source tree, a folder of package data in the wheel), so a ``pip install``
has them too.  A scenario's name is its file's name without ``.yaml``; the map files
(``*_map.yaml``) are not scenarios.  :func:`scenario_file` is what the command line
calls on every SCENARIO it is given: a file that exists is always read as given.
"""

from __future__ import annotations

import re
from pathlib import Path

from htnagent.errors import ScenarioError

__all__ = ["BUILTIN_DIR", "builtin_scenarios", "scenario_file"]

BUILTIN_DIR = Path(__file__).resolve().parents[1] / "scenarios"
"""Where the built-in scenarios are (the package's ``scenarios`` folder)."""


def builtin_scenarios() -> tuple[str, ...]:
    """The names of the built-in scenarios, sorted."""
    if not BUILTIN_DIR.is_dir():
        return ()
    return tuple(sorted(p.stem for p in BUILTIN_DIR.glob("*.yaml") if not p.stem.endswith("_map")))


def scenario_file(text: str) -> str:
    """The file a SCENARIO argument names: ``text`` itself when it exists (a path wins over a
    name), else the built-in scenario of that name (``museum`` or ``museum.yaml``).

    Raises :class:`~htnagent.errors.ScenarioError` for a bare name (no folder in it) that is
    neither, listing the built-in names; any other path is returned as it is, for the
    reader to say what is wrong with it.
    """
    try:
        if Path(text).exists():
            return text
    except (OSError, ValueError):  # a name too long, or with a NUL: the reader says so
        return text
    name = text.removesuffix(".yaml")
    if re.fullmatch(r"[A-Za-z0-9_.-]+", name) is None:  # a path, or no name at all
        return text
    names = builtin_scenarios()
    if name in names:
        return str(BUILTIN_DIR / f"{name}.yaml")
    listed = ", ".join(names) if names else "none (they were not installed)"
    raise ScenarioError(
        text, "", f"no such file, nor a built-in scenario; the built-in scenarios are {listed}"
    )
