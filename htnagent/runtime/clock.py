"""One clock for the whole runtime, and the mailboxes whose traffic it watches.

Simulated time advances only when the runtime is idle: every message sent to a
:class:`Mailbox` counts as work until its receiver comes back for the next one,
so when nothing is in flight the clock jumps to the next timer (virtual time:
as fast as the machine allows, the same trace every run).  With a ``speed`` it
first waits for the matching wall-clock time (``speed`` simulated seconds per
real second); either way only the time keeper moves ``now``, so results do not
depend on the pace.

Timers are messages too: :meth:`Clock.call_at` delivers a message into a
mailbox at a simulated time; all the timers due at one instant are delivered
together.

Agents in other processes (:mod:`htnagent.remote`) keep wall-clock time and
keep their clocks in step through their messages: a message from a peer is
stamped with its sender's time and delivered by :meth:`Clock.call_from_peer`,
which moves this clock on to that time at once if it is behind.  An order
awaiting a peer's answer is *outside work* (:meth:`Clock.add_outside`): time
goes on meanwhile, but the runtime is not idle for good.

How this fails: a task woken by anything but a mailbox (an event, say) is not
work.  The time keeper lets the event loop run three rounds before a timer of
its own fires, so that such a task acts at the instant it was woken if it is
ready by then; a task that takes longer, or a message from a peer (handled
without those rounds: its moment is the network's), may find time moved on.
"""

from __future__ import annotations

import asyncio
import heapq
import itertools
import math
import time
from collections import deque
from collections.abc import Callable, Iterator
from dataclasses import dataclass, field
from typing import Generic, TypeVar

import anyio
import anyio.lowlevel

from htnagent.errors import SettingsError

T = TypeVar("T")


@dataclass(order=True)
class _Timer:
    when: float
    seq: int
    deliver: Callable[[], None] = field(compare=False)
    cancelled: bool = field(default=False, compare=False)
    paced: bool = field(default=True, compare=False)
    """False for a peer's message: due at once, whatever the wall clock says."""


class TimerHandle:
    """Cancels a pending timer."""

    __slots__ = ("_timer",)

    def __init__(self, timer: _Timer) -> None:
        self._timer = timer

    def cancel(self) -> None:
        """The timer will not fire (no effect if it already has)."""
        self._timer.cancelled = True


