"""Plan maintenance (docs/design.md §2–§3): one test per rule, each failing without it."""

from __future__ import annotations

import math
from pathlib import Path

import pytest
import yaml

from htnagent.domains import areas_domain, nodes_domain
from htnagent.domains.maps import WorldMap
from htnagent.model.domain import Domain, State
from htnagent.model.plans import Plan, Step, replay, tidy
from htnagent.model.terms import Atom, parse
from htnagent.planning.planner import PlannerSettings, Search, plan
from htnagent.scenario import parse_map
from htnagent.upkeep import OnlinePlanSet, PlanSet, Replanning, new_plan_set
from htnagent.upkeep import online as online_module
from htnagent.upkeep import repair as repair_module
from htnagent.upkeep.quality import COMPARISON_FACTOR, COMPARISON_FLOOR, comparison_budget
from htnagent.upkeep.repair import LOCAL_MIN, LOCAL_SHARE
from tests.support import record_repair_searches

ROOT = Path(__file__).resolve().parent.parent


@pytest.fixture(scope="module")
def world() -> WorldMap:
    return parse_map(yaml.safe_load((ROOT / "scenarios" / "museum_map.yaml").read_text()), "museum_map.yaml")


@pytest.fixture(scope="module")
def nav(world: WorldMap) -> Domain:
    return nodes_domain(world)


def a(text: str) -> Atom:
    return parse(text)


def texts(p: Plan | None) -> list[str]:
    assert p is not None
    return p.text()


def execute(ps: PlanSet, domain: Domain, belief: State, action: str) -> State:
    act = a(action)
    after = domain.apply(belief, act)
    assert after is not None, f"{action} is not applicable"
    ps.action_succeeded(act, belief, after)
    return after


def repairs_given_all_they_need(monkeypatch: pytest.MonkeyPatch) -> None:
    """Repairs below the goal get their whole budget before the goal is re-planned (not
    LOCAL_SHARE of the first plan's expansions): for tests of what follows a repair."""
    monkeypatch.setattr(online_module, "LOCAL_SHARE", 1e9)
    monkeypatch.setattr(repair_module, "LOCAL_SHARE", 1e9)


def line_domain(undo: bool, doors: bool = False) -> Domain:
    """Nodes p0..p4 on a line plus a shortcut p0-p2; step(X,Y) moves; goal reach(X).
    With ``doors`` a link may be shut: ``closed(X,Y)``, a dynamic fact."""
    d = Domain("line")
    d.operator(
        "step(?x,?y)",
        pre=["at(?x)", "link(?x,?y)", *(["not closed(?x,?y)"] if doors else [])],
        add=["at(?y)"],
        delete=["at(?x)"],
        cost=1.0,
        undo="step(?y,?x)" if undo else None,
    )
    if doors:
        d.operator("shut(?x,?y)", add=["closed(?x,?y)"])  # makes closed(...) a dynamic fact
    d.method("reach(?n)", "here", when=["at(?n)"], do=[])
    d.method("reach(?n)", "go", when=["not at(?n)", "at(?x)", "link(?x,?y)"], do=["step(?x,?y)", "reach(?n)"])
    links = [("p0", "p1"), ("p1", "p2"), ("p2", "p3"), ("p3", "p4"), ("p0", "p2")]
    d.facts = tuple(Atom("link", pair) for x, y in links for pair in ((x, y), (y, x)))
    return d


def line_state(d: Domain, at: str) -> State:
    return State.from_facts([*d.facts, Atom("at", (at,))], d.dynamic_predicates)


# -- §2.1 an action finished with success ------------------------------------------------


def test_success_removes_the_executed_first_action(nav: Domain) -> None:
    belief = nav.initial_state("n1")
    ps = new_plan_set(nav, a("goto_node(n10)"))
    ps.make(belief)
    assert texts(ps.best) == ["move(n1,n6,arc5)", "move(n6,n10,arc12)"]
    belief = execute(ps, nav, belief, "move(n1,n6,arc5)")
    assert texts(ps.best) == ["move(n6,n10,arc12)"]
    belief = execute(ps, nav, belief, "move(n6,n10,arc12)")
    assert ps.finished


def test_success_puts_the_undo_in_front_of_other_plans() -> None:
    d = line_domain(undo=True)
    belief = line_state(d, "p0")
    ps = new_plan_set(d, a("reach(p3)"), settings=PlannerSettings(alternatives=3))
    ps.make(belief)
    # An action no plan starts with (an emergency's move) is undone in front of every plan.
    after = d.apply(belief, a("step(p0,p1)"))
    assert after is not None
    other = [p for p in ps.plans if p.steps[0].action != a("step(p0,p1)")]
    assert other
    ps.action_succeeded(a("step(p0,p1)"), belief, after)
    assert ps.stats.repairs == 0
    assert any(p.text()[:1] == ["step(p1,p0)"] for p in ps.plans)
    for p in ps.plans:
        assert replay(d, after, p.actions) is not None


def test_success_without_undo_rechecks_and_repairs() -> None:
    d = line_domain(undo=False)
    belief = line_state(d, "p0")
    ps = new_plan_set(d, a("reach(p4)"), settings=PlannerSettings(alternatives=1))
    ps.make(belief)
    assert texts(ps.best) == ["step(p0,p2)", "step(p2,p3)", "step(p3,p4)"]
    belief = execute(ps, d, belief, "step(p0,p2)")
    # An action no plan starts with, and no undo: the plan is re-checked, found
    # broken at its first step, and repaired below the goal.
    after = d.apply(belief, a("step(p2,p1)"))
    assert after is not None
    ps.action_succeeded(a("step(p2,p1)"), belief, after)
    assert ps.stats.repairs == 1
    assert ps.stats.from_scratch == 1
    assert texts(ps.best) == ["step(p1,p2)", "step(p2,p3)", "step(p3,p4)"]


