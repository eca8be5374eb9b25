"""Reading scenario and map files without trusting them: bytes to text to plain data.

:func:`read_yaml` (or its two steps, :func:`read_text` then :func:`yaml_document`,
where the text itself is wanted too) is the only way htnagent reads a file a user
names.  It answers with plain data (dicts, lists, strings, numbers, ...) or raises one
:class:`~htnagent.errors.ScenarioError` naming the file, the line and what is
wrong -- for anything: a FIFO or a device instead of a file, a file too big, a
name too long, bytes that are not text, YAML that is invalid, nested too deep
or full of aliases that repeat each other (see :mod:`htnagent.limits`).

Why not ``yaml.load``: PyYAML builds a tree of nodes first, recursively (a
document nested 20,000 deep overflows the stack) and, in pure Python, slowly
(a 12 MB map took 90 s).  Here the parser's events (libyaml's when PyYAML has
it, else PyYAML's own parser; both are iterative) are turned into data
directly, in one loop that keeps its own stack, so the bounds are checked as
the document is read, before anything has grown.  The values are those of
``yaml.safe_load`` (the YAML 1.1 types, merge keys ``<<``), except that:

- as in YAML 1.2, ``1:30`` is a string (base 60 is not read) and ``1e9`` a float;
- a key may appear once in a mapping (PyYAML keeps the last silently);
- an alias may not name a collection that contains it (a recursive value);
- the tags ``!!set``, ``!!omap``, ``!!pairs`` and application tags are refused.

Text forms inside flow collections are mended: in ``{action:
move(n40,n35,arc59), progress: 0.5}`` YAML splits the action at its commas.
A plain value or item with more ``(`` than ``)`` is joined with the plain
pieces that follow it, comma after comma, until its parentheses balance; the
text form is then the source from its start to there.  If something else
comes first (a quoted value, a ``:``, the end of the collection), the pieces
stay as YAML read them.  Each piece is looked at once, so mending is linear.
"""

from __future__ import annotations

import re
from collections import deque
from collections.abc import Callable
from pathlib import Path
from typing import Any

import yaml
from yaml import events as ev
from yaml.constructor import SafeConstructor
from yaml.resolver import Resolver

from htnagent.errors import ScenarioError, shown
from htnagent.files import gc_paused, read_text
from htnagent.limits import (
    ALIAS_ALLOWANCE,
    ALIAS_RATIO,
    MAX_YAML_DEPTH,
    MAX_YAML_VALUES,
)

__all__ = ["gc_paused", "load_yaml_text", "read_text", "read_yaml", "yaml_document"]

# libyaml's parser when PyYAML was built with it (the usual wheels are), else the pure-Python one.
_Parser: Callable[[str], Any] = getattr(yaml, "CSafeLoader", yaml.SafeLoader)


def read_yaml(path: str | Path, what: str, max_bytes: int | None = None) -> Any:
    """The plain data of the YAML file at ``path`` (a ``what``: "scenario", "map").

    ``max_bytes`` bounds the file's size (default: :func:`~htnagent.limits.max_file_bytes`).
    An empty file is an error too: a scenario or map is never empty.
    """
    return yaml_document(read_text(path, what, max_bytes), str(path), what)


def yaml_document(text: str, file: str, what: str) -> Any:
    """The plain data of ``text``, read from ``file`` (a ``what``); an empty document is an
    error, as in :func:`read_yaml`."""
    data = load_yaml_text(text, file)
    if data is None:
        raise ScenarioError(file, "", f"the file is empty; expected a {what}")
    return data


# -- text to data --------------------------------------------------------------------

_IMPLICIT = Resolver.yaml_implicit_resolvers
_STR = "tag:yaml.org,2002:str"
_INT = "tag:yaml.org,2002:int"
_FLOAT = "tag:yaml.org,2002:float"
_BOOL = "tag:yaml.org,2002:bool"
_NULL = "tag:yaml.org,2002:null"
_MERGE = "tag:yaml.org,2002:merge"
_SEQ = "tag:yaml.org,2002:seq"
_MAP = "tag:yaml.org,2002:map"
_SCALAR_TAGS = frozenset(
    {_STR, _INT, _FLOAT, _BOOL, _NULL, "tag:yaml.org,2002:timestamp", "tag:yaml.org,2002:binary"}
)
_DECIMAL = frozenset("0123456789")
_LETTERS = frozenset("fFnN")  # the ends of .inf and .nan
_CONSTRUCTOR = SafeConstructor()