class Clock:
    """Simulated time, advanced by :meth:`keep_time` whenever the runtime is idle."""

    def __init__(self, speed: float | None = None) -> None:
        if speed is not None and not (speed > 0 and math.isfinite(speed)):
            raise SettingsError(f"speed must be a positive number, not {speed}")
        self.speed = speed
        self._now = 0.0
        self._timers: list[_Timer] = []
        self._seq = itertools.count()
        self._busy = 0
        # The running backend's own event class, looked up once: ``anyio.Event()`` looks the
        # backend up (sniffio, then anyio's table) at every call, about 4.9 us against 1 us,
        # and the runtime makes one for nearly every message a mailbox waits for and every
        # wait of its time keeper (a fleet's serving process: some 250 a robot, a museum run).
        # Outside an event loop it is anyio's adapter, which finds the backend when used.
        self.new_event: Callable[[], anyio.Event] = type(anyio.Event())
        self._idle = self.new_event()
        self._changed = self.new_event()
        self._idle_callbacks: list[Callable[[], None]] = []
        self._stopped = False
        self._quiet = self.new_event()
        self._wall: float | None = None  # paced: the wall-clock time at which ``now`` was reached
        self._outside = 0
        self._pacing = False  # the time keeper waits for the wall clock to reach a timer
        self._settled: list[Callable[[], None]] = []

    # -- time ---------------------------------------------------------------------

    def now(self) -> float:
        """The simulated time in seconds."""
        return self._now

    def call_at(self, when: float, deliver: Callable[[], None]) -> TimerHandle:
        """Run ``deliver`` (which sends a message) at simulated time ``when``."""
        timer = _Timer(max(when, self._now), next(self._seq), deliver)
        heapq.heappush(self._timers, timer)
        self._poke()
        return TimerHandle(timer)

    def call_from_peer(self, when: float, deliver: Callable[[], None]) -> TimerHandle:
        """Run ``deliver`` for a message from another process, stamped with its sender's time.

        It is handled as soon as the runtime is idle, after the timers due before
        ``when``; if this clock is behind ``when`` it moves on to it at once (the
        two clocks keep in step).  Messages from one sender keep their order.
        """
        timer = _Timer(max(when, self._now), next(self._seq), deliver, paced=False)
        heapq.heappush(self._timers, timer)
        self._poke()
        return TimerHandle(timer)

    def call_later(self, delay: float, deliver: Callable[[], None]) -> TimerHandle:
        """Run ``deliver`` after ``delay`` simulated seconds."""
        return self.call_at(self._now + max(delay, 0.0), deliver)

    async def stop(self) -> None:
        """Let time stand still from now on, and wait until no work is in flight.

        A run that has reached its end lets the messages already on their way be
        handled (a clear to a child, say) without anything new happening.
        """
        self._stopped = True
        self._poke()
        await self._quiet.wait()

    def on_idle(self, callback: Callable[[], None]) -> None:
        """Call ``callback`` whenever the runtime is idle with no timer left.

        Also when it is idle already: the time keeper looks again at once.
        """
        self._idle_callbacks.append(callback)
        self._poke()

    def when_settled(self, callback: Callable[[], None]) -> None:
        """Call ``callback`` once, as soon as the runtime is idle: everything this instant
        brought has been handled, before time moves on (or the time keeper waits)."""
        self._settled.append(callback)
        self._poke()

    # -- work accounting ------------------------------------------------------------

    def add_work(self, n: int = 1) -> None:
        """A message is in flight (or a receiver holds one)."""
        self._busy += n
        self._poke_unless_pacing()

    def done_work(self, n: int = 1) -> None:
        """A receiver finished with messages it held."""
        self._busy -= n
        assert self._busy >= 0, "work accounting went negative"
        if self._busy == 0:
            self._idle.set()
        self._poke_unless_pacing()

    def add_outside(self, n: int = 1) -> None:
        """An answer is awaited from outside the process: time goes on, but the runtime is
        not idle for good (no :meth:`on_idle` callback) until :meth:`done_outside`."""
        self._outside += n
        self._poke_unless_pacing()

    def done_outside(self, n: int = 1) -> None:
        """Answers awaited from outside came (or will never come)."""
        self._outside -= n
        assert self._outside >= 0, "outside work accounting went negative"
        self._poke()  # idle callbacks may be due now: the time keeper looks again

    def _poke(self) -> None:
        self._changed.set()

    def _renew_changed(self) -> None:
        # Before a wait: a poke from now on wakes it (an event is made only when the last
        # one was set: most waits end by a time limit, and making one costs).
        if self._changed.is_set():
            self._changed = self.new_event()

    def _poke_unless_pacing(self) -> None:
        # Work and awaited answers change nothing for a time keeper with nothing to do
        # (:meth:`_nothing_to_do`): it looks at them when its wait ends (busy: it waits for
        # idle first).  Waking it for every message (two pokes each) cost a fleet's
        # runtimes a loop round each, to no end.
        if not self._pacing:
            self._changed.set()

    def _nothing_to_do(self) -> float | None:
        """How long the time keeper has nothing to do, whether the runtime is busy or not:
        until a paced timer is due (not a peer's message), or for ever (``inf``) with no
        timer and nobody to tell that the runtime is idle; nothing settled to tell, not
        stopped.  None if it has something to do when the runtime is next idle."""
        if self._settled or self._stopped:
            return None
        while self._timers and self._timers[0].cancelled:
            heapq.heappop(self._timers)
        if not self._timers:
            return math.inf if not self._idle_callbacks or self._outside else None
        nxt = self._timers[0]
        if self.speed is None or self._wall is None or not nxt.paced:
            return None  # due now (or the wall clock not known yet: looked at when idle)
        wait = self._wall + max(nxt.when - self._now, 0.0) / self.speed - time.monotonic()
        return wait if wait > 1e-6 else None

    def _peer_next(self) -> bool:
        """Whether what is due next is a peer's message (not stopped, no idle callbacks due)."""
        while self._timers and self._timers[0].cancelled:
            heapq.heappop(self._timers)
        return not self._stopped and bool(self._timers) and not self._timers[0].paced

    async def _pace(self, wait: float) -> None:
        # Until the wall clock reaches a timer, or a poke (an earlier timer, a peer's message,
        # something settled to tell, an idle callback, an answer from outside, stop); work
        # and idleness do not poke meanwhile.
        self._renew_changed()
        self._pacing = True
        changed = self._changed
        try:
            try:
                loop = asyncio.get_running_loop()
            except RuntimeError:  # not asyncio (trio): a cancel scope's deadline ends the wait
                with anyio.move_on_after(wait):
                    await changed.wait()
                return
            # asyncio: the wall clock's turn pokes, as anything else does.  A cancel scope's
            # deadline cancelled the wait instead: a CancelledError raised through the frames
            # and caught, for every paced timer of every robot (about 30 us each; a fleet's
            # serving process paces some 30 times a robot).
            turn = None if math.isinf(wait) else loop.call_later(wait, changed.set)
            try:
                await changed.wait()
            finally:
                if turn is not None:
                    turn.cancel()
        finally:
            self._pacing = False

    async def keep_time(self) -> None:
        """Advance time forever: when idle, fire the next timer (the runtime's time keeper)."""
        while True:
            wait = self._nothing_to_do()
            if wait is not None:
                # Nothing to do before a paced timer is due (or anything pokes): whether the
                # runtime is busy or idle meanwhile does not matter, so neither wakes the
                # time keeper -- no round of checkpoints after every message, which a
                # fleet's runtimes paid for each message.  Looked at again once it is due.
                await self._pace(wait)
                continue
            if self._busy > 0:
                if self._idle.is_set():  # an event is made only when the last one was used
                    self._idle = self.new_event()
                await self._idle.wait()
                continue
            if self._settled:
                # Everything of this instant counted as work has been handled: what is to
                # be told of it (a remote link's payload) goes now, before the rounds below.
                # A task those rounds let run that still sends something at this instant
                # sends it in a payload of its own, after this one.
                settled, self._settled = self._settled, []
                for cb in settled:
                    cb()
                if self._busy > 0:
                    continue  # what they did is work: handled first
            if not self._peer_next():
                # Let tasks that are ready but have not yet picked up their work run first
                # (as soon as one has, it is work: wait for it instead).  Not before a peer's
                # message: its moment is the network's, and a task still to act at this
                # instant acts after it as if it had come a little sooner (a fleet's parent
                # ran three rounds of the event loop per message and robot, each round a
                # turn of every other robot's work).
                for _ in range(3):
                    await anyio.lowlevel.checkpoint()
                    if self._busy > 0:
                        break
                if self._busy > 0 or self._settled:
                    continue
            if self._stopped:
                self._quiet.set()  # nothing in flight, and time is to stand still
                self._renew_changed()
                await self._changed.wait()
                continue
            while self._timers and self._timers[0].cancelled:
                heapq.heappop(self._timers)
            if not self._timers:
                for cb in list(self._idle_callbacks) if not self._outside else ():
                    cb()
                if self._busy > 0 or self._timers:
                    continue
                self._renew_changed()
                await self._changed.wait()
                continue
            nxt = self._timers[0]
            if self.speed is not None and nxt.paced:
                # Paced: ``now`` was reached at wall time ``_wall``; the timer is due
                # (when - now) / speed later, however often the wait is woken meanwhile.
                if self._wall is None:
                    self._wall = time.monotonic()
                due = self._wall + max(nxt.when - self._now, 0.0) / self.speed
                wait = due - time.monotonic()
                if wait > 1e-6:
                    await self._pace(wait)
                    continue  # woken early (an earlier timer, a peer's message, stop), or due now
                self._wall = due
            heapq.heappop(self._timers)
            if nxt.cancelled:
                continue
            if not nxt.paced and nxt.when > self._now and self.speed is not None:
                self._wall = time.monotonic()  # a peer's time, reached now
            self._now = max(self._now, nxt.when)
            # Everything due at this instant is delivered together, before anyone acts on
            # any of it: two emergencies of one instant are seen together (§4).
            batch = [nxt]
            while self._timers and self._timers[0].when <= nxt.when:
                later = heapq.heappop(self._timers)
                if not later.cancelled:
                    batch.append(later)
            for timer in batch:
                timer.deliver()


