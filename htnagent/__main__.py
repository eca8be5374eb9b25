"""``python -m htnagent``: the command line (see :mod:`htnagent.cli`)."""

from htnagent.cli import main

raise SystemExit(main())
