"""Reading total-order HDDL (the IPC's HTN language) into :mod:`htnagent.hddl.model`.

:func:`read_domain` and :func:`read_problem` read files the way scenario files
are read (regular files only, the size bound of :mod:`htnagent.limits`;
:func:`htnagent.files.read_text`); :func:`parse_domain` and
:func:`parse_problem` take the text.  Each answers with a model that has passed
the semantic checks of :mod:`htnagent.hddl.semantics`, or raises one
:class:`~htnagent.errors.HddlError`, ``FILE:LINE:COL: reason``.

What is read: sections in any order; ``:requirements``, ``:types`` (with
supertypes, ``either`` too; a supertype named but not declared is declared by
naming it, as PDDL readers do), ``:constants``, ``:predicates``, ``:task``,
``:action`` and ``:method`` in the domain; ``:objects``, ``:htn``, ``:init``
and ``:goal`` in the problem.  A method's subtasks are ``:ordered-subtasks``
(``:ordered-tasks``), or ``:subtasks`` (``:tasks``) with an ``:ordering`` that
orders them totally -- turned into that order; anything less is refused,
naming the method and two subtasks left unordered.  Preconditions and goals
are formulas with ``and``, ``or``, ``not``, ``=``, ``imply``, ``forall``,
``exists``; effects have ``and``, ``not``, ``forall`` and ``when``.  Numeric
fluents and action costs (``:functions``, ``increase``) are refused: no IPC
total-order domain uses them.
"""

from __future__ import annotations

import re
from collections.abc import Iterable, Iterator
from pathlib import Path

from htnagent.errors import HddlError, ScenarioError, shown
from htnagent.files import gc_paused, read_text
from htnagent.hddl.model import (
    NO_EFFECT,
    OBJECT,
    TRUE,
    Action,
    And,
    AndEffect,
    Domain,
    Effect,
    Equals,
    Exists,
    Forall,
    ForallEffect,
    Formula,
    Imply,
    Literal,
    Method,
    Not,
    Or,
    Pred,
    Predicate,
    Problem,
    SortOf,
    Source,
    Subtask,
    Task,
    Typed,
    When,
)
from htnagent.hddl.semantics import check_domain, check_problem
from htnagent.hddl.sexpr import SExpr, SList, parse, text_of
from htnagent.model.terms import Atom

__all__ = ["parse_domain", "parse_problem", "read_domain", "read_file", "read_problem"]

_NAME = re.compile(r"[a-z][a-z0-9_\-]*")
_VARIABLE = re.compile(r"\?[a-z][a-z0-9_\-]*")


def read_domain(path: str | Path, max_bytes: int | None = None) -> Domain:
    """The checked domain in the HDDL file at ``path``."""
    return parse_domain(read_file(path, "HDDL domain", max_bytes), str(path))


def read_problem(path: str | Path, domain: Domain, max_bytes: int | None = None) -> Problem:
    """The problem in the HDDL file at ``path``, checked against ``domain``."""
    return parse_problem(read_file(path, "HDDL problem", max_bytes), domain, str(path))


def parse_domain(text: str, file: str = "<domain>") -> Domain:
    """The checked domain an HDDL text defines (``file`` names it in messages)."""
    source = Source(file, text)
    with gc_paused():
        domain = _Reader(source).domain(_definition(source, "domain"))
    check_domain(domain)
    return domain


def parse_problem(text: str, domain: Domain, file: str = "<problem>") -> Problem:
    """The problem an HDDL text defines, checked against ``domain``."""
    source = Source(file, text)
    with gc_paused():
        problem = _Reader(source).problem(_definition(source, "problem"))
    check_problem(domain, problem)
    return problem


def read_file(path: str | Path, what: str, max_bytes: int | None = None) -> str:
    """The text of a file a user names (a regular file, within the size bound), or HddlError.

    Line ends are made ``\n``: a file written with ``\r`` alone (old Mac style) would
    otherwise be one line, its first ``;`` comment running to the end of the file."""
    try:
        text = read_text(path, what, max_bytes)
    except ScenarioError as e:  # the reading of scenario files, said the HDDL way
        line = int(e.where[5:]) if e.where.startswith("line ") and e.where[5:].isdigit() else None
        raise HddlError(e.file, e.reason, line) from None
    return text.replace("\r\n", "\n").replace("\r", "\n") if "\r" in text else text


