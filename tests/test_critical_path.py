"""Work kept off the critical path (docs/design.md §4), checked on the real agents.

- A resumption made ready while the emergency's last action ran is taken over as it
  is: its plans are not walked again at the next update.
- The suspended goals' upkeep waits until the emergency's first order has reached
  the robot, however many agents it passes through.
"""

from __future__ import annotations

import gc
import weakref
from pathlib import Path

import pytest

from htnagent.agent import Agent, GoalEntry
from htnagent.agent.look_ahead import LookAhead, PredictedSuccess
from htnagent.agent.resumption import Resumption
from htnagent.model.domain import State
from htnagent.model.terms import Atom
from htnagent.reading import read_yaml
from htnagent.runtime.events import GoalFinished, GoalReceived, MessageSent, RobotMoving, TraceEvent
from htnagent.scenario import load_scenario, parse_scenario
from htnagent.system.runtime import Runtime
from htnagent.system.simulation import run_scenario
from htnagent.upkeep import OnlinePlanSet, PlanSet, SearchMemo

# -- the agent takes a prepared resumption over without walking its plans again ---------------------

SCENARIOS = Path(__file__).resolve().parent.parent / "scenarios"


async def _guide_rechecks(file: str) -> int:
    runtimes: list[Runtime] = []
    report = await run_scenario(
        load_scenario(SCENARIOS / file), replanning="online", on_start=runtimes.append
    )
    assert report.succeeded
    return runtimes[0].agents["guide"].stats.rechecks


@pytest.mark.parametrize("file", ["paper_n1_n40_n13.yaml", "paper_n40_n1_n28.yaml"])
async def test_a_resumption_made_ready_ahead_is_not_walked_again(
    file: str, monkeypatch: pytest.MonkeyPatch
) -> None:
    taken_over = await _guide_rechecks(file)
    # The agent takes the predicted belief itself as its belief: the plans made ready
    # from it are known valid by identity, with nothing to re-base.
    monkeypatch.setattr(PlanSet, "rebase", lambda self, state: None)
    assert await _guide_rechecks(file) == taken_over
    # Had it taken beliefs worked out again (equal, but other objects) — after the
    # emergency's last action, and after each suspended action it clears — only a re-base
    # would spare the walk.
    came_true, resume = PredictedSuccess.came_true, Agent._resume

    def fresh_after_action(self: PredictedSuccess, action: Atom, before: State, after: State) -> bool:
        if not came_true(self, action, before, after):
            return False
        self.after = after
        return True

    def fresh_after_clears(self: Agent, entry: GoalEntry) -> None:
        if entry.foreseen is not None:
            worked_out = entry.foreseen.resumption
            worked_out.clears = [(a, s.with_dynamic(frozenset(s.dynamic))) for a, s in worked_out.clears]
        resume(self, entry)

    monkeypatch.setattr(PredictedSuccess, "came_true", fresh_after_action)
    monkeypatch.setattr(Agent, "_resume", fresh_after_clears)
    assert taken_over < await _guide_rechecks(file)


# -- what a resumption replaced is let go of once the resumed goal's first order is out (§4) ---------


