"""Starting the command line: ``python -m htnagent`` and the ``htnagent`` script.

Ctrl-C or SIGTERM must end the command cleanly (exit 130, one line, no
traceback) however early or late it comes:

- ``plan --hddl`` imports only the HDDL reader and the planner (:mod:`.hddl_plan`):
  a planner is timed from its start.
- The handlers are installed first, with the standard library only, before the
  command line's heavy imports (rich, pydantic, anyio, the planner) — the
  package's ``__init__`` imports nothing heavy.  Until a run starts there is
  nothing to save, and the handler ends the process at once.
- A run installs its own handlers, which let it stop and print its summary
  (:class:`htnagent.cli.commands._RunSignals`), and keeps them to the end.
- Once the command has returned, signals are ignored: at shutdown Python would
  put the default actions back, and a late SIGTERM would kill the process
  after its result was printed.  ``plan --hddl`` then ends the process at once
  (``os._exit``), its output flushed: a search of millions of nodes would
  otherwise take seconds to free them one by one, past its ``--timeout``.
- A signal the process was started ignoring (``trap '' INT``, the background
  jobs of a non-interactive shell) stays ignored throughout, as Python leaves it.
"""

import contextlib
import os
import signal
from typing import NoReturn


def _interrupted(signum: int, frame: object) -> None:
    os.write(2, b"htnagent: interrupted\n")
    os._exit(130)  # nothing to flush or save yet; and no exception to land in half-done imports


def run() -> NoReturn:
    """Run the command line on ``sys.argv`` and exit with its code."""
    for sig in (signal.SIGINT, signal.SIGTERM):
        if signal.getsignal(sig) is not signal.SIG_IGN:
            signal.signal(sig, _interrupted)
    import sys

    # After the handlers, on purpose.  plan --hddl first: it needs none of the rest.
    from htnagent.cli.hddl_plan import fast_main

    try:
        code = fast_main(sys.argv[1:], owns_process=True)
        if code is None:
            from htnagent.cli.commands import main

            code = main(owns_process=True)
            raise SystemExit(code)
    finally:
        signal.signal(signal.SIGINT, signal.SIG_IGN)
        signal.signal(signal.SIGTERM, signal.SIG_IGN)
    # plan --hddl has printed its answer (standard output flushed, by fast_main) and has
    # nothing to save: the process ends here, its memory given back whole.  Python's own
    # shutdown would free a long search's millions of objects one by one: a second or more
    # past --timeout.
    with contextlib.suppress(AttributeError, OSError, ValueError):  # closed, or started without one
        sys.stderr.flush()
    os._exit(code)
