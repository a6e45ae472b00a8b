"""Memory-bound work on one view split by columns over the cores, robust to a busy machine.

``predict`` of one image-sized view is a few GEMVs that read tens of MB: one core streams
~26 GB/s here, two ~52 GB/s. OpenBLAS's own threads would split it, but on a busy 2-core
machine they spin-wait for each other (a 40 x 230400 GEMV: 1.7 ms on one thread, ~12 ms on
two at load 4-5; :func:`mapping._validation.single_threaded_blas`). :func:`map_columns`
splits by hand instead: the calling thread and a pool thread (one per further core) take
column chunks from a shared counter, each running single-threaded BLAS. A pool thread that
the scheduler does not run in time takes no chunk, and the caller does them all, so the
split is never much slower than doing the work on one thread; it waits only for chunks a
pool thread has claimed.
"""

from __future__ import annotations

import itertools
import os
import threading
import time
from collections.abc import Callable
from concurrent.futures import ThreadPoolExecutor
from typing import TypeVar

T = TypeVar("T")

_POOL: ThreadPoolExecutor | None = None
_POOL_LOCK = threading.Lock()


def cores() -> int:
    """Cores this process may run on."""
    try:
        return len(os.sched_getaffinity(0))
    except AttributeError:  # not on Linux
        return os.cpu_count() or 1


def _forget_pool() -> None:
    # a forked child has the pool object but not its threads: work submitted there would
    # never run (the caller would do every chunk) and the queue would keep its arrays
    global _POOL
    _POOL = None


if hasattr(os, "register_at_fork"):
    os.register_at_fork(after_in_child=_forget_pool)


def _pool() -> ThreadPoolExecutor:
    global _POOL
    with _POOL_LOCK:
        if _POOL is None:
            _POOL = ThreadPoolExecutor(max(1, cores() - 1), thread_name_prefix="topomap-columns")
        return _POOL


def busy() -> bool:
    """Whether the machine has no core to spare: the 1-minute load average at least the cores
    less half a core (a split then waits on threads the scheduler holds back: on the shared
    2-core machine at load 3-4 it made ``predict`` of one image 4.7 -> 7.0 ms)."""
    try:
        return os.getloadavg()[0] >= cores() - 0.5
    except OSError:  # no load average on this platform
        return False


def map_columns(fn: Callable[[slice], T], d: int, chunks: int) -> list[T]:
    """``[fn(cols) for cols in chunks of range(d)]``, in chunk order, the chunks shared between
    the calling thread and the pool's threads (one per further core; none for ``chunks`` 1, a
    single core or a :func:`busy` machine). ``fn`` must release the GIL for most of its time
    (numpy, BLAS), be deterministic and write only to its own columns: a chunk that a pool
    thread claimed and has not finished within half the time the caller took per chunk is
    computed again by the caller (the thread was likely descheduled), so a late pool thread
    never holds the call up much. An exception raised by ``fn`` is raised here."""
    if d < 1 or chunks < 1:
        raise ValueError(f"d and chunks must be >= 1, got {d}, {chunks}")
    chunks = min(chunks, d)
    bounds = [d * i // chunks for i in range(chunks + 1)]
    tasks = [slice(a, b) for a, b in itertools.pairwise(bounds)]
    helpers = min(cores(), chunks) - 1
    if helpers <= 0 or busy():
        return [fn(cols) for cols in tasks]
    results: list = [None] * chunks
    failed: list[BaseException | None] = [None] * chunks
    done = [threading.Event() for _ in tasks]
    mine: list[int] = []
    taken = itertools.count()  # next() on it is atomic under the GIL

    def work(own: list[int] | None = None) -> None:
        while (i := next(taken)) < chunks:
            try:
                results[i] = fn(tasks[i])
            except BaseException as err:  # raised in the caller below
                failed[i] = err
            finally:
                if own is not None:
                    own.append(i)
                done[i].set()

    pool = _pool()
    for _ in range(helpers):
        pool.submit(work)
    start = time.perf_counter()
    work(mine)
    patience = 0.5 * (time.perf_counter() - start) / max(len(mine), 1)
    for i, event in enumerate(done):  # only chunks a pool thread claimed can be running
        if not event.wait(timeout=patience):
            results[i] = fn(tasks[i])  # the same values the pool thread will write
        elif failed[i] is not None:
            raise failed[i]
    return results
