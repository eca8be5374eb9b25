"""The pages in ``docs/`` and the code stay in step.

- Every section number the code cites (``§2.4``, ranges like ``§4–§6`` by both
  ends) has a heading carrying it in ``docs/design.md``.
- Every reference ``docs/NAME.md "Heading"`` or ``docs/NAME.md §N`` names a page
  that exists and a heading on it.
- Nothing cites the old design notes that lived outside the repository any more
  (``tools/rewrite_doc_refs.py`` rewrites such references).
- The trace event table of ``docs/contracts.md`` lists exactly the event kinds
  the code emits, each with the fields the code gives it.
- The documentation site (``mkdocs.yml``): every page is in its navigation, the pages
  link to each other (never to the README) and every link resolves; every
  ``examples/...`` file the README or a page names exists; the benchmark page's
  figures are made from ``bench/results/``, each with its file, commit and machine;
  the Python examples on the pages run and print what the pages say.

Pure file reading (and, if it exists, importing the event registry), and a few
examples run in simulated time: fast. ``mkdocs build --strict`` itself runs in
``.ci/run``.
"""

from __future__ import annotations

import ast
import contextlib
import dataclasses
import functools
import importlib
import importlib.util
import io
import json
import os
import re
import shutil
import subprocess
import sys
from collections.abc import Iterator, Mapping
from pathlib import Path
from types import ModuleType

import pytest

ROOT = Path(__file__).resolve().parent.parent
DOCS = ROOT / "docs"
THIS = Path(__file__).resolve()

SECTION = re.compile("\u00a7" + r"(\d+(?:\.\d+)?)")
"""A section number as cited: ``§2`` or ``§2.4``."""

_SECTIONS = r"\u00a7\d+(?:\.\d+)?(?:\s*[\u2013-]\s*\u00a7\d+(?:\.\d+)?)?"
DOC_REF = re.compile(r'docs/([\w-]+\.md)(?:\s+(?:"([^"\n]+)"|(' + _SECTIONS + r")))?")
"""``docs/NAME.md``, optionally followed by a quoted heading or a section (range)."""

OLD_NOTES = re.compile(r"(?<![\w/.-])(" + "|".join(("ALGORITHMS", "CONTRACTS", "STYLE")) + r")\.md\b")
"""The design notes that lived outside the repository (built in pieces so that the
rewrite script, which skips this file anyway, would find nothing here to rewrite)."""

ENVELOPE = frozenset({"t", "agent", "event"})
"""What every trace event has; the table lists the fields beyond these."""


# -- what is scanned ----------------------------------------------------------------------------


def cited_files() -> list[Path]:
    """Code, tests, scenarios, examples and the README: the files whose references must resolve."""
    found: list[Path] = []
    for folder in ("htnagent", "executors", "bench", "tests", "examples"):
        found += sorted((ROOT / folder).rglob("*.py"))
    found += sorted((ROOT / "bench" / "results").glob("*.md"))
    found += sorted((ROOT / "scenarios").glob("*.yaml"))
    found += sorted((ROOT / "examples").rglob("*.py"))
    found += sorted((ROOT / "examples").rglob("*.yaml")) + sorted((ROOT / "examples").rglob("*.md"))
    found.append(ROOT / "README.md")
    return [p for p in found if p.is_file() and p.resolve() != THIS and ".venv" not in p.parts]


def doc_pages() -> list[Path]:
    """Every page of the documentation site, the how-to guides included."""
    return sorted(DOCS.rglob("*.md"))


def lines_of(path: Path) -> Iterator[tuple[int, str]]:
    yield from enumerate(path.read_text(encoding="utf-8").splitlines(), start=1)


def where(path: Path, line: int) -> str:
    return f"{path.relative_to(ROOT)}:{line}"


# -- headings ------------------------------------------------------------------------------------


def headings(page: Path) -> list[str]:
    """The page's Markdown headings (``#`` lines outside code blocks), without the hashes."""
    out: list[str] = []
    fenced = False
    for _, line in lines_of(page):
        if line.startswith("```"):
            fenced = not fenced
        elif not fenced and re.match(r"#{1,6} ", line):
            out.append(line.lstrip("#").strip())
    return out


