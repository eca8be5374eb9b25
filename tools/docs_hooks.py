"""MkDocs hooks (``hooks:`` in ``mkdocs.yml``): the benchmark page, and the API page's roles.

The benchmark page is made from ``bench/results/`` when the site is built.
``docs/benchmarks.md`` holds the prose; each
line ``<!-- bench: NAME -->`` on it becomes the figures of ``bench/results/NAME.json`` (or
``NAME.md`` where the bench writes its own tables), headed by the file, the commit that last
changed it (``git log -1 -- FILE``) and the machine it was measured on, as the file records
it. The pictures the benches draw (``bench/results/*.png``) are added to the site as
``images/bench/NAME.png``. Nothing here reaches the network.

The docstrings use Sphinx's cross-reference roles (``:class:`~htnagent.Runtime```), which
mkdocstrings shows as they are written: :func:`plain_roles` turns them into plain code, the
name as Sphinx would show it.

The functions here are plain Python, so tests call them without MkDocs.
"""

from __future__ import annotations

import json
import re
import subprocess
from collections.abc import Callable, Iterable, Mapping, Sequence
from pathlib import Path
from typing import Any

ROOT = Path(__file__).resolve().parent.parent
RESULTS = ROOT / "bench" / "results"
PAGE = "benchmarks.md"
MARKER = re.compile(r"^<!-- bench: ([\w-]+) -->$", re.M)
MACHINE_LINE = re.compile(r"(?:Machine: )?([^.;:]*\d+ cores, Python [\d.]+, \w+)")

Row = Mapping[str, Any]


# -- where a result comes from -------------------------------------------------------------------


def commit_of(path: Path) -> str:
    """The short hash of the last commit that changed ``path``, or "not committed"."""
    try:
        out = subprocess.run(
            ["git", "log", "-1", "--format=%h", "--", str(path.relative_to(ROOT))],
            cwd=ROOT,
            capture_output=True,
            text=True,
            timeout=30,
            check=False,
        ).stdout.strip()
    except (OSError, subprocess.SubprocessError):
        out = ""
    return out or "not committed"


def machine_of(name: str) -> str:
    """The machine the file says its figures come from (its ``machine`` key, the machine
    ``python -m bench`` noted for it in ``machines.json``, or the machine line of the ``.md`` the
    bench wrote beside it); "not recorded in the file" otherwise."""
    data = load(name)
    if isinstance(data, Mapping) and isinstance(data.get("machine"), str):
        return str(data["machine"])
    record = RESULTS / "machines.json"  # written by python -m bench for every file it writes
    if record.is_file():
        machines = json.loads(record.read_text(encoding="utf-8"))
        for file in (f"{name}.json", f"{name}.md"):
            if isinstance(machines.get(file), str):
                return str(machines[file])
    md = RESULTS / f"{name}.md"
    if md.is_file():
        found = MACHINE_LINE.search(md.read_text(encoding="utf-8"))
        if found:
            return found.group(1).strip()
    return "not recorded in the file"


def source_line(name: str) -> str:
    """The line under each figure: file, commit, machine."""
    files = [p for p in (RESULTS / f"{name}.json", RESULTS / f"{name}.md") if p.is_file()]
    if not files:
        raise FileNotFoundError(f"bench/results/{name}.json: no such result")
    where = " and ".join(f"`bench/results/{p.name}`" for p in files)
    return f"*From {where}, commit `{commit_of(files[0])}`; machine: {machine_of(name)}.*"


def load(name: str) -> Any:
    path = RESULTS / f"{name}.json"
    return json.loads(path.read_text(encoding="utf-8")) if path.is_file() else None


# -- tables ------------------------------------------------------------------------------------------


def cell(value: Any) -> str:
    if isinstance(value, bool):
        return "yes" if value else "no"
    if value is None:
        return "—"
    if isinstance(value, float):
        return f"{value:,.4g}" if abs(value) < 1000 else f"{value:,.0f}"
    if isinstance(value, int):
        return f"{value:,}"
    if isinstance(value, Mapping | list):
        return json.dumps(value).replace("|", "\\|")
    return str(value).replace("|", "\\|")


