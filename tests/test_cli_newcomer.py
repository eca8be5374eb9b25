"""What a newcomer meets first on the command line (docs/contracts.md "Command line"):
``--version``, ``--help`` with examples and exit codes, the built-in scenarios by name,
``plan --tree``, the progress of ``plan --hddl`` on a terminal, and ``| head``.
"""

from __future__ import annotations

import io
import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

import htnagent.planning.planner
from htnagent.cli.commands import EXIT_CODES, main
from htnagent.hddl import read_domain, read_problem
from htnagent.planning.hddl_solving import solve
from htnagent.planning.planner import PlanStatus, Search
from htnagent.scenario.builtin import BUILTIN_DIR, builtin_scenarios, scenario_file
from htnagent.version import VERSION
from htnagent.views.console import SearchProgress, search_progress
from tests.support import SCENARIO_DIR, SHIPPED, one_error_line

HDDL = Path(__file__).resolve().parent / "hddl"

# A task that decomposes into itself and one more action, or ends where q holds, which it
# never does: the search goes on until its time is up.
# The task list grows without end: t ends only where q holds and p does not, and the only
# way to q (c) needs p first, which nothing deletes.  A relaxation (which keeps "not p" true
# once it was) sees a way out, so the grounded search runs on as well, to the time limit.
# No plan, and no search ends: the task list grows with every decomposition, and the end
# needs q and r together, which no state has (a adds q and deletes r, b the other way round)
# -- though each on its own is within reach, for the estimates too.
FOREVER_DOMAIN = (
    "(define (domain forever) (:requirements :hierarchy)"
    " (:predicates (q) (r))"
    " (:task t :parameters ())"
    " (:method m :parameters () :task (t) :ordered-subtasks (and (a) (t) (b)))"
    " (:method end :parameters () :task (t) :precondition (and (q) (r)) :ordered-subtasks ())"
    " (:action a :parameters () :effect (and (q) (not (r))))"
    " (:action b :parameters () :effect (and (r) (not (q)))))"
)
FOREVER_PROBLEM = "(define (problem p) (:domain forever) (:htn :ordered-subtasks (t)) (:init))"


# -- --version and --help ---------------------------------------------------------------------


def test_version_prints_the_version_and_exits_0(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["--version"]) == 0
    assert capsys.readouterr() == (f"htnagent {VERSION}\n", "")


def test_help_gives_examples_the_built_in_scenarios_and_every_exit_code(
    capsys: pytest.CaptureFixture[str],
) -> None:
    assert main(["--help"]) == 0
    out = " ".join(capsys.readouterr().out.split())  # as wrapped to any width
    assert "Examples:" in out
    assert "htnagent run museum" in out
    assert 'htnagent plan museum --agent guide --task "goto(n28)" --tree' in out
    assert "Built-in scenarios" in out and "nested_emergencies" in out
    assert "Exit codes:" in out
    for code, what in EXIT_CODES:
        assert f"{code} {what}" in out


def test_the_help_of_plan_shows_tree(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["plan", "--help"]) == 0
    assert "--tree" in capsys.readouterr().out


def test_importing_the_package_loads_neither_rich_nor_its_help_formatter() -> None:
    # The command line installs its signal handlers before the heavy imports (launch.py).
    code = "import sys, htnagent; print(sorted(m for m in ('rich', 'rich_argparse') if m in sys.modules))"
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout
    assert out.strip() == "[]"


# -- the built-in scenarios, by name ----------------------------------------------------------


def test_the_built_in_scenarios_are_the_shipped_ones() -> None:
    assert BUILTIN_DIR.resolve() == SCENARIO_DIR
    assert [f"{name}.yaml" for name in builtin_scenarios()] == list(SHIPPED)


