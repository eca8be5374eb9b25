"""What agents and executors are made of: messages, the clock and mailboxes, trace events,
progress signals, and the executor interface.  The agent (:mod:`htnagent.agent`) and the
system that runs agents together (:mod:`htnagent.system`) sit on top."""
