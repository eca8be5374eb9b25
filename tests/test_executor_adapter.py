"""The adapter between the message protocol and a user's :class:`Executor` (htnagent.runtime.executor).

A ``Suspend`` names an order by its ``seq`` and action.  The adapter passes it on to the
user's ``suspend`` only when that very order is running; anything else is answered
``Refused`` at once, without the user's code hearing of it:

| the Suspend names                                  | answer     | user's suspend called |
|----------------------------------------------------|------------|-----------------------|
| the running order (its seq and action)             | Suspended  | yes                   |
| an order that has already finished                 | Refused    | no                    |
| the seq of a running order, another order's action | Refused    | no                    |
| a seq no order was given                           | Refused    | no                    |

The tests speak to an :class:`AdapterActor` directly, as a parent agent would: orders into
its mailbox, answers out of a reply mailbox.  The user's executor runs each action until
the test lets it end — no sleeps, the test waits on events.
"""

from __future__ import annotations

from collections.abc import AsyncIterator
from contextlib import asynccontextmanager

import anyio

from htnagent.model.terms import Atom, atom
from htnagent.runtime.clock import Clock, Mailbox
from htnagent.runtime.executor import ActionOutcome, AdapterActor, Executor
from htnagent.runtime.messages import Execute, Message, Refused, Success, Suspend, Suspended
from htnagent.runtime.trace import Trace

GUARD = 5.0  # real seconds: a test that takes longer has hung

A = atom("go(a,b)")
B = atom("go(c,d)")
C = atom("scan(a)")


class Gated(Executor):
    """A user's executor: every action may be suspended; each runs until :meth:`finish`.

    It records every call to :meth:`suspend`.
    """

    def __init__(self) -> None:
        self.suspend_calls: list[Atom] = []
        self._started: dict[Atom, anyio.Event] = {}
        self._gates: dict[Atom, anyio.Event] = {}
        self._outcomes: dict[Atom, ActionOutcome] = {}

    def can_suspend(self, action: Atom) -> bool:
        return True

    async def execute(self, action: Atom) -> ActionOutcome:
        self._event(self._started, action).set()
        await self._event(self._gates, action).wait()
        return self._outcomes.pop(action, ActionOutcome.SUCCESS)

    async def suspend(self, action: Atom) -> None:
        self.suspend_calls.append(action)
        self.finish(action, ActionOutcome.SUSPENDED)

    def finish(self, action: Atom, outcome: ActionOutcome = ActionOutcome.SUCCESS) -> None:
        """Let the action end (now, or as soon as it starts)."""
        self._outcomes[action] = outcome
        self._event(self._gates, action).set()

    async def started(self, action: Atom) -> None:
        """Wait until the action has started."""
        await self._event(self._started, action).wait()

    @staticmethod
    def _event(events: dict[Atom, anyio.Event], action: Atom) -> anyio.Event:
        return events.setdefault(action, anyio.Event())


class Parent:
    """The adapter's parent: sends orders, reads answers."""

    def __init__(self, actor: AdapterActor, replies: Mailbox[Message]) -> None:
        self.actor = actor
        self.replies = replies
        self.answers: list[Message] = []

    def send(self, order: Message) -> None:
        self.actor.inbox.send(order)

    async def until(self, kind: type[Message], seq: int) -> list[Message]:
        """Read answers up to the first ``kind`` for ``seq``; the answers read on the way."""
        read: list[Message] = []
        while True:
            answer = await self.replies.receive()
            read.append(answer)
            self.answers.append(answer)
            if isinstance(answer, kind) and getattr(answer, "seq", None) == seq:
                return read


@asynccontextmanager
async def adapter(user: Executor) -> AsyncIterator[Parent]:
    """An AdapterActor over ``user``, running, with a parent mailbox for its answers."""
    clock = Clock()
    trace = Trace(clock)
    actor = AdapterActor("executor", clock, trace, user)
    replies: Mailbox[Message] = Mailbox(clock, "parent")
    actor.connect(replies)
    failed: Exception | None = None
    with anyio.fail_after(GUARD):
        async with anyio.create_task_group() as tg:
            await tg.start(actor.run)
            try:
                yield Parent(actor, replies)
            except Exception as exc:  # the test's own failure: out as it is, not in an ExceptionGroup
                failed = exc
            tg.cancel_scope.cancel()
    if failed is not None:
        raise failed


async def test_a_suspend_for_the_running_order_reaches_the_users_executor() -> None:
    user = Gated()
    async with adapter(user) as parent:
        parent.send(Execute(action=A, seq=1))
        await user.started(A)
        parent.send(Suspend(action=A, seq=1))
        # Expect: the user's suspend is called; the running execute answers Suspended.
        assert await parent.until(Suspended, 1) == [Suspended(action=A, seq=1)]
    assert user.suspend_calls == [A]


async def test_a_suspend_for_an_order_that_has_finished_is_refused_without_asking_the_executor() -> None:
    user = Gated()
    async with adapter(user) as parent:
        parent.send(Execute(action=A, seq=1))
        await user.started(A)
        user.finish(A)
        assert await parent.until(Success, 1) == [Success(action=A, seq=1)]
        # Order 1 is over.  A late suspend of it, then an order that ends at once: the
        # adapter handles orders in turn, so the answer to the suspend comes first.
        parent.send(Suspend(action=A, seq=1))
        user.finish(C)
        parent.send(Execute(action=C, seq=2))
        assert await parent.until(Success, 2) == [Refused(action=A, seq=1), Success(action=C, seq=2)]
    assert user.suspend_calls == []


async def test_a_suspend_whose_seq_names_another_running_order_is_refused_and_both_go_on() -> None:
    user = Gated()
    async with adapter(user) as parent:
        parent.send(Execute(action=A, seq=1))
        parent.send(Execute(action=B, seq=2))
        await user.started(A)
        await user.started(B)
        # Seq 2 is order B, not A: neither is stopped.
        parent.send(Suspend(action=A, seq=2))
        user.finish(C)
        parent.send(Execute(action=C, seq=3))
        assert await parent.until(Success, 3) == [Refused(action=A, seq=2), Success(action=C, seq=3)]
        assert user.suspend_calls == []
        # Both orders run on to their end.
        user.finish(A)
        assert await parent.until(Success, 1) == [Success(action=A, seq=1)]
        user.finish(B)
        assert await parent.until(Success, 2) == [Success(action=B, seq=2)]
    assert user.suspend_calls == []


async def test_a_suspend_for_an_order_never_given_is_refused_without_asking_the_executor() -> None:
    user = Gated()
    async with adapter(user) as parent:
        parent.send(Execute(action=A, seq=1))
        await user.started(A)
        parent.send(Suspend(action=A, seq=7))
        user.finish(C)
        parent.send(Execute(action=C, seq=2))
        assert await parent.until(Success, 2) == [Refused(action=A, seq=7), Success(action=C, seq=2)]
        user.finish(A)
        assert await parent.until(Success, 1) == [Success(action=A, seq=1)]
    assert user.suspend_calls == []