def _definition(source: Source, kind: str) -> SList:
    """The one ``(define (KIND name) ...)`` of the file."""
    top = parse(source)
    if not top.items:
        raise source.error(None, f"the file is empty (or only comments); expected an HDDL {kind}")
    first = top.items[0]
    if isinstance(first, str) or not first.items or first.items[0] != "define":
        raise source.error(top.ats[0], f"expected (define ({kind} NAME) ...), got {text_of(first)}")
    if len(top.items) > 1:
        extra = top.items[1]
        raise source.error(top.ats[1], f"unexpected {text_of(extra)} after the end of the {kind} definition")
    return first


class _Reader:
    """Lists to model elements, each failure an HddlError at the offending item."""

    def __init__(self, source: Source) -> None:
        self.source = source

    def error(self, at: int, reason: str) -> HddlError:
        return self.source.error(at, reason)

    # -- small pieces ------------------------------------------------------------------------------

    def name(self, node: SList, i: int, what: str) -> str:
        """Item ``i`` of ``node``: a name (letters, digits, ``-``, ``_``; a letter first)."""
        if i >= len(node.items):
            raise self.error(node.end, f"{what} is missing before ')'")
        item = node.items[i]
        if isinstance(item, SList):
            raise self.error(item.at, f"expected {what}, got a list {text_of(item)}")
        if _NAME.fullmatch(item) is None:
            raise self.error(
                node.ats[i],
                f"expected {what}, got {shown(item)} (a name is a letter, then letters, digits, '-' or '_')",
            )
        return item

    def term(self, node: SList, i: int) -> str:
        """Item ``i``: a variable ``?x`` or a name."""
        item = node.items[i]
        if isinstance(item, SList):
            raise self.error(item.at, f"expected a variable or a constant, got a list {text_of(item)}")
        if _NAME.fullmatch(item) is None and _VARIABLE.fullmatch(item) is None:
            raise self.error(node.ats[i], f"expected a variable or a constant, got {shown(item)}")
        return item

    def slist(self, node: SList, i: int, what: str) -> SList:
        if i >= len(node.items):
            raise self.error(node.end, f"{what} is missing before ')'")
        item = node.items[i]
        if isinstance(item, str):
            raise self.error(node.ats[i], f"expected {what} in parentheses, got {shown(item)}")
        return item

    def keyed(self, node: SList, start: int, keys: Iterable[str], what: str) -> dict[str, tuple[SExpr, int]]:
        """``:key value`` pairs from item ``start`` on; each key at most once, only ``keys``."""
        allowed = set(keys)
        found: dict[str, tuple[SExpr, int]] = {}
        i = start
        items = node.items
        while i < len(items):
            key = items[i]
            at = node.ats[i]
            if isinstance(key, SList) or not key.startswith(":"):
                raise self.error(
                    at, f"expected a keyword of {what} ({', '.join(sorted(allowed))}), got {text_of(key)}"
                )
            if key not in allowed:
                raise self.error(at, f"{what} has no {key} (expected one of {', '.join(sorted(allowed))})")
            if key in found:
                raise self.error(at, f"{key} is given twice in {what}")
            if i + 1 >= len(items):
                raise self.error(at, f"{key} has no value")
            found[key] = (items[i + 1], node.ats[i + 1])
            i += 2
        return found

    def typed_list(self, node: SList, start: int, variables: bool, what: str) -> tuple[Typed, ...]:
        """``a b - t c - (either t u) d`` from item ``start`` on (untyped names are objects)."""
        out: list[Typed] = []
        pending: list[tuple[str, int]] = []
        items = node.items
        i = start
        seen: dict[str, int] = {}
        while i < len(items):
            item = items[i]
            at = node.ats[i]
            if item == "-":
                if not pending:
                    raise self.error(at, f"'-' with nothing before it (expected {what}, then '- type')")
                if i + 1 >= len(items):
                    raise self.error(at, "'-' with no type after it")
                types = self.type_ref(node, i + 1)
                out.extend(Typed(n, types, a) for n, a in pending)
                pending = []
                i += 2
                continue
            if isinstance(item, SList):
                raise self.error(item.at, f"expected {what}, got a list {text_of(item)}")
            pattern = _VARIABLE if variables else _NAME
            if pattern.fullmatch(item) is None:
                hint = "a variable such as ?x" if variables else "a name"
                raise self.error(at, f"expected {what} ({hint}), got {shown(item)}")
            if item in seen:
                line, col = self.source.where(seen[item])
                raise self.error(at, f"{item} is declared twice in this list (first at {line}:{col})")
            seen[item] = at
            pending.append((item, at))
            i += 1
        out.extend(Typed(n, (OBJECT,), a) for n, a in pending)
        return tuple(out)

    def type_ref(self, node: SList, i: int) -> tuple[str, ...]:
        """A type after '-': a name, or ``(either t ...)``."""
        item = node.items[i]
        if isinstance(item, str):
            return (self.name(node, i, "a type name"),)
        if not item.items or item.items[0] != "either":
            raise self.error(item.at, f"expected a type name or (either ...), got {text_of(item)}")
        if len(item.items) < 2:
            raise self.error(item.at, "(either) names no type")
        return tuple(dict.fromkeys(self.name(item, j, "a type name") for j in range(1, len(item.items))))

    def call(self, node: SList, what: str) -> Atom:
        """``(name term ...)``: a task, predicate or fact."""
        name = self.name(node, 0, what)
        return Atom(name, tuple(self.term(node, j) for j in range(1, len(node.items))))

    # -- formulas ------------------------------------------------------------------------------------

    def formula(self, item: SExpr, at: int, constraints: bool = False) -> Formula:
        if isinstance(item, str):
            raise self.error(at, f"expected a formula in parentheses, got {shown(item)}")
        items = item.items
        if not items:
            return And((), item.at)
        head = items[0]
        if isinstance(head, SList):
            raise self.error(
                head.at, f"expected a predicate or and, or, not, ..., got a list {text_of(head)}"
            )
        if head == "and":
            return And(tuple(self.formula(x, a, constraints) for x, a in self.rest(item)), item.at)
        if head == "or":
            return Or(tuple(self.formula(x, a, constraints) for x, a in self.rest(item)), item.at)
        if head == "not":
            self.count(item, 1, "not")
            return Not(self.formula(items[1], item.ats[1], constraints), item.at)
        if head == "imply":
            self.count(item, 2, "imply")
            cond = self.formula(items[1], item.ats[1], constraints)
            return Imply(cond, self.formula(items[2], item.ats[2], constraints), item.at)
        if head in ("forall", "exists"):
            self.count(item, 2, head)
            params = self.typed_list(self.slist(item, 1, "the quantified variables"), 0, True, "a variable")
            body = self.formula(items[2], item.ats[2], constraints)
            return (Forall if head == "forall" else Exists)(params, body, item.at)
        if head == "=":
            self.count(item, 2, "=")
            return Equals(self.term(item, 1), self.term(item, 2), item.at)
        if head in ("sortof", "typeof") and constraints:
            params = self.typed_list(item, 1, True, "a variable")
            if len(params) != 1:
                raise self.error(item.at, f"({head} ?v - type) names one variable and its type")
            return SortOf(params[0].name, params[0].types, item.at)
        if head in ("when", "increase", "decrease", "assign", "scale-up", "scale-down"):
            raise self.error(item.at, f"({head} ...) is an effect, not a condition")
        if head in ("<", ">", "<=", ">="):
            raise self.error(item.at, f"numeric comparisons ({head} ...) are not supported")
        return Pred(self.call(item, "a predicate name"), item.at)

    def rest(self, node: SList) -> Iterator[tuple[SExpr, int]]:
        return zip(node.items[1:], node.ats[1:], strict=True)

    def count(self, node: SList, n: int, head: str) -> None:
        if len(node.items) - 1 != n:
            noun = "part" if n == 1 else "parts"
            raise self.error(node.at, f"({head} ...) takes {n} {noun}, got {len(node.items) - 1}")

    def effect(self, item: SExpr, at: int) -> Effect:
        if isinstance(item, str):
            raise self.error(at, f"expected an effect in parentheses, got {shown(item)}")
        items = item.items
        if not items:
            return AndEffect((), item.at)
        head = items[0]
        if isinstance(head, SList):
            raise self.error(
                head.at, f"expected a predicate or and, not, forall, when, got a list {text_of(head)}"
            )
        if head == "and":
            return AndEffect(tuple(self.effect(x, a) for x, a in self.rest(item)), item.at)
        if head == "not":
            self.count(item, 1, "not")
            inner = self.slist(item, 1, "the deleted fact")
            if not inner.items or inner.items[0] in _KEYWORDS:
                raise self.error(inner.at, f"(not ...) in an effect deletes a fact; got {text_of(inner)}")
            return Literal(self.call(inner, "a predicate name"), False, item.at)
        if head == "forall":
            self.count(item, 2, "forall")
            params = self.typed_list(self.slist(item, 1, "the quantified variables"), 0, True, "a variable")
            return ForallEffect(params, self.effect(items[2], item.ats[2]), item.at)
        if head == "when":
            self.count(item, 2, "when")
            cond = self.formula(items[1], item.ats[1])
            return When(cond, self.effect(items[2], item.ats[2]), item.at)
        if head in ("increase", "decrease", "assign", "scale-up", "scale-down"):
            raise self.error(item.at, f"numeric effects ({head} ...) and action costs are not supported")
        if head in _KEYWORDS:
            raise self.error(item.at, f"({head} ...) cannot be an effect")
        return Literal(self.call(item, "a predicate name"), True, item.at)

    # -- task networks --------------------------------------------------------------------------------

    def subtasks(self, item: SExpr, at: int) -> tuple[Subtask, ...]:
        """``()``, ``(and st ...)`` or one ``st``: ``(name args)`` or ``(id (name args))``."""
        if isinstance(item, str):
            raise self.error(at, f"expected subtasks in parentheses, got {shown(item)}")
        if not item.items:
            return ()
        if item.items[0] == "and":
            parts = list(self.rest(item))
        else:
            parts = [(item, item.at)]
        out: list[Subtask] = []
        ids: dict[str, int] = {}
        for part, part_at in parts:
            if isinstance(part, str):
                raise self.error(
                    part_at, f"expected a subtask (name args) or (id (name args)), got {shown(part)}"
                )
            if len(part.items) == 2 and isinstance(part.items[1], SList):
                ident = self.name(part, 0, "a subtask id")
                if ident in ids:
                    line, col = self.source.where(ids[ident])
                    raise self.error(part.at, f"subtask id {ident} is used twice (first at {line}:{col})")
                ids[ident] = part.at
                call = part.items[1]
                out.append(Subtask(self.call(call, "a task name"), ident, call.at))
            else:
                out.append(Subtask(self.call(part, "a task name"), None, part.at))
        return tuple(out)

    def network(self, keys: dict[str, tuple[SExpr, int]], what: str, at: int) -> tuple[Subtask, ...]:
        """The subtasks of a method or of ``:htn``, in their total order."""
        ordered = [k for k in (":ordered-subtasks", ":ordered-tasks") if k in keys]
        unordered = [k for k in (":subtasks", ":tasks") if k in keys]
        given = ordered + unordered
        if len(given) > 1:
            raise self.error(
                keys[given[1]][1], f"{what} gives its subtasks twice ({given[0]} and {given[1]})"
            )
        if not given:
            if ":ordering" in keys:
                raise self.error(keys[":ordering"][1], f"{what} has an :ordering but no :subtasks")
            return ()
        tasks = self.subtasks(*keys[given[0]])
        if ordered:
            if ":ordering" in keys:
                raise self.error(
                    keys[":ordering"][1], f"{what} has :ordered-subtasks; an :ordering is not needed"
                )
            return tasks
        constraints = self.ordering(*keys[":ordering"]) if ":ordering" in keys else []
        return self.total_order(tasks, constraints, what, at)

    def ordering(self, item: SExpr, at: int) -> list[tuple[str, str, int]]:
        """``()``, ``(and (< a b) ...)`` or ``(< a b)``: the pairs (before, after, where)."""
        if isinstance(item, str):
            raise self.error(at, f"expected ordering constraints in parentheses, got {shown(item)}")
        if not item.items:
            return []
        parts = list(self.rest(item)) if item.items[0] == "and" else [(item, item.at)]
        out: list[tuple[str, str, int]] = []
        for part, part_at in parts:
            if isinstance(part, str) or len(part.items) != 3 or part.items[0] not in ("<", ">"):
                raise self.error(part_at, f"expected an ordering constraint (< id1 id2), got {text_of(part)}")
            a = self.name(part, 1, "a subtask id")
            b = self.name(part, 2, "a subtask id")
            out.append((a, b, part.at) if part.items[0] == "<" else (b, a, part.at))
        return out

    def total_order(
        self, tasks: tuple[Subtask, ...], pairs: list[tuple[str, str, int]], what: str, at: int
    ) -> tuple[Subtask, ...]:
        """The subtasks in the one order ``pairs`` allow; refused if they allow none or several."""
        if len(tasks) <= 1 and not pairs:
            return tasks
        by_id: dict[str, int] = {}
        for i, t in enumerate(tasks):
            if t.id is None:
                raise self.error(
                    t.at, f"{what}: a subtask of :subtasks with several subtasks needs an id for :ordering"
                )
            by_id[t.id] = i
        after: list[set[int]] = [set() for _ in tasks]
        before_count = [0] * len(tasks)
        for a, b, where in pairs:
            for x in (a, b):
                if x not in by_id:
                    raise self.error(where, f"{what}: the ordering names {x}, which is no subtask id")
            i, j = by_id[a], by_id[b]
            if i == j:
                raise self.error(where, f"{what}: {a} cannot come before itself")
            if j not in after[i]:
                after[i].add(j)
                before_count[j] += 1
        order: list[int] = []
        ready = [i for i, n in enumerate(before_count) if n == 0]
        while ready:
            if len(ready) > 1:
                first, second = sorted(ready)[:2]
                raise self.error(
                    at,
                    f"{what}: its subtasks are only partially ordered ({tasks[first].id} and "
                    f"{tasks[second].id} may come in either order); only total-order HDDL is read",
                )
            i = ready.pop()
            order.append(i)
            for j in sorted(after[i]):
                before_count[j] -= 1
                if before_count[j] == 0:
                    ready.append(j)
        if len(order) < len(tasks):
            stuck = next(tasks[i].id for i, n in enumerate(before_count) if n > 0)
            raise self.error(at, f"{what}: the ordering has a cycle (through {stuck})")
        return tuple(tasks[i] for i in order)

    # -- the domain -------------------------------------------------------------------------------------

    def header(self, define: SList, kind: str) -> str:
        head = self.slist(define, 1, f"({kind} NAME)")
        if len(head.items) != 2 or head.items[0] != kind:
            raise self.error(head.at, f"expected ({kind} NAME), got {text_of(head)}")
        return self.name(head, 1, f"the {kind}'s name")

    def sections(self, define: SList, kind: str, allowed: dict[str, bool]) -> Iterator[tuple[str, SList]]:
        """Each ``(:section ...)`` of the definition; ``allowed`` maps a section to whether it may repeat."""
        seen: dict[str, int] = {}
        for i in range(2, len(define.items)):
            section = self.slist(define, i, f"a section such as ({next(iter(allowed))} ...)")
            key = section.items[0] if section.items else ""
            if isinstance(key, SList) or not key.startswith(":"):
                raise self.error(section.at, f"expected a section (:keyword ...), got {text_of(section)}")
            if key not in allowed:
                if key in _NUMERIC_SECTIONS:
                    raise self.error(section.at, f"{key} (numeric fluents, action costs) is not supported")
                raise self.error(section.at, f"a {kind} has no {key} section (expected {', '.join(allowed)})")
            if not allowed[key] and key in seen:
                line, col = self.source.where(seen[key])
                raise self.error(section.at, f"a second {key} section (the first is at {line}:{col})")
            seen[key] = section.at
            yield key, section

    def domain(self, define: SList) -> Domain:
        name = self.header(define, "domain")
        requirements: list[str] = []
        types: dict[str, tuple[str, ...]] = {}
        type_at: dict[str, int] = {}
        constants: list[Typed] = []
        predicates: dict[str, Predicate] = {}
        tasks: dict[str, Task] = {}
        actions: dict[str, Action] = {}
        methods: dict[str, Method] = {}
        where: dict[str, int] = {}  # every task and action name: tasks and actions share one name space
        for key, section in self.sections(define, "domain", _DOMAIN_SECTIONS):
            if key == ":requirements":
                requirements += self.requirements(section)
            elif key == ":types":
                for t in self.typed_list(section, 1, False, "a type name"):
                    if t.name in types:
                        raise self.twice(t.at, "type", t.name, type_at[t.name])
                    if t.name == OBJECT and t.types != (OBJECT,):
                        raise self.error(t.at, "the type object is the root; it has no supertype")
                    types[t.name] = () if t.name == OBJECT else t.types
                    type_at[t.name] = t.at
            elif key == ":constants":
                constants += self.typed_list(section, 1, False, "a constant")
            elif key == ":predicates":
                for j in range(1, len(section.items)):
                    p = self.slist(section, j, "a predicate (name ?x - type ...)")
                    pname = self.name(p, 0, "a predicate name")
                    if pname in predicates:
                        raise self.twice(p.at, "predicate", pname, predicates[pname].at)
                    predicates[pname] = Predicate(pname, self.typed_list(p, 1, True, "a parameter"), p.at)
            elif key == ":task":
                task = self.task(section)
                self.new_operation(task.name, section.at, where)
                tasks[task.name] = task
            elif key == ":action":
                action = self.action(section)
                self.new_operation(action.name, section.at, where)
                actions[action.name] = action
            else:
                method = self.method(section)
                if method.name in methods:
                    raise self.twice(section.at, "method", method.name, methods[method.name].at)
                methods[method.name] = method
        for parents in list(types.values()):  # a supertype named only after '-' is declared by naming it
            for parent in parents:
                types.setdefault(parent, (OBJECT,) if parent != OBJECT else ())
        types.setdefault(OBJECT, ())
        self.no_cycle(types, type_at)
        return Domain(
            name,
            tuple(dict.fromkeys(requirements)),
            types,
            tuple(constants),
            predicates,
            tasks,
            actions,
            methods,
            self.source,
        )

    def no_cycle(self, types: dict[str, tuple[str, ...]], type_at: dict[str, int]) -> None:
        for name, parents in types.items():
            seen = {name}
            todo = list(parents)
            while todo:
                t = todo.pop()
                if t == name:
                    raise self.error(type_at.get(name, 0), f"type {name} is its own supertype (a cycle)")
                if t not in seen:
                    seen.add(t)
                    todo.extend(types.get(t, ()))

    def twice(self, at: int, kind: str, name: str, first: int) -> HddlError:
        line, col = self.source.where(first)
        return self.error(at, f"{kind} {name} is declared twice (first at {line}:{col})")

    def new_operation(self, name: str, at: int, where: dict[str, int]) -> None:
        if name in where:
            line, col = self.source.where(where[name])
            raise self.error(at, f"task or action {name} is declared twice (first at {line}:{col})")
        where[name] = at

    def requirements(self, section: SList) -> list[str]:
        out: list[str] = []
        for j in range(1, len(section.items)):
            item = section.items[j]
            if isinstance(item, SList) or not item.startswith(":") or _NAME.fullmatch(item[1:]) is None:
                raise self.error(
                    section.ats[j], f"expected a requirement such as :typing, got {text_of(item)}"
                )
            out.append(item)
        return out

    def parameters(self, keys: dict[str, tuple[SExpr, int]]) -> tuple[Typed, ...]:
        if ":parameters" not in keys:
            return ()
        item, at = keys[":parameters"]
        if isinstance(item, str):
            raise self.error(at, f"expected a parameter list (?x - type ...), got {shown(item)}")
        return self.typed_list(item, 0, True, "a parameter")

    def task(self, section: SList) -> Task:
        name = self.name(section, 1, "the task's name")
        keys = self.keyed(section, 2, (":parameters",), f"task {name}")
        return Task(name, self.parameters(keys), section.at)

    def action(self, section: SList) -> Action:
        name = self.name(section, 1, "the action's name")
        keys = self.keyed(section, 2, (":parameters", ":precondition", ":effect"), f"action {name}")
        pre = self.formula(*keys[":precondition"]) if ":precondition" in keys else TRUE
        eff = self.effect(*keys[":effect"]) if ":effect" in keys else NO_EFFECT
        return Action(name, self.parameters(keys), pre, eff, section.at)

    def method(self, section: SList) -> Method:
        name = self.name(section, 1, "the method's name")
        what = f"method {name}"
        keys = self.keyed(section, 2, _METHOD_KEYS, what)
        if ":task" not in keys:
            raise self.error(section.at, f"{what} has no :task")
        task_item, task_at = keys[":task"]
        if isinstance(task_item, str) or not task_item.items:
            raise self.error(task_at, f"{what}: expected :task (name args), got {text_of(task_item)}")
        task = self.call(task_item, "a task name")
        pre = self.formula(*keys[":precondition"]) if ":precondition" in keys else TRUE
        constraints = (
            self.formula(*keys[":constraints"], constraints=True) if ":constraints" in keys else TRUE
        )
        subtasks = self.network(keys, what, section.at)
        return Method(name, self.parameters(keys), task, pre, subtasks, constraints, section.at)

    # -- the problem ------------------------------------------------------------------------------------

    def problem(self, define: SList) -> Problem:
        name = self.header(define, "problem")
        domain = ""
        domain_at = 0
        requirements: list[str] = []
        objects: list[Typed] = []
        htn_params: tuple[Typed, ...] = ()
        htn: tuple[Subtask, ...] = ()
        htn_constraints: Formula = TRUE
        init: list[Atom] = []
        init_at: list[int] = []
        goal: Formula = TRUE
        for key, section in self.sections(define, "problem", _PROBLEM_SECTIONS):
            if key == ":domain":
                if len(section.items) != 2:
                    raise self.error(section.at, f"expected (:domain NAME), got {text_of(section)}")
                domain = self.name(section, 1, "the domain's name")
                domain_at = section.ats[1]
            elif key == ":requirements":
                requirements += self.requirements(section)
            elif key == ":objects":
                objects += self.typed_list(section, 1, False, "an object")
            elif key == ":htn":
                keys = self.keyed(section, 1, _HTN_KEYS, "the initial task network (:htn)")
                htn_params = self.parameters(keys)
                htn = self.network(keys, "the initial task network (:htn)", section.at)
                if ":constraints" in keys:
                    htn_constraints = self.formula(*keys[":constraints"], constraints=True)
            elif key == ":init":
                self.facts(section, init, init_at)
            else:
                self.count(section, 1, ":goal")
                goal = self.formula(section.items[1], section.ats[1])
        return Problem(
            name,
            domain,
            tuple(dict.fromkeys(requirements)),
            tuple(objects),
            htn_params,
            htn,
            htn_constraints,
            tuple(init),
            goal,
            self.source,
            tuple(init_at),
            domain_at,
        )

    def facts(self, section: SList, into: list[Atom], ats: list[int]) -> None:
        """The ground atoms of ``(:init ...)``: names only, no variables, no numbers."""
        items = section.items
        for j in range(1, len(items)):
            fact = items[j]
            if isinstance(fact, str) or not fact.items:
                raise self.error(
                    section.ats[j], f"expected an initial fact (predicate object ...), got {text_of(fact)}"
                )
            head = fact.items[0]
            if head in ("=", "not") or isinstance(head, SList):
                what = "numeric fluents are" if head == "=" else "only facts are"
                raise self.error(fact.at, f"{text_of(fact)} in :init: {what} not supported")
            args = fact.items[1:]
            for k, arg in enumerate(args, start=1):
                if isinstance(arg, SList) or _NAME.fullmatch(arg) is None:
                    raise self.error(
                        fact.ats[k], f"expected an object in an initial fact, got {text_of(arg)}"
                    )
            name = self.name(fact, 0, "a predicate name")
            into.append(Atom(name, tuple(args)))  # type: ignore[arg-type]  # all names, checked above
            ats.append(fact.at)


def _keys(*names: str) -> tuple[str, ...]:
    return names


_DOMAIN_SECTIONS = {
    ":requirements": True,
    ":types": True,
    ":constants": True,
    ":predicates": True,
    ":task": True,
    ":method": True,
    ":action": True,
}
_PROBLEM_SECTIONS = {
    ":domain": False,
    ":requirements": True,
    ":objects": True,
    ":htn": False,
    ":init": False,
    ":goal": False,
}
_NUMERIC_SECTIONS = frozenset({":functions", ":metric"})
_METHOD_KEYS = _keys(
    ":parameters",
    ":task",
    ":precondition",
    ":ordered-subtasks",
    ":ordered-tasks",
    ":subtasks",
    ":tasks",
    ":ordering",
    ":constraints",
)
_HTN_KEYS = _keys(
    ":parameters", ":ordered-subtasks", ":ordered-tasks", ":subtasks", ":tasks", ":ordering", ":constraints"
)
_KEYWORDS = frozenset({"and", "or", "not", "imply", "forall", "exists", "when", "=", "either"})