# Which plain scalars are not strings.  Those starting with a letter are a few words only;
# those starting with a digit, sign or dot go through PyYAML's own regular expressions.
_WORDS: dict[str, str] = {
    **dict.fromkeys(("yes", "Yes", "YES", "no", "No", "NO", "true", "True", "TRUE"), _BOOL),
    **dict.fromkeys(("false", "False", "FALSE", "on", "On", "ON", "off", "Off", "OFF"), _BOOL),
    **dict.fromkeys(("~", "null", "Null", "NULL", ""), _NULL),
    "<<": _MERGE,
    "=": "tag:yaml.org,2002:value",
}
_NUMERIC_START = frozenset("0123456789+-.")


_EXPONENT = re.compile(r"[-+]?(?:\.[0-9]+|[0-9]+(?:\.[0-9]*)?)[eE][-+]?[0-9]+")
"""A float YAML 1.2 reads and YAML 1.1 leaves a string (no dot: ``1e9``, ``1e-6``)."""


def _plain_tag(value: str) -> str:
    """The tag a plain scalar gets: what PyYAML's resolver says (YAML 1.1), without its cost —
    except that, as in YAML 1.2, base 60 (``1:30``) is a string and ``1e9`` a float."""
    first = value[:1]
    if first in _NUMERIC_START and first:
        for tag, pattern in _IMPLICIT[first]:
            if pattern.match(value):
                # Base 60 is read digit group by digit group, in time that grows as the
                # square of the length, and may overflow a float: YAML 1.2 dropped it.
                return _STR if tag in (_INT, _FLOAT) and ":" in value else str(tag)
        return _FLOAT if _EXPONENT.fullmatch(value) else _STR
    return _WORDS.get(value, _STR)


_SIMPLE_NUMBER = re.compile(r"[-+]?(?:(0|[1-9][0-9]{0,17})|[0-9]{1,300}\.[0-9]{0,300})")


def _number(event: Any, file: str) -> Any:
    """A plain scalar starting like a number: ``12`` and ``1.5`` at once, anything else as PyYAML would."""
    value: str = event.value
    simple = _SIMPLE_NUMBER.fullmatch(value)
    if simple is None:
        return _scalar(event, file)
    return int(value) if simple.group(1) is not None else float(value)


def _scalar(event: Any, file: str) -> Any:
    """The value of a scalar event, as ``yaml.safe_load`` would construct it."""
    value: str = event.value
    tag = event.tag
    if tag is None or tag == "!":
        if not event.implicit[0]:
            return value  # quoted, or tagged '!': a string
        tag = _plain_tag(value)
    if tag == _STR:
        return value
    if tag in (_INT, _FLOAT) and ":" in value:  # only through an explicit !!int or !!float
        reason = f"cannot read {shown(value)}: base-60 numbers are not read; write it in decimal"
        raise _at(event, file, reason)
    try:
        if tag == _INT:
            body = value[1:] if value[:1] in "+-" else value
            if body and _DECIMAL.issuperset(body) and (body == "0" or body[0] != "0"):
                return int(value)  # the common case; PyYAML's constructor handles 0x, 0o, 1_000, 1:30
        elif tag == _FLOAT:
            # The resolver has checked the form; Python reads it too, but for 1_000.5, 1:30.5, .inf, .nan.
            if "_" not in value and ":" not in value and value[-1:] not in _LETTERS:
                return float(value)
        elif tag == _NULL:
            return None
        elif tag == _BOOL:
            return SafeConstructor.bool_values[value.lower()]
        elif tag in (_MERGE, "tag:yaml.org,2002:value"):
            return value  # '<<' or '=' where no key is expected: PyYAML has no value for them either
        elif tag not in _SCALAR_TAGS:
            raise _at(event, file, f"unsupported tag {shown(tag)}; scenario files use plain YAML values")
        node = yaml.ScalarNode(tag, value, event.start_mark, event.end_mark, event.style)
        return _CONSTRUCTOR.construct_object(node, deep=True)
    except ScenarioError:
        raise
    except (ValueError, OverflowError) as e:
        if tag == _INT and "digits" in str(e):  # Python refuses to read more than 4,300 digits
            digits = sum(c.isdigit() for c in value)
            raise _at(event, file, f"a whole number of {digits:,} digits is too long") from None
        raise _at(event, file, f"cannot read {shown(value)} as {tag.rpartition(':')[2]}: {e}") from None
    except yaml.YAMLError as e:
        raise _at(event, file, f"cannot read {shown(value)}: {getattr(e, 'problem', None) or e}") from None


