"""The domain model: fact bases and states, SHOP-style matching, self-checking operators and methods."""

from __future__ import annotations

import itertools
from collections.abc import Callable

import pytest

from htnagent.errors import DomainError, PlanningError
from htnagent.model.domain import (
    Domain,
    Effect,
    FactBase,
    Literal,
    Method,
    Operator,
    State,
    Suspension,
    satisfiers,
)
from htnagent.model.terms import Atom, parse
from htnagent.planning.planner import heuristic

StateAt = Callable[[Domain, str], State]


def _nav() -> Domain:
    """A tiny navigation domain: ``at`` is dynamic, ``edge`` and ``closed`` are static."""
    d = Domain("nav")
    d.operator(
        "move(?f,?t)",
        pre=["at(?f)", "edge(?f,?t)", "not closed(?f,?t)"],
        add=["at(?t)"],
        delete=["at(?f)"],
        cost=2.0,
        undo="move(?t,?f)",
    )
    d.operator("wait", cost=0.0)
    return d


def _state(domain: Domain, *facts: str) -> State:
    return State.from_facts(facts, domain.dynamic_predicates)


def _all(pre: list[str], state: State) -> list[dict[str, object]]:
    return [dict(b) for b in satisfiers([Literal.parse(p) for p in pre], state, {})]


# -- fact bases and states -----------------------------------------------------


def test_fact_base_answers_membership_and_candidates() -> None:
    fb = FactBase([parse("edge(a,b)"), parse("edge(a,c)"), parse("edge(b,c)"), parse("in(a,r1)")])
    assert parse("edge(a,b)") in fb
    assert parse("edge(b,a)") not in fb
    assert len(fb) == 4
    assert set(fb) == fb.facts
    assert set(fb.candidates("edge", None, "")) == {
        parse("edge(a,b)"),
        parse("edge(a,c)"),
        parse("edge(b,c)"),
    }
    assert set(fb.candidates("edge", 0, "a")) == {parse("edge(a,b)"), parse("edge(a,c)")}
    assert set(fb.candidates("edge", 1, "c")) == {parse("edge(a,c)"), parse("edge(b,c)")}
    assert fb.candidates("edge", 0, "z") == []
    assert fb.candidates("nothing", None, "") == []


def test_fact_base_changes_make_a_new_fact_base() -> None:
    fb = FactBase([parse("edge(a,b)")])
    fb.candidates("edge", 0, "a")  # build an index that must not leak into the copy
    changed = fb.with_changes(add=[parse("edge(a,c)")], delete=[parse("edge(a,b)")])
    assert changed.facts == {parse("edge(a,c)")}
    assert changed.candidates("edge", 0, "a") == [parse("edge(a,c)")]
    assert fb.facts == {parse("edge(a,b)")}
    assert fb.candidates("edge", 0, "a") == [parse("edge(a,b)")]


def test_a_start_belief_is_made_once_and_robots_at_other_starts_share_its_static_facts() -> None:
    d = _nav()
    d.world_facts = lambda start: [parse(f"at({start})"), parse("edge(a,b)"), parse("edge(b,a)")]
    at_a = d.initial_state("a")
    assert d.initial_state("a") is at_a  # a value: one for every robot on the map
    at_b = d.initial_state("b")
    assert at_b.dynamic == {parse("at(b)")} and at_a.dynamic == {parse("at(a)")}
    assert at_b.static is at_a.static  # one fact base: its indexes, an action's ways, made once
    # A domain still being built gives the start as it is now.
    d.world_facts = lambda start: [parse(f"at({start})"), parse("edge(a,b)")]
    assert d.initial_state("a").static.facts == {parse("edge(a,b)")}
    d.operator("shut(?f,?t)", pre=["edge(?f,?t)"], add=["closed(?f,?t)"])  # closed is dynamic now
    again = d.initial_state("a")
    assert "closed" in again.dynamic_predicates and again.static.facts == {parse("edge(a,b)")}


