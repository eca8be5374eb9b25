"""``python -m htnagent``: the command line (:mod:`htnagent.cli`)."""

from htnagent.cli.launch import run

run()
