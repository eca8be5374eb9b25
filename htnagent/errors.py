"""The exceptions htnagent raises, all rooted at :class:`HtnAgentError`.

::

    HtnAgentError
    ├── TextFormError        a task, action or fact text is not ``name(arg,...)``
    ├── DomainError          a domain definition is inconsistent (unknown variable, clash)
    ├── ScenarioError        a scenario or map file is invalid (file, key path, reason)
    ├── PlanningError        a task names something the domain cannot do
    ├── PlotError            ``run --plot`` cannot draw (no matplotlib, bad file name)
    └── RuntimeClosedError   a goal is given to a runtime that is not running

Planning that finds no plan is a result (:class:`htnagent.planner.PlanStatus`),
not an exception; exceptions are for misuse and invalid input.  Faults while
agents run (an executor that raises, hangs or crashes) become failed actions and
``agent_crashed`` trace events, not exceptions.
"""

from __future__ import annotations


class HtnAgentError(Exception):
    """Base class of every error htnagent raises on purpose."""


class TextFormError(HtnAgentError, ValueError):
    """Raised when a text form such as ``goto(n1)`` cannot be parsed."""


class DomainError(HtnAgentError):
    """Raised when an operator, method or domain is built inconsistently."""


class ScenarioError(HtnAgentError):
    """Raised when a scenario or map file is invalid.

    ``file`` is the file, ``where`` the key path or line in it, ``reason`` what is wrong;
    ``str()`` gives the one line the CLI prints.
    """

    def __init__(self, file: str, where: str, reason: str) -> None:
        self.file = file
        self.where = where
        self.reason = reason
        place = f"{file}: {where}" if where else file
        super().__init__(f"{place}: {reason}")


class PlanningError(HtnAgentError):
    """Raised when a task names something the domain does not know."""


class PlotError(HtnAgentError):
    """Raised when the picture of a run cannot be drawn (no matplotlib, unwritable file)."""


class RuntimeClosedError(HtnAgentError):
    """Raised when a goal is submitted to a runtime that is not running (not entered, or closed)."""
