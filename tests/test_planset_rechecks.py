"""Which plans an update walks again: only what a change can touch is re-checked.

A plan known valid from the belief before an update is trusted after it, without
a walk, when nothing it reads changed (no step's precondition names a changed
predicate), when a suspension's ``resume(A)`` ends where A would have, or when a
prepared plan set is taken over for a belief equal to the one it was checked
from.  Each shortcut is pinned both ways: it saves the walk when it may, and the
plan is walked — and found broken — when it may not.
"""

from __future__ import annotations

from htnagent.model.domain import Domain, Effect, State, Suspension
from htnagent.model.plans import Plan, Step
from htnagent.model.terms import Atom, parse
from htnagent.planning.planner import PlannerSettings
from htnagent.upkeep import OnlinePlanSet

# -- a belief change that no step reads ---------------------------------------------------------


def lamp_and_doors() -> Domain:
    """From s to t through door d1 (cost 1) or d2 (cost 2); a lamp no action cares about."""
    d = Domain("lamp")
    d.operator(
        "pass(?x,?y,?d)",
        pre=["at(?x)", "door(?x,?y,?d)", "not closed(?d)"],
        add=["at(?y)"],
        delete=["at(?x)"],
        cost=lambda action: 1.0 if action.args[2] == "d1" else 2.0,
    )
    d.operator("shut(?d)", add=["closed(?d)"])  # closed(...) is a dynamic fact
    d.operator("switch", add=["lamp"])  # and so is lamp
    d.method("reach(?n)", "here", when=["at(?n)"], do=[])
    d.method("reach(?n)", "through", when=["not at(?n)", "at(?x)", "door(?x,?n,?d)"], do=["pass(?x,?n,?d)"])
    d.facts = (Atom("door", ("s", "t", "d1")), Atom("door", ("s", "t", "d2")))
    return d


def _planned(d: Domain, goal: str, *facts: str, alternatives: int = 2) -> tuple[OnlinePlanSet, State]:
    belief = State.from_facts([*d.facts, *map(parse, facts)], d.dynamic_predicates)
    ps = OnlinePlanSet(d, parse(goal), settings=PlannerSettings(alternatives=alternatives))
    ps.make(belief)
    return ps, belief


def test_a_change_no_step_reads_walks_no_plan() -> None:
    ps, belief = _planned(lamp_and_doors(), "reach(t)", "at(s)")
    assert [p.text() for p in ps.plans] == [["pass(s,t,d1)"], ["pass(s,t,d2)"]]
    rechecks = ps.stats.rechecks
    ps.belief_changed(belief, belief.updated(add=[parse("lamp")]))
    assert ps.stats.rechecks == rechecks
    assert [p.text() for p in ps.plans] == [["pass(s,t,d1)"], ["pass(s,t,d2)"]]


def test_a_change_a_step_reads_walks_the_plans_and_finds_the_broken_one() -> None:
    ps, belief = _planned(lamp_and_doors(), "reach(t)", "at(s)")
    rechecks = ps.stats.rechecks
    shut = belief.updated(add=[parse("closed(d1)")])
    ps.belief_changed(belief, shut)
    assert ps.stats.rechecks > rechecks
    assert [p.text() for p in ps.plans] == [["pass(s,t,d2)"]]


def test_a_plan_not_checked_from_the_belief_before_is_walked() -> None:
    ps, belief = _planned(lamp_and_doors(), "reach(t)", "at(s)")
    other = belief.updated(add=[parse("closed(d1)")])  # not the belief the plans were checked from
    rechecks = ps.stats.rechecks
    ps.belief_changed(other, other.updated(add=[parse("lamp")]))
    assert ps.stats.rechecks > rechecks
    assert [p.text() for p in ps.plans] == [["pass(s,t,d2)"]]


# -- a suspended action's resume -------------------------------------------------------------------