def sections(page: Path) -> set[str]:
    """The section numbers the page's headings carry (``2.4`` for ``### §2.4 ...``)."""
    return {n for h in headings(page) for n in SECTION.findall(h)}


def heading_names(page: Path) -> set[str]:
    """Each heading as it may be cited: as written, and without its section number."""
    names: set[str] = set()
    for h in headings(page):
        plain = h.replace("`", "").strip()
        names.add(plain.casefold())
        names.add(SECTION.sub("", plain).strip().casefold())
    return names


def test_design_numbers_its_sections() -> None:
    found = sections(DOCS / "design.md")
    expected = {str(n) for n in range(1, 7)} | {f"2.{n}" for n in range(1, 9)}
    assert expected <= found, f"design.md lacks headings for §{', §'.join(sorted(expected - found))}"


# -- 1. section numbers ------------------------------------------------------------------------------


def test_every_cited_section_has_a_heading_in_design() -> None:
    known = sections(DOCS / "design.md")
    missing = [
        f"{where(path, n)}: \u00a7{number}"
        for path in [*cited_files(), *doc_pages()]
        for n, line in lines_of(path)
        for number in SECTION.findall(line)
        if number not in known
    ]
    assert not missing, "sections cited but not in docs/design.md:\n" + "\n".join(missing)


# -- 2. references to pages and headings --------------------------------------------------------


def test_every_docs_reference_resolves() -> None:
    broken: list[str] = []
    for path in [*cited_files(), *doc_pages()]:
        for n, line in lines_of(path):
            for m in DOC_REF.finditer(line):
                name, heading, numbers = m.groups()
                page = DOCS / name
                if not page.is_file():
                    broken.append(f"{where(path, n)}: docs/{name} does not exist")
                elif heading is not None and heading.strip().casefold() not in heading_names(page):
                    broken.append(f'{where(path, n)}: docs/{name} has no heading "{heading}"')
                elif numbers is not None:
                    absent = [s for s in SECTION.findall(numbers) if s not in sections(page)]
                    if absent:
                        broken.append(f"{where(path, n)}: docs/{name} has no \u00a7{', '.join(absent)}")
    assert not broken, "references that do not resolve:\n" + "\n".join(broken)


def test_nothing_cites_the_old_design_notes() -> None:
    # Run ``python tools/rewrite_doc_refs.py`` to point such references at docs/.
    old = [
        f"{where(path, n)}: {m.group(0)}"
        for path in cited_files()
        for n, line in lines_of(path)
        for m in OLD_NOTES.finditer(line)
    ]
    assert not old, "references to notes outside the repository:\n" + "\n".join(old)


# -- 3. trace events ---------------------------------------------------------------------------------


@functools.cache
def documented_events() -> dict[str, frozenset[str]]:
    """The trace event table of docs/contracts.md: event kind → fields.

    The table sits under the heading "Trace events"; its first column names the
    kind, its second the fields, each in backticks.
    """
    out: dict[str, frozenset[str]] = {}
    in_section = False
    for _, line in lines_of(DOCS / "contracts.md"):
        if line.startswith("#"):
            in_section = line.lstrip("#").strip() == "Trace events"
            continue
        if not in_section or not line.startswith("|"):
            continue
        cells = [c.strip() for c in line.strip().strip("|").split("|")]
        kinds = re.findall(r"`([a-z_]+)`", cells[0])
        if not kinds:
            continue  # the header and the rule
        fields = frozenset(re.findall(r"`([a-z_]+)`", cells[1])) if len(cells) > 1 else frozenset()
        for kind in kinds:
            assert kind not in out, f"trace event {kind} is listed twice in docs/contracts.md"
            out[kind] = fields
    return out


@functools.cache
def code_events() -> dict[str, frozenset[str] | None]:
    """Every event kind the code emits → its fields (None where the code does not tell).

    From the typed event registry when there is one, else from the ``emit(...)``
    calls in the source.
    """
    registry = event_registry()
    return registry if registry is not None else scanned_events()


