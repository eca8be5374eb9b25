"""One line about the machine the figures came from."""

from __future__ import annotations

import os
import platform


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
