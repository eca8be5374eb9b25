"""TEMPORARY SHIM: removed at merge.  Revival lives in :mod:`htnagent.upkeep.revival`."""

# TEMPORARY SHIM: removed at merge.

from htnagent.upkeep.revival import Revival

__all__ = ["Revival"]