def test_state_splits_facts_into_dynamic_and_static() -> None:
    d = _nav()
    s = _state(d, "at(a)", "edge(a,b)", "closed(a,b)")
    assert d.dynamic_predicates == frozenset({"at"})
    assert s.dynamic == frozenset({parse("at(a)")})
    assert s.static.facts == {parse("edge(a,b)"), parse("closed(a,b)")}
    assert s.holds(parse("at(a)"))
    assert s.holds(parse("edge(a,b)"))
    assert not s.holds(parse("at(b)"))
    assert not s.holds(parse("edge(b,a)"))
    assert s.facts() == {parse("at(a)"), parse("edge(a,b)"), parse("closed(a,b)")}


def test_states_are_equal_by_their_facts() -> None:
    d = _nav()
    s1 = _state(d, "at(a)", "edge(a,b)")
    s2 = _state(d, "edge(a,b)", "at(a)")
    assert s1 == s2
    assert hash(s1) == hash(s2)
    assert s1 != _state(d, "at(b)", "edge(a,b)")
    assert s1 != _state(d, "at(a)", "edge(b,a)")


def test_match_binds_static_and_dynamic_facts() -> None:
    d = _nav()
    s = _state(d, "at(a)", "edge(a,b)", "edge(a,c)", "edge(b,c)")
    assert [dict(b) for b in s.match(parse("at(?x)"), {})] == [{"?x": "a"}]
    assert {b["?t"] for b in s.match(parse("edge(?f,?t)"), {"?f": "a"})} == {"b", "c"}
    assert {(b["?f"], b["?t"]) for b in s.match(parse("edge(?f,?t)"), {})} == {
        ("a", "b"),
        ("a", "c"),
        ("b", "c"),
    }
    assert list(s.match(parse("edge(?f,b)"), {"?f": "c"})) == []


def test_state_updated_changes_static_and_dynamic_facts_in_a_copy() -> None:
    d = _nav()
    s = _state(d, "at(a)", "edge(a,b)")
    closed = s.updated(add=[parse("closed(a,b)")])
    assert closed.holds(parse("closed(a,b)"))
    assert not s.holds(parse("closed(a,b)"))
    assert closed.static is not s.static
    assert d.apply(s, parse("move(a,b)")) is not None
    assert d.apply(closed, parse("move(a,b)")) is None
    moved = s.updated(add=[parse("at(b)")], delete=[parse("at(a)")])
    assert moved.dynamic == {parse("at(b)")}
    assert moved.static is s.static  # nothing static changed: the indexed facts are shared
    # Deleted first, then added: a fact both deleted and added stays.
    assert s.updated(add=[parse("at(a)")], delete=[parse("at(a)")]).holds(parse("at(a)"))


# -- SHOP-style matching of preconditions -------------------------------------


def test_literal_text_form() -> None:
    assert Literal.parse("not at(?x)") == Literal(parse("at(?x)"), positive=False)
    assert Literal.parse("  at(?x) ") == Literal(parse("at(?x)"))
    assert str(Literal.parse("not at(?x)")) == "not at(?x)"
    assert Literal.parse(parse("at(a)")) == Literal(parse("at(a)"))


def test_precondition_binds_left_to_right() -> None:
    d = _nav()
    s = _state(d, "at(a)", "edge(a,b)", "edge(a,c)", "edge(b,c)", "edge(c,a)")
    # at(?x) binds ?x first, so only edges leaving a are tried.
    got = _all(["at(?x)", "edge(?x,?y)"], s)
    assert sorted(b["?y"] for b in got) == ["b", "c"]  # type: ignore[type-var]
    assert all(b["?x"] == "a" for b in got)
    # The other order enumerates every edge and keeps those leaving the robot's node.
    assert sorted(map(str, (b["?y"] for b in _all(["edge(?x,?y)", "at(?x)"], s)))) == ["b", "c"]


def test_static_bindings_follow_the_order_of_the_belief() -> None:
    # SHOP tries the facts of the belief in their order, so ties between equal-cost plans
    # are broken the same way in every run (a frozenset's order changes with the hash seed).
    d = _nav()
    ends = ["e", "b", "d", "c"]
    for order in itertools.permutations(ends):
        s = _state(d, "at(a)", *(f"edge(a,{t})" for t in order))
        assert [b["?y"] for b in _all(["at(?x)", "edge(?x,?y)"], s)] == list(order)
        assert [b["?y"] for b in _all(["edge(?x,?y)"], s)] == list(order)


