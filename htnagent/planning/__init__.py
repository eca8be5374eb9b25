"""The planner (ALGORITHMS §1), and HDDL problems translated to the planning model and solved."""