async def test_what_a_resumption_replaced_is_freed_after_its_first_order_reaches_the_robot(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    # Freeing plans kept for long is work: on a large map, tens of microseconds at the
    # moment of resuming.  What the resumed goal's plans replaced is kept until its first
    # order has reached the robot, and freed then — not before, and not never.
    replaced: list[weakref.ref[PlanSet]] = []
    adopt = OnlinePlanSet.adopt

    def recording_adopt(self: OnlinePlanSet, other: PlanSet) -> PlanSet:
        old = adopt(self, other)  # the plans, records and revival store it replaced
        replaced.append(weakref.ref(old))
        return old

    monkeypatch.setattr(OnlinePlanSet, "adopt", recording_adopt)
    alive_at_order: list[bool] = []
    ended = False

    def observe(event: TraceEvent) -> None:
        nonlocal ended
        if isinstance(event, GoalFinished) and event.goal == "goto(n28)":
            ended = True
        elif ended and isinstance(event, MessageSent) and event.to == "robot" and not alive_at_order:
            alive_at_order.append(bool(replaced) and all(r() is not None for r in replaced))

    scenario = load_scenario(SCENARIOS / "paper_n40_n1_n28.yaml")
    report = await run_scenario(scenario, replanning="online", observers=[observe])
    assert report.succeeded
    assert alive_at_order == [True]
    gc.collect()
    assert all(r() is None for r in replaced)


# -- the stacked goals' upkeep waits until the emergency's first move is under way (§4) --------------


async def test_the_emergency_reaches_the_robot_before_the_stacked_plans_are_kept_up(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    # Two levels: the guide's order for the emergency goes through the navigator to the
    # robot.  The guide's deferred upkeep of its suspended goal must come after the robot
    # has started moving for the emergency, not between the navigator and the robot.
    order: list[str] = []
    flush = Agent._catch_up

    def recording_flush(self: Agent) -> None:
        if self.upkeep.waiting:
            order.append(f"upkeep {self.name}")
        flush(self)

    monkeypatch.setattr(Agent, "_catch_up", recording_flush)

    def observe(event: TraceEvent) -> None:
        if isinstance(event, GoalReceived) and event.emergency:
            order.append("emergency")
        elif isinstance(event, RobotMoving):
            order.append("robot moves")

    scenario = load_scenario(SCENARIOS / "paper_n40_n1_n28.yaml")
    report = await run_scenario(scenario, replanning="online", observers=[observe])
    assert report.succeeded
    after = order[order.index("emergency") :]
    assert "upkeep guide" in after
    assert after.index("robot moves") < after.index("upkeep guide")


# -- a child gets ready for its parent's next order only with its last action to go (§5) ------------


@pytest.mark.parametrize("file", ["paper_n40_n1_n38.yaml", "four_emergencies.yaml"])
async def test_a_child_readies_its_held_goal_for_the_parent_s_resume_on_its_last_action(
    file: str, monkeypatch: pytest.MonkeyPatch
) -> None:
    # The parent's prepare hint comes when the parent's last emergency order starts; the
    # child carries that order out in several actions.  Readying the held goal then would
    # mean updating a copy of its plans for every one of them, and again for real as they
    # are done: the child waits until the last one is under way.
    replayed: list[int] = []
    foresee = LookAhead._foresee_resumption

    def recording(
        self: LookAhead,
        entry: GoalEntry,
        plans: PlanSet,
        belief: State,
        done: tuple[Atom, ...],
        memo: SearchMemo | None = None,
    ) -> Resumption:
        replayed.append(len(done))
        return foresee(self, entry, plans, belief, done, memo)

    monkeypatch.setattr(LookAhead, "_foresee_resumption", recording)
    report = await run_scenario(load_scenario(SCENARIOS / file), replanning="online")
    assert report.succeeded
    assert replayed and max(replayed) == 1


# -- only the goal that resumes is made ready ahead; the others are only rewritten (§4) ------------


async def test_only_the_goal_that_resumes_is_copied_and_updated_ahead(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    # With several goals stacked, the emergency's last action gets the goal below it
    # ready ahead; the goals further down keep being rewritten as usual (lazy), not
    # copied and updated ahead as well.
    copies: list[int] = []
    fork = PlanSet.fork
    prepare = LookAhead.foresee

    def counting_fork(self: PlanSet) -> PlanSet:
        if copies:
            copies[-1] += 1
        return fork(self)

    def recording(self: LookAhead, action: Atom) -> bool:
        copies.append(0)
        depth = len(self.agent.stack)
        made = prepare(self, action)
        if copies[-1] == 0 or depth < 2:
            copies.pop()  # nothing made ready, or nothing below the goal that resumes
        return made

    monkeypatch.setattr(PlanSet, "fork", counting_fork)
    monkeypatch.setattr(LookAhead, "foresee", recording)
    report = await run_scenario(load_scenario(SCENARIOS / "nested_emergencies.yaml"), replanning="online")
    assert report.succeeded
    # Expect: the resuming goal's copy, and the copy of it that is made ready.
    assert copies and max(copies) == 2


# -- an order carries the very action the agent planned ------------------------------------------


def test_a_message_carries_the_atom_itself_and_refuses_what_is_not_one() -> None:
    from pydantic import ValidationError

    from htnagent.model.terms import atom
    from htnagent.runtime.messages import BeliefUpdate, Execute, Resume, Submit

    # Validated as the named tuple it is, an atom was rebuilt argument by argument: a copy,
    # and the better part of a message's cost on the way to the robot.
    action = atom("drive(truck-0,city-loc-1,city-loc-2)")
    assert Execute(action=action, seq=1).action is action
    assert Resume(action=action, seq=2).action is action
    assert Submit(goal=action, ticket=3).goal is action
    assert BeliefUpdate(add=(action,)).add[0] is action
    for wrong in ("drive(a,b,c)", ("drive", ("a",)), None):
        with pytest.raises(ValidationError):
            Execute(action=wrong, seq=1)  # type: ignore[arg-type]


# -- an emergency that comes as an order reaches the robot is seen before the upkeep (§4) -------------


async def test_an_emergency_given_as_the_order_reaches_the_robot_is_seen_before_the_upkeep(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    # goto(n28) runs over the stacked goto(n1), whose upkeep for each of goto(n28)'s
    # actions waits until the next order is on its way.  An application watching the
    # robot gives a second emergency the moment that order's first move starts, while
    # the guide lets its order through: the guide must ask for the suspension before it
    # works off that upkeep (§4: nothing that keeps the suspended plans valid may delay
    # the reaction), not after.
    order: list[str] = []  # from the moment the application gives the emergency
    flush = Agent._catch_up

    def recording_flush(self: Agent) -> None:
        if order and self.upkeep.waiting and self.name == "guide":
            order.append("upkeep")
        flush(self)

    monkeypatch.setattr(Agent, "_catch_up", recording_flush)
    runtimes: list[Runtime] = []

    def observe(event: TraceEvent) -> None:
        if isinstance(event, RobotMoving) and event.action == "move(n31,n29,arc50)" and not order:
            order.append("emergency")
            runtimes[0].submit("guide", Atom("goto", ("n38",)), emergency=True)
        elif order and isinstance(event, MessageSent) and event.agent == "guide" and event.kind == "suspend":
            order.append("suspend")

    data = read_yaml(SCENARIOS / "nested_emergencies.yaml", "scenario")
    del data["goals"][2]  # the second emergency is the application's
    scenario = parse_scenario(data, "nested_emergencies.yaml", SCENARIOS)
    report = await run_scenario(scenario, replanning="online", observers=[observe], on_start=runtimes.append)
    assert report.succeeded
    assert order[:2] == ["emergency", "suspend"], order
    assert "upkeep" in order