def test_dynamic_bindings_follow_the_text_order_of_the_facts() -> None:
    d = Domain("blocks")
    d.operator("pick(?b)", pre=["clear(?b)"], delete=["clear(?b)"])
    for order in itertools.permutations(["c", "a", "d", "b"]):
        s = _state(d, *(f"clear({b})" for b in order))
        assert [b["?b"] for b in _all(["clear(?b)"], s)] == ["a", "b", "c", "d"]


def test_negative_literal_filters_bound_variables() -> None:
    d = _nav()
    s = _state(d, "at(a)", "edge(a,b)", "edge(a,c)", "closed(a,b)")
    got = _all(["at(?x)", "edge(?x,?y)", "not closed(?x,?y)"], s)
    assert got == [{"?x": "a", "?y": "c"}]


def test_negative_literal_before_its_variables_are_bound_means_no_such_fact() -> None:
    d = _nav()
    s = _state(d, "at(a)", "edge(a,b)", "edge(a,c)", "closed(a,b)")
    # `not closed(?x,?y)` with ?x, ?y unbound: "no closed fact at all", which is false here.
    assert _all(["not closed(?x,?y)", "at(?x)", "edge(?x,?y)"], s) == []
    assert (
        len(_all(["not closed(?x,?y)", "at(?x)", "edge(?x,?y)"], s.updated(delete=[parse("closed(a,b)")])))
        == 2
    )


def test_negative_literal_on_dynamic_facts() -> None:
    d = _nav()
    s = _state(d, "at(a)")
    assert _all(["not at(b)"], s) == [{}]
    assert _all(["not at(a)"], s) == []
    assert _all(["not at(?x)"], s) == []
    assert _all(["not at(?x)"], _state(d)) == [{}]


def test_empty_precondition_holds_once() -> None:
    assert _all([], _state(_nav())) == [{}]


# -- operators and methods check themselves -----------------------------------


def test_operator_effect_with_unbound_variable_is_rejected() -> None:
    with pytest.raises(DomainError, match=r"move\(\?f,\?t\).*add effect at\(\?z\)"):
        Operator(parse("move(?f,?t)"), add=(parse("at(?z)"),))
    with pytest.raises(DomainError, match="delete effect"):
        Domain("d").operator("move(?f,?t)", delete=["at(?z)"])


def test_variable_bound_only_by_a_negative_literal_is_unbound() -> None:
    with pytest.raises(DomainError, match=r"\?z"):
        Domain("d").operator("drop(?x)", pre=["not holding(?z)"], add=["dropped(?z)"])


def test_precondition_variables_count_as_bound_in_effects() -> None:
    op = Domain("d").operator("step", pre=["at(?x)", "edge(?x,?y)"], add=["at(?y)"], delete=["at(?x)"])
    assert op.add == (parse("at(?y)"),)


def test_suspension_effect_with_unbound_variable_is_rejected() -> None:
    with pytest.raises(DomainError, match="suspension add"):
        Domain("d").operator("move(?f,?t)", add=["at(?t)"], suspend=Suspension(add=("on(?arc)",)))


def test_undo_with_unbound_variable_is_rejected() -> None:
    with pytest.raises(DomainError, match="undo"):
        Domain("d").operator("move(?f,?t)", pre=["via(?v)"], undo="move(?t,?v)")


@pytest.mark.parametrize("cost", [-1, float("nan"), float("inf")])
def test_a_cost_that_is_negative_or_not_a_number_is_rejected(cost: float) -> None:
    with pytest.raises(DomainError, match=f"cost {cost}: a cost is a finite number, not negative"):
        Domain("d").operator("wait", cost=cost)


@pytest.mark.parametrize("given", ["3", "nan", "inf"])
def test_cost_function_giving_a_negative_cost_or_not_a_number_is_rejected_when_costed(given: str) -> None:
    # A NaN cost was taken, and plans were then no longer in cost order (NaN compares
    # false with everything): the first plan found was not the cheapest.
    d = Domain("d")
    d.operator("pay(?x)", cost=lambda action: -float(str(action.args[0])))
    assert d.actions.cost(parse("pay(-2)")) == 2.0
    value = -float(given)
    with pytest.raises(DomainError, match=rf"cost {value} for pay\({given}\): a cost is a finite number"):
        d.actions.cost(parse(f"pay({given})"))