def table(rows: Iterable[Row], columns: Sequence[str] | None = None) -> str:
    """A Markdown table of ``rows`` (their scalar keys, in first-seen order, unless given)."""
    rows = list(rows)
    if columns is None:
        seen: dict[str, None] = {}
        for row in rows:
            for key, value in row.items():
                if not isinstance(value, Mapping | list):
                    seen.setdefault(key)
        columns = list(seen)
    lines = ["| " + " | ".join(c.replace("_", " ") for c in columns) + " |"]
    lines.append("|" + "".join("---:|" if _numeric(rows, c) else "---|" for c in columns))
    lines += ["| " + " | ".join(cell(row.get(c)) for c in columns) + " |" for row in rows]
    return "\n".join(lines)


def _numeric(rows: Sequence[Row], column: str) -> bool:
    values = [r.get(column) for r in rows if r.get(column) is not None]
    return bool(values) and all(isinstance(v, int | float) and not isinstance(v, bool) for v in values)


def md_tables(name: str) -> str:
    """The tables of the ``.md`` a bench wrote (its headings one level down, prose left out)."""
    out: list[str] = []
    for line in (RESULTS / f"{name}.md").read_text(encoding="utf-8").splitlines():
        if line.startswith("|"):
            out.append(line)
        elif line.startswith("## "):
            out += ["", "#" + line.strip() if not out else "\n#" + line.strip(), ""]
        elif out and out[-1].startswith("|"):
            out.append("")
    return "\n".join(out).strip()


def scalars(data: Row, prefix: str = "") -> list[dict[str, Any]]:
    """A nested mapping's numbers and words as ``what | value`` rows (lists left out)."""
    rows: list[dict[str, Any]] = []
    for key, value in data.items():
        if isinstance(value, Mapping):
            rows += scalars(value, f"{prefix}{key} ")
        elif not isinstance(value, list):
            rows.append({"what": f"{prefix}{key}".replace("_", " "), "value": value})
    return rows


# -- one renderer per result file -----------------------------------------------------------------


def _replanning() -> str:
    rows = [r for r in load("replanning") if r.get("look_ahead", True) is not False]
    by: dict[tuple[str, str, str], Row] = {(r["case"], r["level"], r["mode"]): r for r in rows}
    cases = list(dict.fromkeys(r["case"] for r in rows))
    out = []
    for case in cases:
        on, nv = by.get((case, "total", "online")), by.get((case, "total", "naive"))
        if on is None or nv is None:
            continue
        out.append(
            {
                "case": case,
                "on-line replan ms": on.get("replan_ms"),
                "naive replan ms": nv.get("replan_ms"),
                "replan naive / on-line": (
                    f"{nv['replan_ms'] / on['replan_ms']:.1f}×"
                    if on.get("replan_ms") and nv.get("replan_ms")
                    else "—"
                ),
                "on-line window ms": on["median_ms"],
                "naive window ms": nv["median_ms"],
                "window naive / on-line": f"{nv['median_ms'] / on['median_ms']:.1f}×",
                "on-line planning ms": on["planning_ms"],
                "naive planning ms": nv["planning_ms"],
                "on-line m": on["distance"],
                "naive m": nv["distance"],
            }
        )
    return table(out, list(out[0])) + "\n\n![Resume time, on-line and naive](images/bench/replanning.png)"


def _scaling() -> str:
    rows = load("scaling")
    replan = ["replan_ms"] if rows and "replan_ms" in rows[0] else []
    cols = ["areas", "nodes", "emergency", "mode", *replan, "resume_ms", "planning_ms", "distance", "runs"]
    return table(rows, cols) + "\n\n![Resume time by map size](images/bench/scaling.png)"


def _reliability() -> str:
    data = load("reliability")
    parts = [f"**{k}**\n\n" + table([data[k]]) for k in ("storms", "crashes", "closes")]
    parts.append("**nested**\n\n" + table(data["nested"]))
    return "\n\n".join(parts)


