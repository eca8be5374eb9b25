"""How much input htnagent accepts: the bounds that keep hostile files from hurting.

A scenario or map file may come from anyone, so reading it must stay cheap in
time and memory whatever it holds, and every refusal must be one clear line
(docs/contracts.md "Command line").  The bounds sit far above anything a real
scenario needs; each is named here, with why it is what it is, so that a
refusal can say which bound was hit.

Only the file-size bound can be changed from outside (a keyword of
:func:`~htnagent.scenario.load_scenario`, or the environment variable
``HTNAGENT_MAX_FILE_BYTES``); the others guard recursion and arithmetic, where
a larger value would only bring the crash back.

This module imports nothing but the standard library, so anything may use it.
"""

from __future__ import annotations

import os

from htnagent.errors import ScenarioError, SettingsError

MAX_FILE_BYTES = 64 * 1024 * 1024
"""Default largest scenario or map file read, in bytes (64 MiB).

A generated map of 100,000 nodes is about 12 MB; 64 MiB leaves room for five
times that while keeping the memory of loading it well under a gigabyte.
"""

MAX_FILE_BYTES_ENV = "HTNAGENT_MAX_FILE_BYTES"
"""The environment variable that overrides :data:`MAX_FILE_BYTES`."""

MAX_YAML_DEPTH = 100
"""Deepest nesting of YAML collections (lists and mappings) in a file.

A scenario nests five levels deep at most; the bound stops a document of
``[[[[…`` from exhausting the stack of whatever walks the data afterwards.
"""

MAX_YAML_VALUES = 8_000_000
"""Most values (scalars and collections, counting repeats through aliases) in one file.

The 100,000-node map holds about 1.5 million; at the file-size bound a
document of tiny values (``- {}`` lines) would otherwise build some 13 million
Python objects, past a gigabyte.
"""

ALIAS_ALLOWANCE = 10_000
"""How many values aliases may repeat, at least (see :data:`ALIAS_RATIO`).

A YAML alias (``*name``) stands for the whole value its anchor names; ten
nested levels of ten aliases ("billion laughs") stand for 10^10 values in a
few hundred bytes.  Everything that later walks the data (validation, error
messages) pays for the repeats, so they are bounded.
"""

ALIAS_RATIO = 1
"""Aliases may repeat at most this many times as many values as the file writes out."""

MAX_GOALS = 100_000
"""Most goals a scenario may give.  Each becomes a checked record, a ticket and a trace of its
own: at this bound a scenario takes some 150 MB; 1.5 million goals (a 50 MB file) took 1.8 GB."""

MAX_EVENTS = 100_000
"""Most world events (doors shut and opened, facts changed) a scenario may give, for the same reason."""

MAX_TERM_DEPTH = 32
"""Deepest nesting of a text form such as ``resume(move(n40,n35,arc59))`` (depth 2).

Atoms are walked recursively (printing, unification, ground checks), so a
bound far below Python's recursion limit keeps every such walk safe.
"""

MAX_HDDL_DEPTH = 100
"""Deepest nesting of parentheses in an HDDL file.

The IPC domains nest about ten levels (a ``forall`` in a ``not`` in an
``and`` in an action); formulas are read and evaluated recursively, so a bound
far below Python's recursion limit keeps ``((((…`` a one-line error.
"""

MAX_COORDINATE = 1e9
"""Largest absolute map coordinate, in metres: distances between nodes stay finite."""

MAX_ARC_LENGTH = 1e10
"""Longest arc a map may give explicitly, in metres (costs add up without overflowing)."""

MAX_SECONDS = 1e12
"""Longest simulated time a scenario may name (a duration, a timeout, a trigger time): some 30,000
years, and sums of such times stay finite (JSON has no infinity)."""

MIN_SPEED = 1e-6
"""Slowest pace accepted (``run --speed``, ``robot.speed``): slower, time would barely move."""

MAX_SPEED = 1e9
"""Fastest pace accepted: faster, durations would vanish below the clock's resolution."""

MAX_PAYLOAD_BYTES = 1024 * 1024
"""Largest message a remote agent's link accepts (a museum run's largest is a few KiB): a
bigger one is refused (``peer_refused``) before it is parsed."""


def max_file_bytes(override: int | None = None) -> int:
    """The file-size bound: ``override`` if given, else the environment's, else :data:`MAX_FILE_BYTES`."""
    if override is not None:
        if isinstance(override, bool) or not isinstance(override, int) or override < 1:
            raise SettingsError(f"max_file_bytes must be a positive whole number, not {override!r}")
        return override
    text = os.environ.get(MAX_FILE_BYTES_ENV)
    if text is None or not text.strip():
        return MAX_FILE_BYTES
    value = text.strip().replace("_", "")
    if not (value.isascii() and value.isdigit()) or len(value) > 18 or int(value) < 1:
        shown = text if len(text) <= 40 else text[:37] + "..."
        raise ScenarioError(
            MAX_FILE_BYTES_ENV, "", f"expected a positive whole number of bytes, got {shown!r}"
        )
    return int(value)
