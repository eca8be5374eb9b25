"""A saved trace (the output of ``run --json``) read back as typed events, trusting nothing.

The file is read as scenario files are (:func:`htnagent.scenario.read_text`:
regular files only, at most ``HTNAGENT_MAX_FILE_BYTES``, UTF-8), then line by
line: each non-blank line one JSON object that :func:`~htnagent.runtime.events.event_from_dict`
accepts, the ``summary`` event last.  Whatever is wrong is one
:class:`~htnagent.errors.TraceFormatError` naming the file, the line and the
reason (docs/contracts.md "Command line").
"""

from __future__ import annotations

import json
import math
from pathlib import Path

from htnagent.errors import ScenarioError, TraceFormatError, shown
from htnagent.runtime.events import Summary, TraceEvent, event_from_dict
from htnagent.scenario import read_text


def read_trace(path: str | Path, max_bytes: int | None = None) -> list[TraceEvent]:
    """The events of the trace file at ``path``, the summary last."""
    file = str(path)
    try:
        text = read_text(path, "trace", max_bytes)
    except ScenarioError as e:
        raise TraceFormatError(str(e)) from None
    events: list[TraceEvent] = []
    last = 0
    for number, line in enumerate(text.splitlines(), start=1):
        if not line.strip():
            continue
        if events and isinstance(events[-1], Summary):
            raise _at(file, number, "an event after the summary; expected one run's trace")
        try:
            data = json.loads(line, parse_constant=_no_constant)
        except ValueError as e:
            raise _at(file, number, f"not JSON ({e}); expected one event per line (run --json)") from None
        except RecursionError:
            raise _at(file, number, "JSON nested too deep") from None
        try:
            event = event_from_dict(data)
        except TraceFormatError as e:
            raise _at(file, number, str(e)) from None
        if not math.isfinite(event.t) or event.t < 0:
            raise _at(file, number, f"t: expected a time of 0 or more, got {shown(event.t)}")
        if events and event.t < events[-1].t:
            before = f"t: {event.t:g} is before the line above ({events[-1].t:g})"
            raise _at(file, number, f"{before}; a trace's time never runs back")
        events.append(event)
        last = number
    if not events:
        raise TraceFormatError(f"{file}: the file is empty; expected a trace of run --json")
    if not isinstance(events[-1], Summary):
        raise _at(file, last, "the trace ends without a summary event; is it a whole run --json output?")
    return events


def _no_constant(name: str) -> float:
    raise ValueError(f"{name} is no JSON number")


def _at(file: str, line: int, reason: str) -> TraceFormatError:
    return TraceFormatError(f"{file}: line {line}: {reason}")
