"""The command line: :mod:`.launch` installs the signal handlers, :mod:`.commands` parses
and runs ``run``, ``plan``, ``check``, ``report``, ``serve``."""
