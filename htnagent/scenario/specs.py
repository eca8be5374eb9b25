"""What the scenario file's models are built from: the frozen base model and the value
types several parts of the file share (a name, a task written ``name(arg,...)``).

Below :mod:`htnagent.scenario.schema` and :mod:`htnagent.scenario.hddl_agent`, which
both build on it.
"""

from __future__ import annotations

from typing import Annotated

from pydantic import BaseModel, ConfigDict, Field, PlainSerializer, PlainValidator

from htnagent.errors import TextFormError
from htnagent.model.terms import Atom, parse

__all__ = ["Name", "Spec", "TextForm", "parse_text_form"]


class Spec(BaseModel):
    """A part of the file: frozen, and no key but those declared.

    Its lists and mappings stop at their first bad item (``fail_fast``): only
    the first error is told, and a file of a million bad goals must not make a
    million errors first.
    """

    model_config = ConfigDict(frozen=True, extra="forbid")


def parse_text_form(value: object) -> Atom:
    """A task or action as the file writes it (``name(arg,...)``); TextFormError if it is not one."""
    if isinstance(value, Atom):
        return value
    if isinstance(value, str):
        return parse(value)  # a TextFormError is a ValueError: pydantic reports it at the key
    raise TextFormError(f"expected text like name(arg,...), got {type(value).__name__}")


TextForm = Annotated[Atom, PlainValidator(parse_text_form), PlainSerializer(str)]
"""A task or action written ``name(arg,...)`` in the file, held as an :class:`Atom`."""

Name = Annotated[str, Field(min_length=1)]