def event_registry() -> dict[str, frozenset[str] | None] | None:
    """Kinds and fields from ``htnagent.runtime.events.EVENT_KINDS``; None if there is no registry.

    The one place to adapt if the registry changes shape: ``EVENT_KINDS`` may map
    names to classes or list the classes (each with an ``event`` name); fields come
    from ``fields_of(kind)`` if the module has it, else from the class (dataclass or
    pydantic model), less ``t``, ``agent`` and ``event``.
    """
    try:
        module = importlib.import_module("htnagent.runtime.events")
    except ModuleNotFoundError as e:
        if e.name == "htnagent.runtime.events":
            return None
        raise
    kinds = getattr(module, "EVENT_KINDS", None)
    if kinds is None:
        return None
    items = kinds.items() if isinstance(kinds, Mapping) else ((cls.event, cls) for cls in kinds)
    fields_of = getattr(module, "fields_of", None)
    out: dict[str, frozenset[str] | None] = {}
    for name, cls in items:
        names: list[str] | None
        if callable(fields_of):
            names = list(fields_of(name))
        elif dataclasses.is_dataclass(cls):
            names = [f.name for f in dataclasses.fields(cls)]
        elif hasattr(cls, "model_fields"):
            names = list(cls.model_fields)
        else:
            names = None
        out[str(name)] = None if names is None else frozenset(names) - ENVELOPE
    return out


def scanned_events() -> dict[str, frozenset[str] | None]:
    """Kinds and fields from the source: ``emit(agent, "kind", field=..., **dict)`` calls,
    and dict literals with a constant ``"event"`` (events made without ``emit``)."""
    fields: dict[str, set[str]] = {}
    unknown: set[str] = set()
    for path in [*sorted((ROOT / "htnagent").rglob("*.py")), *sorted((ROOT / "executors").rglob("*.py"))]:
        for kinds, names in _Scanner(ast.parse(path.read_text(encoding="utf-8"))).events():
            for kind in kinds:
                fields.setdefault(kind, set())
                if names is None:
                    unknown.add(kind)
                else:
                    fields[kind] |= names - ENVELOPE
    return {k: None if k in unknown else frozenset(v) for k, v in fields.items()}


