"""Plan maintenance shortcuts and bounds (docs/design.md §2.1, §2.5), each pinned by a test.

- A plan behind the undo of another goal's action is trusted without a re-check
  only when the undo gives back exactly the belief before the action (§2.1).
- The plans kept for revival are bounded in number: the oldest goes first (§2.5).
- A kept plan follows the agent's actions: the rewrites are logged, and applied in
  order when it is taken out (§2.5).
"""

from __future__ import annotations

from collections.abc import Callable

import pytest

from htnagent.model.domain import Domain, State
from htnagent.model.plans import Plan, Step, replay
from htnagent.model.terms import Atom, parse
from htnagent.planning.planner import PlannerSettings
from htnagent.upkeep import (
    PLAN_SET_KINDS,
    NaivePlanSet,
    OnlinePlanSet,
    PlanSet,
    Replanning,
    Revival,
    new_plan_set,
)

# -- §2.1 trusting a plan behind an undo -------------------------------------------------------


def alarm_domain() -> Domain:
    """a - b - c on a line, and a tunnel a → c that only a quiet robot may take.

    Walking (``go``) sounds an alarm and has an undo, but undoing a walk does not
    silence the alarm: the undo does not lead back to the belief before the walk.
    """
    d = Domain("alarm")
    d.operator(
        "go(?x,?y)",
        pre=["at(?x)", "link(?x,?y)"],
        add=["at(?y)", "alarm"],
        delete=["at(?x)"],
        cost=1.0,
        undo="go(?y,?x)",
    )
    d.operator(
        "sneak(?x,?y)",
        pre=["at(?x)", "tunnel(?x,?y)", "not alarm"],
        add=["at(?y)"],
        delete=["at(?x)"],
        cost=3.0,
    )
    d.method("reach(?n)", "here", when=["at(?n)"], do=[])
    d.method("reach(?n)", "walk", when=["not at(?n)", "at(?x)", "link(?x,?y)"], do=["go(?x,?y)", "reach(?n)"])
    d.method("reach(?n)", "tunnel", when=["not at(?n)", "at(?x)", "tunnel(?x,?n)"], do=["sneak(?x,?n)"])
    links = [("a", "b"), ("b", "c")]
    d.facts = (
        *(Atom("link", pair) for x, y in links for pair in ((x, y), (y, x))),
        Atom("tunnel", ("a", "c")),
    )
    return d


def test_a_plan_behind_an_undo_that_does_not_restore_the_belief_is_rechecked() -> None:
    d = alarm_domain()
    belief = State.from_facts([*d.facts, parse("at(a)")], d.dynamic_predicates)
    ps = new_plan_set(d, parse("reach(c)"), settings=PlannerSettings(alternatives=2))
    ps.make(belief)
    # Expect: walk a → b → c (2), or sneak through the tunnel (3).
    assert [p.text() for p in ps.plans] == [["go(a,b)", "go(b,c)"], ["sneak(a,c)"]]
    walked = d.apply(belief, parse("go(a,b)"))
    assert walked is not None
    ps.action_succeeded(parse("go(a,b)"), belief, walked)
    # The tunnel plan became [go(b,a), sneak(a,c)]; after the walk the alarm rings, and
    # undoing the walk leaves it ringing: the tunnel is shut, so that plan cannot stay.
    assert all(replay(d, walked, p.actions) is not None for p in ps.plans)
    assert ["go(b,a)", "sneak(a,c)"] not in [p.text() for p in ps.plans]
    assert ps.best is not None and ps.best.text() == ["go(b,c)"]


