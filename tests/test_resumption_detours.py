"""A resumed goal that clears its suspended action takes the shorter way that the clear opens
(docs/design.md §2.4, §2.7, §4: Algorithm 2's clear, then :meth:`PlanSet.shorten_detours`).

The cabbie's world::

        m             go(X,Y) walks a road (its length) and takes 1 s; its undo is go(Y,X).
     2 / \\ 2          Stopped half way it only notes heading(X,Y) (the walker is still at
      /   \\           X; the note goes when the walk is cleared); resume costs half the road.
 e -3- s   t          cab(X,Y) takes the walker anywhere for 7, but the dispatcher books one
      \\   /           trip at a time: no cab while a walk is kept for resuming (heading(_,_)).
     3 \\ / 3
        c             goto(N): arrived | direct (a road X-N) | via (roads X-Y-N) | cab.

The story every test here tells:

| t    | what happens                                       | goto(t)'s kept plan (cost)          |
|------|----------------------------------------------------|-------------------------------------|
| 0    | goto(t) from s                                     | go(s,m) go(m,t) (4)                 |
| 0.25 | the door m->t shuts (go(s,m) still runs)           | repaired: go(s,c) go(c,t) (6)       |
| 0.5  | emergency goto(e): go(s,m) is suspended; go(s,e)   | (stacked, heading(s,m) believed)    |
| 1.5  | goto(e) done: goto(t) resumes, from e              | go(e,s) go(s,c) go(c,t) (9)         |

At 1.5 the kept plan starts with the undo of the emergency's walk, a detour.  From the
belief of that moment nothing is shorter: heading(s,m) bars the cab, and from e the
methods reach t by no road.  The kept plan does not resume go(s,m), so go(s,m) is cleared
— and without heading(s,m) the cab (7) beats the detour (9).  The agent must offer it
*after* the clear: once in :meth:`Agent._resume` when the resumption is worked out on the
spot, once in :meth:`Agent._get_ready` when it was worked out ahead, while the emergency's
last action (go(s,e)) ran.  Naive replanning plans afresh after the clear and takes the cab.
"""

from __future__ import annotations

import functools
from pathlib import Path

import anyio
import pytest

from htnagent.agent import AgentConfig, GoalStatus
from htnagent.executors.scripted import ScriptedExecutor
from htnagent.model.domain import Domain, Effect, Suspension
from htnagent.model.terms import Atom, atom
from htnagent.planning.planner import plan
from htnagent.runtime.messages import BeliefUpdate
from htnagent.scenario import parse_scenario
from htnagent.system.runtime import Runtime
from htnagent.system.simulation import run_scenario
from htnagent.upkeep import Replanning
from htnagent.upkeep import repair as repair_module
from tests.support import Event, record

ROADS = {("s", "m"): 2.0, ("m", "t"): 2.0, ("s", "c"): 3.0, ("c", "t"): 3.0, ("s", "e"): 3.0}
LENGTH = {**ROADS, **{(y, x): n for (x, y), n in ROADS.items()}}
CAB = 7.0
WALKER = "walker"
GUARD = 5.0  # real seconds: a story that takes longer has hung


def cabbie_domain() -> Domain:
    d = Domain("cabbie")

    def length(action: Atom) -> float:
        return LENGTH[(str(action.args[0]), str(action.args[1]))]

    d.operator(
        "go(?x,?y)",
        pre=["at(?x)", "road(?x,?y)", "not closed(?x,?y)"],
        add=["at(?y)"],
        delete=["at(?x)", "heading(?x,?y)"],
        cost=length,
        suspend=Suspension(
            add=("heading(?x,?y)",),
            cleared=("heading(?x,?y)",),
            resume=Effect(
                pre=("heading(?x,?y)", "at(?x)"),
                add=("at(?y)",),
                delete=("at(?x)", "heading(?x,?y)"),
                cost=lambda action: length(action) / 2,
            ),
        ),
        undo="go(?y,?x)",
    )
    d.operator(
        "cab(?x,?y)", pre=["at(?x)", "not heading(?p,?q)"], add=["at(?y)"], delete=["at(?x)"], cost=CAB
    )
    d.method("goto(?n)", "arrived", when=["at(?n)"], do=[])
    d.method("goto(?n)", "direct", when=["at(?x)", "road(?x,?n)"], do=["go(?x,?n)"])
    d.method(
        "goto(?n)",
        "via",
        when=["at(?x)", "road(?x,?y)", "road(?y,?n)", "not at(?n)"],
        do=["go(?x,?y)", "go(?y,?n)"],
    )
    d.method("goto(?n)", "cab", when=["at(?x)", "not at(?n)"], do=["cab(?x,?n)"])
    d.facts = tuple(Atom("road", xy) for xy in LENGTH)
    return d


