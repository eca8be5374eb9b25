"""``python -m htnagent``: the command line (see :mod:`htnagent.launch` and :mod:`htnagent.cli`)."""

from htnagent.launch import run

run()
