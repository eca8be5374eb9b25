"""HDDL inputs for tests and benches: every problem of an IPC-style suite, its benchmark
problems, and a large generated one.

- :func:`suite_pairs` -- each folder's ``domain.hddl`` with its other ``.hddl`` files (in
  subfolders too), and feature tests named ``X.hddl`` beside ``X-domain.hddl`` (every file
  to read, as the reading tests want);
- :func:`find_problems` -- the suite's *benchmark* problems, domain by domain in natural
  order (``p2`` before ``p10``), as ``python -m bench ipc`` and ``ipc-interrupt`` attempt
  them: no subfolders, no feature tests;
- :func:`synthetic` -- a small domain and a problem of a given size (objects, facts and
  tasks in their thousands), for reading speed and limits.
"""

from __future__ import annotations

import math
import re
from collections.abc import Iterator, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Literal

__all__ = ["SuiteError", "SuiteProblem", "find_problems", "natural_key", "suite_pairs", "synthetic"]


def suite_pairs(root: Path) -> Iterator[tuple[str, Path, Path]]:
    """``(suite, domain, problem)`` for every problem under ``root``, in name order."""
    for folder in sorted(p for p in root.iterdir() if p.is_dir()):
        domain = folder / "domain.hddl"
        if domain.is_file():
            for problem in sorted(folder.rglob("*.hddl")):
                if problem != domain:
                    yield folder.name, domain, problem
            continue
        for problem in sorted(folder.glob("*.hddl")):
            paired = problem.with_name(problem.stem + "-domain.hddl")
            if not problem.stem.endswith("-domain") and paired.is_file():
                yield folder.name, paired, problem


class SuiteError(ValueError):
    """A suite that is not there or has no such domain; ``about`` says which option was wrong."""

    def __init__(self, message: str, about: Literal["suite", "domains"] = "suite") -> None:
        super().__init__(message)
        self.about = about


@dataclass(frozen=True)
class SuiteProblem:
    """A benchmark problem: its domain folder's name, its domain file and its problem file."""

    domain: str
    domain_file: Path
    problem_file: Path

    @property
    def name(self) -> str:
        return self.problem_file.name


def natural_key(name: str) -> list[int | str]:
    """``p2`` before ``p10``: digits compared as numbers."""
    return [int(part) if part.isdigit() else part.lower() for part in re.split(r"(\d+)", name)]


NOT_DOMAINS = frozenset({"feature-tests", "tests"})
"""Folders of parser tests (the IPC's ``feature-tests``), laid out as a domain whose problems
have domains of their own, but not benchmark problems."""


def find_problems(
    suite: Path, domains: Sequence[str] | None = None, first: int | None = None, picks: Sequence[int] = ()
) -> list[SuiteProblem]:
    """The suite's benchmark problems, by domain (natural order): the ``first`` of each
    (all when None) and the ``picks`` (1-based positions, e.g. the 6th and the 10th).

    A domain folder holds a ``domain.hddl``, or problems each with its ``NAME-domain.hddl``
    (Entertainment, Monroe); its problems are its other ``.hddl`` files, not those of its
    subfolders.  ``domains`` picks folders by name (any case).  A suite that is missing,
    not a folder or without domain folders, or a domain not in it: :class:`SuiteError`.
    """
    if not suite.exists():
        raise SuiteError(f"{suite}: no such folder")
    if not suite.is_dir():
        raise SuiteError(f"{suite}: not a folder")
    folders = sorted(
        (p for p in suite.iterdir() if p.is_dir() and _domain_folder(p)), key=lambda p: natural_key(p.name)
    )
    if not folders:
        raise SuiteError(f"{suite}: no domain folders (a folder with a domain.hddl) in it")
    if domains:
        known = {p.name.casefold(): p for p in folders}
        unknown = [d for d in domains if d.casefold() not in known]
        if unknown:
            raise SuiteError(
                f"no domain {', '.join(unknown)} in {suite} (there: {', '.join(p.name for p in folders)})",
                "domains",
            )
        folders = [known[d.casefold()] for d in domains]
    found: list[SuiteProblem] = []
    for folder in folders:
        files = sorted(
            (f for f in folder.glob("*.hddl") if f.is_file() and not _is_domain_file(f)),
            key=lambda f: natural_key(f.name),
        )
        if not picks:
            chosen = files[:first]
        else:
            upto = 0 if first is None else first
            chosen = [f for i, f in enumerate(files, 1) if i <= upto or i in picks]
        for f in chosen:
            own = f.with_name(f"{f.stem}-domain.hddl")
            found.append(SuiteProblem(folder.name, own if own.is_file() else folder / "domain.hddl", f))
    return found


def _is_domain_file(f: Path) -> bool:
    return f.name == "domain.hddl" or f.name.endswith("-domain.hddl")


def _domain_folder(folder: Path) -> bool:
    if folder.name.casefold() in NOT_DOMAINS:
        return False
    return (folder / "domain.hddl").is_file() or any(folder.glob("*-domain.hddl"))


def synthetic(target_bytes: int = 4_000_000) -> tuple[str, str]:
    """A small domain and a problem of about ``target_bytes``: objects, facts and tasks in their thousands."""
    domain = """(define (domain grid)
  (:requirements :typing :hierarchy :negative-preconditions)
  (:types cell robot - object)
  (:predicates (at ?r - robot ?c - cell) (adj ?a ?b - cell) (free ?c - cell) (visited ?c - cell))
  (:task visit :parameters (?r - robot ?c - cell))
  (:method m-there :parameters (?r - robot ?c - cell) :task (visit ?r ?c)
    :precondition (at ?r ?c) :ordered-subtasks ())
  (:method m-step :parameters (?r - robot ?c ?from ?next - cell) :task (visit ?r ?c)
    :precondition (and (at ?r ?from) (adj ?from ?next) (free ?next))
    :ordered-subtasks (and (move ?r ?from ?next) (visit ?r ?c)))
  (:action move :parameters (?r - robot ?a ?b - cell)
    :precondition (and (at ?r ?a) (adj ?a ?b) (free ?b))
    :effect (and (not (at ?r ?a)) (at ?r ?b) (free ?a) (not (free ?b)) (visited ?b))))
"""
    side = math.isqrt(target_bytes // 163) + 1  # each cell takes about 163 bytes
    cells = [f"cell_{x}_{y}" for x in range(side) for y in range(side)]
    parts = [
        "; generated by htnagent.testing.hddl_inputs\n(define (problem grid-big) (:domain grid)\n (:objects\n"
    ]
    parts += [f"  {c} - cell\n" for c in cells]
    parts.append("  r1 - robot)\n (:htn :parameters () :ordered-subtasks (and\n")
    parts += [f"  (t{i} (visit r1 {c}))\n" for i, c in enumerate(cells[::7])]
    parts.append(" ))\n (:init (at r1 cell_0_0)\n")
    for x in range(side):
        for y in range(side):
            here = f"cell_{x}_{y}"
            parts.append(f"  (free {here})")
            if x + 1 < side:
                parts.append(f" (adj {here} cell_{x + 1}_{y}) (adj cell_{x + 1}_{y} {here})")
            if y + 1 < side:
                parts.append(f" (adj {here} cell_{x}_{y + 1}) (adj cell_{x}_{y + 1} {here})")
            parts.append("\n")
    parts.append(" )\n (:goal (and (visited cell_1_1))))\n")
    return domain, "".join(parts)
