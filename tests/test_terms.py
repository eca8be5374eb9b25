"""The text form ``name(arg,...)`` (docs/contracts.md) and SHOP-style unification."""

from __future__ import annotations

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from htnagent.errors import HtnAgentError, TextFormError
from htnagent.model.terms import Atom, Term, atoms, is_variable, parse, substitute, unify

# -- parsing and printing ------------------------------------------------------


@pytest.mark.parametrize(
    "text",
    [
        "goto(n1)",
        "at",
        "move(n40,n35,arc59)",
        "resume(move(n40,n35,arc59))",
        "rollback(move(n1,n6,arc5))",
        "f(g(h(a)),b,k(c,d))",
        "move(?f,?t,?a)",
        "in_area(n1,area1)",
    ],
)
def test_text_form_round_trips(text: str) -> None:
    assert str(parse(text)) == text


def test_nested_action_parses_into_nested_atoms() -> None:
    assert parse("resume(move(n40,n35,arc59))") == Atom("resume", (Atom("move", ("n40", "n35", "arc59")),))


def test_zero_argument_atom_is_written_without_parentheses() -> None:
    assert parse("at") == Atom("at")
    assert parse("at()") == Atom("at")
    assert str(Atom("at")) == "at"


def test_surrounding_whitespace_is_ignored() -> None:
    assert parse("  goto(n1)\n") == Atom("goto", ("n1",))


def test_atoms_accepts_text_and_atoms() -> None:
    assert atoms(["at(n1)", Atom("at", ("n2",))]) == (Atom("at", ("n1",)), Atom("at", ("n2",)))


@pytest.mark.parametrize(
    "text",
    [
        "",
        "   ",
        "goto(n 1)",
        "goto( n1)",
        "go to(n1)",
        "goto('n1')",
        'goto("n1")',
        "goto(n1",
        "resume(move(n40,n35,arc59)",
        "goto(n1))",
        "goto(n1)x",
        "goto(n1)(n2)",
        "goto(,n1)",
        "goto(n1,)",
        "(n1)",
        "goto((n1))",
        ")",
    ],
)
def test_malformed_text_raises_text_form_error(text: str) -> None:
    with pytest.raises(TextFormError):
        parse(text)


def test_text_form_error_is_a_value_error_and_an_htnagent_error() -> None:
    with pytest.raises(ValueError) as info:
        parse("goto(n1")
    assert isinstance(info.value, HtnAgentError)
    assert "goto(n1" in str(info.value)


def test_parse_rejects_non_text() -> None:
    with pytest.raises(TextFormError, match="int"):
        parse(3)  # type: ignore[arg-type]


# -- variables and unification -------------------------------------------------


def test_variables_are_found_at_any_depth() -> None:
    a = parse("resume(move(?f,n35,?a))")
    assert a.variables() == {"?f", "?a"}
    assert not a.is_ground
    assert parse("resume(move(n40,n35,arc59))").is_ground
    assert is_variable("?x")
    assert not is_variable("x")
    assert not is_variable(Atom("x"))


def test_unify_binds_variables() -> None:
    assert unify(parse("arc(?x,?y,?a)"), parse("arc(n1,n6,arc5)"), {}) == {
        "?x": "n1",
        "?y": "n6",
        "?a": "arc5",
    }


def test_unify_respects_existing_bindings() -> None:
    assert unify(parse("arc(?x,?y)"), parse("arc(n1,n6)"), {"?x": "n1"}) == {"?x": "n1", "?y": "n6"}
    assert unify(parse("arc(?x,?y)"), parse("arc(n1,n6)"), {"?x": "n2"}) is None


def test_repeated_variable_must_bind_the_same_value() -> None:
    assert unify(parse("same(?x,?x)"), parse("same(a,a)"), {}) == {"?x": "a"}
    assert unify(parse("same(?x,?x)"), parse("same(a,b)"), {}) is None