def tell(rt: Runtime, fact: str) -> None:
    """The world tells the walker a fact (a door reported shut)."""
    rt.agents[WALKER].inbox.send(BeliefUpdate(add=(atom(fact),)))


def alarm(rt: Runtime, goal: str) -> None:
    """An emergency goal for the walker."""
    rt.submit(WALKER, atom(goal), emergency=True)


async def story(mode: Replanning, *, report_at: float | None = None) -> tuple[list[Event], list[str]]:
    """The story above in ``mode``; ``report_at``: when, during the emergency, a shut door
    that matters to no plan (t->m) is reported.  The events, and the robot's orders."""
    d = cabbie_domain()
    config = AgentConfig(
        name=WALKER, domain=d, belief=d.initial_state().updated(add=[atom("at(s)")]), replanning=mode
    )
    events: list[Event] = []
    rt = Runtime([config], lambda clock, trace: ScriptedExecutor("robot", suspendable=["go(s,m)"]))
    rt.subscribe(record(events))
    async with rt:
        with anyio.fail_after(GUARD):
            ticket = rt.submit(WALKER, atom("goto(t)"))
            rt.clock.call_at(0.25, functools.partial(tell, rt, "closed(m,t)"))
            rt.clock.call_at(0.5, functools.partial(alarm, rt, "goto(e)"))
            if report_at is not None:
                rt.clock.call_at(report_at, functools.partial(tell, rt, "closed(t,m)"))
            outcome = await rt.outcome(ticket)
    assert outcome.status is GoalStatus.SUCCESS
    robot = rt.bottom_executor
    assert isinstance(robot, ScriptedExecutor)
    return events, [f"{kind} {action}" for kind, action in robot.orders if kind != "resume"]


def resumed_plan(events: list[Event]) -> tuple[list[str], float]:
    """The plan goto(t) was resumed with: the first plan selected after goal_resumed."""
    resumed = next(i for i, e in enumerate(events) if e["event"] == "goal_resumed")
    chosen = next(e for e in events[resumed:] if e["event"] == "plan_selected")
    assert chosen["goal"] == "goto(t)"
    return list(chosen["plan"]), chosen["cost"]


# Expected at resumption (both paths): the clear, then the cab — never the walk back.
ORDERS = [
    "execute go(s,m)",
    "suspend go(s,m)",
    "execute go(s,e)",
    "clear go(s,m)",
    "execute cab(e,t)",
]


async def test_resumption_worked_out_on_the_spot_takes_the_way_the_clear_opens() -> None:
    # At 1.0, while go(s,e) runs, the door t->m is reported shut too.  It matters to no plan,
    # but the belief is no longer the one predicted when go(s,e) started: the resumption
    # worked out ahead is dropped and worked out at 1.5 (Agent._resume, not prepared).
    #
    # | step at 1.5                      | goto(t)'s best plan (cost)     |
    # |----------------------------------|--------------------------------|
    # | kept, re-checked, shortened      | go(e,s) go(s,c) go(c,t) (9)    |
    # | go(s,m) cleared (heading gone)   | go(e,s) go(s,c) go(c,t) (9)    |
    # | shortened again after the clear  | cab(e,t) (7)                   |
    events, orders = await story(Replanning.ONLINE, report_at=1.0)
    assert resumed_plan(events) == (["cab(e,t)"], CAB)
    assert orders == ORDERS


