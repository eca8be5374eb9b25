"""Plans in the IPC HTN output format, read into values.

The format (IPC 2020, as pandaPIparser's verifier reads it)::

    ==>
    0 move a b
    1 move b c
    root 2
    2 goto c -> m-step 0 3
    3 goto c -> m-step 1 4
    4 goto c -> m-here
    <==

Anything before ``==>`` (a planner's other output) and after ``<==`` is
ignored.  Inside: the primitive actions in execution order, ``ID name
arg...``; one ``root ID...`` line; then one line per decomposed task, ``ID
task arg... -> method subtask-ID...``.  Actions and tasks may be written in
parentheses, ``0 (move a b)``.  Names are case-insensitive as in HDDL
(lowered); pandaPIparser compares them as written unless run with ``-l``.

:func:`read_plan` refuses what is not in this form -- a line that is neither,
an ID that is not a whole number or is given twice, no ``==>``, no ``root``
or no ``<==`` (a plan cut short) -- as one :class:`~htnagent.errors.HddlError`, ``FILE:LINE:COL: reason``.
Whether the plan is a *valid* one is :mod:`htnagent.hddl.check`'s business.
:func:`plan_block` finds the plan in a planner's output without reading it (a
bench times and verifies it as the planner printed it).
:func:`format_plan` writes a plan in the format, with the names spelled as the
HDDL files spell them (:func:`spellings`).
"""

from __future__ import annotations

import re
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path

from htnagent.errors import HddlError, shown
from htnagent.hddl.model import Domain, Problem
from htnagent.hddl.reader import read_file
from htnagent.model.terms import Atom

__all__ = [
    "IpcDecomposition",
    "IpcPlan",
    "IpcStep",
    "format_plan",
    "object_spellings",
    "parse_plan",
    "plan_block",
    "read_plan",
    "spellings",
]


@dataclass(frozen=True, slots=True)
class IpcStep:
    """A primitive action of the plan: ``ID name arg...``."""

    id: int
    action: Atom
    line: int = field(default=0, compare=False)


@dataclass(frozen=True, slots=True)
class IpcDecomposition:
    """A decomposed task: ``ID task arg... -> method subtask-ID...``."""

    id: int
    task: Atom
    method: str
    subtasks: tuple[int, ...]
    line: int = field(default=0, compare=False)


@dataclass(frozen=True, slots=True)
class IpcPlan:
    """A whole plan: the actions in order, the root tasks, the decompositions in file order."""

    file: str
    steps: tuple[IpcStep, ...]
    root: tuple[int, ...]
    decompositions: tuple[IpcDecomposition, ...]
    root_line: int = field(default=0, compare=False)


def read_plan(path: str | Path, max_bytes: int | None = None) -> IpcPlan:
    """The plan in the file at ``path`` (read as HDDL files are)."""
    return parse_plan(read_file(path, "plan", max_bytes), str(path))


_INT = re.compile(r"0|[1-9][0-9]{0,17}")
_WORD = re.compile(r"[^\s()]+")


def _bounds(lines: list[str]) -> tuple[int | None, int | None]:
    """The indexes of the first ``==>`` line and of the first ``<==`` line after it (None: no such line)."""
    start = next((i for i, line in enumerate(lines) if line.strip().startswith("==>")), None)
    if start is None:
        return None, None
    end = next((i for i in range(start + 1, len(lines)) if lines[i].strip().startswith("<==")), None)
    return start, end


def plan_block(text: str) -> str | None:
    """The plan in ``text`` (a planner's output), from its ``==>`` line to its ``<==`` line,
    both kept, ending in a newline; None when there is no such pair of lines."""
    lines = text.splitlines()
    start, end = _bounds(lines)
    if start is None or end is None:
        return None
    return "\n".join(lines[start : end + 1]) + "\n"