class _Scanner:
    """Finds the trace events of one module and works out their keyword fields,
    following ``**name`` to the dict it was built as where that is in sight."""

    def __init__(self, tree: ast.Module) -> None:
        self.tree = tree
        self.parents = {child: node for node in ast.walk(tree) for child in ast.iter_child_nodes(node)}
        self.functions = {
            f.name: f for f in ast.walk(tree) if isinstance(f, ast.FunctionDef | ast.AsyncFunctionDef)
        }

    def events(self) -> Iterator[tuple[set[str], set[str] | None]]:
        for node in ast.walk(self.tree):
            if (
                isinstance(node, ast.Call)
                and isinstance(node.func, ast.Attribute)
                and node.func.attr == "emit"
                and len(node.args) >= 2
            ):
                kinds = _strings(node.args[1])
                if kinds:
                    yield kinds, self._keywords(node)
            elif isinstance(node, ast.Dict):
                kinds = {
                    v.value
                    for k, v in zip(node.keys, node.values, strict=True)
                    if isinstance(k, ast.Constant)
                    and k.value == "event"
                    and isinstance(v, ast.Constant)
                    and isinstance(v.value, str)
                }
                if kinds:
                    yield kinds, self._dict_keys(node, self._scope(node))

    def _scope(self, node: ast.AST) -> ast.AST:
        while node in self.parents:
            node = self.parents[node]
            if isinstance(node, ast.FunctionDef | ast.AsyncFunctionDef):
                return node
        return self.tree

    def _keywords(self, call: ast.Call) -> set[str] | None:
        names: set[str] = set()
        for kw in call.keywords:
            if kw.arg is not None:
                names.add(kw.arg)
                continue
            spread = self._dict_keys(kw.value, self._scope(call))
            if spread is None:
                return None
            names |= spread
        return names

    def _dict_keys(self, node: ast.AST, scope: ast.AST, depth: int = 0) -> set[str] | None:
        """The keys of the dict ``node`` evaluates to, if the source shows them."""
        if depth > 5:
            return None
        if isinstance(node, ast.Dict):
            keys: set[str] = set()
            for k, v in zip(node.keys, node.values, strict=True):
                if k is None:
                    inner = self._dict_keys(v, scope, depth + 1)
                    if inner is None:
                        return None
                    keys |= inner
                elif isinstance(k, ast.Constant) and isinstance(k.value, str):
                    keys.add(k.value)
                else:
                    return None
            return keys
        if isinstance(node, ast.IfExp):
            a = self._dict_keys(node.body, scope, depth + 1)
            b = self._dict_keys(node.orelse, scope, depth + 1)
            return None if a is None or b is None else a | b
        if isinstance(node, ast.Call) and isinstance(node.func, ast.Name) and node.func.id in self.functions:
            function = self.functions[node.func.id]
            returns = [r.value for r in ast.walk(function) if isinstance(r, ast.Return) and r.value]
            found: set[str] = set()
            for value in returns:
                keys_of = self._dict_keys(value, function, depth + 1)
                if keys_of is None:
                    return None
                found |= keys_of
            return found if returns else None
        if isinstance(node, ast.Name):
            return self._name_keys(node.id, scope, depth)
        return None

    def _name_keys(self, name: str, scope: ast.AST, depth: int) -> set[str] | None:
        """The keys a local dict variable gets: where it is built, and ``name["key"] = ...``."""
        keys: set[str] = set()
        built = False
        for node in ast.walk(scope):
            if isinstance(node, ast.Assign | ast.AnnAssign) and node.value is not None:
                targets = node.targets if isinstance(node, ast.Assign) else [node.target]
                for target in targets:
                    if isinstance(target, ast.Name) and target.id == name:
                        inner = self._dict_keys(node.value, scope, depth + 1)
                        if inner is None:
                            return None
                        keys |= inner
                        built = True
                    elif (
                        isinstance(target, ast.Subscript)
                        and isinstance(target.value, ast.Name)
                        and target.value.id == name
                        and isinstance(target.slice, ast.Constant)
                        and isinstance(target.slice.value, str)
                    ):
                        keys.add(target.slice.value)
        return keys if built else None


def _strings(node: ast.AST) -> set[str]:
    """The string constants an expression can be (``"a" if x else "b"``)."""
    if isinstance(node, ast.Constant) and isinstance(node.value, str):
        return {node.value}
    if isinstance(node, ast.IfExp):
        return _strings(node.body) | _strings(node.orelse)
    return set()


def test_the_trace_event_table_lists_exactly_the_emitted_kinds() -> None:
    documented = set(documented_events())
    emitted = set(code_events())
    assert emitted, "no trace events found in the code: the scanner or the registry lookup is broken"
    assert documented == emitted, (
        f"in the code but not in docs/contracts.md: {sorted(emitted - documented)}; "
        f"documented but not emitted: {sorted(documented - emitted)}"
    )


@pytest.mark.parametrize("kind", sorted(documented_events()))
def test_each_documented_event_has_the_fields_of_the_code(kind: str) -> None:
    emitted = code_events()
    if kind not in emitted:
        pytest.skip(f"{kind} is not emitted (the kinds test says so)")
    fields = emitted[kind]
    if fields is None:
        pytest.skip(f"the code does not show {kind}'s fields in one place: names only")
    documented = documented_events()[kind]
    assert documented == fields, (
        f"{kind}: docs/contracts.md lists {sorted(documented)}, the code gives {sorted(fields)}"
    )


def test_the_layout_page_lists_every_module_of_the_package() -> None:
    listed = set(re.findall(r"`(htnagent/[a-z_/]+\.py)`", (ROOT / "docs" / "layout.md").read_text()))
    package = ROOT / "htnagent"
    # (htnagent/executors links to the top-level executors/, listed there as one entry.)
    modules = {str(p.relative_to(ROOT)) for p in package.rglob("*.py")}
    modules.add("htnagent/executors/__init__.py")
    assert listed == modules


