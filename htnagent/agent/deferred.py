"""Upkeep that waits until the agent's next order is on its way (§4, Algorithm 3).

Keeping the stacked goals' plans valid must not delay the agent's reaction: "whatever
keeps the suspended plans valid may run after the emergency's first action has been
sent".  :class:`DeferredUpkeep` holds that work:

- the stacked goals' plan updates (§2, and Algorithm 1 for a goal being suspended),
  queued in event order — the running goal's own update is never deferred, its next
  action is chosen from it;
- what is spent (plans a resumption replaced, goals that ended, held goals the parent
  cleared): letting go of plans kept for long frees every step and record only they
  held, which is work too.

The agent runs the queue (:meth:`DeferredUpkeep.run`) once its next order has passed
down to the robot, when it has nothing to do but wait for a message, and just before a
stacked goal resumes (its plans must be up to date then); it lets go of what is spent
once the next order is on its way (:meth:`DeferredUpkeep.let_go`).
"""

from __future__ import annotations

from collections import deque
from collections.abc import Callable

_SPENT_BOUND = 64
"""Goals may end one after another with no order between: let go of them in batches."""


class DeferredUpkeep:
    """Work kept off the critical path: queued plan updates and spent objects."""

    def __init__(self) -> None:
        self._queue: deque[Callable[[], None]] = deque()
        self._spent: list[object] = []

    @property
    def waiting(self) -> int:
        """How many plan updates wait to be run."""
        return len(self._queue)

    @property
    def kept(self) -> int:
        """How many spent objects are held, to be let go of."""
        return len(self._spent)

    @property
    def pending(self) -> bool:
        """Whether anything waits: updates to run or objects to let go of."""
        return bool(self._queue or self._spent)

    def defer(self, update: Callable[[], None]) -> None:
        """Run ``update`` later, after the updates deferred before it."""
        self._queue.append(update)

    def run(self) -> None:
        """Run the waiting updates, oldest first."""
        queue = self._queue
        while queue:
            queue.popleft()()

    def keep_until_sent(self, spent: object) -> None:
        """Hold on to ``spent`` until the next order is on its way, and let go of it then."""
        if len(self._spent) >= _SPENT_BOUND:
            self._spent.clear()
        self._spent.append(spent)

    def let_go(self) -> None:
        """Let go of what is spent (the next order is on its way, or nothing is to do)."""
        self._spent.clear()
