"""Storms (htnagent/testing/storms.py): random museums, goals, nested emergencies, faults, doors."""

from __future__ import annotations

from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from htnagent.testing.storms import storm


@settings(max_examples=60, deadline=None, derandomize=True, suppress_health_check=[HealthCheck.too_slow])
@given(seed=st.integers(0, 10**6))
async def test_storms_keep_every_invariant(seed: int) -> None:
    result = await storm(seed)
    # Expect: every goal ends once, beliefs match the robot, no action starts against
    # the world, stacks are empty, nothing crashes, no task is left.
    assert result.violations == []
    assert result.lost == 0
    assert result.succeeded + result.failed == result.goals