def test_unify_does_not_change_the_given_bindings() -> None:
    given_bindings: dict[str, Term] = {"?x": "n1"}
    out = unify(parse("arc(?x,?y)"), parse("arc(n1,n6)"), given_bindings)
    assert out == {"?x": "n1", "?y": "n6"}
    assert given_bindings == {"?x": "n1"}


@pytest.mark.parametrize(
    ("pattern", "ground"),
    [
        ("at(?x)", "on(n1)"),
        ("at(?x)", "at(n1,n2)"),
        ("at(n2)", "at(n1)"),
        ("resume(move(?f,?t,arc5))", "resume(move(n40,n35,arc59))"),
        ("resume(move(?f,?t,?a))", "resume(n40)"),
        ("resume(n40)", "resume(move(n40,n35,arc59))"),
    ],
)
def test_unify_fails_on_mismatch(pattern: str, ground: str) -> None:
    assert unify(parse(pattern), parse(ground), {}) is None


def test_unify_descends_into_nested_atoms() -> None:
    b = unify(parse("resume(move(?f,?t,?a))"), parse("resume(move(n40,n35,arc59))"), {})
    assert b == {"?f": "n40", "?t": "n35", "?a": "arc59"}


def test_a_variable_can_bind_a_whole_nested_atom() -> None:
    b = unify(parse("resume(?action)"), parse("resume(move(n40,n35,arc59))"), {})
    assert b == {"?action": parse("move(n40,n35,arc59)")}
    assert substitute(parse("rollback(?action)"), b) == parse("rollback(move(n40,n35,arc59))")


def test_substitute_leaves_unbound_variables() -> None:
    assert substitute(parse("move(?f,?t,?a)"), {"?f": "n1"}) == parse("move(n1,?t,?a)")
    assert substitute(parse("at"), {"?f": "n1"}) == parse("at")


# -- properties ------------------------------------------------------------------

_FIRST = "abcdefghijklmnopqrstuvwxyzABCDEFGHIJKLMNOPQRSTUVWXYZ0123456789_"
_NAMES = st.builds(
    lambda first, rest: first + rest,
    st.sampled_from(_FIRST),
    st.text(alphabet=_FIRST + "-.+?", max_size=6),
)


def _compound(children: st.SearchStrategy[Atom | str]) -> st.SearchStrategy[Atom]:
    # A nested atom needs at least one argument: `f(g)` cannot tell a zero-argument g from a constant.
    return st.builds(lambda n, args: Atom(n, tuple(args)), _NAMES, st.lists(children, min_size=1, max_size=4))


_TERMS: st.SearchStrategy[Atom | str] = st.recursive(_NAMES, _compound, max_leaves=12)
_ATOMS = st.one_of(_NAMES.map(Atom), _compound(_TERMS))


@settings(max_examples=300, derandomize=True)
@given(_ATOMS)
def test_printed_atoms_parse_back(a: Atom) -> None:
    text = str(a)
    assert parse(text) == a
    assert str(parse(text)) == text


def _leaves(term: Atom | str) -> list[str]:
    if isinstance(term, str):
        return [term]
    return [leaf for arg in term.args for leaf in _leaves(arg)]


def _abstract(term: Atom | str, constant: str) -> Atom | str:
    if isinstance(term, str):
        return "?v" if term == constant else term
    return Atom(term.name, tuple(_abstract(arg, constant) for arg in term.args))


@settings(max_examples=200, derandomize=True)
@given(_compound(_TERMS), st.data())
def test_unifying_an_abstracted_atom_gives_back_the_constant(a: Atom, data: st.DataObject) -> None:
    constant = data.draw(st.sampled_from(_leaves(a)))
    pattern = _abstract(a, constant)
    assert isinstance(pattern, Atom)
    b = unify(pattern, a, {})
    assert b is not None
    assert substitute(pattern, b) == a
    assert b == {"?v": constant}