def test_every_function_the_design_table_names_exists() -> None:
    # docs/design.md "Where each step is implemented": `module:Qual.name` cells.
    text = (DOCS / "design.md").read_text(encoding="utf-8")
    table = text[text.index("## Where each step is implemented") : text.index("## §1")]
    cited = re.findall(r"`(htnagent[\w.]*):([\w.]+)`", table)
    assert len(cited) >= 30
    for module, qualname in cited:
        value: object = importlib.import_module(module)
        for part in qualname.split("."):
            assert hasattr(value, part), f"{module}:{qualname}"
            value = getattr(value, part)


# -- 4. the documentation site ----------------------------------------------------------------------

LINK = re.compile(r"\]\(([^)\s]+)\)")
"""A Markdown link's target."""


def nav_pages() -> list[str]:
    """The pages ``mkdocs.yml``'s navigation lists, as paths under docs/."""
    text = (ROOT / "mkdocs.yml").read_text(encoding="utf-8")
    return re.findall(r":\s+([\w/.-]+\.md)\s*$", text[text.index("\nnav:") :], re.M)


def test_every_page_is_in_the_navigation_and_every_entry_is_a_page() -> None:
    listed = nav_pages()
    pages = [str(p.relative_to(DOCS)) for p in doc_pages()]
    assert sorted(listed) == sorted(pages), (
        f"pages not in mkdocs.yml's nav: {sorted(set(pages) - set(listed))}; "
        f"nav entries without a page: {sorted(set(listed) - set(pages))}"
    )
    assert len(listed) == len(set(listed))


def test_the_pages_link_to_each_other_and_every_link_resolves() -> None:
    broken: list[str] = []
    for page in doc_pages():
        for n, line in lines_of(page):
            for target in LINK.findall(line):
                if "://" in target or target.startswith(("#", "mailto:")):
                    continue
                path = target.split("#", 1)[0]
                resolved = (page.parent / path).resolve()
                if "README" in path:
                    broken.append(f"{where(page, n)}: {target} (pages link to each other, not to the README)")
                elif not resolved.is_file() or DOCS.resolve() not in resolved.parents:
                    broken.append(f"{where(page, n)}: {target} is not a page or picture of the site")
    assert not broken, "links that do not resolve on the site:\n" + "\n".join(broken)


EXAMPLE = re.compile(r"(?<![\w/.-])examples/[\w./-]*[\w/]")
"""A path under examples/ as the README and the pages cite it."""

EXPECTED_EXAMPLES = {
    "examples/embed_asyncio.py",
    "examples/embed_trio.py",
    "examples/own_domain.py",
    "examples/own_map/",
    "examples/hddl_agent.py",
}
"""The example programs the README and the how-to guides send users to."""


def cited_examples() -> dict[str, list[str]]:
    found: dict[str, list[str]] = {}
    for path in [ROOT / "README.md", *doc_pages()]:
        for n, line in lines_of(path):
            for m in EXAMPLE.finditer(line):
                found.setdefault(m.group(0), []).append(where(path, n))
    return found


def test_the_docs_send_users_to_the_five_examples() -> None:
    assert set(cited_examples()) == EXPECTED_EXAMPLES


def test_every_example_the_docs_name_exists() -> None:
    missing = [f"{name} (cited at {', '.join(at)})" for name, at in cited_examples().items()]
    missing = [m for m in missing if not (ROOT / m.split(" ", 1)[0]).exists()]
    assert not missing, "examples cited but not in examples/:\n" + "\n".join(missing)


# -- the benchmark page -------------------------------------------------------------------------------


@functools.cache
def bench_hook() -> ModuleType:
    """``tools/docs_hooks.py``, the MkDocs hooks (the benchmark page; roles), loaded by path."""
    spec = importlib.util.spec_from_file_location("docs_hooks", ROOT / "tools" / "docs_hooks.py")
    assert spec is not None and spec.loader is not None
    module = importlib.util.module_from_spec(spec)
    sys.modules.setdefault("docs_hooks", module)
    spec.loader.exec_module(module)
    return module


