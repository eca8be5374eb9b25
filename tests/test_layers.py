"""The package's modules import one another without a circle, and never from a higher layer.

``lint-imports`` checks the layers too (``pyproject.toml``); this repeats it on purpose, so
that plain ``pytest`` catches a wrong import as well.  Every import counts, those inside
functions and under ``TYPE_CHECKING`` included: a circle hidden there is still a circle to
a reader.  The layers are read from the import-linter contract itself, so the two cannot
drift apart.
"""

from __future__ import annotations

import ast
import os
import tomllib
from pathlib import Path

import networkx as nx

import htnagent

ROOT = Path(htnagent.__file__).parent
PYPROJECT = Path(__file__).resolve().parents[1] / "pyproject.toml"


def _modules() -> dict[str, Path]:
    """Every module of the package by dotted name (``htnagent/executors`` is a link: followed)."""
    found: dict[str, Path] = {}
    for folder, _, files in os.walk(ROOT, followlinks=True):
        for file in files:
            if file.endswith(".py"):
                parts = (Path(folder) / file).relative_to(ROOT.parent).with_suffix("").parts
                found[".".join(parts[:-1] if parts[-1] == "__init__" else parts)] = Path(folder) / file
    return found


def _imports() -> nx.DiGraph:
    """Which module imports which, each import resolved to the nearest module it names."""
    modules = _modules()

    def nearest(name: str) -> str | None:
        while name and name not in modules:
            name = name.rpartition(".")[0]
        return name or None

    graph = nx.DiGraph()
    for name, path in modules.items():
        graph.add_node(name)
        package = name if path.name == "__init__.py" else name.rpartition(".")[0]
        for node in ast.walk(ast.parse(path.read_text(), str(path))):
            if isinstance(node, ast.Import):
                named = [alias.name for alias in node.names]
            elif isinstance(node, ast.ImportFrom):
                base = node.module or ""
                if node.level:
                    above = package.split(".")[: len(package.split(".")) - node.level + 1]
                    base = ".".join([*above, base] if base else above)
                named = [f"{base}.{alias.name}" for alias in node.names]
            else:
                continue
            for target in filter(None, map(nearest, named)):
                if target != name:
                    graph.add_edge(name, target)
    return graph


def _layers() -> list[tuple[list[str], bool]]:
    """The contract's layers, highest first: each its modules, and whether they are
    independent of one another (``a | b``; ``a : b`` may import each other)."""
    contracts = tomllib.loads(PYPROJECT.read_text())["tool"]["importlinter"]["contracts"]
    (layers,) = [c["layers"] for c in contracts if c["type"] == "layers" and "containers" not in c]
    return [([part.strip() for part in entry.replace(":", "|").split("|")], "|" in entry) for entry in layers]


def test_no_module_imports_itself_round_a_circle() -> None:
    # A strongly connected set of modules is one circle or several: each set is named once,
    # with one of its circles.
    graph = _imports()
    tangles = [tangle for tangle in nx.strongly_connected_components(graph) if len(tangle) > 1]
    told = [
        f"{sorted(tangle)}, e.g. " + " -> ".join(a for a, _ in nx.find_cycle(graph.subgraph(tangle)))
        for tangle in tangles
    ]
    assert not told, "modules importing one another round a circle:\n" + "\n".join(told)


def test_no_module_imports_from_a_higher_layer_or_an_independent_sibling() -> None:
    layers = _layers()

    def place(module: str) -> tuple[int, str, bool] | None:
        for height, (names, independent) in enumerate(layers):
            for name in names:
                if module == name or module.startswith(name + "."):
                    return height, name, independent
        return None

    wrong = []
    for importer, imported in _imports().edges:
        here, there = place(importer), place(imported)
        if here is None or there is None:
            continue
        upward = there[0] < here[0]  # highest first: a smaller index is a higher layer
        sideways = there[0] == here[0] and there[1] != here[1] and here[2]
        if upward or sideways:
            wrong.append(f"{importer} imports {imported}")
    assert not wrong, "\n".join(sorted(wrong))


def test_the_agent_and_plan_upkeep_have_no_function_over_80_lines() -> None:
    # One short function a step of the algorithms (docs/design.md, "Where each step is
    # implemented"): a longer one is several steps to split.
    root = Path(__file__).resolve().parent.parent / "htnagent"
    long = []
    for package in ("agent", "upkeep"):
        for path in sorted((root / package).glob("*.py")):
            for node in ast.walk(ast.parse(path.read_text())):
                if isinstance(node, ast.FunctionDef | ast.AsyncFunctionDef):
                    lines = (node.end_lineno or node.lineno) - node.lineno + 1
                    if lines > 80:
                        long.append(f"{path.name}:{node.lineno} {node.name} ({lines} lines)")
    assert not long, long


def test_the_mode_is_compared_in_one_module_at_most() -> None:
    # The on-line and naive behaviours are objects chosen once (htnagent/agent/modes.py):
    # nothing else asks which mode it is in.
    root = Path(__file__).resolve().parent.parent / "htnagent"
    modes = ("Replanning", "'online'", "'naive'", '"online"', '"naive"')
    asking = set()
    for path in root.rglob("*.py"):
        for node in ast.walk(ast.parse(path.read_text())):
            if isinstance(node, ast.Compare) and any(m in ast.unparse(node) for m in modes):
                asking.add(str(path.relative_to(root)))
    assert len(asking) <= 1, sorted(asking)