def _remote() -> str:
    data = load("remote")
    fleet_cols = ["robots", "processes", "sessions", "success", "wall_s", "setup_s", "cpu_s_parent"]
    fleet_cols += ["cpu_s_serving", "cpu_ms_per_robot", "orders_per_s", "load"]
    security_cols = ["case", "orders_sent", "orders_executed", "refused", "refused_by", "growth_mb"]
    fleet = [{k: r.get(k, "") for k in fleet_cols} for r in data["fleet"]]
    security = [{k: r.get(k, "") for k in security_cols} for r in data.get("security", [])]
    text = (
        table(scalars({k: v for k, v in data.items() if k != "machine"})) + "\n\n" + table(fleet, fleet_cols)
    )
    return text + ("\n\n" + table(security, security_cols) if security else "")


def _fuzz() -> str:
    data = load("fuzz")
    keys = ["runs", "executions", "tracebacks", "timeouts", "over_memory", "bad_exit", "code_ran"]
    keys.append("max_seconds")
    return table([{k: data[k] for k in keys}]) + "\n\nExit codes: " + cell(data["exit_codes"])


def _hddl_read() -> str:
    data = load("hddl_read")
    keys = ("files", "bytes", "total_s", "max", "synthetic")
    return table(scalars({k: data[k] for k in keys}))


def _astar_estimate() -> str:
    rows = []
    for m in load("astar_estimate")["maps"]:
        for k, runs in m["runs"].items():
            for r in runs:
                rows.append(
                    {
                        "nodes": m["nodes"],
                        "plans": k,
                        "pair": r["pair"],
                        "expansions with the estimate": r["with_estimate"]["expansions"],
                        "ms with": r["with_estimate"]["ms"],
                        **{
                            f"{key.replace('_', ' ')} {field}": value
                            for key, sub in r.items()
                            if key.startswith("without") and isinstance(sub, Mapping)
                            for field, value in sub.items()
                        },
                    }
                )
    return table(rows)


def _generic(name: str) -> Callable[[], str]:
    return lambda: table(load(name))


RENDERERS: dict[str, Callable[[], str]] = {
    "replanning": _replanning,
    "scaling": _scaling,
    "reliability": _reliability,
    "remote": _remote,
    "fuzz": _fuzz,
    "hddl_read": _hddl_read,
    "astar_estimate": _astar_estimate,
    **{n: _generic(n) for n in ("nested", "reaction", "fleet", "step", "differential", "planset_updates")},
    **{
        n: (lambda n=n: md_tables(n))
        for n in (
            "ipc",
            "ipc_all",
            "ipc_other_hard",
            "ipc_other_first10",
            "ipc_monroe_po",
            "ipc_assembly",
            "ipc_cap",
            "ipc_cap100",
            "ipc_other_rest",
            "ipc_interrupt",
        )
    },
}


def render(name: str) -> str:
    """The figures of one result file, with where they come from."""
    if name not in RENDERERS:
        raise KeyError(f"{PAGE}: no renderer for bench/results/{name}")
    return RENDERERS[name]() + "\n\n" + source_line(name)


def fill(markdown: str) -> str:
    """The page with every marker replaced by its figures."""
    return MARKER.sub(lambda m: render(m.group(1)), markdown)


# -- Sphinx roles in the docstrings ------------------------------------------------------------------

ROLE = re.compile(r":(?:py:)?(?:meth|class|attr|func|mod|data|exc|obj|const):<code>(~?)([^<]*)</code>")
"""A role as mkdocstrings renders it: the role's name as text, its target in code."""


def plain_roles(html: str) -> str:
    """``:class:<code>~a.b.C</code>`` as ``<code>C</code>``; without ``~`` the whole name."""

    def shown(m: re.Match[str]) -> str:
        name = m.group(2).rsplit(".", 1)[-1] if m.group(1) else m.group(2)
        return f"<code>{name}</code>"

    return ROLE.sub(shown, html)


# -- the MkDocs hook -----------------------------------------------------------------------------------


def on_files(files: Any, config: Any) -> Any:
    from mkdocs.structure.files import File

    for png in sorted(RESULTS.glob("*.png")):
        files.append(File.generated(config, f"images/bench/{png.name}", abs_src_path=str(png)))
    return files


def on_page_markdown(markdown: str, page: Any, config: Any, files: Any) -> str:
    return fill(markdown) if page.file.src_uri == PAGE else markdown


def on_post_page(output: str, page: Any, config: Any) -> str:
    # The finished page: mkdocstrings' output is only complete here.
    return plain_roles(output)
