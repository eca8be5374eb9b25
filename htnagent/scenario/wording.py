"""The one translator from a pydantic ``ValidationError`` to a :class:`~htnagent.errors.ScenarioError`.

Scenario files and map files are both checked by pydantic models
(:mod:`htnagent.scenario.schema`, :mod:`htnagent.scenario.map_file`); whatever
they refuse comes here and leaves as one line, ``FILE: key.path: reason``, in
the words of the file rather than of pydantic: ``goals[1].when.progress: must
be at most 1, got 2``; ``nodes.n1.x: expected a finite number, got 'far'``.
Only the first error is told: one line on stderr, never a list or a traceback.

The key path is pydantic's location written as the file is: ``a.b[2].c``; a
mapping's key that is refused is named by the mapping and the key.  The
location is read along the schema: the tag of a tagged union (which form of
a value was read) is not a key of the file and is left out, and for an unknown
key the reason lists the keys allowed there, read from the model (a pydantic
model or a ``TypedDict``) that the location leads to.  A schema's own error
(a ``Discriminator``'s ``custom_error_message``) is told as written.
"""

from __future__ import annotations

import difflib
import types
from collections.abc import Mapping, Sequence
from typing import (  # typing_extensions' TypedDicts too
    Annotated,
    NotRequired,
    Required,
    Union,
    get_args,
    get_origin,
    get_type_hints,
)

from pydantic import BaseModel, Discriminator, Tag, ValidationError
from pydantic_core import ErrorDetails
from typing_extensions import is_typeddict

from htnagent.errors import ScenarioError, shown

__all__ = ["ENDPOINT_PATTERN", "NAME_PATTERN", "key_path", "kind_of", "scenario_error"]

NAME_PATTERN = r"^[^(),\s\"'?]+$"
ENDPOINT_PATTERN = r"^(tcp|tls)/(\[[0-9A-Fa-f:.]+\]|[A-Za-z0-9.-]+):[0-9]{1,5}$"
"""A Zenoh endpoint: ``tcp/HOST:PORT`` or ``tls/HOST:PORT`` (an IPv6 address in brackets)."""
"""A name usable as one constant of a text form ``name(arg,...)``: what map names must match."""

_PATTERN_RULES = {
    NAME_PATTERN: "is not a valid name (no spaces, parentheses, commas, quotes or '?')",
    ENDPOINT_PATTERN: "is not an endpoint: expected tcp/HOST:PORT or tls/HOST:PORT",
}
"""How each pattern a schema uses is told to a person."""

_BOUNDS = {
    "greater_than": ("gt", "greater than"),
    "greater_than_equal": ("ge", "at least"),
    "less_than": ("lt", "less than"),
    "less_than_equal": ("le", "at most"),
}


def scenario_error(error: ValidationError, file: str, schema: object, prefix: str = "") -> ScenarioError:
    """The first error of ``error`` as a ScenarioError at ``file``, its key path under ``prefix``.

    ``schema`` is the type that was validated (a model class or a TypedDict):
    it tells which keys are allowed where a key is unknown.  ``prefix`` is where
    the validated data sits in the file (``map`` for a map written inline).
    """
    details = error.errors(include_url=False)
    detail = _misspelt(details) or details[0]
    loc, at = _walk(schema, tuple(detail["loc"]))
    if loc[-1:] == ("[key]",):
        return _refused_key(detail, file, loc[:-2], prefix)
    return ScenarioError(file, key_path(loc, prefix), _reason(detail, at))


def _misspelt(details: list[ErrorDetails]) -> ErrorDetails | None:
    """The unknown key that is a required key misspelt (``agentz`` for ``agents``), when the
    first error is that key missing: the typo is what to tell, not the key it left out."""
    first = details[0]
    if first["type"] != "missing" or not first["loc"]:
        return None
    missing = first["loc"][-1]
    for d in details[1:]:
        key = d["loc"][-1] if d["loc"] else None
        if (
            d["type"] == "extra_forbidden"
            and d["loc"][:-1] == first["loc"][:-1]
            and isinstance(key, str)
            and isinstance(missing, str)
            and difflib.get_close_matches(key, [missing], n=1)
        ):
            return d
    return None


