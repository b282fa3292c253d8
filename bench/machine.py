"""The machine a benchmark ran on, printed by every benchmark next to its figures."""

from __future__ import annotations

import os
import platform
from pathlib import Path


def cpu_model() -> str:
    """The CPU's model name from /proc/cpuinfo (platform.processor() elsewhere)."""
    try:
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.startswith("model name"):
                return line.split(":", 1)[1].strip()
    except OSError:
        pass
    return platform.processor() or "unknown CPU"


def describe(*extra: str) -> str:
    """'CPU, N cores, Python x.y.z, OS [, extra…]', with the load average where known (these
    machines are shared: a loaded machine explains a slow figure)."""
    parts = [cpu_model(), f"{os.cpu_count()} cores", f"Python {platform.python_version()}",
             platform.system()]
    try:
        parts.append("load average %.1f" % os.getloadavg()[0])
    except OSError:
        pass
    return ", ".join(parts + list(extra))