@pytest.mark.parametrize("name", ["museum", "museum.yaml"])
def test_a_built_in_scenario_is_checked_by_name_from_any_folder(
    name: str, tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    monkeypatch.chdir(tmp_path)
    assert main(["check", name]) == 0
    assert capsys.readouterr() == ("ok\n", "")


def test_plan_takes_a_built_in_scenario_by_name(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    monkeypatch.chdir(tmp_path)
    assert main(["plan", "paper_n1_n40_n13", "--agent", "guide", "--task", "goto(n40)", "--json"]) == 0
    assert json.loads(capsys.readouterr().out)["plan"][-1] == "goto_node(n40)"


def test_an_existing_file_wins_over_a_built_in_name(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    monkeypatch.chdir(tmp_path)
    Path("museum").write_text("name: [unclosed\n")
    assert scenario_file("museum") == "museum"
    assert main(["check", "museum"]) == 2
    assert one_error_line(capsys.readouterr().err).startswith("htnagent: error: museum: line ")


def test_a_name_that_is_neither_a_file_nor_built_in_lists_the_built_in_names(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    monkeypatch.chdir(tmp_path)
    assert main(["run", "musem"]) == 2
    line = one_error_line(capsys.readouterr().err)
    assert line.startswith("htnagent: error: musem: no such file, nor a built-in scenario;")
    assert line.endswith(", ".join(builtin_scenarios()))


def test_a_missing_path_is_said_as_before(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    missing = tmp_path / "museum.yaml"
    assert main(["check", str(missing)]) == 2
    assert one_error_line(capsys.readouterr().err).endswith(
        f"{missing}: no such file; expected a scenario file"
    )


# -- plan --tree ----------------------------------------------------------------------------


MUSEUM_TREE = [
    "guide (museum.areas) plans goto(n28) from n40:",
    "  goto(n28) -> through_a_door",
    "    1. move_area(area8,area7)",
    "    goto(n28) -> through_a_door",
    "      2. move_area(area7,area5)",
    "      goto(n28) -> through_a_door",
    "        3. move_area(area5,area6)",
    "        goto(n28) -> through_a_door",
    "          4. move_area(area6,area4)",
    "          goto(n28) -> in_its_area",
    "            5. goto_node(n28)",
]


def test_plan_tree_prints_each_task_its_method_and_its_subtasks_indented(
    capsys: pytest.CaptureFixture[str],
) -> None:
    assert main(["plan", "museum", "--agent", "guide", "--task", "goto(n28)", "--tree"]) == 0
    out, err = capsys.readouterr()
    assert err == ""
    assert out.splitlines()[: len(MUSEUM_TREE)] == MUSEUM_TREE
    assert out.splitlines()[len(MUSEUM_TREE)].startswith("cost ")


def test_plan_tree_json_nests_tasks_methods_and_actions(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["plan", "museum", "--agent", "guide", "--task", "goto(n28)", "--tree", "--json"]) == 0
    line = json.loads(capsys.readouterr().out)
    (top,) = line["tree"]
    assert (top["task"], top["method"]) == ("goto(n28)", "through_a_door")
    assert top["subtasks"][0] == "move_area(area8,area7)"
    leaves: list[str] = []

    def walk(node: object) -> None:
        if isinstance(node, str):
            leaves.append(node)
        else:
            assert isinstance(node, dict)
            for sub in node["subtasks"]:
                walk(sub)

    walk(top)
    assert leaves == line["plan"]


COURIER_TREE = """\
deliver(p1,office) -> m-deliver
  goto(r1,kitchen) -> m-goto-step
    1. move(r1,hall,kitchen)
    goto(r1,kitchen) -> m-goto-here
  2. pick(r1,p1,kitchen)
  goto(r1,office) -> m-goto-step
    3. move(r1,kitchen,hall)
    goto(r1,office) -> m-goto-step
      4. move(r1,hall,office)
      goto(r1,office) -> m-goto-here
  5. drop(r1,p1,office)
deliver(p2,office) -> m-already
tidy -> m-tidy
  6. switch-off
"""


def test_plan_hddl_tree_shows_the_ipc_decomposition_empty_methods_too(
    capsys: pytest.CaptureFixture[str],
) -> None:
    files = [str(HDDL / "courier-domain.hddl"), str(HDDL / "courier.hddl")]
    assert main(["plan", "--hddl", *files, "--search", "astar", "--tree"]) == 0
    assert capsys.readouterr() == (COURIER_TREE, "")


def test_plan_hddl_tree_is_refused_with_the_ipc_format(capsys: pytest.CaptureFixture[str]) -> None:
    files = [str(HDDL / "courier-domain.hddl"), str(HDDL / "courier.hddl")]
    assert main(["plan", "--hddl", *files, "--format", "ipc", "--tree"]) == 2
    assert "the ipc format lists the decomposition already" in one_error_line(capsys.readouterr().err)


# -- plan --hddl's progress -------------------------------------------------------------------


def test_the_progress_line_says_the_search_its_expansions_and_the_time() -> None:
    assert search_progress("gbfs", 1234567, 12.34) == "searching (gbfs): 1,234,567 expansions, 12.3 s"
    out = io.StringIO()
    shown = SearchProgress(out)
    shown.close()
    assert out.getvalue() == ""  # nothing shown, nothing to wipe
    shown(Search.DFS, 10, 0.5)
    shown(Search.GBFS, 20, 1.0)
    shown.close()
    assert out.getvalue() == (
        "\rsearching (dfs): 10 expansions, 0.5 s\x1b[K\rsearching (gbfs): 20 expansions, 1.0 s\x1b[K\r\x1b[K"
    )


def test_the_portfolio_reports_both_searches_expansions_in_one_count(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.setattr(htnagent.planning.planner, "PROGRESS_EVERY", 0.0)
    domain_file, problem_file = tmp_path / "d.hddl", tmp_path / "p.hddl"
    domain_file.write_text(FOREVER_DOMAIN)
    problem_file.write_text(FOREVER_PROBLEM)
    domain = read_domain(domain_file)
    heard: list[tuple[Search, int, float]] = []
    solved = solve(
        domain, read_problem(problem_file, domain), timeout=0.3, progress=lambda *a: heard.append(a)
    )
    assert solved.result.status is PlanStatus.TIMED_OUT
    assert {s for s, _, _ in heard} == {Search.DFS, Search.GBFS}
    counts = [n for _, n, _ in heard]
    assert counts == sorted(counts) and 0 < counts[-1] <= solved.result.expansions
    seconds = [t for _, _, t in heard]
    assert seconds == sorted(seconds)


class _Terminal(io.StringIO):
    def isatty(self) -> bool:
        return True


def _forever(tmp_path: Path) -> list[str]:
    (tmp_path / "d.hddl").write_text(FOREVER_DOMAIN)
    (tmp_path / "p.hddl").write_text(FOREVER_PROBLEM)
    return ["plan", "--hddl", str(tmp_path / "d.hddl"), str(tmp_path / "p.hddl"), "--timeout", "0.3"]


def test_plan_hddl_shows_its_progress_on_a_terminal_and_wipes_it(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.setattr(htnagent.planning.planner, "PROGRESS_EVERY", 0.0)
    terminal = _Terminal()
    monkeypatch.setattr(sys, "stderr", terminal)
    assert main(_forever(tmp_path)) == 1
    shown, _, said = terminal.getvalue().rpartition("\r\x1b[K")
    assert shown.startswith("\rsearching (dfs): ") and "searching (gbfs): " in shown
    assert said == "htnagent: no plan: timeout (no plan within 0.3 s)\n"


def test_plan_hddl_into_a_pipe_shows_no_progress(tmp_path: Path) -> None:
    env = {**os.environ, "PYTHONPATH": str(Path(__file__).resolve().parents[1])}
    done = subprocess.run(
        [sys.executable, "-m", "htnagent", *_forever(tmp_path)],
        capture_output=True,
        text=True,
        timeout=60,
        env=env,
    )
    assert done.returncode == 1
    assert done.stderr == "htnagent: no plan: timeout (no plan within 0.3 s)\n"


# -- | head -----------------------------------------------------------------------------------


@pytest.mark.parametrize(
    ("args", "code"),
    [
        # About a second each: the reader is gone long before the run ends.
        (["run", "museum", "--json", "--speed", "65"], 0),
        (["run", "museum", "--speed", "65"], 0),
        (["run", "unreachable_goal", "--speed", "18"], 1),
    ],
)
def test_a_reader_gone_stops_the_printing_quietly_with_the_runs_own_code(args: list[str], code: int) -> None:
    # python -m htnagent run museum --json | head -1
    with subprocess.Popen(
        [sys.executable, "-m", "htnagent", *args],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        cwd=Path(__file__).resolve().parents[1],
    ) as process:
        assert process.stdout is not None and process.stderr is not None
        assert process.stdout.readline()
        process.stdout.close()
        err = process.stderr.read()
        assert process.wait(timeout=60) == code
    assert err == b""
