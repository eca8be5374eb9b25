"""Embedding htnagent under trio: a goal, and an emergency that arrives while it runs.

The same story as ``embed_asyncio.py`` (the runtime is written on anyio, so it runs
under either): the museum's guide is asked to go to n1, an emergency (go to n28)
arrives half way along the robot's first move, the guide suspends its goal, carries
out the emergency and resumes the goal to its end.  Here a task of our own reads
the runtime's event stream and tells the story as it goes.

Run it from the repository root::

    python examples/embed_trio.py
"""

from __future__ import annotations

import sys
from pathlib import Path

import trio

from htnagent import EventStream, GoalStatus, Phase, Progress, Runtime, build_runtime, load_scenario, parse

MUSEUM = Path(__file__).resolve().parent.parent / "scenarios" / "museum.yaml"
TOUR = parse("goto(n1)")
EMERGENCY = parse("goto(n28)")


async def narrate(stream: EventStream, agent: str, resumed: list[str]) -> None:
    """Print what happens to ``agent``'s goals; note in ``resumed`` the goals it resumed.

    The stream ends by itself when the runtime closes.  A reader only watches: the
    agents never wait for it (one that falls far behind is told how many events it lost).
    """
    async with stream:
        async for event in stream:
            e = event.as_dict()
            if e["agent"] != agent:
                continue
            said = f"t={e['t']:6.1f}s  {agent}:"
            if e["event"] == "goal_received":
                print(said, "EMERGENCY" if e["emergency"] else "goal", e["goal"], "received")
            elif e["event"] == "goal_suspended":
                print(said, e["goal"], f"suspended (stack depth {e['stack_depth']})")
            elif e["event"] == "goal_resumed":
                resumed.append(str(e["goal"]))
                print(said, e["goal"], f"resumed ({e['replanning']} re-planning)")
            elif e["event"] == "goal_finished":
                print(said, e["goal"], "ended:", e["status"])


def emergency_half_way(rt: Runtime, tickets: list[int]) -> None:
    """Give the emergency half way along the robot's first move; its ticket goes in ``tickets``.

    Progress listeners and the clock's timers run at a simulated instant, so the
    emergency comes at the same moment every run (a task would wake too late: in
    simulated time the clock may move on before it runs).
    """

    def give() -> None:
        tickets.append(rt.submit("guide", EMERGENCY, emergency=True))

    def listener(progress: Progress) -> None:
        if progress.actor == "robot" and progress.phase is Phase.STARTED:
            stop_listening()
            rt.clock.call_later(progress.duration / 2, give)

    stop_listening = rt.on_progress(listener)


async def main() -> int:
    runtime, _ = build_runtime(load_scenario(MUSEUM))  # the agents and robot; not its goals
    tickets: list[int] = []
    resumed: list[str] = []
    async with trio.open_nursery() as nursery, runtime as rt:
        # The runtime is left before the nursery: its end closes the stream, and the
        # narrator's task ends with it.
        nursery.start_soon(narrate, rt.events(), "guide", resumed)
        emergency_half_way(rt, tickets)
        tour = await rt.achieve("guide", TOUR)
        emergency = await rt.outcome(tickets[0]) if tickets else None
    if emergency is None:
        print("the emergency never came")
        return 1
    print(f"emergency {emergency.goal}: {emergency.status and emergency.status.value}")
    was = "suspended, resumed" if str(TOUR) in resumed else "never suspended"
    print(f"goal {tour.goal}: {was}, {tour.status and tour.status.value}")
    ok = tour.status is GoalStatus.SUCCESS and emergency.status is GoalStatus.SUCCESS
    return 0 if ok and str(TOUR) in resumed else 1


if __name__ == "__main__":
    sys.exit(trio.run(main))