def test_method_subtask_with_unbound_variable_is_rejected() -> None:
    with pytest.raises(DomainError, match=r"method via of goto\(\?n\).*move\(\?x,\?y\)"):
        Domain("d").method("goto(?n)", "via", when=["at(?x)"], do=["move(?x,?y)"])
    with pytest.raises(DomainError):
        Method(parse("goto(?n)"), "via", (Literal.parse("not at(?y)"),), (parse("visit(?y)"),))


def test_primitive_and_compound_task_names_cannot_clash() -> None:
    d = Domain("d")
    d.operator("move(?f,?t)")
    with pytest.raises(DomainError, match="already a primitive"):
        d.method("move(?a,?b)", "m")
    d.method("goto(?n)", "m")
    with pytest.raises(DomainError, match="already a compound"):
        d.operator("goto(?n)")
    with pytest.raises(DomainError, match="primitive"):
        d.estimate("move", lambda task, state: 0.0)


def test_resume_and_rollback_are_reserved_names() -> None:
    for name in ("resume", "rollback"):
        with pytest.raises(DomainError, match="reserved"):
            Domain("d").operator(f"{name}(?a)")


def test_method_reads_as_when_then_do() -> None:
    m = Domain("d").method("goto(?n)", "step", when=["at(?x)", "not at(?n)"], do=["hop(?x)", "goto(?n)"])
    assert str(m) == "step: when at(?x), not at(?n) do hop(?x), goto(?n)"
    assert str(Domain("d").method("goto(?n)", "arrived")) == "arrived: when always do nothing"


# -- the domain: dynamic predicates, apply, suspend, undo ----------------------


def test_dynamic_predicates_are_those_some_effect_changes() -> None:
    d = _nav()
    assert d.dynamic_predicates == {"at"}
    d.operator("lock(?f,?t)", pre=["edge(?f,?t)"], add=["closed(?f,?t)"])
    assert d.dynamic_predicates == {"at", "closed"}


def test_suspension_effects_make_predicates_dynamic(nodes: Domain, areas: Domain) -> None:
    assert nodes.dynamic_predicates == {"at", "on_arc"}
    assert areas.dynamic_predicates == {"at", "moving", "visiting"}


def test_apply_progresses_the_dynamic_facts() -> None:
    d = _nav()
    s = _state(d, "at(a)", "edge(a,b)")
    after = d.apply(s, parse("move(a,b)"))
    assert after is not None
    assert after.dynamic == {parse("at(b)")}
    assert after.static is s.static
    assert s.dynamic == {parse("at(a)")}
    assert d.apply(s, parse("move(b,a)")) is None
    assert d.apply(s, parse("wait")) == s
    assert d.actions.cost(parse("move(a,b)")) == 2.0


def test_apply_of_an_unknown_action_raises() -> None:
    d = _nav()
    with pytest.raises(PlanningError, match="fly"):
        d.apply(_state(d, "at(a)"), parse("fly(a,b)"))
    with pytest.raises(PlanningError):
        d.actions.cost(parse("move(a,b,c)"))


def test_undo_of_names_the_inverse_action(nodes: Domain) -> None:
    d = _nav()
    assert d.actions.undo_of(parse("move(a,b)")) == parse("move(b,a)")
    assert d.actions.undo_of(parse("wait")) is None
    assert nodes.actions.undo_of(parse("move(n1,n6,arc5)")) == parse("move(n6,n1,arc5)")
    assert nodes.actions.undo_of(parse("resume(move(n40,n35,arc59))")) is None
    assert nodes.actions.undo_of(parse("rollback(move(n40,n35,arc59))")) is None


