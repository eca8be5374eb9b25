"""Point references to the old design notes at the pages in ``docs/``.

The design notes the code used to cite lived outside the repository; ``docs/``
now holds the project's own pages with the same section numbers.  Run from the
repository root::

    python tools/rewrite_doc_refs.py          # rewrite in place, list the files changed
    python tools/rewrite_doc_refs.py --check  # change nothing; exit 1 if a file would change

Rewrites, in ``htnagent/``, ``executors/``, ``bench/`` (Python files and the
generated ``bench/results/*.md``), ``tests/``, ``scenarios/`` and ``README.md``:

- ``ALGORITHMS.md §2 item N``  → ``docs/design.md §2.N``
- ``ALGORITHMS.md``            → ``docs/design.md`` (so ``ALGORITHMS.md §x`` → ``docs/design.md §x``)
- ``CONTRACTS.md``             → ``docs/contracts.md`` (so ``CONTRACTS.md "Trace events"`` keeps its heading)
- ``STYLE.md``                 → ``docs/style.md``

It is idempotent.  ``tests/test_docs.py`` is left alone (it names the old files on
purpose), and so are data files such as ``bench/results/fuzz.json`` (a record of
inputs).  Python lines that grow past the project's line length (110) are listed,
to be wrapped by hand.
"""

from __future__ import annotations

import re
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
LINE_LENGTH = 110

OLD = {"ALGORITHMS": "docs/design.md", "CONTRACTS": "docs/contracts.md", "STYLE": "docs/style.md"}
_NOT_A_PATH_BEFORE = r"(?<![\w/.-])"
_ITEM = re.compile(_NOT_A_PATH_BEFORE + r"ALGORITHMS\.md §2 item (\d)\b")
_NAME = re.compile(_NOT_A_PATH_BEFORE + r"(ALGORITHMS|CONTRACTS|STYLE)\.md\b")

SKIP = {Path("tests/test_docs.py")}


def files(root: Path = ROOT) -> list[Path]:
    """The files whose references are rewritten (and checked by tests/test_docs.py)."""
    found: list[Path] = []
    for folder in ("htnagent", "executors", "bench", "tests"):
        found += sorted((root / folder).rglob("*.py"))
    found += sorted((root / "bench" / "results").glob("*.md"))
    found += sorted((root / "scenarios").glob("*.yaml"))
    found.append(root / "README.md")
    return [p for p in found if p.is_file() and p.relative_to(root) not in SKIP and ".venv" not in p.parts]


def rewrite(text: str) -> str:
    """The text with every reference to an old design note pointed at ``docs/``."""
    text = _ITEM.sub(r"docs/design.md §2.\1", text)
    return _NAME.sub(lambda m: OLD[m.group(1)], text)


def main(argv: list[str]) -> int:
    check = "--check" in argv
    changed: list[Path] = []
    for path in files():
        text = path.read_text(encoding="utf-8")
        new = rewrite(text)
        if new == text:
            continue
        changed.append(path)
        rel = path.relative_to(ROOT)
        if not check:
            path.write_text(new, encoding="utf-8")
        print(rel)
        if path.suffix == ".py":
            for n, line in enumerate(new.splitlines(), start=1):
                if len(line) > LINE_LENGTH:
                    print(f"  {rel}:{n}: {len(line)} characters, longer than {LINE_LENGTH}", file=sys.stderr)
    verb = "would change" if check else "changed"
    print(f"{len(changed)} files {verb}", file=sys.stderr)
    return 1 if check and changed else 0


if __name__ == "__main__":
    raise SystemExit(main(sys.argv[1:]))