def test_an_alternative_beside_a_valid_plan_is_repaired_by_no_search_of_its_own(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    # Without undo, an alternative that does not start with the action taken breaks at
    # every action: repaired by a search of its own each time (an IPC network's plans cost
    # a local search an action), it would cost more than planning afresh ever does.
    d = line_domain(undo=False)
    belief = line_state(d, "p0")
    ps = new_plan_set(d, a("reach(p3)"), settings=PlannerSettings(alternatives=2))
    ps.make(belief)
    assert [texts(p) for p in ps.plans] == [
        ["step(p0,p2)", "step(p2,p3)"],
        ["step(p0,p1)", "step(p1,p2)", "step(p2,p3)"],
    ]
    searched = record_repair_searches(monkeypatch)
    belief = execute(ps, d, belief, "step(p0,p2)")
    # Expect: the best plan moved on; the alternative broke at step(p0,p1) and, a valid
    # plan being kept, went for revival without a search.
    assert searched == []
    assert [texts(p) for p in ps.plans] == [["step(p2,p3)"]]
    assert ps.stats.repairs == 0 and ps.stats.removed == 1


def test_a_plan_revived_beside_a_cheaper_valid_plan_stays_out() -> None:
    # §2.5: a plan comes back when its fact holds again "and it is then the cheaper one".
    d = line_domain(undo=False)
    belief = line_state(d, "p0")
    ps = new_plan_set(d, a("reach(p3)"), settings=PlannerSettings(alternatives=2))
    ps.make(belief)
    belief = execute(ps, d, belief, "step(p0,p2)")  # the longer way goes for revival
    assert len(ps.plans) == 1
    # The robot is found back at p0: the longer way's fact holds again, but the best
    # plan, repaired from p0, is the shorter way again -- the longer one stays out.
    back = belief.updated(add=[a("at(p0)")], delete=[a("at(p2)")])
    ps.belief_changed(belief, back)
    assert [texts(p) for p in ps.plans] == [["step(p0,p2)", "step(p2,p3)"]]
    assert ps.stats.revivals == 0


def test_a_plan_broken_at_the_goal_level_is_replanned_once_from_the_belief() -> None:
    d = line_domain(undo=False)
    belief = line_state(d, "p0")
    ps = new_plan_set(d, a("reach(p3)"), settings=PlannerSettings(alternatives=2))
    ps.make(belief)
    assert len(ps.plans) == 2
    # The robot is found elsewhere (a belief change from outside).
    after = belief.updated(add=[a("at(p4)")], delete=[a("at(p0)")])
    expansions = ps.stats.expansions
    ps.belief_changed(belief, after)
    # Both alternatives broke at their first step, whose only ancestor is the goal:
    # the goal was re-decomposed once from the belief, and both repairs share it.
    assert ps.stats.repairs == 2
    assert texts(ps.best) == ["step(p4,p3)"]
    single = plan(d, after, [a("reach(p3)")], PlannerSettings(alternatives=1))
    assert ps.stats.expansions - expansions == single.expansions


# -- §2.2 an action failed -------------------------------------------------------------------


def test_failure_removes_plans_starting_with_the_failed_action(nav: Domain) -> None:
    belief = nav.initial_state("n1")
    ps = new_plan_set(nav, a("goto_node(n10)"))
    ps.make(belief)
    starts = {p.steps[0].action for p in ps.plans}
    assert a("move(n1,n6,arc5)") in starts and len(starts) > 1
    ps.action_failed(a("move(n1,n6,arc5)"), belief, belief)
    assert ps.plans and all(p.steps[0].action != a("move(n1,n6,arc5)") for p in ps.plans)


# -- §2.3 and §2.4 the belief changed; re-check and repair ------------------------------------


def test_belief_change_repairs_the_plan_around_a_closed_arc(nav: Domain) -> None:
    belief = nav.initial_state("n40")
    ps = new_plan_set(nav, a("goto_node(n1)"), settings=PlannerSettings(alternatives=1))
    ps.make(belief)
    assert "move(n10,n6,arc12)" in texts(ps.best)
    closed = belief.updated(add=[a("closed(arc12)")])
    ps.belief_changed(belief, closed)
    best = ps.best
    assert best is not None and "move(n10,n6,arc12)" not in best.text()
    # Repaired, not planned again: the part before the closed arc is kept as it was.
    assert ps.stats.repairs == 1 and ps.stats.from_scratch == 1
    assert best.text()[:6] == [
        "move(n40,n35,arc59)",
        "move(n35,n31,arc51)",
        "move(n31,n29,arc50)",
        "move(n29,n22,arc44)",
        "move(n22,n18,arc38)",
        "move(n18,n12,arc22)",
    ]
    assert replay(nav, closed, best.actions) is not None


@pytest.mark.parametrize("search", list(Search))
def test_repair_works_in_every_search_order(nav: Domain, search: Search) -> None:
    # docs/design.md §1.1: the records are the same in every order, so is repair (§2.4).
    belief = nav.initial_state("n40")
    ps = new_plan_set(nav, a("goto_node(n1)"), settings=PlannerSettings(alternatives=1, search=search))
    ps.make(belief)
    best = ps.best
    assert best is not None
    closed_arc = next(
        arc for action in best.actions if (arc := str(action.args[2])) and action.name == "move"
    )
    closed = belief.updated(add=[a(f"closed({closed_arc})")])
    ps.belief_changed(belief, closed)
    repaired = ps.best
    assert repaired is not None
    assert all(str(x.args[2]) != closed_arc for x in repaired.actions if x.name == "move")
    assert replay(nav, closed, repaired.actions) is not None
    assert all(s.record is not None for s in repaired.steps)


def test_a_repair_longer_than_a_fresh_plan_gives_way_to_it(
    world: WorldMap, monkeypatch: pytest.MonkeyPatch
) -> None:
    repairs_given_all_they_need(monkeypatch)
    areas = areas_domain(world)
    belief = areas.initial_state("n40")
    ps = new_plan_set(areas, a("goto(n1)"), settings=PlannerSettings(alternatives=1))
    ps.make(belief)
    assert texts(ps.best) == [
        "move_area(area8,area7)",
        "move_area(area7,area5)",
        "move_area(area5,area3)",
        "move_area(area3,area1)",
        "goto_node(n1)",
    ]
    # Shut the door area3 -> area1 (arc12): the step from area3 breaks.
    closed = belief.updated(add=[a("closed(arc12)")])
    searched = record_repair_searches(monkeypatch)
    ps.belief_changed(belief, closed)
    # §2.4: the repair re-decomposes only goto(n1) as it was in area3 — into a walk to
    # area3's dead end and back — which is longer than planning afresh, so the fresh
    # plan (not through area3) is the one kept.  The plan afresh is made first; the
    # repair below the goal comes after it, and gives way to it.
    assert ps.stats.repairs == 1 and ps.stats.fresher == 1
    fresh = plan(areas, closed, [a("goto(n1)")], PlannerSettings(alternatives=1)).best
    assert fresh is not None and ps.best is not None
    assert searched[0].tasks == ["goto(n1)"] and searched[0].settings.max_tasks is None
    assert [s.tasks for s in searched[1:]] == [["goto(n1)"]] and searched[1].settings.max_tasks is not None
    assert ps.best.actions == fresh.actions
    assert "move_area(area5,area3)" not in texts(ps.best)
    best = ps.best
    records = [s.record for s in best.steps]
    assert all(r is not None and r.chain()[-1].task == a("goto(n1)") for r in records)


def test_the_repair_a_fresh_plan_beat_is_not_kept_as_an_alternative(
    world: WorldMap, monkeypatch: pytest.MonkeyPatch
) -> None:
    repairs_given_all_they_need(monkeypatch)
    areas = areas_domain(world)
    belief = areas.initial_state("n40")
    ps = new_plan_set(areas, a("goto(n1)"), settings=PlannerSettings(alternatives=2))
    ps.make(belief)
    ps.plans = ps.plans[:1]  # a goal's first plan comes alone (§1, §4)
    closed = belief.updated(add=[a("closed(arc12)")])
    ps.belief_changed(belief, closed)
    # Expect: the walk to area3's dead end and back lost to the fresh plan, and went: kept
    # as an alternative it would be re-checked (and repaired) at every action for nothing.
    assert ps.stats.repairs == 1
    assert len(ps.plans) == 1 and "move_area(area5,area3)" not in texts(ps.best)


def test_a_repair_that_searched_the_goal_s_own_task_answers_the_fresh_comparison(
    world: WorldMap, monkeypatch: pytest.MonkeyPatch
) -> None:
    # The guide's goto(N) is recursive (goto = move_area, then goto): repairing a plan
    # broken in area5 re-decomposes goto(n1) as it stands there -- the goal's own task,
    # under another record.  The comparison with a fresh plan (§2.4) takes that search's
    # cost instead of searching the goal again.
    repairs_given_all_they_need(monkeypatch)
    areas = areas_domain(world)
    belief = areas.initial_state("n40")
    ps = new_plan_set(areas, a("goto(n1)"), settings=PlannerSettings(alternatives=1))
    ps.make(belief)
    for action in ("move_area(area8,area7)", "move_area(area7,area5)"):
        belief = execute(ps, areas, belief, action)
    searched = record_repair_searches(monkeypatch)
    shut = belief.updated(add=[a("closed(arc22)")])  # the door area5 -> area3
    ps.belief_changed(belief, shut)
    assert ps.stats.repairs == 1 and "move_area(area5,area3)" not in texts(ps.best)
    # Expect: one search of goto(n1), the repair's; none more for the comparison.
    assert [s.tasks for s in searched] == [["goto(n1)"]]


def test_the_fresh_comparison_plans_as_naive_would_within_what_planning_afresh_took(
    world: WorldMap, monkeypatch: pytest.MonkeyPatch
) -> None:
    # §2.4: a repaired plan gives way to a cheaper plan afresh -- "never a longer route than
    # naive" -- so the comparison plans the goal as naive would at resumption: the same
    # search, to its first plan (not a search under the repaired plan's cost, which finds
    # that plan no later but, where none is cheaper, looks on until its budget is spent).
    repairs_given_all_they_need(monkeypatch)
    areas = areas_domain(world)
    belief = areas.initial_state("n40")
    ps = new_plan_set(areas, a("goto(n1)"), settings=PlannerSettings(alternatives=1))
    ps.make(belief)
    searched = record_repair_searches(monkeypatch)
    closed = belief.updated(add=[a("closed(arc12)")])
    ps.belief_changed(belief, closed)
    # The goal is planned afresh first, as naive would; the repair (a walk to area3's dead
    # end and back) is searched under that plan's cost and finds none: the plan afresh is
    # taken.
    assert ps.stats.repairs == 1
    comparison = [s.settings for s in searched if s.tasks == ["goto(n1)"] and s.settings.max_tasks is None]
    naive = plan(areas, closed, [a("goto(n1)")], PlannerSettings(alternatives=1)).best
    assert len(comparison) == 1 and comparison[0].cost_bound is None
    assert naive is not None and ps.best is not None and ps.best.actions == naive.actions
    # ... given what planning the goal from scratch took (at least COMPARISON_FLOOR), not
    # the planner's whole budget: a network that cannot be planned afresh is not searched
    # through to the end of it.
    first = plan(areas, belief, [a("goto(n1)")], PlannerSettings(alternatives=1)).expansions
    assert comparison[0].budget == max(COMPARISON_FLOOR, COMPARISON_FACTOR * first) < PlannerSettings().budget


def test_the_plan_afresh_may_take_twice_what_the_first_plan_from_scratch_took(world: WorldMap) -> None:
    # The rest of a recursive network planned afresh from its middle can take as many
    # expansions as the whole from the start (IPC Towers): a search given only that many is
    # cut just short of its plan and made again with the whole budget.
    areas = areas_domain(world)
    ps = new_plan_set(areas, a("goto(n1)"), settings=PlannerSettings(alternatives=1))
    ps.make(areas.initial_state("n40"))
    ps.scratch_expansions = 400
    assert comparison_budget(ps) == 800
    ps.scratch_expansions = 10
    assert comparison_budget(ps) == COMPARISON_FLOOR


def test_repairs_below_the_goal_get_a_share_of_what_planning_it_afresh_took(
    world: WorldMap, monkeypatch: pytest.MonkeyPatch
) -> None:
    # §2.4's repair is worth making because it is cheaper than planning afresh, and the plan
    # afresh is needed for the comparison whatever the repair finds: the goal is planned
    # afresh first (one search, naive's), and the repairs below the goal then share
    # LOCAL_SHARE of the expansions that search took -- not of the goal's first plan from
    # scratch, which planned all of it.  No comparison follows.  (The museum's plans take a
    # few dozen expansions: their share is below LOCAL_MIN, which the next test is about;
    # here any share is searched.)
    monkeypatch.setattr(online_module, "LOCAL_MIN", 1)
    monkeypatch.setattr(repair_module, "LOCAL_MIN", 1)
    areas = areas_domain(world)
    belief = areas.initial_state("n40")
    ps = new_plan_set(areas, a("goto(n1)"), settings=PlannerSettings(alternatives=1))
    ps.make(belief)
    searched = record_repair_searches(monkeypatch)
    closed = belief.updated(add=[a("closed(arc12)")])
    ps.belief_changed(belief, closed)
    goal, local = searched[0], searched[1:]
    assert goal.tasks == ["goto(n1)"] and goal.settings.max_tasks is None and goal.settings.cost_bound is None
    assert local and all(s.settings.max_tasks is not None for s in local)
    assert local[0].settings.budget == math.ceil(LOCAL_SHARE * goal.expansions)
    assert sum(s.expansions for s in local) <= math.ceil(LOCAL_SHARE * goal.expansions)
    # The walk to area3's dead end and back did not fit in the share: the plan afresh,
    # which is what naive plans, is taken, and compared with nothing more.
    naive = plan(areas, closed, [a("goto(n1)")], PlannerSettings(alternatives=1)).best
    assert naive is not None and ps.best is not None and ps.best.actions == naive.actions
    assert ps.stats.repairs == 1 and ps.stats.fresher == 0


def test_a_share_too_small_to_pay_for_a_search_goes_straight_to_the_goal(
    world: WorldMap, monkeypatch: pytest.MonkeyPatch
) -> None:
    # A search's own cost is a few expansions' worth: a tenth of the museum's 10 is one
    # expansion, less than LOCAL_MIN -- no search below the goal; the goal is re-planned.
    areas = areas_domain(world)
    belief = areas.initial_state("n40")
    ps = new_plan_set(areas, a("goto(n1)"), settings=PlannerSettings(alternatives=1))
    ps.make(belief)
    assert ps.scratch_expansions is not None
    assert math.ceil(LOCAL_SHARE * ps.scratch_expansions) < LOCAL_MIN
    searched = record_repair_searches(monkeypatch)
    closed = belief.updated(add=[a("closed(arc12)")])
    ps.belief_changed(belief, closed)
    assert [(s.tasks, s.settings.max_tasks) for s in searched] == [(["goto(n1)"], None)]
    naive = plan(areas, closed, [a("goto(n1)")], PlannerSettings(alternatives=1)).best
    assert naive is not None and ps.best is not None and ps.best.actions == naive.actions


def test_plan_is_removed_when_no_ancestor_can_be_redecomposed(world: WorldMap) -> None:
    areas = areas_domain(world)
    belief = areas.initial_state("n1")
    ps = new_plan_set(areas, a("goto(n40)"), settings=PlannerSettings(alternatives=1))
    ps.make(belief)
    # area8 is reachable only through arc51: every ancestor up to the goal fails.
    closed = belief.updated(add=[a("closed(arc51)")])
    ps.belief_changed(belief, closed)
    assert ps.plans == []
    assert ps.stats.failed_repairs == 1 and ps.stats.removed == 1


# -- §2.5 revival ---------------------------------------------------------------------------------


def test_plans_kept_for_revival_follow_the_actions_the_one_plan_takes() -> None:
    # After a repair the plan as it was waits for revival (§2.5) while the one plan runs on
    # (its common case, no re-check): it follows each action -- its undo put in front -- so
    # that, revived, it is valid from where the robot is then.
    d = line_domain(undo=True, doors=True)
    belief = line_state(d, "p0")
    ps = OnlinePlanSet(d, a("reach(p3)"), settings=PlannerSettings(alternatives=1))
    ps.make(belief)
    assert texts(ps.best) == ["step(p0,p2)", "step(p2,p3)"]
    shut = belief.updated(add=[a("closed(p0,p2)")])
    ps.belief_changed(belief, shut)
    assert texts(ps.best) == ["step(p0,p1)", "step(p1,p2)", "step(p2,p3)"] and len(ps.revival) == 1
    after = execute(ps, d, shut, "step(p0,p1)")
    kept = ps.revival.plans
    assert [q.text() for q in kept] == [["step(p1,p0)", "step(p0,p2)", "step(p2,p3)"]]
    assert replay(d, after.updated(delete=[a("closed(p0,p2)")]), kept[0].actions) is not None


def test_plan_removed_by_a_closed_door_is_revived_when_it_opens(world: WorldMap) -> None:
    areas = areas_domain(world)
    belief = areas.initial_state("n1")
    ps = new_plan_set(areas, a("goto(n40)"), settings=PlannerSettings(alternatives=1))
    ps.make(belief)
    original = texts(ps.best)
    closed = belief.updated(add=[a("closed(arc51)")])
    ps.belief_changed(belief, closed)
    assert ps.plans == []
    reopened = closed.updated(delete=[a("closed(arc51)")])
    from_scratch = ps.stats.from_scratch
    ps.belief_changed(closed, reopened)
    assert texts(ps.best) == original
    assert ps.stats.revivals == 1
    assert ps.stats.from_scratch == from_scratch


def test_a_plan_that_comes_back_cheaper_takes_the_place_of_the_one_it_beats(world: WorldMap) -> None:
    # §2.5: the door area3 -> area1 shut, the goal takes another way; open again, the first
    # route comes back, cheaper -- and the other way goes (as a plan beaten by a cheaper one
    # afresh goes, §2.4): kept beside it as an alternative, it would be re-checked at every
    # action for nothing.  K = 2: room for it, had it stayed.
    areas = areas_domain(world)
    belief = areas.initial_state("n40")
    ps = new_plan_set(areas, a("goto(n1)"), settings=PlannerSettings(alternatives=2))
    ps.make(belief)
    ps.plans = ps.plans[:1]  # a goal's first plan comes alone (§1, §4)
    original = texts(ps.best)
    closed = belief.updated(add=[a("closed(arc12)")])
    ps.belief_changed(belief, closed)
    assert texts(ps.best) != original and len(ps.plans) == 1
    reopened = closed.updated(delete=[a("closed(arc12)")])
    ps.belief_changed(closed, reopened)
    assert ps.stats.revivals == 1
    assert [texts(p) for p in ps.plans] == [original]


def test_revival_is_bounded_in_time(world: WorldMap) -> None:
    areas = areas_domain(world)
    belief = areas.initial_state("n1")
    ps = OnlinePlanSet(areas, a("goto(n40)"), settings=PlannerSettings(alternatives=1), revival_window=2)
    ps.make(belief)
    closed = belief.updated(add=[a("closed(arc51)")])
    ps.belief_changed(belief, closed)
    for _ in range(3):
        ps.belief_changed(closed, closed)
    reopened = closed.updated(delete=[a("closed(arc51)")])
    ps.belief_changed(closed, reopened)
    assert ps.plans == [] and ps.stats.revivals == 0


# -- §2.6 tidy-up -----------------------------------------------------------------------------------


def test_tidy_removes_an_action_followed_by_its_undo(nav: Domain) -> None:
    steps = [Step(a(t), 1.0) for t in ("move(n1,n6,arc5)", "move(n6,n1,arc5)", "move(n1,n2,arc1)")]
    assert [str(s) for s in tidy(nav, steps)] == ["move(n1,n2,arc1)"]


def test_tidy_turns_rollback_then_action_into_resume(nav: Domain) -> None:
    steps = [Step(a("rollback(move(n1,n6,arc5))"), 1.0), Step(a("move(n1,n6,arc5)"), 1.0)]
    assert [str(s) for s in tidy(nav, steps)] == ["resume(move(n1,n6,arc5))"]


def test_success_then_tidy_cancels_undo_against_the_plan(nav: Domain) -> None:
    belief = nav.initial_state("n1")
    ps = new_plan_set(nav, a("goto_node(n10)"), settings=PlannerSettings(alternatives=1))
    ps.make(belief)
    # An emergency goes n1 -> n4: the undo n4 -> n1 is put in front of [n1 -> n6, n6 -> n10].
    belief = execute(ps, nav, belief, "move(n1,n4,arc3)")
    assert texts(ps.best) == ["move(n4,n1,arc3)", "move(n1,n6,arc5)", "move(n6,n10,arc12)"]
    # Coming back n4 -> n1 is the first action of that plan: it moves on, no undo left.
    belief = execute(ps, nav, belief, "move(n4,n1,arc3)")
    assert texts(ps.best) == ["move(n1,n6,arc5)", "move(n6,n10,arc12)"]


# -- §2.7 from scratch ----------------------------------------------------------------------------------


def test_plans_from_scratch_when_nothing_is_left(nav: Domain) -> None:
    belief = nav.initial_state("n1")
    ps = new_plan_set(nav, a("goto_node(n10)"))
    assert ps.ensure(belief)
    assert ps.stats.from_scratch == 1
    assert ps.ensure(belief) and ps.stats.from_scratch == 1
    unreachable = new_plan_set(nav, a("goto_node(n10)"))
    walled = belief.updated(add=[a("closed(arc5)"), a("closed(arc3)"), a("closed(arc1)")])
    assert not unreachable.ensure(walled)


# -- §3 Algorithm 1 -----------------------------------------------------------------------------------


def test_suspension_replaces_the_running_action_by_resume(nav: Domain) -> None:
    belief = nav.initial_state("n40")
    ps = new_plan_set(nav, a("goto_node(n1)"), settings=PlannerSettings(alternatives=2))
    ps.make(belief)
    running = a("move(n40,n35,arc59)")
    assert all(p.steps[0].action == running for p in ps.plans)
    after = nav.suspend(belief, running)
    assert a("on_arc(arc59,n40,n35)") in after.dynamic  # step 1, done by the agent
    ps.action_suspended(running, belief, after)
    assert all(p.text()[0] == "resume(move(n40,n35,arc59))" for p in ps.plans)
    assert ps.stats.repairs == 0
    for p in ps.plans:
        assert replay(nav, after, p.actions) is not None


def test_suspension_puts_rollback_in_front_of_other_plans(nav: Domain) -> None:
    belief = nav.initial_state("n1")
    ps = new_plan_set(nav, a("goto_node(n10)"), settings=PlannerSettings(alternatives=3))
    ps.make(belief)
    running = a("move(n1,n6,arc5)")
    others = [p for p in ps.plans if p.steps[0].action != running]
    assert others
    after = nav.suspend(belief, running)
    ps.action_suspended(running, belief, after)
    firsts = {p.text()[0] for p in ps.plans}
    assert firsts == {"resume(move(n1,n6,arc5))", "rollback(move(n1,n6,arc5))"}
    for p in ps.plans:
        assert replay(nav, after, p.actions) is not None


def test_suspension_drops_plans_in_naive_mode(nav: Domain) -> None:
    belief = nav.initial_state("n40")
    ps = new_plan_set(nav, a("goto_node(n1)"), Replanning.NAIVE)
    ps.make(belief)
    assert len(ps.plans) == 1
    running = a("move(n40,n35,arc59)")
    after = nav.suspend(belief, running)
    ps.action_suspended(running, belief, after)
    assert ps.plans == []
    assert ps.ensure(after) and ps.stats.from_scratch == 2
    assert texts(ps.best)[0] == "resume(move(n40,n35,arc59))"


def test_clearing_a_suspended_action_removes_its_half_done_facts(world: WorldMap) -> None:
    areas = areas_domain(world)
    belief = areas.initial_state("n40")
    running = a("move_area(area8,area7)")
    suspended = areas.suspend(belief, running)
    assert a("moving(area8,area7)") in suspended.dynamic
    assert a("moving(area8,area7)") not in areas.clear(suspended, running).dynamic


# -- the published situations on the real agents: tests/test_museum.py
# (test_the_published_situations_resume_at_the_cost_of_a_fresh_plan) --------------------------


def test_stacked_plans_are_updated_while_the_emergency_runs(nav: Domain) -> None:
    """The n38 situation at the child: the kept alternative through n38 becomes the best plan."""
    belief = nav.initial_state("n40")
    stacked = new_plan_set(nav, a("move_area(area8,area7)"))
    stacked.make(belief)
    running = a("move(n40,n35,arc59)")
    after = nav.suspend(belief, running)
    stacked.action_suspended(running, belief, after)
    belief = after
    emergency = plan(nav, belief, [a("goto_node(n38)")]).best
    assert emergency is not None
    assert emergency.text() == ["rollback(move(n40,n35,arc59))", "move(n40,n38,arc58)"]
    for action in emergency.actions:
        nxt = nav.apply(belief, action)
        assert nxt is not None
        stacked.action_succeeded(action, belief, nxt)
        belief = nxt
    assert texts(stacked.best) == ["move(n38,n35,arc52)", "move(n35,n31,arc51)"]
    assert stacked.stats.from_scratch == 1


@pytest.mark.parametrize(
    ("goal", "emergency"),
    [
        ("move_area(area8,area7)", "goto_node(n38)"),
        ("goto_node(n1)", "goto_node(n28)"),
        # The emergency finishes the suspended move first: a step of the stacked goal's own.
        ("goto_node(n1)", "goto_node(n30)"),
    ],
)
def test_a_stacked_goal_s_plans_are_checked_once_when_it_runs_again_and_end_as_if_kept_up(
    nav: Domain, goal: str, emergency: str
) -> None:
    """§4: while the goal waits (lazy) its plans follow every rewrite unchecked; checked when it
    is about to run again, its best plan is the one keeping them up after every event gives,
    and its done steps (what repair reads, §2.4) are the same."""
    start = nav.initial_state("n40")
    sets = {lazy: new_plan_set(nav, a(goal)) for lazy in (False, True)}
    running = a("move(n40,n35,arc59)")
    after = nav.suspend(start, running)
    for lazy, stacked in sets.items():
        stacked.make(start)
        stacked.lazy = lazy
        stacked.action_suspended(running, start, after)
    emergency_plan = plan(nav, after, [a(emergency)]).best
    assert emergency_plan is not None and len(emergency_plan.steps) >= 2
    belief = after
    kept_when_stacked = list(sets[True].plans)
    for action in emergency_plan.actions:
        nxt = nav.apply(belief, action)
        assert nxt is not None
        for stacked in sets.values():
            stacked.action_succeeded(action, belief, nxt)
        belief = nxt
    waited = sets[True]
    # Expect: nothing walked or repaired while the goal waited, and no plan copied: the
    # rewrites are logged, and made in one pass when it is about to run again.
    assert waited.stats.rechecks == 0 and waited.stats.repairs == 0
    assert all(p is q for p, q in zip(waited.plans, kept_when_stacked, strict=True))
    waited.lazy = False
    assert waited.ensure(belief) and sets[False].ensure(belief)
    mine, kept_up = waited.best, sets[False].best
    assert texts(mine) == texts(kept_up)
    assert mine is not None and kept_up is not None
    assert mine.cost == pytest.approx(kept_up.cost)
    assert done_steps(waited) == done_steps(sets[False])


def done_steps(ps: PlanSet) -> list[str]:
    """The goal's done steps, oldest first."""
    out: list[str] = []
    link = ps.done
    while link is not None:
        out.append(str(link.step))
        link = link.before
    return out[::-1]


def test_resumption_takes_a_shortcut_instead_of_walking_the_undo_detour(nav: Domain) -> None:
    """n1 -> n10 was planned through n6; an emergency took the robot to n4 meanwhile."""
    belief = nav.initial_state("n1")
    stacked = new_plan_set(nav, a("goto_node(n10)"), settings=PlannerSettings(alternatives=1))
    stacked.make(belief)
    belief = execute(stacked, nav, belief, "move(n1,n4,arc3)")
    # Expect: the undo of the emergency's move in front of the kept route.
    assert texts(stacked.best) == ["move(n4,n1,arc3)", "move(n1,n6,arc5)", "move(n6,n10,arc12)"]
    assert stacked.shorten_detours(belief)
    scratch = plan(nav, belief, [a("goto_node(n10)")]).best
    assert scratch is not None and stacked.best is not None
    assert stacked.best.cost == pytest.approx(scratch.cost)
    assert texts(stacked.best) == ["move(n4,n6,arc6)", "move(n6,n10,arc12)"]
    assert stacked.stats.shortcuts == 1
    assert not stacked.shorten_detours(belief)  # nothing left to shorten


def test_the_detour_a_shortcut_beat_is_not_kept_as_an_alternative(nav: Domain) -> None:
    belief = nav.initial_state("n1")
    stacked = new_plan_set(nav, a("goto_node(n10)"), settings=PlannerSettings(alternatives=2))
    stacked.make(belief)
    stacked.plans = stacked.plans[:1]  # a goal's first plan comes alone (§1, §4)
    belief = execute(stacked, nav, belief, "move(n1,n4,arc3)")
    assert texts(stacked.best)[0] == "move(n4,n1,arc3)"  # the undo detour
    assert stacked.shorten_detours(belief)
    # Expect: only the shortcut; the walk back would be re-checked at every action for nothing.
    assert [p.text() for p in stacked.plans] == [["move(n4,n6,arc6)", "move(n6,n10,arc12)"]]


def test_clearing_a_suspension_turns_its_resume_into_the_whole_action(world: WorldMap) -> None:
    areas = areas_domain(world)
    belief = areas.initial_state("n1")
    ps = new_plan_set(areas, a("goto(n40)"), settings=PlannerSettings(alternatives=1))
    ps.make(belief)
    running = a("move_area(area1,area3)")
    suspended = areas.suspend(belief, running)
    ps.action_suspended(running, belief, suspended)
    assert texts(ps.best)[0] == "resume(move_area(area1,area3))"
    cleared = areas.clear(suspended, running)
    ps.suspension_cleared(running, suspended, cleared)
    # Expect: still one plan, no repair, no planning: the move is made in full.
    assert texts(ps.best)[0] == "move_area(area1,area3)"
    assert ps.stats.repairs == 0 and ps.stats.from_scratch == 1
    best = ps.best
    assert best is not None and replay(areas, cleared, best.actions) is not None


def test_a_waiting_goal_does_the_whole_action_another_goal_rolled_back(nav: Domain) -> None:
    """A goal waits with ``resume(A)``; an emergency's plan rolls A back and goes elsewhere.
    A is no longer half done: the waiting plan does the whole A, valid without a repair."""
    belief = nav.initial_state("n40")
    stacked = new_plan_set(nav, a("goto_node(n31)"))
    stacked.make(belief)
    running = a("move(n40,n35,arc59)")
    assert texts(stacked.best)[0] == str(running)
    half = nav.suspend(belief, running)
    stacked.action_suspended(running, belief, half)
    stacked.lazy = True
    belief = half
    for action in ("rollback(move(n40,n35,arc59))", "move(n40,n38,arc58)"):
        belief = execute(stacked, nav, belief, action)
    stacked.lazy = False
    assert stacked.ensure(belief)
    kept = [p.text() for p in stacked.plans]
    assert ["move(n38,n40,arc58)", "move(n40,n35,arc59)", "move(n35,n31,arc51)"] in kept
    assert stacked.stats.repairs == 0 and stacked.stats.from_scratch == 1
    for p in stacked.plans:
        assert replay(nav, belief, p.actions) is not None


def test_a_waiting_goal_undoes_the_action_another_goal_resumed(world: WorldMap) -> None:
    """The guide's goal waits to resume ``goto_node(n38)`` in area8; an emergency resumes the
    move to area7 that an older goal had begun.  Its undo, as after the move itself, leads
    the waiting plan back to area8: valid, no repair (the resume alone has no undo)."""
    areas = areas_domain(world)
    belief = areas.initial_state("n40")
    moving = a("move_area(area8,area7)")
    belief = areas.suspend(belief, moving)
    stacked = new_plan_set(areas, a("goto(n38)"))
    stacked.make(belief)
    visiting = a("goto_node(n38)")
    assert texts(stacked.best) == [str(visiting)]
    half = areas.suspend(belief, visiting)
    stacked.action_suspended(visiting, belief, half)
    stacked.lazy = True
    belief = execute(stacked, areas, half, "resume(move_area(area8,area7))")
    stacked.lazy = False
    assert stacked.ensure(belief)
    assert texts(stacked.best) == ["move_area(area7,area8)", "resume(goto_node(n38))"]
    assert stacked.stats.repairs == 0 and stacked.stats.from_scratch == 1


def _waited_through_an_emergency(nav: Domain) -> tuple[PlanSet, State]:
    """goto_node(n1) waits on the stack while an emergency walks the robot from n40 to n28:
    its lone plan goes behind the undo of every move (§2.1), the rewrites logged, unchecked."""
    start = nav.initial_state("n40")
    stacked = new_plan_set(nav, a("goto_node(n1)"))
    assert stacked.ensure(start) and len(stacked.plans) == 1  # a goal's plan comes alone
    stacked.lazy = True
    emergency = plan(nav, start, [a("goto_node(n28)")]).best
    assert emergency is not None and len(emergency.actions) > 2
    belief = start
    for action in emergency.actions:
        after = nav.apply(belief, action)
        assert after is not None
        stacked.action_succeeded(action, belief, after)
        belief = after
    return stacked, belief


def test_a_detour_beaten_by_a_way_proven_optimal_is_not_walked(
    nav: Domain, monkeypatch: pytest.MonkeyPatch
) -> None:
    """At resumption the shorter way is searched before the detour is walked (§2.4): proven
    optimal by the estimate, it is taken, and walking the detour would change nothing."""
    stacked, belief = _waited_through_an_emergency(nav)
    stacked.lazy = False  # it resumes
    optimum = plan(nav, belief, [a("goto_node(n1)")]).best
    assert optimum is not None
    rechecks = stacked.stats.rechecks
    assert stacked.ensure(belief)
    assert texts(stacked.best) == optimum.text() and stacked.stats.shortcuts == 1
    assert stacked.stats.rechecks == rechecks  # the detour was not walked
    assert not stacked.shorten_detours(belief)
    # Not proven: the detour is walked first, as it always was, and loses all the same.
    monkeypatch.setattr(online_module, "proven_optimal", lambda ps, p, state: False)
    walked, belief = _waited_through_an_emergency(nav)
    walked.lazy = False
    rechecks = walked.stats.rechecks
    assert walked.ensure(belief) and walked.stats.rechecks > rechecks
    assert walked.best is not None and walked.best.steps[0].record is None  # behind its undo steps
    assert walked.shorten_detours(belief) and texts(walked.best) == optimum.text()


def test_repairs_of_a_goal_made_unreachable_cost_about_one_search() -> None:
    """A long recursive plan, then its target is walled off: repair must not search per level."""
    from htnagent.domains.maps import generate_map

    world = generate_map(10, 10, 3, 1)
    nodes = nodes_domain(world)
    names = sorted(world.nodes)
    start = names[0]
    target = max(names, key=lambda n: world.distance(start, n))
    belief = nodes.initial_state(start)
    ps = new_plan_set(nodes, Atom("goto_node", (target,)))
    ps.make(belief)
    best = ps.best
    assert best is not None and len(best) > 30
    walled = belief.updated(
        add=[Atom("closed", (arc.name,)) for arc in world.arcs.values() if target in (arc.a, arc.b)]
    )
    before = ps.stats.expansions
    ps.belief_changed(belief, walled)
    assert ps.plans == []
    one_search = plan(nodes, walled, [Atom("goto_node", (target,))], PlannerSettings(alternatives=1))
    assert ps.stats.expansions - before <= 2 * one_search.expansions
    # The repair proved the goal impossible from this belief: no second search for it.
    from_scratch = ps.stats.from_scratch
    assert not ps.ensure(walled) and ps.stats.from_scratch == from_scratch


def test_a_plan_moved_on_keeps_its_actions_and_text_without_walking_them_again() -> None:
    steps = tuple(Step(Atom("go", (f"n{i}", f"n{i + 1}")), 1.0) for i in range(50))
    whole = Plan(steps)
    fresh = Plan(steps[1:])
    assert whole.rest() == fresh and whole.rest().actions == fresh.actions
    _ = whole.actions, whole.shown
    rest = whole.rest()
    # Worked out on the whole plan, sliced for the rest: not walked step by step again.
    assert rest._actions == fresh.actions and rest._shown == fresh.shown
    assert rest.text() == fresh.text() and rest.cost == fresh.cost
    # What is left once the first step is done is the very tuple the agent kept when it
    # showed the plan: unchanged by identity, with no comparison of the two.
    assert rest.actions is whole.later_actions == fresh.actions


def test_the_rewrites_a_waiting_goal_logged_are_timed_as_plan_upkeep_when_a_copy_makes_them(
    nav: Domain,
) -> None:
    """The look-ahead forks a waiting goal's plans, which makes the rewrites the goal logged:
    that is plan keeping, and counts in its planning time like the rewrites it replaced."""
    stacked, _ = _waited_through_an_emergency(nav)
    before = stacked.stats.seconds
    copy = stacked.fork()
    assert stacked.stats.seconds > before
    assert copy.plans[0].steps[0].record is None  # the undo of the emergency's last move