async def test_resumption_prepared_during_the_last_emergency_action_takes_the_way_the_clear_opens() -> None:
    # Nothing unforeseen while go(s,e) runs: the resumption is worked out ahead, from the
    # belief go(s,e)'s success will give (Agent._get_ready), and taken over at 1.5.
    #
    # | step while go(s,e) runs          | goto(t)'s best plan (cost)     |
    # |----------------------------------|--------------------------------|
    # | predicted, re-checked, shortened | go(e,s) go(s,c) go(c,t) (9)    |
    # | go(s,m) to be cleared            | go(e,s) go(s,c) go(c,t) (9)    |
    # | shortened again after the clear  | cab(e,t) (7)                   |
    events, orders = await story(Replanning.ONLINE)
    assert resumed_plan(events) == (["cab(e,t)"], CAB)
    assert orders == ORDERS


@pytest.mark.parametrize("report_at", [1.0, None], ids=["worked-out-on-the-spot", "prepared-ahead"])
async def test_resumption_after_a_clear_is_no_costlier_online_than_naive(report_at: float | None) -> None:
    # Naive replanning drops the kept plans: from the belief at 1.5 it finds none (no cab,
    # no road), clears go(s,m), plans again and takes the cab.  On-line must do as well.
    online, online_orders = await story(Replanning.ONLINE, report_at=report_at)
    naive, naive_orders = await story(Replanning.NAIVE, report_at=report_at)
    assert resumed_plan(naive) == (["cab(e,t)"], CAB)
    assert resumed_plan(online)[1] <= resumed_plan(naive)[1]
    assert online_orders == naive_orders == ORDERS


# -- one resumption, one belief: each search made once -------------------------------------


def test_a_resumption_searches_each_task_list_once_from_its_belief(monkeypatch: pytest.MonkeyPatch) -> None:
    """Working out a resumption is one update from one belief (Algorithm 2 for a resumed
    goal): the re-check of the plans left unchecked while the goal waited may plan the goal
    afresh (§2.4), and shortening the detour then asks for that very plan -- it is not
    searched for twice.  Museum, two emergencies nested: the navigator's suspended
    move_area was planned afresh twice at its resumption before its steps shared their
    searches."""
    searches: list[tuple[str, tuple[object, ...], tuple[str, ...]]] = []

    def recording(domain: Domain, state: object, tasks: list[object], *args: object, **kw: object) -> object:
        named = tuple(str(t[0] if isinstance(t, tuple) else t) for t in tasks)
        searches.append((domain.name, state.key(), named))  # type: ignore[attr-defined]
        return plan(domain, state, tasks, *args, **kw)  # type: ignore[arg-type]

    monkeypatch.setattr(repair_module, "plan", recording)
    root = Path(__file__).resolve().parents[1] / "scenarios"
    scenario = parse_scenario(
        {
            "name": "nested",
            "map": "museum_map.yaml",
            "robot": {"start": "n40", "speed": 1.0},
            "agents": [
                {"name": "guide", "domain": "museum.areas", "executor": "navigator"},
                {"name": "navigator", "domain": "museum.nodes", "executor": "robot"},
            ],
            "goals": [
                {"agent": "guide", "task": "goto(n1)"},
                {"agent": "guide", "task": "goto(n38)", "emergency": True, "when": {"time": 1.0}},
                {"agent": "guide", "task": "goto(n28)", "emergency": True, "when": {"time": 3.0}},
            ],
        },
        "nested.yaml",
        root,
    )
    report = anyio.run(functools.partial(run_scenario, scenario, replanning="online"))
    assert report.succeeded
    assert any(agent == "museum.nodes" for agent, _, _ in searches)  # the navigator did repair
    repeated = [s for s in set(searches) if searches.count(s) > 1]
    assert not repeated, repeated
