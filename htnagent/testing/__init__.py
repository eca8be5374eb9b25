"""Test oracles that ship with the library: run invariants and the differential harness.

They are used by the test suite and by ``python -m bench`` alike, and are
independent of the agents' own logic: they watch the trace and the simulated
robot's physical state, and compare with shortest paths computed here.

- :mod:`htnagent.testing.invariants` — what must hold in every run (every goal
  ends once, beliefs match the robot, nothing starts against the world,
  emergencies are served at once, a reached goal has the robot there);
- :mod:`htnagent.testing.differential` — random scenarios run in both
  replanning modes and compared;
- :mod:`htnagent.testing.storms` — random and extreme scenarios, run and checked;
- :mod:`htnagent.testing.hostile_inputs` — hostile inputs for the command line, and their judge;
- :mod:`htnagent.testing.hddl_inputs` — HDDL problems of a suite (and its benchmark
  problems, as the IPC benches attempt them), and a large generated one;
- :mod:`htnagent.testing.peer_plans` — a unified-planning plan (a peer planner's) in the IPC
  plan format;
- :mod:`htnagent.testing.emergencies` — an emergency for an HDDL problem, chosen from the
  problem (the IPC interruption benchmark's).
"""