def _start(event: Any) -> int:
    """Where ``event`` starts in the text (a character index)."""
    return int(event.start_mark.index)


def _at(event: Any, file: str, reason: str) -> ScenarioError:
    mark = event.start_mark
    return ScenarioError(file, f"line {mark.line + 1}, column {mark.column + 1}", reason)


def load_yaml_text(text: str, file: str) -> Any:
    """The plain data of a one-document YAML text (None for an empty document).

    Raises ScenarioError at the line for invalid YAML, a duplicate key, a
    document nested more than :data:`~htnagent.limits.MAX_YAML_DEPTH` deep,
    aliases that repeat too much, and the like.
    """
    try:
        with gc_paused():
            return _build(text, file)
    except yaml.MarkedYAMLError as e:
        mark = e.problem_mark or e.context_mark
        where = f"line {mark.line + 1}, column {mark.column + 1}" if mark is not None else ""
        if e.problem is not None and "maximum nesting depth" in e.problem:
            # libyaml (PyYAML >= 6.0.3) refuses flow nesting past 1,000 levels in its own
            # words before our builder sees level MAX_YAML_DEPTH; the refusal is the same.
            raise ScenarioError(file, where, f"nested more than {MAX_YAML_DEPTH} levels deep") from None
        if mark is not None and (tab := _tab_indenting(text, mark.line)) is not None:
            raise ScenarioError(
                file,
                f"line {mark.line + 1}, column {tab + 1}",
                "a tab character is not allowed for indentation in YAML; use spaces",
            ) from None
        reason = e.problem or e.context or "invalid YAML"
        if e.context and e.context_mark is not None and e.problem:
            reason += f" ({e.context} at line {e.context_mark.line + 1})"
        raise ScenarioError(file, where, f"invalid YAML: {reason}") from None
    except yaml.reader.ReaderError as e:
        where = _line_of_offset(text, e.position, _Parser is not yaml.SafeLoader)
        char = f"#x{e.character:04x}" if isinstance(e.character, int) else shown(e.character)
        raise ScenarioError(file, where, f"invalid YAML: unacceptable character {char}: {e.reason}") from None
    except yaml.YAMLError as e:
        raise ScenarioError(file, "", f"invalid YAML: {' '.join(str(e).split())}") from None
    except UnicodeEncodeError as e:  # lone surrogates (only from text not read from a file)
        raise ScenarioError(file, "", f"not valid Unicode text at character {e.start}") from None
    except MemoryError:
        raise ScenarioError(file, "", "ran out of memory reading it; the file is too big") from None
    except RecursionError:  # cannot be (the loop keeps its own stack); said plainly all the same
        raise ScenarioError(file, "", "too deeply nested to read") from None


_YAML_LINE_BREAK = re.compile("\r\n|[\r\n\x85\u2028\u2029]")
"""What YAML 1.1 counts as a line break (not str.splitlines's form feeds and the like)."""


def _tab_indenting(text: str, line: int) -> int | None:
    """The column of a tab in the indentation of ``line`` (0-based), if there is one: YAML
    refuses tabs there in the parser's words ("cannot start any token", "violates
    indentation"), and a person needs to hear the cause."""
    lines = _YAML_LINE_BREAK.split(text)
    if not 0 <= line < len(lines):
        return None
    row = lines[line]
    indent = row[: len(row) - len(row.lstrip(" \t"))]
    return indent.index("\t") if "\t" in indent else None


