"""One line about the machine the figures came from, and the record of which machine wrote
each results file (``bench/results/machines.json``: file name -> machine line)."""

from __future__ import annotations

import json
import os
import platform
from collections.abc import Callable
from pathlib import Path

RESULTS = Path(__file__).resolve().parent / "results"
RECORD = "machines.json"


def machine_line() -> str:
    """CPU model, cores, Python version and platform."""
    cpu = platform.processor() or ""
    try:
        with open("/proc/cpuinfo") as f:
            for line in f:
                if line.startswith("model name"):
                    cpu = line.split(":", 1)[1].strip()
                    break
    except OSError:
        pass
    python = platform.python_version()
    return f"{cpu or 'unknown CPU'}, {os.cpu_count()} cores, Python {python}, {platform.system()}"


def recording_machine(run: Callable[[], int], results: Path = RESULTS) -> int:
    """``run()``, then the machine written down for every results file it wrote or changed.

    The studies write their own files; this notes the machine beside them, once, for all of
    them (the documentation's benchmark page says which machine each figure comes from).
    """

    def stamps() -> dict[str, int]:
        return {p.name: p.stat().st_mtime_ns for p in results.glob("*") if p.suffix in (".json", ".md")}

    before = stamps()
    code = run()
    written = sorted(name for name, stamp in stamps().items() if before.get(name) != stamp and name != RECORD)
    if written:
        record_file = results / RECORD
        record = json.loads(record_file.read_text()) if record_file.is_file() else {}
        line = machine_line()
        record.update({name: line for name in written})
        record_file.write_text(json.dumps(dict(sorted(record.items())), indent=2) + "\n")
    return code
