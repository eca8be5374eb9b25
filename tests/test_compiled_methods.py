"""Compiled methods give exactly what matching the precondition against the state gives.

A method is compiled once into one function (``htnagent.model.preconditions.compile_method``);
the oracle is the generic form: the head unified with the task, every satisfier of
:func:`~htnagent.model.preconditions.all_satisfiers` in its order, the subtasks substituted.
Random methods over random beliefs: positive and negated literals, constants,
variables met twice, nested atoms, static and dynamic predicates, heads that do not
match.  Runs derandomized, so failures reproduce.
"""

from __future__ import annotations

from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from htnagent.model.preconditions import Literal, all_satisfiers, bound_by, compile_method
from htnagent.model.state import FactBase, State
from htnagent.model.terms import Atom, Term, substitute, unify

MANY = settings(
    max_examples=400,
    derandomize=True,
    deadline=None,
    suppress_health_check=[HealthCheck.too_slow],
)

CONSTANTS = ("a", "b", "c")
VARIABLES = ("?x", "?y", "?z", "?w")
PREDICATES = {"p": 1, "q": 2, "r": 3, "s": 2}


def _constant(draw: st.DrawFn) -> Term:
    if draw(st.integers(0, 9)) == 0:
        return Atom("f", (draw(st.sampled_from(CONSTANTS)),))  # now and then a nested atom
    return draw(st.sampled_from(CONSTANTS))


def _pattern_arg(draw: st.DrawFn) -> Term:
    kind = draw(st.integers(0, 9))
    if kind < 6:
        return draw(st.sampled_from(VARIABLES))
    if kind < 9:
        return draw(st.sampled_from(CONSTANTS))
    return Atom("f", (draw(st.sampled_from(VARIABLES)),))


@st.composite
def cases(draw: st.DrawFn) -> tuple[Atom, tuple[Literal, ...], tuple[Atom, ...], State, Atom]:
    """A method (head, precondition, subtasks), a belief and a task."""
    dynamic_predicates = frozenset(draw(st.sets(st.sampled_from(sorted(PREDICATES)))))
    facts: list[Atom] = []
    for name, arity in PREDICATES.items():
        for _ in range(draw(st.integers(0, 6))):
            facts.append(Atom(name, tuple(_constant(draw) for _ in range(arity))))
    if draw(st.booleans()):
        facts.append(Atom("q", (_constant(draw),)))  # the same name with another arity
    state = State(
        FactBase(f for f in facts if f.name not in dynamic_predicates),
        frozenset(f for f in facts if f.name in dynamic_predicates),
        dynamic_predicates,
    )
    head = Atom("t", tuple(_pattern_arg(draw) for _ in range(draw(st.integers(0, 2)))))
    pre = tuple(
        Literal(
            Atom(name, tuple(_pattern_arg(draw) for _ in range(PREDICATES[name]))),
            positive=draw(st.integers(0, 3)) > 0,
        )
        for name in draw(st.lists(st.sampled_from(sorted(PREDICATES)), max_size=4))
    )
    known = sorted(head.variables() | bound_by(pre))
    subtasks = tuple(
        Atom(
            draw(st.sampled_from(("u", "v"))),
            tuple(draw(st.sampled_from(known + list(CONSTANTS))) for _ in range(draw(st.integers(0, 3)))),
        )
        for _ in range(draw(st.integers(0, 3)))
    )
    task = Atom("t", tuple(_constant(draw) for _ in range(len(head.args))))
    if draw(st.integers(0, 9)) == 0:
        task = Atom("t", (*task.args, "a"))  # a task the head does not match
    return head, pre, subtasks, state, task


@MANY
@given(cases())
def test_a_compiled_method_gives_the_satisfiers_subtasks_in_order(
    case: tuple[Atom, tuple[Literal, ...], tuple[Atom, ...], State, Atom],
) -> None:
    head, pre, subtasks, state, task = case
    b = unify(head, task, {})
    expected = (
        []
        if b is None
        else [tuple(substitute(s, found) for s in subtasks) for found in all_satisfiers(pre, state, b)]
    )
    assert compile_method(head, pre, subtasks, state.dynamic_predicates)(task, state) == expected


def test_a_compiled_method_is_made_of_its_own_text_only() -> None:
    """Names and constants of the domain reach the compiled function as values, never as
    text: one that looks like code is only ever compared with."""
    sneaky = "x),__import__('os').system('false'),(y"
    head = Atom("t", ("?n",))
    pre = (Literal(Atom("p", ("?n", sneaky))), Literal(Atom(sneaky, ("?n",)), positive=False))
    subtasks = (Atom(sneaky, (sneaky, "?n")),)
    state = State(FactBase([Atom("p", ("a", sneaky))]), frozenset(), frozenset())
    run = compile_method(head, pre, subtasks, frozenset())
    assert run(Atom("t", ("a",)), state) == [(Atom(sneaky, (sneaky, "a")),)]
    assert run(Atom("t", ("b",)), state) == []


def test_a_precondition_too_long_for_one_python_function_is_matched_the_generic_way() -> None:
    """Python nests at most 20 loops in a function: 30 literals that each bind a variable
    still give their answer."""
    pre = tuple(Literal(Atom("next", (f"?v{i}", f"?v{i + 1}"))) for i in range(30))
    chain = FactBase(Atom("next", (f"c{i}", f"c{i + 1}")) for i in range(40))
    state = State(chain, frozenset(), frozenset())
    run = compile_method(Atom("t", ("?v0",)), pre, (Atom("end", ("?v30",)),), frozenset())
    assert run(Atom("t", ("c2",)), state) == [(Atom("end", ("c32",)),)]
    assert run(Atom("t", ("c20",)), state) == []
