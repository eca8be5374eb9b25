"""The command line: :mod:`.launch` installs the signal handlers, :mod:`.commands` parses
and runs ``run``, ``plan``, ``check``, ``report``, ``serve``; :mod:`.hddl_plan` runs
``plan --hddl`` importing only the planner (:mod:`.common` what both share)."""
