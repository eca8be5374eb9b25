"""Ground actions whose precondition binds a variable from the map (``move_area(A,B)``
finds its door's arc) run by ways worked out once per static fact base — and give
exactly what matching the precondition against the state gives, binding included.

The oracle is the operator itself: its first satisfier (SHOP's left-to-right order)
and its effects under that binding, on random beliefs.
"""

from __future__ import annotations

import random

import pytest

from htnagent.domains.maps import generate_map
from htnagent.domains.museum import areas_domain, areas_facts
from htnagent.model.domain import Domain
from htnagent.model.state import State
from htnagent.model.terms import Atom, parse


def _by_matching(d: Domain, state: State, action: Atom) -> frozenset[Atom] | None:
    op, bindings = d.actions.ground(action)
    full = op.applicable(state, bindings)
    return None if full is None else op.effects_on(state.dynamic, full)


def two_doors() -> Domain:
    """Rooms joined by two doors: the first open one (in the map's order) is taken, and
    passing marks it used — so which door was bound shows in the effects."""
    d = Domain("two doors")
    d.operator(
        "pass(?a,?b)",
        pre=["at(?a)", "door(?a,?b,?d)", "not shut(?d)"],
        add=["at(?b)", "used(?d)"],
        delete=["at(?a)"],
    )
    d.operator("close(?d)", add=["shut(?d)"])
    d.facts = (parse("door(r1,r2,front)"), parse("door(r1,r2,back)"))
    return d


def test_the_first_open_door_in_the_maps_order_is_taken() -> None:
    d = two_doors()
    compiled = d.actions.compiled(parse("pass(r1,r2)"))
    assert compiled.checks is None and compiled.static_bound
    base = State.from_facts([*d.facts, parse("at(r1)")], d.dynamic_predicates)
    for shut, used in [((), "front"), (("front",), "back"), (("back",), "front"), (("front", "back"), None)]:
        state = base.updated(add=[Atom("shut", (s,)) for s in shut])
        after = compiled.apply_dynamic(state)
        assert after == _by_matching(d, state, parse("pass(r1,r2)"))
        if used is None:
            assert after is None
        else:
            assert after is not None and Atom("used", (used,)) in after


def test_a_changed_map_gets_ways_of_its_own() -> None:
    d = two_doors()
    compiled = d.actions.compiled(parse("pass(r1,r2)"))
    state = State.from_facts([*d.facts, parse("at(r1)")], d.dynamic_predicates)
    assert compiled.apply_dynamic(state) is not None
    walled = state.updated(delete=[parse("door(r1,r2,front)"), parse("door(r1,r2,back)")])
    assert walled.static is not state.static
    assert compiled.apply_dynamic(walled) is None
    assert compiled.apply_dynamic(state) is not None


def test_a_variable_a_dynamic_fact_binds_is_matched_each_time() -> None:
    d = Domain("carry")
    d.operator("drop(?x)", pre=["holding(?x)", "here(?r)"], add=["in(?x,?r)"], delete=["holding(?x)"])
    d.operator("walk(?r)", add=["here(?r)"])
    compiled = d.actions.compiled(parse("drop(box)"))
    assert compiled.checks is None and not compiled.static_bound
    state = State.from_facts([parse("holding(box)"), parse("here(hall)")], d.dynamic_predicates)
    assert compiled.apply_dynamic(state) == _by_matching(d, state, parse("drop(box)"))


@pytest.mark.parametrize("seed", range(4))
def test_museum_areas_actions_agree_with_matching_on_random_beliefs(seed: int) -> None:
    rng = random.Random(seed)
    world = generate_map(rng.randint(2, 5), rng.randint(2, 5), 3, seed)
    d = areas_domain(world)
    areas = sorted(world.area_nodes)
    arcs = sorted({arc.name for _, _, arc in world.doors})
    nodes = sorted(world.nodes)
    for _ in range(60):
        facts = [*areas_facts(world, rng.choice(nodes))]
        facts += [Atom("closed", (a,)) for a in rng.sample(arcs, rng.randint(0, len(arcs)))]
        if rng.random() < 0.3:
            facts.append(Atom("moving", (rng.choice(areas), rng.choice(areas))))
        state = State.from_facts(facts, d.dynamic_predicates)
        a, b = rng.choice(areas), rng.choice(areas)
        for action in (Atom("move_area", (a, b)), Atom("goto_node", (rng.choice(nodes),))):
            compiled = d.actions.compiled(action)
            assert compiled.static_bound == (action.name == "move_area")  # the door's arc, from the map
            assert compiled.apply_dynamic(state) == _by_matching(d, state, action), action
