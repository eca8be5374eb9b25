"""The exceptions htnagent raises, all rooted at :class:`HtnAgentError`.

::

    HtnAgentError
    ├── TextFormError        a task, action or fact text is not ``name(arg,...)``   (also a ValueError)
    ├── DomainError          a domain definition is inconsistent (unknown variable, clash)
    ├── ScenarioError        a scenario or map file is invalid (file, key path, reason)
    ├── HddlError            an HDDL domain, problem or IPC plan file is invalid (FILE:LINE:COL: reason)
    ├── PlanningError        a task or action names something the domain cannot do
    ├── SettingsError        a setting out of range or at odds: planner, plan set, runtime,
    │                        clock, event stream, size limit (also a ValueError)
    ├── TraceFormatError     a saved trace line is not an event of ``run --json`` (also a ValueError)
    ├── PlotError            ``run --plot`` cannot draw (no matplotlib, bad file name)
    ├── RuntimeClosedError   a goal is given to a runtime that is not running
    ├── RemoteError          a remote peer is not reached at start-up, or the ``zenoh`` extra is missing
    └── UnknownNameError     an agent name or goal ticket the runtime does not have (also a KeyError)

Messages quote what they refuse with :func:`shown`, never with a bare ``repr``:
a hostile file can hold values whose ``repr`` is huge, slow or refused outright
(an integer of 5,000 digits), and one line on stderr must stay one short line.

Planning that finds no plan is a result (:class:`htnagent.planning.planner.PlanStatus`),
not an exception; exceptions are for misuse and invalid input.  Faults while
agents run (an executor that raises, hangs or crashes) become failed actions and
``agent_crashed`` trace events, not exceptions.
"""

from __future__ import annotations

import reprlib
from collections.abc import Iterator
from contextlib import contextmanager
from typing import Any


class HtnAgentError(Exception):
    """Base class of every error htnagent raises on purpose."""


class TextFormError(HtnAgentError, ValueError):
    """Raised when a text form such as ``goto(n1)`` cannot be parsed."""


class DomainError(HtnAgentError):
    """Raised when an operator, method or domain is built inconsistently."""


class ScenarioError(HtnAgentError):
    """Raised when a scenario or map file is invalid.

    ``file`` is the file, ``where`` the key path or line in it, ``reason`` what is wrong;
    ``str()`` gives the one line the CLI prints.
    """

    def __init__(self, file: str, where: str, reason: str) -> None:
        # Each part is clipped: a file name, a key or a quoted value may be as long as the file.
        self.file = _clipped(file, 512)
        self.where = _clipped(where, 300)
        self.reason = _clipped(reason, 1000)
        place = f"{self.file}: {self.where}" if self.where else self.file
        super().__init__(f"{place}: {self.reason}")


class HddlError(HtnAgentError):
    """Raised when an HDDL domain or problem, or a plan in the IPC format, is invalid.

    ``str()`` is one line, ``FILE:LINE:COL: reason`` (``FILE: reason`` when no
    place in the file is to blame, such as an empty file); ``line`` and ``col``
    count from 1.
    """

    def __init__(self, file: str, reason: str, line: int | None = None, col: int | None = None) -> None:
        self.file = _clipped(file, 512)
        self.reason = _clipped(" ".join(reason.split()), 1000)
        self.line = line
        self.col = col
        if line is None:
            place = self.file
        elif col is None:
            place = f"{self.file}:{line}"
        else:
            place = f"{self.file}:{line}:{col}"
        super().__init__(f"{place}: {self.reason}")


class PlanningError(HtnAgentError):
    """Raised when a task or action names something the domain does not know, or asks
    what its operator cannot do (suspending an action that declares no suspension)."""


class SettingsError(HtnAgentError, ValueError):
    """Raised when a setting is out of range or at odds: planner settings (``alternatives``
    below 1, say), a replanning mode a plan set does not implement, a runtime with no agent,
    a clock's speed, an event stream's room, a size limit."""


class TraceFormatError(HtnAgentError, ValueError):
    """Raised when a saved trace's line is not an event ``run --json`` writes (unknown kind,
    missing or mistyped field)."""


class PlotError(HtnAgentError):
    """Raised when the picture of a run cannot be drawn (no matplotlib, unwritable file)."""


@contextmanager
def drawing(file: str, what: str) -> Iterator[None]:
    """Turn whatever drawing ``what`` into ``file`` raises into a :class:`PlotError` naming
    the file: matplotlib may fail in ways of its own, and a run's result must survive it."""
    try:
        yield
    except PlotError:
        raise
    except Exception as e:
        raise PlotError(f"{file}: drawing {what} failed: {type(e).__name__}: {e}") from None


class _Short(reprlib.Repr):
    """``reprlib`` bounds, plus integers too long to print (Python refuses 4,300+ digits)."""

    def __init__(self, width: int) -> None:
        super().__init__()
        self.maxlevel = 3
        self.maxstring = width
        self.maxother = width
        self.maxlong = width

    def repr_int(self, x: int, level: int) -> str:
        if x.bit_length() > 200:
            digits = int(x.bit_length() * 0.30103) + 1
            return f"<a whole number of about {digits} digits>"
        return super().repr_int(x, level)

    def repr_bytes(self, x: bytes, level: int) -> str:
        return self.repr_instance(x[: 2 * self.maxother], level)  # only a slice is ever turned into text


_SHORT = _Short(60)


def shown(value: Any, width: int = 60) -> str:
    """``repr(value)`` for an error message: at most about ``width`` characters, cheap for any value.

    Containers show their first few items, long text its start; nothing is
    turned into text whole, so quoting a value costs the same however big it is.
    """
    short = _SHORT if width == 60 else _Short(width)
    try:
        text = short.repr(value)
    except Exception:  # a value whose repr fails (user objects): name its type instead
        text = f"<{type(value).__name__}>"
    return text if len(text) <= width + 3 else text[:width] + "..."


def _clipped(text: str, limit: int) -> str:
    """``text`` with its middle left out if longer than ``limit``: one error line stays readable."""
    if len(text) <= limit:
        return text
    half = (limit - 3) // 2
    return f"{text[:half]}...{text[-half:]}"


class RuntimeClosedError(HtnAgentError):
    """Raised when a goal is submitted to a runtime that is not running (not entered, or closed)."""


class RemoteError(HtnAgentError):
    """Raised when agents in other processes cannot be reached: the ``zenoh`` extra is not
    installed, an endpoint cannot be opened, or no peer serves a remote agent within the
    start-up wait.  A peer lost once running is no exception: orders fail with ``peer lost``."""


class UnknownNameError(HtnAgentError, KeyError):
    """Raised when an agent name or goal ticket is not the runtime's."""

    def __str__(self) -> str:
        return str(self.args[0]) if self.args else ""
