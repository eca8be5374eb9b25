"""Total-order HDDL, the language of the IPC's HTN track: read, checked, and plans verified.

- :mod:`~htnagent.hddl.model` -- domains and problems as immutable values;
- :mod:`~htnagent.hddl.sexpr` -- the text to nested lists, with positions;
- :mod:`~htnagent.hddl.reader` -- lists to the model (:func:`read_domain`, :func:`read_problem`);
- :mod:`~htnagent.hddl.semantics` -- what must hold beyond syntax (names, arities, variables);
- :mod:`~htnagent.hddl.plan_file` -- plans in the IPC output format;
- :mod:`~htnagent.hddl.check` -- an independent plan checker (:func:`check_plan`).

Everything here is plain synchronous code over the model; it knows nothing of
the planner or the runtime (a ``lint-imports`` contract).
"""

from __future__ import annotations

from htnagent.hddl.model import Domain, Problem
from htnagent.hddl.reader import parse_domain, parse_problem, read_domain, read_problem

__all__ = ["Domain", "Problem", "parse_domain", "parse_problem", "read_domain", "read_problem"]
