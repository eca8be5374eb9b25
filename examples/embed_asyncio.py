"""Embedding htnagent under asyncio: a goal, and an emergency that arrives while it runs.

The museum of ``scenarios/museum.yaml``: a guide that plans over areas, a navigator
that plans over nodes, and a simulated robot at n40.  The guide is asked to go to
n1; half way along the robot's first move an emergency arrives (go to n28 first).
The guide suspends its goal (the robot stops on the arc), carries out the
emergency, then resumes the suspended goal and finishes it.

Run it from the repository root::

    python examples/embed_asyncio.py

Time is simulated (the runtime's clock jumps ahead whenever nothing is in flight),
so the whole story takes a fraction of a second.
"""

from __future__ import annotations

import asyncio
import sys
from pathlib import Path

from htnagent import GoalStatus, Phase, Progress, Runtime, TraceEvent, build_runtime, load_scenario, parse

MUSEUM = Path(__file__).resolve().parent.parent / "scenarios" / "museum.yaml"
TOUR = parse("goto(n1)")
EMERGENCY = parse("goto(n28)")


class Narrator:
    """A trace observer: prints what happens to one agent's goals, and notes which were resumed.

    It only watches (observers must not block, and nothing the agents do depends on them).
    """

    def __init__(self, agent: str) -> None:
        self.agent = agent
        self.resumed: list[str] = []

    def __call__(self, event: TraceEvent) -> None:
        e = event.as_dict()
        if e["agent"] != self.agent:
            return
        said = f"t={e['t']:6.1f}s  {self.agent}:"
        if e["event"] == "goal_received":
            print(said, "EMERGENCY" if e["emergency"] else "goal", e["goal"], "received")
        elif e["event"] == "goal_suspended":
            print(said, e["goal"], f"suspended (stack depth {e['stack_depth']})")
        elif e["event"] == "goal_resumed":
            self.resumed.append(str(e["goal"]))
            print(said, e["goal"], f"resumed ({e['replanning']} re-planning)")
        elif e["event"] == "goal_finished":
            print(said, e["goal"], "ended:", e["status"])


def emergency_half_way(rt: Runtime, tickets: list[int]) -> None:
    """Give the emergency half way along the robot's first move; its ticket goes in ``tickets``.

    The runtime calls progress listeners at the simulated instant a move starts, and a
    timer of its clock fires at a simulated instant too: the emergency comes at the same
    moment every run, whatever the machine's speed.  (A task awaiting ``rt.events()``
    would do as well on the wall clock, but in simulated time the clock may have moved
    on by the time that task runs.)
    """

    def give() -> None:
        tickets.append(rt.submit("guide", EMERGENCY, emergency=True))

    def listener(progress: Progress) -> None:
        if progress.actor == "robot" and progress.phase is Phase.STARTED:
            stop_listening()
            print(f"t={rt.clock.now():6.1f}s  robot: starts {progress.action} ({progress.duration:.1f} s)")
            rt.clock.call_later(progress.duration / 2, give)

    stop_listening = rt.on_progress(listener)


async def main() -> int:
    # The scenario file gives the agents, their domains and the robot; its own goals are
    # not given here: we give ours.
    runtime, _ = build_runtime(load_scenario(MUSEUM))
    narrator = Narrator("guide")
    tickets: list[int] = []
    async with runtime as rt:
        rt.subscribe(narrator)
        emergency_half_way(rt, tickets)
        tour = await rt.achieve("guide", TOUR)  # returns once the tour has ended
        if not tickets:
            print("the emergency never came")
            return 1
        emergency = await rt.outcome(tickets[0])
    resumed = str(TOUR) in narrator.resumed
    print(f"emergency {emergency.goal}: {emergency.status and emergency.status.value}")
    print(
        f"goal {tour.goal}: {'suspended, resumed' if resumed else 'never suspended'}, "
        f"{tour.status and tour.status.value}"
    )
    ok = resumed and tour.status is GoalStatus.SUCCESS and emergency.status is GoalStatus.SUCCESS
    return 0 if ok else 1


if __name__ == "__main__":
    sys.exit(asyncio.run(main()))
