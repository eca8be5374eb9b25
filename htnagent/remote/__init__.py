"""Agents in other processes and on other hosts, over Eclipse Zenoh (the ``zenoh`` extra).

A parent agent reaches a child agent served by another process through a
:class:`~htnagent.remote.proxy.RemoteChild`, an executor actor standing in for
the child; ``python -m htnagent serve`` runs the child and everything below it
behind a :class:`~htnagent.system.serving.Host`.  The protocol is the in-process
one (:mod:`htnagent.runtime.messages`), as JSON (:mod:`htnagent.remote.codec`), on keys
under the scenario's namespace (:mod:`htnagent.remote.link`).  A peer that dies
or freezes is a reported failure (``peer lost``), never a hang.

Nothing outside this package imports :mod:`zenoh`, and the command line and the
simulation import this package only when a scenario names a remote agent (an
import-linter contract): without the extra, importing it raises
:class:`~htnagent.errors.RemoteError` naming the extra to install.
"""

from __future__ import annotations

from htnagent.errors import RemoteError

try:
    import zenoh  # noqa: F401  (only whether it is there)
except ImportError:
    raise RemoteError(
        "agents in other processes need the zenoh extra: pip install 'htnagent[zenoh]'"
    ) from None

__all__ = ["RemoteError"]