def _refused_key(
    detail: ErrorDetails, file: str, mapping: tuple[int | str, ...], prefix: str
) -> ScenarioError:
    """A mapping's key that is not a valid name: named by the mapping, and the key when it is text."""
    key = detail.get("input")
    if detail["type"] == "string_pattern_mismatch" and isinstance(key, str):
        rule = _PATTERN_RULES.get(str((detail.get("ctx") or {}).get("pattern")), "is not a valid name")
        return ScenarioError(file, key_path((*mapping, key), prefix), f"{shown(key)} {rule}")
    if detail["type"] == "string_too_short":
        return ScenarioError(file, key_path(mapping, prefix), "a key is empty; expected a name")
    return ScenarioError(file, key_path(mapping, prefix), f"{shown(key)} is not a valid name (expected text)")


def _reason(detail: ErrorDetails, at: list[object]) -> str:
    """Why, in the words of the file; ``at`` are the types the error's location leads to."""
    kind = detail["type"]
    got = detail.get("input")
    ctx = detail.get("ctx") or {}
    if kind == "missing":
        return "required, but missing"
    if kind == "extra_forbidden":
        keys = _keys_in(at)
        if not keys:
            return "unknown key"
        key = detail["loc"][-1] if detail["loc"] else None
        close = difflib.get_close_matches(key, keys, n=1) if isinstance(key, str) else []
        guess = f"did you mean {close[0]}? " if close else ""
        return f"unknown key; {guess}expected one of {', '.join(keys)}"
    if kind in ("model_type", "dict_type", "model_attributes_type"):
        return f"expected a mapping, got {kind_of(got)}"
    if kind in ("tuple_type", "list_type"):
        return f"expected a list, got {kind_of(got)}"
    if kind == "too_short" and ctx.get("min_length") == 1:
        return "must not be empty"
    if kind in ("too_short", "too_long") and ctx.get("field_type") == "Tuple":
        wanted = ctx.get("min_length") if kind == "too_short" else ctx.get("max_length")
        return f"expected {wanted} items, got {ctx.get('actual_length')}"
    if kind == "string_type":
        if isinstance(got, int | float) and not isinstance(got, bool):
            # YAML reads 12, 1e1 and 0x1f as numbers: a name written so needs quotes.
            return f"expected text, got {shown(got)} (a number: put a name in quotes, '1e1')"
        return f"expected text, got {shown(got)}"
    if kind == "string_too_short":
        return "must not be empty"
    if kind == "string_pattern_mismatch":
        rule = _PATTERN_RULES.get(str(ctx.get("pattern")), f"must match {ctx.get('pattern')}")
        return f"{shown(got)} {rule}"
    if kind in ("float_type", "float_parsing", "finite_number"):
        return f"expected a finite number, got {shown(got)}"
    if kind in ("int_type", "int_parsing", "int_from_float"):
        return f"expected a whole number, got {shown(got)}"
    if kind in ("bool_type", "bool_parsing"):
        return f"expected true or false, got {shown(got)}"
    if kind in _BOUNDS:
        bound, words = _BOUNDS[kind]
        return f"must be {words} {_number(ctx.get(bound))}, got {shown(got)}"
    if kind == "literal_error":
        return f"expected {ctx.get('expected', 'one of the allowed values')}, got {shown(got)}"
    if kind in ("value_error", "assertion_error"):
        return str(detail["msg"]).removeprefix("Value error, ").removeprefix("Assertion failed, ")
    return f"{detail['msg']}, got {shown(got)}"


def key_path(loc: Sequence[int | str], prefix: str = "") -> str:
    """``loc`` written as in the file: ``goals[1].when``, under ``prefix`` when there is one."""
    out = prefix
    for part in loc:
        if isinstance(part, int):
            out += f"[{part}]"
        else:
            out += f".{part}" if out else str(part)
    return out