def _line_of_offset(text: str, offset: int, in_bytes: bool) -> str:
    """``line L`` of a reader error's offset (libyaml counts UTF-8 bytes, PyYAML characters)."""
    if offset < 0:
        return ""
    head = text.encode("utf-8", "replace")[:offset] if in_bytes else text[:offset].encode("utf-8", "replace")
    newline = b"\n"
    return f"line {head.count(newline) + 1}"


def _build(text: str, file: str) -> Any:
    parser = _Parser(text)
    try:
        return _Builder(text, file).run(parser.get_event)
    finally:
        parser.dispose()


_NO_KEY: Any = object()
_PIECE: Any = object()  # a key that was a piece of a mended text form: its pair is dropped
_BREAKS = re.compile(r"[{}\[\]:\n\0]")


class _Collection:
    """A list or mapping being read, with what reading it needs to remember."""

    __slots__ = (
        "anchor",
        "count0",
        "flow",
        "is_map",
        "key",
        "key_event",
        "lines",
        "mend",
        "merges",
        "no_mend_before",
        "value",
    )

    def __init__(self, value: list[Any] | dict[Any, Any], event: Any, count: int) -> None:
        self.value: Any = value
        self.is_map = isinstance(value, dict)
        self.anchor: str | None = event.anchor
        self.flow = bool(event.flow_style)
        self.count0 = count  # values counted before this one's content: its size is the difference
        self.key: Any = _NO_KEY  # a mapping's key waiting for its value
        self.key_event: Any = None
        self.lines: dict[Any, int] = {}  # a mapping's keys -> the line each was first written on
        self.merges: list[dict[Any, Any]] | None = None  # '<<' values, weakest first
        self.mend: _Mend | None = None  # a text form being put back together
        self.no_mend_before = -1  # pieces of a text form that could not be mended stay as they are


class _Mend:
    """A text form cut at flow commas, being read on: its pieces so far and its open parentheses."""

    __slots__ = ("depth", "end", "events", "expect_key", "start")

    def __init__(self, event: Any, depth: int, in_map: bool) -> None:
        self.events = [event]
        self.depth = depth
        self.start: int = event.start_mark.index
        self.end: int = event.end_mark.index
        self.expect_key = in_map  # in a mapping the pieces are key, value, key, ...