def test_suspending_a_move_leaves_the_robot_on_the_arc(nodes: Domain, state_at: StateAt) -> None:
    move = parse("move(n40,n35,arc59)")
    s = nodes.suspend(state_at(nodes, "n40"), move)
    assert s.dynamic == {parse("on_arc(arc59,n40,n35)")}
    resume, rollback = nodes.actions.resume_of(move), nodes.actions.rollback_of(move)
    assert resume == parse("resume(move(n40,n35,arc59))")
    assert rollback == parse("rollback(move(n40,n35,arc59))")
    resumed, rolled_back = nodes.apply(s, resume), nodes.apply(s, rollback)
    assert resumed is not None and resumed.dynamic == {parse("at(n35)")}
    assert rolled_back is not None and rolled_back.dynamic == {parse("at(n40)")}
    # Each half is costed at half the arc (the planner cannot know how far the robot got).
    assert nodes.actions.cost(resume) == pytest.approx(nodes.actions.cost(move) / 2)
    assert nodes.actions.cost(rollback) == pytest.approx(nodes.actions.cost(move) / 2)
    # Resume and rollback need the robot on that arc.
    assert nodes.apply(state_at(nodes, "n40"), resume) is None


def test_resume_is_blocked_by_a_closed_arc(nodes: Domain, state_at: StateAt) -> None:
    move = parse("move(n40,n35,arc59)")
    s = nodes.suspend(state_at(nodes, "n40"), move).updated(add=[parse("closed(arc59)")])
    assert nodes.apply(s, parse("resume(move(n40,n35,arc59))")) is None
    assert nodes.apply(s, parse("rollback(move(n40,n35,arc59))")) is not None


def test_parent_suspension_only_notes_the_move(areas: Domain, state_at: StateAt) -> None:
    move = parse("move_area(area8,area7)")
    s = areas.suspend(state_at(areas, "n40"), move)
    assert s.dynamic == {parse("at(area8)"), parse("moving(area8,area7)")}
    assert areas.actions.rollback_of(move) is None
    resumed = areas.apply(s, parse("resume(move_area(area8,area7))"))
    assert resumed is not None and resumed.dynamic == {parse("at(area7)")}


def test_only_suspendable_actions_can_be_suspended() -> None:
    d = _nav()
    with pytest.raises(PlanningError, match="not suspendable"):
        d.suspend(_state(d, "at(a)", "edge(a,b)"), parse("move(a,b)"))
    assert d.actions.resume_of(parse("move(a,b)")) is None
    assert d.actions.rollback_of(parse("move(a,b)")) is None


def test_resume_precondition_defaults_to_the_suspension_facts() -> None:
    d = Domain("d")
    d.operator(
        "fill(?tank)",
        add=["full(?tank)"],
        suspend=Suspension(
            add=("filling(?tank)",), resume=Effect(add=("full(?tank)",), delete=("filling(?tank)",))
        ),
    )
    (resume,) = d.operators["resume"]
    assert resume.pre == (Literal.parse("filling(?tank)"),)
    assert resume.cost == 1.0  # the action's own cost unless the effect gives one
    assert "rollback" not in d.operators


def test_initial_state_joins_domain_and_world_facts(nodes: Domain) -> None:
    s = nodes.initial_state("n1")
    assert s.dynamic == {parse("at(n1)")}
    assert s.holds(parse("arc(n1,n6,arc5)")) and s.holds(parse("arc(n6,n1,arc5)"))
    assert s.holds(parse("in_area(n40,area8)"))
    d = Domain("d", facts=(Atom("at", ("a",)), Atom("edge", ("a", "b"))))
    d.operator("move(?f,?t)", pre=["at(?f)", "edge(?f,?t)"], add=["at(?t)"], delete=["at(?f)"])
    assert d.initial_state().dynamic == {parse("at(a)")}
    assert d.initial_state("ignored without world facts").holds(parse("edge(a,b)"))


def test_estimate_is_the_first_compound_tasks_from_the_current_state() -> None:
    d = _nav()
    d.method("goto(?n)", "m")
    d.method("tour(?n)", "m")
    d.estimate("goto", lambda task, state: 3.0 if task == parse("goto(a)") else 5.0)
    s = _state(d, "at(a)")
    # Later compound tasks start elsewhere: their estimates from here could over-estimate.
    assert heuristic(d, [parse("goto(a)"), parse("move(a,b)"), parse("goto(b)")], s) == 3.0
    assert heuristic(d, [parse("move(a,b)"), parse("goto(b)")], s) == 5.0
    assert heuristic(d, [parse("tour(a)"), parse("goto(b)")], s) == 0.0  # no estimate for the first
    assert heuristic(_nav(), [parse("move(a,b)")], s) == 0.0