def test_a_plan_behind_an_undo_that_restores_the_belief_is_kept() -> None:
    d = Domain("quiet")
    d.operator(
        "go(?x,?y)", pre=["at(?x)", "link(?x,?y)"], add=["at(?y)"], delete=["at(?x)"], undo="go(?y,?x)"
    )
    d.method("reach(?n)", "here", when=["at(?n)"], do=[])
    d.method("reach(?n)", "walk", when=["not at(?n)", "at(?x)", "link(?x,?y)"], do=["go(?x,?y)", "reach(?n)"])
    d.facts = tuple(Atom("link", p) for p in [("a", "b"), ("b", "a"), ("a", "c"), ("c", "a"), ("b", "c")])
    belief = State.from_facts([*d.facts, parse("at(a)")], d.dynamic_predicates)
    ps = new_plan_set(d, parse("reach(c)"), settings=PlannerSettings(alternatives=2))
    ps.make(belief)
    assert [p.text() for p in ps.plans] == [["go(a,c)"], ["go(a,b)", "go(b,c)"]]
    moved = d.apply(belief, parse("go(a,b)"))
    assert moved is not None
    rechecks = ps.stats.rechecks
    ps.action_succeeded(parse("go(a,b)"), belief, moved)
    # go(b,a) leads back exactly: the plan behind it is trusted, and neither is walked again.
    assert [p.text() for p in ps.plans] == [["go(b,c)"], ["go(b,a)", "go(a,c)"]]
    assert ps.stats.rechecks == rechecks


# -- §2.5 the revival store is bounded in number ---------------------------------------------------


def doors_domain(doors: int = 3) -> Domain:
    """From s to t through one of the doors d1 (cost 1), d2 (cost 2), d3 (cost 3)..."""
    costs = {f"d{i}": float(i) for i in range(1, doors + 1)}
    d = Domain("doors")
    d.operator(
        "pass(?x,?y,?d)",
        pre=["at(?x)", "door(?x,?y,?d)", "not closed(?d)"],
        add=["at(?y)"],
        delete=["at(?x)"],
        cost=lambda action: costs[str(action.args[2])],
    )
    d.operator("shut(?d)", add=["closed(?d)"])  # makes closed(...) a dynamic fact
    d.method("reach(?n)", "here", when=["at(?n)"], do=[])
    d.method("reach(?n)", "through", when=["not at(?n)", "at(?x)", "door(?x,?n,?d)"], do=["pass(?x,?n,?d)"])
    d.facts = tuple(Atom("door", ("s", "t", door)) for door in costs)
    return d


def _shut_d1_then_d2(capacity: int) -> tuple[Domain, OnlinePlanSet, State]:
    d = doors_domain()
    belief = State.from_facts([*d.facts, parse("at(s)")], d.dynamic_predicates)
    settings = PlannerSettings(alternatives=1)
    ps = OnlinePlanSet(d, parse("reach(t)"), settings=settings, revival_capacity=capacity)
    ps.make(belief)
    assert ps.best is not None and ps.best.text() == ["pass(s,t,d1)"]
    one = belief.updated(add=[parse("closed(d1)")])
    ps.belief_changed(belief, one)  # repaired through d2; the d1 plan waits for d1 to open
    assert ps.best is not None and ps.best.text() == ["pass(s,t,d2)"]
    two = one.updated(add=[parse("closed(d2)")])
    ps.belief_changed(one, two)  # repaired through d3; the d2 plan waits for d2 to open
    assert ps.best is not None and ps.best.text() == ["pass(s,t,d3)"]
    return d, ps, two


def test_a_plan_removed_by_a_door_comes_back_when_it_opens() -> None:
    _, ps, two = _shut_d1_then_d2(capacity=32)
    assert len(ps.revival) == 2
    ps.belief_changed(two, two.updated(delete=[parse("closed(d1)")]))
    assert ps.best is not None and ps.best.text() == ["pass(s,t,d1)"]
    assert ps.stats.revivals == 1


def test_revival_keeps_at_most_its_capacity_the_oldest_going_first() -> None:
    _, ps, two = _shut_d1_then_d2(capacity=1)
    # Only the latest removed plan (through d2) is kept: the one through d1 is gone.
    assert [p.text() for p in ps.revival.plans] == [["pass(s,t,d2)"]]
    ps.belief_changed(two, two.updated(delete=[parse("closed(d1)")]))
    assert ps.stats.revivals == 0
    assert ps.best is not None and ps.best.text() == ["pass(s,t,d3)"]


