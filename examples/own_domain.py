"""Writing a domain in Python, planning with it, and running it on an executor of one's own.

A mail robot in a small office.  It walks between rooms (the cost of a walk is its
length in metres), picks letters up and drops them off.  A walk can be stopped half
way: the robot is then *between* two rooms, and can later finish the walk
(``resume``) or walk back (``rollback``), each costing half the walk.

1. The domain: operators with costs, a suspendable operator, and methods that read
   "when this holds, do these subtasks".
2. Planning with :func:`htnagent.plan`: a delivery, and a trip that starts half way
   along a walk (the planner chooses between resume and rollback).
3. Running it: an agent over an :class:`htnagent.Executor` written here (``Legs``), in
   simulated time.  While the robot carries a letter to the office, an urgent letter
   must go to the lab: the agent suspends its goal, the robot stops in the corridor,
   the emergency is carried out, and the first delivery resumes from where the robot is.

Run it from the repository root::

    python examples/own_domain.py
"""

from __future__ import annotations

import sys

import anyio

from htnagent import (
    ActionFailed,
    ActionOutcome,
    AgentConfig,
    Alarm,
    Atom,
    Domain,
    Effect,
    Executor,
    GoalStatus,
    Phase,
    Progress,
    Runtime,
    State,
    Suspension,
    TraceEvent,
    parse,
    plan,
)

# The office: rooms and the corridors between them, in metres (both ways).
CORRIDORS = {
    ("mailroom", "hall"): 6.0,
    ("hall", "office"): 8.0,
    ("hall", "kitchen"): 5.0,
    ("kitchen", "lab"): 7.0,
    ("office", "lab"): 4.0,
}
METRES = {**CORRIDORS, **{(b, a): m for (a, b), m in CORRIDORS.items()}}


def length(walk: Atom) -> float:
    """The metres of ``walk(A,B)`` (an operator's cost may be a function of the action)."""
    return METRES[(str(walk.args[0]), str(walk.args[1]))]


def half_length(walk: Atom) -> float:
    return length(walk) / 2


def mail_domain() -> Domain:
    d = Domain("mail")
    d.operator(
        "walk(?a,?b)",
        pre=["at(?a)", "corridor(?a,?b)"],
        add=["at(?b)"],
        delete=["at(?a)"],
        cost=length,
        # Stopped half way, the robot is between the rooms; it can finish the walk or go back.
        suspend=Suspension(
            add=("between(?a,?b)",),
            delete=("at(?a)",),
            resume=Effect(add=("at(?b)",), delete=("between(?a,?b)",), cost=half_length),
            rollback=Effect(add=("at(?a)",), delete=("between(?a,?b)",), cost=half_length),
        ),
    )
    d.operator("pick(?l,?p)", pre=["at(?p)", "lies(?l,?p)"], add=["holding(?l)"], delete=["lies(?l,?p)"])
    d.operator("drop(?l,?p)", pre=["at(?p)", "holding(?l)"], add=["lies(?l,?p)"], delete=["holding(?l)"])
    # goto(P): when the robot is at P, nothing to do; else walk a corridor and go on.
    d.method("goto(?p)", "here", when=["at(?p)"], do=[])
    d.method(
        "goto(?p)", "step", when=["not at(?p)", "at(?x)", "corridor(?x,?y)"], do=["walk(?x,?y)", "goto(?p)"]
    )
    # deliver(L,P): a letter already there needs nothing; one lying elsewhere is fetched.
    d.method("deliver(?l,?p)", "there", when=["lies(?l,?p)"], do=[])
    d.method(
        "deliver(?l,?p)",
        "fetch",
        when=["lies(?l,?from)", "not lies(?l,?p)"],
        do=["goto(?from)", "pick(?l,?from)", "goto(?p)", "drop(?l,?p)"],
    )
    d.method("deliver(?l,?p)", "carry", when=["holding(?l)"], do=["goto(?p)", "drop(?l,?p)"])
    d.facts = tuple(parse(f"corridor({a},{b})") for a, b in METRES)
    return d


def start_belief(d: Domain) -> State:
    start = ["at(mailroom)", "lies(letter,mailroom)", "lies(urgent,kitchen)"]
    return d.initial_state().updated(add=[parse(f) for f in start])