class Mailbox(Generic[T]):
    """An unbounded message queue whose traffic the clock counts as work.

    A message counts from :meth:`send` until its receiver asks for the next
    one (or calls :meth:`settle`), so the clock never advances while a message
    is being handled.  One task receives; any code of the runtime may send.
    """

    def __init__(self, clock: Clock, name: str) -> None:
        self.clock = clock
        self.name = name
        self._queue: deque[T] = deque()
        self._wakeup: anyio.Event | None = None
        self._held = 0
        self.closed = False

    def send(self, message: T) -> None:
        """Queue a message (never blocks). Sending to a closed mailbox drops it."""
        if self.closed:
            return
        self.clock.add_work()
        self._queue.append(message)
        if self._wakeup is not None:
            self._wakeup.set()

    async def receive(self) -> T:
        """The next message; what was received before counts as handled.

        Raises ``anyio.EndOfStream`` once the mailbox is closed.
        """
        self.settle()
        if self._queue:
            # A message is waiting: take it at once, yielding to the other ready tasks
            # only if cancelled (they run when this receiver next waits).
            await anyio.lowlevel.checkpoint_if_cancelled()
        else:
            await anyio.lowlevel.checkpoint()
        while not self._queue:
            if self.closed:
                raise anyio.EndOfStream
            self._wakeup = self.clock.new_event()
            await self._wakeup.wait()
        self._held += 1
        return self._queue.popleft()

    def waiting(self) -> Iterator[T]:
        """The messages waiting to be received, oldest first (they stay waiting)."""
        return iter(self._queue)

    def receive_nowait(self) -> T | None:
        """The next message if one is waiting, else None (never blocks).

        What is received counts as held, like :meth:`receive`'s, until the
        receiver next blocks.
        """
        if not self._queue:
            return None
        self._held += 1
        return self._queue.popleft()

    def hand_over(self, wakeup: anyio.Event) -> None:
        """The receiver steps away; another task will receive next, once ``wakeup`` is set.

        What the receiver holds counts as handled now (it must not wait before its
        work is done), and ``wakeup`` is set as soon as a message waits — at once if
        one does — or the mailbox closes.
        """
        self.settle()
        if self._queue or self.closed:
            wakeup.set()
        else:
            self._wakeup = wakeup

    def settle(self) -> None:
        """The receiver has finished with what it holds (it will block next)."""
        if self._held:
            self.clock.done_work(self._held)
            self._held = 0

    def close(self) -> None:
        """No more messages; pending ones are dropped and their work released."""
        if self.closed:
            return
        self.closed = True
        self.settle()
        dropped = len(self._queue)
        self._queue.clear()
        if dropped:
            self.clock.done_work(dropped)
        if self._wakeup is not None:
            self._wakeup.set()
