"""How many cores this process may run on, and whether it can start worker processes at all.

The cores are the process's CPU affinity, not the machine's core count.
"""

from __future__ import annotations

import multiprocessing
import os
import sys


def available_cores() -> int:
    """Return the number of cores this process may run on.

    Its affinity where the platform has one (Linux), else ``os.cpu_count()``; at least 1.

    Returns
    -------
    int
        The number of usable cores, at least 1.
    """
    if hasattr(os, "sched_getaffinity"):
        return max(1, len(os.sched_getaffinity(0)))
    return os.cpu_count() or 1


def spawn_problem() -> str | None:
    """Say why worker processes started by ``multiprocessing``'s ``"spawn"`` could not run here.

    A spawned worker imports the main module again, by its module name or by its file:
    a main module read from standard input (``python - <<EOF``, a notebook's ``%%bash`` cell
    piping to Python) has the file ``"<stdin>"``, which no worker can import, and every worker
    dies at start (``BrokenProcessPool``). A daemonic process (a worker of Stable-Baselines3's
    ``SubprocVecEnv``, of Gymnasium's ``AsyncVectorEnv``, of a ``multiprocessing`` pool) may
    start no children at all (``AssertionError: daemonic processes are not allowed to have
    children``).

    Returns
    -------
    str or None
        The reason workers could not run, or None when they can.
    """
    if multiprocessing.current_process().daemon:
        return (
            "this process is a daemonic worker (a vector env's or a pool's), which may start no "
            "worker processes of its own"
        )
    main = sys.modules.get("__main__")
    if main is None or getattr(getattr(main, "__spec__", None), "name", None):
        return None  # no main module, or one imported by name (python -m)
    path = getattr(main, "__file__", None)
    if path is not None and not os.path.isfile(path):
        return (
            f"the main module was read from {path!r}, not from a file, so worker processes "
            "cannot import it again; save the script to a file and run that to use several"
        )
    return None
