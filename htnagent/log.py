"""The package's logger, ``htnagent``, with a library's ``NullHandler`` on it (what to show
is the application's choice).  Only the modules that log import it, so that a command
that never logs (``plan --hddl``) does not import :mod:`logging` at all."""

from __future__ import annotations

import logging

_LOG = logging.getLogger("htnagent")
if not any(isinstance(h, logging.NullHandler) for h in _LOG.handlers):
    _LOG.addHandler(logging.NullHandler())


def library_log() -> logging.Logger:
    """The ``htnagent`` logger."""
    return _LOG


__all__ = ["library_log"]
