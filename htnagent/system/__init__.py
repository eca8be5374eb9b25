"""Agents, executors and one clock in one task group: the embedding API (:mod:`.runtime`),
a scenario run to its summary (:mod:`.simulation`), fleets, and serving an agent to a
parent in another process (:mod:`.serving`)."""
