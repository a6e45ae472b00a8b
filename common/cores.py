"""How many cores this process may run on (its CPU affinity, not the machine's core count)."""

from __future__ import annotations

import os


def available_cores() -> int:
    """Cores this process may run on: its affinity where the platform has one (Linux), else
    ``os.cpu_count()``; at least 1."""
    if hasattr(os, "sched_getaffinity"):
        return max(1, len(os.sched_getaffinity(0)))
    return os.cpu_count() or 1