def bench_markers() -> list[str]:
    found: list[str] = bench_hook().MARKER.findall((DOCS / "benchmarks.md").read_text(encoding="utf-8"))
    return found


def test_the_benchmark_page_shows_each_main_result_once() -> None:
    markers = bench_markers()
    assert len(markers) == len(set(markers))
    assert set(markers) == set(bench_hook().RENDERERS)
    # Every result a bench writes under its own name is shown (the others are one-off re-runs).
    benches = {p.stem for p in (ROOT / "bench" / "results").glob("*.json")}
    assert set(markers) <= benches
    assert {"replanning", "scaling", "reaction", "fleet", "differential", "reliability"} <= set(markers)


@pytest.mark.parametrize("name", bench_markers() if (DOCS / "benchmarks.md").is_file() else [])
def test_each_benchmark_figure_names_its_file_commit_and_machine(name: str) -> None:
    text = bench_hook().render(name)
    assert f"`bench/results/{name}." in text
    source = text.strip().splitlines()[-1]
    assert re.search(r"commit `([0-9a-f]{4,40}|not committed)`", source), source
    assert "machine: " in source
    assert "|" in text, f"{name}: no table"


def test_the_benchmark_page_is_filled_and_its_pictures_added() -> None:
    page = bench_hook().fill((DOCS / "benchmarks.md").read_text(encoding="utf-8"))
    assert "<!-- bench:" not in page
    for picture in re.findall(r"\]\(images/bench/([\w.-]+\.png)\)", page):
        assert (ROOT / "bench" / "results" / picture).is_file(), picture


def test_a_machine_line_is_read_from_the_results_md() -> None:
    # replanning.json has no machine of its own; the .md the bench wrote beside it does.
    assert "cores, Python" in bench_hook().machine_of("replanning")