def walk_domain(resume_tires: bool) -> Domain:
    """a → b → c; a walk can be stopped half way.  When ``resume_tires``, finishing a
    stopped walk leaves the robot ``tired``, and a tired robot cannot walk on."""
    d = Domain("walks")
    d.operator(
        "walk(?x,?y)",
        pre=["at(?x)", "link(?x,?y)", "not tired"],
        add=["at(?y)"],
        delete=["at(?x)"],
        suspend=Suspension(
            add=("half(?x,?y)",),
            cleared=("half(?x,?y)",),
            resume=Effect(
                pre=("half(?x,?y)", "at(?x)"),
                add=("at(?y)", "tired") if resume_tires else ("at(?y)",),
                delete=("at(?x)", "half(?x,?y)"),
            ),
        ),
    )
    d.operator("rest", add=["tired"])  # tired is a dynamic fact
    d.method("reach(?n)", "here", when=["at(?n)"], do=[])
    d.method(
        "reach(?n)", "walk", when=["not at(?n)", "at(?x)", "link(?x,?y)"], do=["walk(?x,?y)", "reach(?n)"]
    )
    d.facts = (Atom("link", ("a", "b")), Atom("link", ("b", "c")))
    return d


def _suspend_first_walk(resume_tires: bool) -> OnlinePlanSet:
    d = walk_domain(resume_tires)
    ps, belief = _planned(d, "reach(c)", "at(a)")
    assert ps.best is not None and ps.best.text() == ["walk(a,b)", "walk(b,c)"]
    stopped = d.actions.suspend(belief, parse("walk(a,b)"))
    ps.action_suspended(parse("walk(a,b)"), belief, stopped)
    return ps


def test_a_resume_that_ends_where_the_action_would_keeps_the_plan_unwalked() -> None:
    ps = _suspend_first_walk(resume_tires=False)
    assert ps.stats.rechecks == 0
    assert ps.best is not None and ps.best.text() == ["resume(walk(a,b))", "walk(b,c)"]


def test_a_resume_that_ends_elsewhere_has_the_plan_walked_and_dropped() -> None:
    ps = _suspend_first_walk(resume_tires=True)
    assert ps.stats.rechecks > 0
    # resume(walk(a,b)) leaves the robot tired: walk(b,c) can no longer follow it.
    assert all(p.text() != ["resume(walk(a,b))", "walk(b,c)"] for p in ps.plans)


# -- a plan set made ahead for a belief equal to the present one --------------------------------


def test_a_plan_set_rebased_on_an_equal_belief_is_trusted_by_the_next_update() -> None:
    d = lamp_and_doors()
    ps, belief = _planned(d, "reach(t)", "at(s)", alternatives=1)  # the plan that runs the action
    same = belief.with_dynamic(frozenset(belief.dynamic))  # equal, but another object
    after = d.apply(same, parse("pass(s,t,d1)"))
    assert after is not None
    unrebased = ps.fork()
    unrebased.action_succeeded(parse("pass(s,t,d1)"), same, after)
    walked = ps.stats.rechecks  # the fork shares the statistics
    assert walked > 0
    ps.rebase(same)
    ps.action_succeeded(parse("pass(s,t,d1)"), same, after)
    assert ps.stats.rechecks == walked


def test_rebase_ignores_a_belief_that_differs() -> None:
    d = lamp_and_doors()
    ps, belief = _planned(d, "reach(t)", "at(s)")
    other = belief.updated(add=[parse("closed(d1)")])
    ps.rebase(other)
    rechecks = ps.stats.rechecks
    ps.belief_changed(other, other.updated(add=[parse("lamp")]))
    assert ps.stats.rechecks > rechecks  # still not trusted: walked, and the d1 plan goes
    assert [p.text() for p in ps.plans] == [["pass(s,t,d2)"]]


# -- plans as values ----------------------------------------------------------------------------------


def test_a_plans_cached_cost_and_actions_do_not_change_equality() -> None:
    steps = (Step(parse("go(a,b)"), 1.5), Step(parse("go(b,c)"), 2.0))
    p, q = Plan(steps), Plan(steps)
    assert p.cost == 3.5 and p.actions == (parse("go(a,b)"), parse("go(b,c)"))
    assert p == q and hash(p) == hash(q)
    assert Plan(steps[:1]) != p