def test_revival_store_never_grows_past_its_capacity() -> None:
    d = doors_domain(12)
    belief = State.from_facts([*d.facts, parse("at(s)")], d.dynamic_predicates)
    ps = OnlinePlanSet(d, parse("reach(t)"), settings=PlannerSettings(alternatives=1), revival_capacity=3)
    ps.make(belief)
    for i in range(1, 12):
        # Shutting the door of the best plan removes it (for revival) and repairs through the next.
        shut = belief.updated(add=[parse(f"closed(d{i})")])
        ps.belief_changed(belief, shut)
        assert ps.best is not None and ps.best.text() == [f"pass(s,t,d{i + 1})"]
        assert len(ps.revival) == min(i, 3)
        belief = shut
    # The three kept are the latest removed.
    assert [p.text() for p in ps.revival.plans] == [[f"pass(s,t,d{i})"] for i in (9, 10, 11)]


# -- one class per mode ------------------------------------------------------------------------------


def test_plan_set_mode_picks_the_class() -> None:
    d = doors_domain()
    goal = parse("reach(t)")
    assert type(new_plan_set(d, goal)) is OnlinePlanSet
    assert type(new_plan_set(d, goal, Replanning.NAIVE)) is NaivePlanSet
    assert type(new_plan_set(d, goal, mode=Replanning.ONLINE)) is OnlinePlanSet
    # Every mode has its class: the mode is a lookup, never a comparison.
    assert set(PLAN_SET_KINDS) == set(Replanning)
    # The shared base answers no event by itself: a plan set is one mode's or the other's.
    with pytest.raises(TypeError, match="abstract"):
        PlanSet(d, goal)  # type: ignore[abstract]


def test_a_fork_keeps_its_own_revival_store() -> None:
    _, ps, two = _shut_d1_then_d2(capacity=32)
    fork = ps.fork()
    assert isinstance(fork, OnlinePlanSet)
    fork.belief_changed(two, two.updated(delete=[parse("closed(d1)")]))
    assert len(fork.revival) == 1 and len(ps.revival) == 2
    assert ps.best is not None and ps.best.text() == ["pass(s,t,d3)"]


# -- the rewrites of kept plans are logged and applied when a plan is taken out ---------------------


def test_a_revived_plan_has_had_every_rewrite_since_it_was_kept_in_order() -> None:
    d = doors_domain()
    shut = State.from_facts([*d.facts, parse("at(s)"), parse("closed(d1)")], d.dynamic_predicates)
    opened = shut.updated(delete=[parse("closed(d1)")])
    store = Revival(d, window=2)  # a long log is caught up with past 4 × window rewrites

    def tag(n: int) -> Callable[[Plan], Plan]:
        return lambda p: Plan((Step(parse(f"mark({n})"), 0.0), *p.steps))

    store.rewrite(tag(0))  # nothing kept yet: not logged, never applied
    store.keep(Plan((Step(parse("pass(s,t,d1)"), 1.0),)), parse("pass(s,t,d1)"), shut)
    for n in range(1, 8):
        store.rewrite(tag(n))
    store.keep(Plan((Step(parse("pass(s,t,d1)"), 2.0),)), parse("pass(s,t,d1)"), shut)
    store.rewrite(tag(8))
    copy = store.copy()
    copy.rewrite(tag(9))  # the copy's own rewrite: the store does not get it
    first, second = store.revive(shut, opened)
    assert first.text() == [*(f"mark({n})" for n in range(8, 0, -1)), "pass(s,t,d1)"]
    assert second.text() == ["mark(8)", "pass(s,t,d1)"]
    assert [p.text()[0] for p in copy.plans] == ["mark(9)", "mark(9)"]
    assert len(store) == 0