class Legs(Executor):
    """The robot: walks at 1 m/s, picks and drops in 1 s, and stops a walk when asked.

    It waits through its context's clock, so under a runtime made with a factory it
    runs in simulated time; it reports each walk's start (and stop) so that progress
    listeners (and scenario triggers) can follow it.
    """

    name = "legs"

    def __init__(self) -> None:
        self.at = "mailroom"
        self.walking: tuple[Atom, Alarm] | None = None  # the walk under way, and its end
        self.stopped: dict[Atom, float] = {}  # walks stopped half way: the fraction covered

    async def execute(self, action: Atom) -> ActionOutcome:
        if action.name == "walk":
            return await self._walk(action, action, 0.0, 1.0)
        if action.name == "rollback":  # rollback(walk(A,B)): back to A from where it stopped
            walk = action.args[0]
            assert isinstance(walk, Atom)
            return await self._walk(action, walk, self.stopped.pop(walk), 0.0)
        if action.name in ("pick", "drop"):
            await self.context.sleep(1.0)
            return ActionOutcome.SUCCESS
        raise ActionFailed(f"legs cannot do {action}")  # the agent sees this reason

    async def resume(self, action: Atom) -> ActionOutcome:
        return await self._walk(action, action, self.stopped.pop(action), 1.0)

    def can_suspend(self, action: Atom) -> bool:
        return self.walking is not None and self.walking[0] == action

    async def suspend(self, action: Atom) -> None:
        assert self.walking is not None
        self.walking[1].stop()  # the running walk wakes early, and returns SUSPENDED

    async def clear(self, action: Atom) -> None:
        self.stopped.pop(action, None)  # the agent will neither resume nor roll it back

    async def _walk(self, action: Atom, walk: Atom, start: float, end: float) -> ActionOutcome:
        """Carry out ``action``: walk from the fraction ``start`` of ``walk`` to ``end``
        (1: its far end, 0: back where it began)."""
        seconds = abs(end - start) * length(walk)
        alarm = self.context.alarm(seconds)  # rings after ``seconds`` of the runtime's time
        self.walking = (action, alarm)
        done = start if action == walk else 0.0  # a resumed walk has covered some already
        self.context.report_progress(action, Phase.STARTED, seconds, done)
        finished = await alarm.wait()  # False: stopped early by suspend
        self.walking = None
        if not finished:
            covered = (self.context.now() - alarm.started_at) / seconds if seconds else 1.0
            self.stopped[walk] = start + (end - start) * covered
            self.context.report_progress(action, Phase.STOPPED)
            return ActionOutcome.SUSPENDED
        self.at = str(walk.args[1] if end == 1.0 else walk.args[0])
        return ActionOutcome.SUCCESS


def show_plans(d: Domain) -> None:
    belief = start_belief(d)
    result = plan(d, belief, [parse("deliver(letter,office)")])
    print("deliver(letter,office):", result.status.name, result.best)
    # Half way along hall -> office, the quickest way to the kitchen starts by walking back.
    between = belief.updated(
        add=[parse("between(hall,office)"), parse("holding(letter)")],
        delete=[parse("at(mailroom)"), parse("lies(letter,mailroom)")],
    )
    result = plan(d, between, [parse("goto(kitchen)")])
    print("goto(kitchen) from half way to the office:", result.best)


async def run(d: Domain) -> int:
    legs = Legs()
    seen: list[str] = []

    def watch(event: TraceEvent) -> None:
        e = event.as_dict()
        if e["event"] in ("goal_received", "goal_suspended", "goal_resumed", "goal_finished"):
            line = f"t={e['t']:5.1f}s  {e['event']:<14} {e['goal']}"
            if e["event"] == "goal_received" and e["emergency"]:
                line += "  (emergency)"
            seen.append(e["event"])
            print(line)
        elif e["event"] == "action_started":
            print(f"t={e['t']:5.1f}s    {e['action']}")

    # A factory (clock, trace) -> executor runs it in simulated time; an Executor given
    # as it is would be taken for real hardware, and the runtime would keep wall-clock time.
    async with Runtime([AgentConfig("postbot", d, start_belief(d))], lambda clock, trace: legs) as rt:
        rt.subscribe(watch)
        tickets: list[int] = []

        def urgent_letter() -> None:
            tickets.append(rt.submit("postbot", parse("deliver(urgent,lab)"), emergency=True))

        def half_way_to_the_office(progress: Progress) -> None:
            # Called at the simulated instant the walk starts; the timer fires half way along.
            if progress.action == parse("walk(hall,office)") and progress.phase is Phase.STARTED:
                stop_listening()
                rt.clock.call_later(progress.duration / 2, urgent_letter)

        stop_listening = rt.on_progress(half_way_to_the_office)
        first = await rt.achieve("postbot", parse("deliver(letter,office)"))
        urgent = await rt.outcome(tickets[0]) if tickets else None
    print(f"the robot is at {legs.at}")
    ok = (
        first.status is GoalStatus.SUCCESS
        and urgent is not None
        and urgent.status is GoalStatus.SUCCESS
        and "goal_resumed" in seen
    )
    print("both letters delivered, the first one resumed" if ok else "something failed")
    return 0 if ok else 1


def main() -> int:
    d = mail_domain()
    show_plans(d)
    return anyio.run(run, d)


if __name__ == "__main__":
    sys.exit(main())
