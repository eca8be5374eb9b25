"""Atoms, variables and the text form ``name(arg1,arg2,...)``.

Facts, tasks and actions are all :class:`Atom` values: an immutable name and a
tuple of arguments, each argument a constant (``str``) or a nested atom
(``resume(move(n40,n35,arc59))``).  In domain definitions a constant that starts
with ``?`` is a variable.  This module parses and prints the text form of
docs/contracts.md and unifies patterns with ground atoms (SHOP-style binding).

Atoms nest at most :data:`~htnagent.limits.MAX_TERM_DEPTH` deep when parsed:
everything that walks an atom does so recursively, and a text form typed by
hand never comes near the bound.
"""

from __future__ import annotations

import re
from collections.abc import Iterable, Mapping
from typing import NamedTuple, Union

from htnagent.errors import TextFormError, shown
from htnagent.limits import MAX_TERM_DEPTH

Term = Union[str, "Atom"]
Bindings = dict[str, Term]


class Atom(NamedTuple):
    """A fact, task or action: ``name(args...)``; immutable and hashable."""

    name: str
    args: tuple[Term, ...] = ()

    def __str__(self) -> str:
        text = _TEXT.get(self)
        if text is None:
            if len(_TEXT) >= _TEXT_LIMIT:
                _TEXT.clear()
            text = self.name if not self.args else f"{self.name}({','.join(str(a) for a in self.args)})"
            _TEXT[self] = text
        return text

    def __repr__(self) -> str:
        return f"Atom({str(self)!r})"

    @property
    def is_ground(self) -> bool:
        """True when no argument, at any depth, is a variable."""
        return all((not a.startswith("?")) if isinstance(a, str) else a.is_ground for a in self.args)

    def variables(self) -> set[str]:
        """The variables of the atom, at any depth."""
        out: set[str] = set()
        for a in self.args:
            if isinstance(a, str):
                if a.startswith("?"):
                    out.add(a)
            else:
                out |= a.variables()
        return out


def is_variable(term: Term) -> bool:
    """True for a variable such as ``?x``."""
    return isinstance(term, str) and term.startswith("?")


_DELIMS = frozenset("(),")
_NAME = re.compile(r"[^(),\s\"']*")


def parse(text: str) -> Atom:
    """Parse ``name(arg,...)`` into an :class:`Atom`; raise TextFormError if malformed."""
    if not isinstance(text, str):
        raise TextFormError(f"expected text like name(arg,...), got {type(text).__name__}")
    src = text.strip()
    if not src:
        raise TextFormError("empty text; expected name(arg,...)")
    atom, pos = _parse_at(src, 0, text, 1)
    if pos != len(src):
        raise TextFormError(f"{shown(text)}: unexpected {shown(src[pos:])} after the closing parenthesis")
    return atom


def _parse_at(src: str, pos: int, whole: str, depth: int) -> tuple[Atom, int]:
    name, pos = _read_name(src, pos, whole)
    if pos >= len(src) or src[pos] != "(":
        return Atom(name), pos
    if depth > MAX_TERM_DEPTH:
        raise TextFormError(
            f"{shown(whole)}: nested more than {MAX_TERM_DEPTH} deep (at position {pos}); "
            "a text form is name(arg,...) with few levels"
        )
    pos += 1
    args: list[Term] = []
    if pos < len(src) and src[pos] == ")":
        return Atom(name), pos + 1
    while True:
        start = pos
        token, pos = _read_name(src, pos, whole)
        if pos < len(src) and src[pos] == "(":
            nested, pos = _parse_at(src, start, whole, depth + 1)
            args.append(nested)
        else:
            args.append(token)
        if pos >= len(src):
            raise TextFormError(f"{shown(whole)}: missing ')'")
        if src[pos] == ",":
            pos += 1
            continue
        if src[pos] == ")":
            return Atom(name, tuple(args)), pos + 1
        raise TextFormError(f"{shown(whole)}: unexpected {src[pos]!r} at position {pos}")


def _read_name(src: str, pos: int, whole: str) -> tuple[str, int]:
    # A regular expression, not a loop over characters: a hostile text form may be megabytes long.
    end = _NAME.match(src, pos).end()  # type: ignore[union-attr]  # matches the empty string at worst
    if end < len(src) and src[end] not in _DELIMS:
        raise TextFormError(f"{shown(whole)}: no spaces or quotes allowed in the text form (position {end})")
    if end == pos:
        raise TextFormError(f"{shown(whole)}: a name is missing at position {pos}")
    return src[pos:end], end


def atom(text: str | Atom) -> Atom:
    """Accept an atom or its text form."""
    return text if isinstance(text, Atom) else parse(text)


def atoms(items: Iterable[str | Atom]) -> tuple[Atom, ...]:
    """Parse several text forms at once."""
    return tuple(atom(i) for i in items)


def substitute(pattern: Atom, bindings: Mapping[str, Term]) -> Atom:
    """The pattern with its bound variables replaced by their values."""
    args = pattern.args
    if not args:
        return pattern
    out: list[Term] = []
    for a in args:
        if isinstance(a, str):
            out.append(bindings.get(a, a) if a[:1] == "?" else a)
        else:
            out.append(substitute(a, bindings))
    return _new_atom(Atom, (pattern.name, tuple(out)))


_new_atom = tuple.__new__

_TEXT: dict[Atom, str] = {}
"""Text forms already made: traces print the same actions again and again."""
_TEXT_LIMIT = 100_000


def unify(pattern: Atom, ground: Atom, bindings: Bindings) -> Bindings | None:
    """Match ``pattern`` against the ground atom, extending a copy of ``bindings``.

    Returns the extended bindings, or None when they do not match.
    """
    if pattern.name != ground.name or len(pattern.args) != len(ground.args):
        return None
    out = bindings
    copied = False
    for p, g in zip(pattern.args, ground.args, strict=True):
        if isinstance(p, str):
            if p.startswith("?"):
                bound = out.get(p)
                if bound is None:
                    if not copied:
                        out = dict(out)
                        copied = True
                    out[p] = g
                elif bound != g:
                    return None
            elif p != g:
                return None
        else:
            if isinstance(g, str):
                return None
            sub = unify(p, g, out)
            if sub is None:
                return None
            if sub is not out:
                out = sub
                copied = True
    return out