def parse_plan(text: str, file: str = "<plan>") -> IpcPlan:
    """The plan written in ``text`` (``file`` names it in messages)."""
    lines = text.splitlines()
    start, end = _bounds(lines)
    if start is None:
        raise HddlError(file, "no '==>' line; a plan in the IPC format starts with '==>'")
    steps: list[IpcStep] = []
    decompositions: list[IpcDecomposition] = []
    root: tuple[int, ...] | None = None
    root_line = 0
    ids: dict[int, int] = {}
    for i in range(start + 1, len(lines) if end is None else end):
        number = i + 1
        line = lines[i]
        stripped = line.strip()
        if not stripped or stripped.startswith(";"):
            continue
        words = [(m.group(), m.start()) for m in _WORD.finditer(line.lower())]
        if not words:
            raise HddlError(
                file, f"expected an action, root or decomposition line, got {shown(stripped)}", number, 1
            )
        if words[0][0] == "root":
            if root is not None:
                raise HddlError(file, f"a second root line (the first is line {root_line})", number, 1)
            root = tuple(_number(file, number, w, at) for w, at in words[1:])
            root_line = number
            continue
        ident = _number(file, number, *words[0])
        if ident in ids:
            raise HddlError(
                file, f"ID {ident} is given twice (first on line {ids[ident]})", number, words[0][1] + 1
            )
        ids[ident] = number
        arrow = next((k for k, (w, _) in enumerate(words) if w == "->"), None)
        if root is None:
            if arrow is not None:
                raise HddlError(
                    file, "a decomposition line before the root line", number, words[arrow][1] + 1
                )
            if len(words) < 2:
                raise HddlError(file, f"ID {ident} names no action", number, words[0][1] + 1)
            steps.append(IpcStep(ident, Atom(words[1][0], tuple(w for w, _ in words[2:])), number))
            continue
        if arrow is None:
            raise HddlError(file, "expected 'ID task args -> method subtask-IDs' (no '->')", number, 1)
        if arrow < 2:
            raise HddlError(file, f"ID {ident} names no task before '->'", number, words[arrow][1] + 1)
        if arrow + 1 >= len(words):
            raise HddlError(file, "no method after '->'", number, words[arrow][1] + 1)
        task = Atom(words[1][0], tuple(w for w, _ in words[2:arrow]))
        method = words[arrow + 1][0]
        subtasks = tuple(_number(file, number, w, at) for w, at in words[arrow + 2 :])
        decompositions.append(IpcDecomposition(ident, task, method, subtasks, number))
    if root is None:
        raise HddlError(file, "no 'root' line after the actions (it lists the root task IDs)")
    if end is None:
        raise HddlError(file, "no '<==' line after the plan; was it cut short?", len(lines))
    return IpcPlan(file, tuple(steps), root, tuple(decompositions), root_line)


def _number(file: str, line: int, word: str, at: int) -> int:
    if _INT.fullmatch(word) is None:
        raise HddlError(file, f"expected an ID (a whole number), got {shown(word)}", line, at + 1)
    return int(word)


def format_plan(
    plan: IpcPlan, spelling: Mapping[str, str] | None = None, objects: Mapping[str, str] | None = None
) -> str:
    """The plan in the IPC 2020 plan format (what :func:`parse_plan` reads), ending in a newline.

    ``spelling`` gives each (lower-case) name as the HDDL files write it (see
    :func:`spellings`), ``objects`` each object's as it is declared (see
    :func:`object_spellings`; an object ``a`` and a type ``A`` are one word to HDDL, two
    to the verifier): HDDL is case-insensitive, the IPC verifier is not.
    """
    spell = spelling or {}
    named = {**spell, **(objects or {})}

    def words(name: str, *args: object) -> str:
        return " ".join((spell.get(name, name), *(named.get(str(a), str(a)) for a in args)))

    lines = ["==>"]
    lines += [f"{s.id} {words(s.action.name, *s.action.args)}" for s in plan.steps]
    lines.append(" ".join(("root", *map(str, plan.root))))
    for d in plan.decompositions:
        tail = " ".join(map(str, d.subtasks))
        lines.append(
            f"{d.id} {words(d.task.name, *d.task.args)} -> {words(d.method)}{' ' if tail else ''}{tail}"
        )
    lines.append("<==")
    return "\n".join(lines) + "\n"


_NAME = re.compile(r";[^\n]*|[A-Za-z][A-Za-z0-9_\-]*")


def spellings(*texts: str) -> dict[str, str]:
    """Each name of the HDDL texts, lower case, to its spelling where it first appears."""
    out: dict[str, str] = {}
    for text in texts:
        for found in _NAME.finditer(text):
            word = found.group()
            if word[0] != ";":
                out.setdefault(word.lower(), word)
    return out


def object_spellings(domain: Domain, problem: Problem) -> dict[str, str]:
    """Each constant and object, lower case, to its spelling where it is declared."""
    out: dict[str, str] = {}
    for source, items in ((domain.source, domain.constants), (problem.source, problem.objects)):
        for o in items:
            text = source.text[o.at : o.at + len(o.name)]
            if text.lower() == o.name:
                out[o.name] = text
    return out
