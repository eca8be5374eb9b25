"""A user's domain, named in a scenario as ``package.module:attribute``.

A scenario that names Python code runs that code: importing the module runs its
top level, and a domain factory runs when it is called.  What this module
makes sure of is that nothing *else* runs:

- a standard-library module is never imported as a domain -- ``venv.__main__``
  makes a virtual environment when imported, ``code:interact`` opens a prompt,
  ``sys:exit`` exits -- nor is any ``__main__`` module (a program, not a library);
- the module is looked up in the scenario file's folder first, then in the
  installed packages; not in the current working directory by accident;
- the attribute must be a :class:`~htnagent.model.domain.Domain` or a function marked
  with :func:`~htnagent.domains.domain_factory`, and this is checked before
  anything is called;
- whatever the user's code raises, ``SystemExit`` and ``KeyboardInterrupt``
  included, becomes one :class:`~htnagent.errors.ScenarioError`; what it prints
  goes to stderr, since stdout may be carrying JSON Lines.

Built-in domains are looked up here too: :func:`resolve_domain` answers every
``agents[].domain`` with the domain and its :class:`~htnagent.domains.DomainInfo`
(what its arguments name on the map, which actions are the robot's moves).  A
user's factory carries the info it declared with ``@domain_factory(...)``; a
``Domain`` object named directly has the defaults (no argument checked against
the map; the robot's moves are :data:`~htnagent.domains.ROBOT_TRAVEL`).
"""

from __future__ import annotations

import contextlib
import importlib
import os
import sys
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import Any, NamedTuple

from htnagent.domains import BUILTIN, DomainInfo, declared_info
from htnagent.domains.maps import WorldMap
from htnagent.errors import ScenarioError, shown
from htnagent.model.domain import Domain

__all__ = ["ResolvedDomain", "resolve_domain"]


class ResolvedDomain(NamedTuple):
    """An agent's domain, built for the scenario's map, and what it declares about itself."""

    domain: Domain
    info: DomainInfo


def resolve_domain(spec: str, world: WorldMap, base_dir: Path, file: str, where: str) -> ResolvedDomain:
    """A built-in domain by name, or a user's ``package.module:attribute`` looked up from ``base_dir``.

    Every failure, the user's code's included, is a ScenarioError at ``file`` and ``where``.
    """
    builtin = BUILTIN.get(spec)
    if builtin is not None:
        return ResolvedDomain(builtin.factory(world), builtin)
    if ":" not in spec:
        raise ScenarioError(
            file,
            where,
            f"unknown domain {shown(spec)}; built-in domains are {', '.join(sorted(BUILTIN))}, "
            "or name your own as package.module:attribute",
        )
    module_name, _, attr_path = spec.partition(":")
    parts = module_name.split(".")
    if not all(p.isidentifier() for p in parts) or not all(a.isidentifier() for a in attr_path.split(".")):
        raise ScenarioError(file, where, f"{shown(spec)}: expected package.module:attribute")
    if parts[0] in sys.stdlib_module_names or parts[0] in sys.builtin_module_names:
        raise ScenarioError(
            file,
            where,
            f"{spec}: {parts[0]} is a standard-library module, not a domain; "
            "a scenario may name only your own modules and installed packages",
        )
    if "__main__" in parts:
        raise ScenarioError(file, where, f"{spec}: a __main__ module is a program, not a domain")
    target = _attribute(spec, module_name, attr_path, base_dir, file, where)
    if isinstance(target, Domain):
        return ResolvedDomain(target, DomainInfo(_as_is(target)))
    info = declared_info(target)
    if info is None:
        raise ScenarioError(
            file,
            where,
            f"{spec} is a {type(target).__name__}, not a Domain nor a function marked "
            "@htnagent.domains.domain_factory; only those are taken, so that a scenario cannot call "
            "anything else",
        )
    with _user_code(base_dir):
        try:
            built = info.factory(world)
        except BaseException as e:  # the user's factory, whatever it raises (even SystemExit)
            raise ScenarioError(file, where, f"calling {spec}(map) failed: {_one_line(e)}") from None
    if not isinstance(built, Domain):
        raise ScenarioError(file, where, f"{spec}(map) returned a {type(built).__name__}, not a Domain")
    return ResolvedDomain(built, info)


def _as_is(domain: Domain) -> Callable[[WorldMap], Domain]:
    """The factory of a domain given ready-made: whatever the map, that domain."""
    return lambda _world: domain


def _attribute(spec: str, module_name: str, attr_path: str, base_dir: Path, file: str, where: str) -> Any:
    """Import the module and walk the attribute path; every failure is a ScenarioError."""
    with _user_code(base_dir):
        try:
            module = importlib.import_module(module_name)
        except ModuleNotFoundError as e:
            if e.name is not None and module_name.startswith(e.name):
                raise ScenarioError(
                    file,
                    where,
                    f"cannot import module {module_name!r}: {e} "
                    f"(looked in {shown(str(base_dir), 80)} and the installed packages)",
                ) from None
            raise ScenarioError(file, where, f"importing {module_name!r} failed: {_one_line(e)}") from None
        except BaseException as e:  # the user's module runs its top level: anything may come out
            raise ScenarioError(file, where, f"importing {module_name!r} failed: {_one_line(e)}") from None
        target: Any = module
        for part in attr_path.split("."):
            try:
                found = hasattr(target, part)  # may run a module's __getattr__
                target = getattr(target, part) if found else None
            except BaseException as e:
                raise ScenarioError(file, where, f"looking up {spec} failed: {_one_line(e)}") from None
            if not found:
                raise ScenarioError(file, where, f"module {module_name!r} has no attribute {attr_path!r}")
    return target


@contextlib.contextmanager
def _user_code(base_dir: Path) -> Iterator[None]:
    """While user code runs: the scenario's folder first on sys.path, the cwd off it, prints to stderr."""
    saved = list(sys.path)
    folder = _real(str(base_dir))
    cwd = _real(".")
    # '' and '.' mean the current directory, and so does its full name (python -m puts it first).
    kept = [e for e in saved if _real(e or ".") not in (cwd, folder)]
    sys.path[:] = ([folder] if folder is not None else []) + kept
    importlib.invalidate_caches()  # a module written since the last import must be found
    try:
        with contextlib.redirect_stdout(sys.stderr):
            yield
    finally:
        sys.path[:] = saved


def _real(path: str) -> str | None:
    try:
        return os.path.realpath(path)
    except (OSError, ValueError):  # a folder that vanished, a name with a NUL
        return None


def _one_line(e: BaseException) -> str:
    try:
        text = " ".join(str(e).split())
    except Exception:  # an exception whose str() fails
        text = ""
    text = text if len(text) <= 200 else text[:197] + "..."
    return f"{type(e).__name__}: {text}" if text else type(e).__name__