class _Builder:
    """Turns parser events into data, checking the bounds on the way (one pass, no recursion).

    Every value is counted once where it is written and again, in full, each
    time an alias repeats it; ``count`` is the running total, so the size of a
    collection (what an alias to it repeats) is the count it adds.
    """

    def __init__(self, text: str, file: str) -> None:
        self.text = text
        self.file = file
        self.stack: list[_Collection] = []
        self.anchors: dict[str, tuple[Any, int]] = {}
        self.open_anchors: set[str] = set()
        self.count = 0  # values so far, repeats included
        self.repeated = 0  # of which repeats through aliases
        self.replay: deque[Any] = deque()  # events read ahead by a text form that did not close

    def run(self, get_event: Callable[[], Any]) -> Any:
        # The hot loop: a big map is millions of events.  The current collection's
        # container and pending key live in local variables (written back to its
        # _Collection only around the rare cases handled by the other methods).
        stack, replay, file = self.stack, self.replay, self.file
        scalar_event, alias_event = ev.ScalarEvent, ev.AliasEvent
        mapping_start, sequence_start = ev.MappingStartEvent, ev.SequenceStartEvent
        mapping_end, sequence_end = ev.MappingEndEvent, ev.SequenceEndEvent
        numeric_start, words, no_key = _NUMERIC_START, _WORDS, _NO_KEY
        root: Any = None
        documents = 0
        top: _Collection | None = None
        container: Any = None  # top.value
        lines: dict[Any, int] = {}  # top.lines
        key: Any = no_key  # top.key
        key_event: Any = None  # top.key_event
        is_map = flow = False  # top.is_map, top.flow
        while True:
            event = replay.popleft() if replay else get_event()
            kind = type(event)
            # In a flow collection, a text form cut at commas may start or go on here.
            if (
                flow
                and top is not None
                and (top.mend is not None or (kind is scalar_event and "(" in event.value))
            ):
                top.key, top.key_event = key, key_event
                if top.mend is not None:
                    self._mend_step(top, event)
                    key, key_event = top.key, top.key_event
                    continue
                if self._mend_begins(top, event):
                    self.count += 1
                    continue
            if kind is scalar_event:
                self.count += 1
                value = event.value
                # A plain word needs no more work; a million of them make a big map.
                if event.tag is not None or not event.implicit[0] or value in words:
                    value = _scalar(event, file)
                elif value[:1] in numeric_start:
                    value = _number(event, file)
                if event.anchor is not None:
                    self.anchors[event.anchor] = (value, 1)
                if not self.count & 0xFFFF:
                    self._check_count(event)
            elif kind is mapping_start or kind is sequence_start:
                if top is not None:
                    top.key, top.key_event = key, key_event
                top = self._open(event, kind is mapping_start)
                container, lines, is_map, flow = top.value, top.lines, top.is_map, top.flow
                key, key_event = no_key, None
                continue
            elif kind is mapping_end or kind is sequence_end:
                assert top is not None
                top.key = key
                value = self._close()
                top = stack[-1] if stack else None
                if top is not None:
                    container, lines, is_map, flow = top.value, top.lines, top.is_map, top.flow
                    key, key_event = top.key, top.key_event
                else:
                    is_map = flow = False
            elif kind is alias_event:
                value = self._alias(event)
            elif kind is ev.DocumentStartEvent:
                documents += 1
                if documents > 1:
                    raise _at(event, file, "a second YAML document (after ---); a file holds one document")
                continue
            elif kind is ev.StreamEndEvent:
                return root
            else:  # stream start, document end
                continue
            if top is None:
                root = value
            elif not is_map:
                container.append(value)
            elif key is no_key:
                key, key_event = value, event
            elif type(key) is str and key not in container and key != "<<":
                # The commonest pair, a new text key; _put handles every other.
                lines[key] = key_event.start_mark.line + 1
                container[key] = value
                key = no_key
            else:
                top.key, top.key_event = key, key_event
                self._put(top, value)
                key = top.key

    # -- collections ----------------------------------------------------------------

    def _check_count(self, event: Any) -> None:
        if self.count > MAX_YAML_VALUES:
            raise _at(event, self.file, f"more than {MAX_YAML_VALUES:,} values; too big a document")

    def _open(self, event: Any, is_map: bool) -> _Collection:
        self.count += 1
        if self.count > MAX_YAML_VALUES:
            self._check_count(event)
        if len(self.stack) >= MAX_YAML_DEPTH:
            raise _at(event, self.file, f"nested more than {MAX_YAML_DEPTH} levels deep")
        tag = event.tag
        if tag is not None and tag not in ("!", _MAP if is_map else _SEQ):
            what = "a mapping" if is_map else "a list"
            raise _at(event, self.file, f"unsupported tag {shown(tag)} on {what}; use plain YAML")
        frame = _Collection({} if is_map else [], event, self.count)
        if frame.anchor is not None:
            self.open_anchors.add(frame.anchor)
        self.stack.append(frame)
        return frame

    def _close(self) -> Any:
        frame = self.stack.pop()
        value = frame.value
        if frame.mend is not None:  # cannot be: the end event fails the text form first
            raise AssertionError("a text form left open")
        if frame.key is not _NO_KEY:  # cannot be: YAML gives every key a value
            raise AssertionError("a key left without a value")
        if frame.merges:
            merged: dict[Any, Any] = {}
            for m in frame.merges:
                merged.update(m)
            merged.update(value)
            value = merged
        if frame.anchor is not None:
            self.open_anchors.discard(frame.anchor)
            self.anchors[frame.anchor] = (value, self.count - frame.count0 + 1)
        return value

    def _alias(self, event: Any) -> Any:
        name = event.anchor
        if name in self.open_anchors:
            raise _at(event, self.file, f"the alias *{name} is inside the value it names (a recursive value)")
        found = self.anchors.get(name)
        if found is None:
            raise _at(event, self.file, f"the alias *{name} names no anchor &{name} before it")
        value, size = found
        self.count += size
        self.repeated += size
        allowed = max(ALIAS_ALLOWANCE, ALIAS_RATIO * (self.count - self.repeated))
        if self.repeated > allowed:
            raise _at(
                event,
                self.file,
                f"aliases repeat more than {allowed:,} values (an alias bomb?); write the values out instead",
            )
        self._check_count(event)
        return value

    def _put(self, top: _Collection, value: Any) -> None:
        """Store a mapping's pair: refuse duplicate and unhashable keys, collect merges."""
        key, key_event = top.key, top.key_event
        top.key = _NO_KEY
        if key is _PIECE:
            return
        if (
            key == "<<"
            and type(key_event) is ev.ScalarEvent
            and key_event.tag is None
            and not key_event.style
        ):
            self._merge(top, value, key_event)
            return
        if isinstance(key, dict | list):
            raise _at(key_event, self.file, "a mapping key must be a single value, not a list or mapping")
        try:
            first = top.lines.get(key)
        except TypeError:  # unhashable
            raise _at(key_event, self.file, f"{shown(key)} cannot be a mapping key") from None
        if first is not None:
            raise _at(key_event, self.file, f"duplicate key {shown(key)} (first at line {first})")
        top.lines[key] = key_event.start_mark.line + 1
        top.value[key] = value

    def _merge(self, top: _Collection, value: Any, key_event: Any) -> None:
        """``<<: *base`` or ``<<: [*a, *b]``: keys written in the mapping win, then the earlier merge."""
        merges = top.merges if top.merges is not None else []
        if isinstance(value, dict):
            merges.append(value)
        elif isinstance(value, list) and all(isinstance(m, dict) for m in value):
            merges.extend(reversed(value))
        else:
            raise _at(key_event, self.file, "a merge key (<<) takes a mapping or a list of mappings")
        top.merges = merges

    # -- text forms cut at flow commas ----------------------------------------------

    def _mend_begins(self, top: _Collection, event: Any) -> bool:
        """Start mending if ``event`` (in a flow collection) opens more parentheses than it closes."""
        value: str = event.value
        if (
            event.style
            or event.tag is not None
            or event.anchor is not None
            or (top.is_map and top.key is _NO_KEY)  # only values and items are text forms
            or event.start_mark.index < top.no_mend_before
        ):
            return False
        depth = value.count("(") - value.count(")")
        if depth <= 0:
            return False
        top.mend = _Mend(event, depth, top.is_map)
        return True

    def _mend_step(self, top: _Collection, event: Any) -> None:
        """Take the next event while a text form is open; store the text form once it closes."""
        mend = top.mend
        assert mend is not None
        piece = (
            type(event) is ev.ScalarEvent
            and not event.style
            and event.tag is None
            and event.anchor is None
            and _BREAKS.search(self.text, mend.end, _start(event)) is None
        )
        if not piece:
            # The parentheses never closed: the pieces stay as YAML read them, read again.
            top.mend = None
            top.no_mend_before = event.start_mark.index
            first, *rest = mend.events
            self.count -= len(rest)
            self.replay.extendleft(reversed([*rest, event]))
            self._store(top, _scalar(first, self.file), first)
            return
        self.count += 1
        closing_key = top.is_map and mend.expect_key
        if top.is_map:
            mend.expect_key = not mend.expect_key
        mend.events.append(event)
        if event.value:
            mend.depth += event.value.count("(") - event.value.count(")")
            mend.end = event.end_mark.index
        if mend.depth > 0:
            return
        top.mend = None
        self._store(top, self.text[mend.start : mend.end], event)
        if closing_key:
            top.key = _PIECE  # its (empty) value comes next, and goes with it

    def _store(self, top: _Collection, value: Any, event: Any) -> None:
        """A value or item of ``top`` (never a key: text forms are values)."""
        if top.is_map:
            self._put(top, value)
        else:
            top.value.append(value)
