"""Property tests of plan maintenance on random maps and random update sequences."""

from __future__ import annotations

import random

from hypothesis import HealthCheck, example, given, settings
from hypothesis import strategies as st

from htnagent.domains import nodes_domain
from htnagent.domains.maps import generate_map
from htnagent.model.domain import Domain, Effect, State, Suspension
from htnagent.model.plans import Plan, Step, replay, tidy
from htnagent.model.terms import Atom, parse
from htnagent.planning.planner import PlannerSettings, plan
from htnagent.upkeep import Replanning, new_plan_set
from htnagent.upkeep.success import followed, moved_on, ran

OPS = st.sampled_from(["follow", "wander", "suspend", "close", "open", "fail"])


def _at(belief: State) -> str | None:
    for f in belief.dynamic:
        if f.name == "at":
            return str(f.args[0])
    return None


def _moves(domain: Domain, belief: State, node: str) -> list[Atom]:
    out = []
    for f in belief.static.candidates("arc", 0, node):
        action = Atom("move", f.args)
        if domain.apply(belief, action) is not None:
            out.append(action)
    return sorted(out)


@settings(max_examples=60, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(
    shape=st.tuples(st.integers(1, 2), st.integers(1, 3), st.integers(2, 3)),
    seed=st.integers(0, 10_000),
    ops=st.lists(OPS, min_size=1, max_size=25),
    k=st.integers(1, 4),
)
def test_kept_plans_stay_valid_and_agree_with_naive(
    shape: tuple[int, int, int], seed: int, ops: list[str], k: int
) -> None:
    cols, rows, side = shape
    world = generate_map(cols, rows, side, seed)
    domain = nodes_domain(world)
    rng = random.Random(seed)
    names = sorted(world.nodes)
    start, target = rng.choice(names), rng.choice(names)
    goal = Atom("goto_node", (target,))
    belief = domain.initial_state(start)
    online = new_plan_set(domain, goal, Replanning.ONLINE, PlannerSettings(alternatives=k))
    naive = new_plan_set(domain, goal, Replanning.NAIVE)
    # The same goal waiting on a stack (lazy): its rewrites are logged, and made when it is
    # about to run again -- here at random moments -- then re-checked from the belief.
    waiting = new_plan_set(domain, goal, Replanning.ONLINE, PlannerSettings(alternatives=k))
    online.make(belief)
    naive.make(belief)
    waiting.make(belief)
    waiting.lazy = True
    arcs = sorted(world.arcs)

    def everyone(event: str, *args: object) -> None:
        for ps in (online, naive, waiting):
            getattr(ps, event)(*args)

    for op in ops:
        here = _at(belief)
        if here is None:
            # The robot is on an arc: a suspended move must be resumed or rolled back first.
            half = next(f for f in belief.dynamic if f.name == "on_arc")
            arc, frm, to = (str(x) for x in half.args)
            inner = Atom("move", (frm, to, arc))
            options = [Atom("rollback", (inner,)), Atom("resume", (inner,))]
            action = next(o for o in options[:: rng.choice([1, -1])] if domain.apply(belief, o))
            after = domain.apply(belief, action)
            assert after is not None
            everyone("action_succeeded", action, belief, after)
            belief = after
        elif op == "follow" and online.best is not None and online.best.steps:
            action = online.best.steps[0].action
            after = domain.apply(belief, action)
            assert after is not None
            everyone("action_succeeded", action, belief, after)
            belief = after
        elif op in ("wander", "follow", "suspend", "fail"):
            moves = _moves(domain, belief, here)
            if not moves:
                continue
            action = rng.choice(moves)
            if op == "suspend":
                after = domain.suspend(belief, action)
                everyone("action_suspended", action, belief, after)
            elif op == "fail":
                after = belief
                everyone("action_failed", action, belief, after)
            else:
                after = domain.apply(belief, action)
                assert after is not None
                everyone("action_succeeded", action, belief, after)
            belief = after
        else:
            fact = Atom("closed", (rng.choice(arcs),))
            after = belief.updated(add=[fact]) if op == "close" else belief.updated(delete=[fact])
            everyone("belief_changed", belief, after)
            belief = after

        reachable = online.ensure(belief)
        assert naive.ensure(belief) == reachable
        if rng.random() < 0.3:  # the waiting goal runs again, for a moment
            waiting.lazy = False
            assert waiting.ensure(belief) == reachable
            for p in waiting.plans:
                end = replay(domain, belief, p.actions)
                assert end is not None and Atom("at", (target,)) in end.dynamic
            waiting.lazy = True
        optimum = plan(domain, belief, [goal], PlannerSettings(alternatives=1)).best
        assert (optimum is not None) == reachable
        for p in online.plans:
            end = replay(domain, belief, p.actions)
            assert end is not None, f"kept plan {p} is not valid from {belief}"
            assert Atom("at", (target,)) in end.dynamic
        if reachable:
            best = online.best
            assert best is not None and optimum is not None
            assert best.cost >= optimum.cost - 1e-9
            costs = [p.cost for p in online.plans]
            assert costs == sorted(costs)


# -- a waiting goal's plans take an emergency's actions all at once --------------------------


def _walker() -> Domain:
    """go(X,Y) has an undo, go(Y,X), a resume and a rollback; hop(X,Y) has none."""
    d = Domain("walker")
    d.operator(
        "go(?x,?y)",
        pre=["at(?x)"],
        add=["at(?y)"],
        delete=["at(?x)"],
        cost=2.0,
        suspend=Suspension(
            add=("heading(?x,?y)",),
            cleared=("heading(?x,?y)",),
            resume=Effect(
                pre=("heading(?x,?y)",), add=("at(?y)",), delete=("at(?x)", "heading(?x,?y)"), cost=1.0
            ),
            rollback=Effect(pre=("heading(?x,?y)",), delete=("heading(?x,?y)",), cost=1.0),
        ),
        undo="go(?y,?x)",
    )
    d.operator("hop(?x,?y)", pre=["at(?x)"], add=["at(?y)"], delete=["at(?x)"], cost=5.0)
    return d


WALKER = _walker()
PLACES = ["a", "b", "c"]
KINDS = ["go", "hop", "resume", "rollback"]


def _walk(kind: str, x: str, y: str) -> Atom:
    return parse(f"{kind}(go({x},{y}))" if kind in ("resume", "rollback") else f"{kind}({x},{y})")


@settings(max_examples=200, deadline=None)
@given(
    plans=st.lists(
        st.lists(
            st.tuples(st.sampled_from(KINDS), st.sampled_from(PLACES), st.sampled_from(PLACES)),
            max_size=6,
        ),
        max_size=3,
    ),
    moves=st.lists(
        st.tuples(st.sampled_from(KINDS), st.sampled_from(PLACES), st.sampled_from(PLACES)),
        max_size=8,
    ),
)
# Behind an undo, another goal's rollback(go(a,b)) leaves rollback(go(b,c)) meeting go(b,c):
# the tidy-up makes resume(go(b,c)), costed alike both ways (it once was not).
@example(
    plans=[[("rollback", "b", "c"), ("rollback", "a", "b"), ("go", "b", "c")]],
    moves=[("go", "c", "a"), ("rollback", "a", "b")],
)
def test_a_waiting_goal_takes_the_actions_at_once_as_one_by_one(
    plans: list[list[tuple[str, str, str]]], moves: list[tuple[str, str, str]]
) -> None:
    """``followed`` (one pass) gives the plans and done steps that §2.1's rewrite, action by
    action, gives: undo steps in front, cancelled where they meet their action (§2.6), a
    resume behind an undo costed as the whole action, the plan that ran an action moving on,
    and a suspension another goal resumed or rolled back settled in the others."""
    actions = WALKER.actions

    def step(kind: str, x: str, y: str) -> Step:
        action = _walk(kind, x, y)
        return Step(action, actions.cost(action), None)

    # Kept plans are tidy (§2.6: the planner and every rewrite tidy them up), which the
    # rewrites count on: generated plans are tidied first.
    kept = [Plan(tidy(WALKER, tuple(step(*s) for s in p))) for p in plans]
    logged = [moved_on(WALKER, _walk(*m)) for m in moves]
    one_by_one, done = list(kept), []
    for move in logged:
        if (s := ran(one_by_one, move.action)) is not None:
            done.append(s)
        one_by_one = [move(p) or p for p in one_by_one]
    at_once, ran_steps = followed(WALKER, kept, logged)
    assert [p.steps for p in at_once] == [p.steps for p in one_by_one]
    assert ran_steps == done