def _walk(schema: object, loc: tuple[int | str, ...]) -> tuple[tuple[int | str, ...], list[object]]:
    """``loc`` without the tags of tagged unions, and the types of the mapping holding its last part.

    For an unknown key, the types are those of the mapping the key was found in.
    """
    kept: list[int | str] = []
    here: list[object] = [schema]
    parents: list[object] = []
    for part in loc:
        members = [m for t in here for m in _tagged(t, part)]
        if members:  # which form of the value was read: not a key of the file
            here = members
            continue
        kept.append(part)
        parents = here
        here = [s for t in here for s in _step(t, part)]
    return tuple(kept), parents


def _tagged(t: object, tag: int | str) -> list[object]:
    """The member tagged ``tag`` of ``t`` if ``t`` is a tagged union (``Discriminator``), else none."""
    if get_origin(t) is not Annotated:
        return []
    inner, *metadata = get_args(t)
    if any(isinstance(m, Discriminator) for m in metadata):
        for member in get_args(inner):
            if get_origin(member) is Annotated and any(
                isinstance(m, Tag) and m.tag == tag for m in get_args(member)[1:]
            ):
                return [get_args(member)[0]]
        return []
    return _tagged(inner, tag)


def _keys_in(types_here: list[object]) -> tuple[str, ...]:
    """The keys allowed in a mapping of one of these types (none if unknown)."""
    for t in types_here:
        keys = _fields(t)
        if keys:
            return keys
    return ()


def _step(t: object, part: int | str) -> list[object]:
    """The types one step of a location leads to from ``t``."""
    origin = get_origin(t)
    if origin is Annotated:
        return _step(get_args(t)[0], part)
    if origin is Union or origin is types.UnionType:
        return [s for arg in get_args(t) for s in _step(arg, part)]
    if isinstance(t, type) and issubclass(t, BaseModel):
        field = t.model_fields.get(str(part))
        if field is None:
            return []
        # pydantic keeps a field's Annotated metadata apart: a Discriminator among it
        # makes the field a tagged union, whose tags are then left out of key paths.
        tagged = [m for m in field.metadata if isinstance(m, Discriminator)]
        return [Annotated[field.annotation, *tagged] if tagged else field.annotation]
    if is_typeddict(t):
        hints = get_type_hints(t, include_extras=True)
        return [_required_inner(hints[str(part)])] if str(part) in hints else []
    args = get_args(t)
    if origin in (dict, Mapping) and len(args) == 2:
        return [args[1]]  # the part is a key of the file's mapping
    if origin in (list, tuple, Sequence) and isinstance(part, int) and args:
        return [args[min(part, len(args) - 1)] if origin is tuple and args[-1] is not Ellipsis else args[0]]
    return []


def _required_inner(t: object) -> object:
    """``T`` of ``NotRequired[T]`` / ``Required[T]``; anything else as it is."""
    if get_origin(t) in (NotRequired, Required):
        return get_args(t)[0]
    return t


def _fields(t: object) -> tuple[str, ...]:
    origin = get_origin(t)
    if origin is Annotated:
        return _fields(get_args(t)[0])
    if origin is Union or origin is types.UnionType:
        for arg in get_args(t):
            found = _fields(arg)
            if found:
                return found
        return ()
    if isinstance(t, type) and issubclass(t, BaseModel):
        return tuple(t.model_fields)
    if is_typeddict(t):
        return tuple(get_type_hints(t))
    return ()


def kind_of(value: object) -> str:
    """What ``value`` is, in a few words of the file: ``a mapping``, ``a list``, ``text 'x'``, ``nothing``."""
    if value is None:
        return "nothing"
    if isinstance(value, Mapping):
        return "a mapping"
    if isinstance(value, list | tuple):
        return "a list"
    if isinstance(value, bool):
        return f"{value!r}".lower()
    if isinstance(value, str):
        return f"text {shown(value)}"
    return f"{type(value).__name__} {shown(value)}"


def _number(value: object) -> str:
    return f"{value:g}" if isinstance(value, float) else str(value)
