"""HDDL text to nested lists: one regular expression over the whole text, one loop.

HDDL is Lisp-like: parentheses, names and ``;`` comments to the end of the
line.  :func:`parse` lowers the text (names are case-insensitive), finds every
token with one pass of :data:`_TOKEN` and builds :class:`SList` nodes with an
explicit stack, so a file nested ``((((…`` deep is a one-line error at the
first parenthesis past :data:`~htnagent.limits.MAX_HDDL_DEPTH`, never a
RecursionError.  Positions are character offsets; lines and columns are worked
out only for a message (:meth:`htnagent.hddl.model.Source.where`), which keeps
a 4 MB problem to about a second.
"""

from __future__ import annotations

import re

from htnagent.errors import shown
from htnagent.hddl.model import Source
from htnagent.limits import MAX_HDDL_DEPTH

# Every character but white space is matched: "(" or ")", a comment, or a run of anything else.
_TOKEN = re.compile(r"[()]|;[^\n]*|[^\s();]+")


_ASCII_LOWER = {c: c + 32 for c in range(ord("A"), ord("Z") + 1)}


class SList:
    """A parenthesised list: its items (names or lists), where each starts, where it opens and closes."""

    __slots__ = ("at", "ats", "end", "items")

    def __init__(self, at: int) -> None:
        self.at = at
        self.end = at
        self.items: list[SExpr] = []
        self.ats: list[int] = []

    def __len__(self) -> int:
        return len(self.items)

    def __repr__(self) -> str:
        return f"SList({self.items!r})"


SExpr = str | SList
"""A name (any run of characters other than white space, parentheses and ``;``) or a list."""


def parse(source: Source) -> SList:
    """The top-level items of the text of ``source``, lowered, as one list (``at`` 0).

    Raises HddlError for a ``)`` that closes nothing, a ``(`` never closed, or
    nesting deeper than :data:`~htnagent.limits.MAX_HDDL_DEPTH`.
    """
    text = source.text
    # Lowering keeps every offset where it was only for ASCII ("İ".lower() is two characters);
    # names are ASCII, so other characters are left as they are, to be refused where they stand.
    text = text.lower() if text.isascii() else text.translate(_ASCII_LOWER)
    top = SList(0)
    node = top
    stack: list[SList] = []
    for m in _TOKEN.finditer(text):
        token = m.group()
        first = token[0]
        if first == "(":
            if len(stack) >= MAX_HDDL_DEPTH:
                raise source.error(m.start(), f"nested more than {MAX_HDDL_DEPTH} parentheses deep")
            child = SList(m.start())
            node.items.append(child)
            node.ats.append(child.at)
            stack.append(node)
            node = child
        elif first == ")":
            if not stack:
                raise source.error(m.start(), "this ')' closes no '('")
            node.end = m.start()
            node = stack.pop()
        elif first != ";":
            node.items.append(token)
            node.ats.append(m.start())
    if stack:
        raise source.error(node.at, "this '(' is never closed")
    return top


def text_of(item: SExpr) -> str:
    """A short quotation of ``item`` for a message."""
    if isinstance(item, str):
        return shown(item)
    return shown(_flat(item, 0))


def _flat(item: SList, depth: int) -> str:
    parts: list[str] = []
    for x in item.items[:6]:
        if isinstance(x, str):
            parts.append(x)
        else:
            parts.append("(…)" if depth > 1 else _flat(x, depth + 1))
    if len(item.items) > 6:
        parts.append("…")
    return "(" + " ".join(parts) + ")"