def test_the_machine_python_m_bench_noted_for_a_file_is_named(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    hook = bench_hook()
    monkeypatch.setattr(hook, "RESULTS", tmp_path)
    (tmp_path / "step.json").write_text("[]")
    assert hook.machine_of("step") == "not recorded in the file"
    (tmp_path / "machines.json").write_text('{"step.json": "A CPU, 2 cores, Python 3.11.7, Linux"}')
    assert hook.machine_of("step") == "A CPU, 2 cores, Python 3.11.7, Linux"


def test_python_m_bench_notes_the_machine_of_each_file_it_writes(tmp_path: Path) -> None:
    # A study run as users run it (the smallest: one hostile input, written to the results folder
    # of a copy of the repository's bench/) leaves the machine beside the file it wrote.
    shutil.copytree(
        ROOT / "bench", tmp_path / "bench", ignore=shutil.ignore_patterns("results", "__pycache__")
    )
    env = {**os.environ, "PYTHONPATH": str(ROOT)}
    done = subprocess.run(
        [sys.executable, "-m", "bench", "fuzz", "--runs", "1", "--subprocess-every", "1000"],
        cwd=tmp_path,
        env=env,
        capture_output=True,
        text=True,
        timeout=60,
    )
    assert done.returncode == 0, done.stderr
    record = json.loads((tmp_path / "bench" / "results" / "machines.json").read_text())
    assert list(record) == ["fuzz.json"]
    assert "cores, Python" in record["fuzz.json"]


# -- the examples on the pages run ---------------------------------------------------------------------


def python_blocks(page: Path) -> list[str]:
    return re.findall(r"```python\n(.*?)```", page.read_text(encoding="utf-8"), re.S)


def run_block(code: str, name: str) -> str:
    out = io.StringIO()
    with contextlib.redirect_stdout(out):
        exec(compile(code, name, "exec"), {"__name__": "__docs__"})
    return out.getvalue()


@pytest.mark.parametrize("page", ["tutorial.md", "howto/own-domain.md"])
def test_the_planning_example_prints_what_the_page_says(page: str) -> None:
    start = "from htnagent import Domain, parse, plan\n"
    blocks = [b for b in python_blocks(DOCS / page) if b.startswith(start)]
    assert blocks, f"{page} has no planning example"
    promised = re.search(r"# (PlanStatus\.SOLVED .*)", blocks[0])
    assert promised is not None
    assert run_block(blocks[0], page).strip() == promised.group(1).strip()


def test_the_embedding_example_sends_an_emergency_while_a_goal_runs() -> None:
    page = DOCS / "howto" / "embedding.md"
    code = next(b for b in python_blocks(page) if "emergency=True" in b and "anyio.run(main)" in b)
    text = page.read_text(encoding="utf-8")
    promised = text[text.index("It prints:") :].split("```")[1].strip()
    assert run_block(code, "embedding.md").strip() == promised
    assert "goal_suspended" in promised and "goal_resumed" in promised


def test_the_executor_example_is_suspended_half_way_and_resumed() -> None:
    import anyio

    from htnagent import AgentConfig, Domain, Effect, GoalStatus, Runtime, Suspension, parse
    from htnagent.runtime.events import ActionStarted

    namespace: dict[str, object] = {"__name__": "__docs__"}
    exec(python_blocks(DOCS / "howto" / "executor.md")[0], namespace)
    walker = namespace["Walker"]
    d = Domain("line")
    back = Effect(pre=("between(?f,?t)",), add=("at(?f)",), delete=("between(?f,?t)",), cost=1.0)
    on = Effect(pre=("between(?f,?t)",), add=("at(?t)",), delete=("between(?f,?t)",), cost=1.0)
    d.operator(
        "move(?f,?t)",
        pre=["at(?f)", "link(?f,?t)"],
        add=["at(?t)"],
        delete=["at(?f)"],
        cost=2.0,
        suspend=Suspension(add=("between(?f,?t)",), delete=("at(?f)",), resume=on, rollback=back),
    )
    d.method("reach(?n)", "here", when=["at(?n)"], do=[])
    step = ["move(?x,?y)", "reach(?n)"]
    d.method("reach(?n)", "step", when=["not at(?n)", "at(?x)", "link(?x,?y)"], do=step)
    d.facts = tuple(parse(f) for f in ["link(a,b)", "link(b,a)", "link(b,c)", "link(c,b)"])
    belief = d.initial_state().updated(add=[parse("at(a)")])
    kinds: list[str] = []

    async def main() -> None:
        async with Runtime([AgentConfig("agent", d, belief)], lambda clock, trace: walker()) as rt:  # type: ignore[operator]
            rt.subscribe(lambda e: kinds.append(f"{e.event} {getattr(e, 'result', '')}".strip()))
            events = rt.events()
            goal = rt.submit("agent", parse("reach(b)"))
            async for event in events:
                if isinstance(event, ActionStarted):
                    break
            urgent = rt.submit("agent", parse("reach(c)"), emergency=True)
            assert (await rt.outcome(urgent)).status is GoalStatus.SUCCESS
            assert (await rt.outcome(goal)).status is GoalStatus.SUCCESS
            await events.aclose()

    anyio.run(main)
    assert "action_finished suspended" in kinds
    assert "goal_resumed" in kinds


def test_sphinx_roles_in_the_docstrings_show_as_plain_code() -> None:
    plain = bench_hook().plain_roles
    assert plain("see :meth:<code>operator</code>.") == "see <code>operator</code>."
    assert plain(":class:<code>~htnagent.runtime.messages.Execute</code>") == "<code>Execute</code>"
    assert plain(":func:<code>htnagent.plan</code>") == "<code>htnagent.plan</code>"
    assert plain("<code>x</code>") == "<code>x</code>"


def test_no_page_dates_itself() -> None:
    # History goes to CHANGELOG.md; a page describes the current version.
    dated = re.compile(r"\b(this|last|next) (week|month)\b|\byesterday\b|\bissue #?\d+", re.I)
    found = [
        f"{where(page, n)}: {m.group(0)!r}"
        for page in doc_pages()
        for n, line in lines_of(page)
        for m in dated.finditer(line)
    ]
    assert not found, "pages that date themselves:\n" + "\n".join(found)
