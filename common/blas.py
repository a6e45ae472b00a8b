"""The BLAS thread policy of the numeric code.

Small eigendecompositions and solves run with BLAS on one thread (`single_threaded_blas`),
big products keep all threads unless the machine is busy (`busy`).

Shared by the estimators of ``mapping`` and the controllers and evaluation of ``servo``.
"""

from __future__ import annotations

import os

import threadpoolctl

from common.cores import available_cores

_BLAS: list | None = None  # threadpoolctl's controllers of the loaded BLAS libraries
# threadpoolctl >= 3.8 lets one Python thread at a time set OpenBLAS's threads and counts the
# limits a thread holds (it gives the control up at 0); hold one, as ``limit`` does
_OWNERSHIP = getattr(threadpoolctl, "CONTROLLING_THREAD_OWNERSHIP", None)


class _OneBlasThread:
    """Limit every BLAS library to one thread on entry; give each its own count back on exit."""

    __slots__ = ("_saved",)

    def __enter__(self) -> _OneBlasThread:
        if _OWNERSHIP is not None:
            _OWNERSHIP.increment()
        self._saved = [(lib, lib.get_num_threads()) for lib in _BLAS]
        for lib, threads in self._saved:
            if threads != 1:
                lib.set_num_threads(1)
        return self

    def __exit__(self, *exc) -> None:
        for lib, threads in self._saved:
            if threads != 1:
                lib.set_num_threads(threads)
        if _OWNERSHIP is not None:
            _OWNERSHIP.decrement()


def single_threaded_blas() -> _OneBlasThread:
    """Return a context running BLAS on one thread.

    The manifold search does hundreds of eigendecompositions of matrices of a few hundred rows
    and ``predict`` hundreds of small solves; OpenBLAS gains little from threads at that size
    and, on a busy 2-core machine, its spinning threads made a 600-point fit 6x slower
    (3 s -> 20 s) and ``predict`` of 450 views 8x slower (0.3 s -> 2.3 s). Big Gram products
    run outside this context and keep all threads.

    The libraries' own thread setters (threadpoolctl's controllers, found once), not
    ``ThreadpoolController.limit``: that one reads every library's full ``info`` on entry,
    ~0.1 ms, a sixth of ``predict`` for one view at d = 2000.

    Returns
    -------
    context manager
        Limits every BLAS library to one thread on entry and restores each count on exit.
    """
    global _BLAS
    if _BLAS is None:  # scanning the loaded libraries costs ~2 ms; do it once
        _BLAS = threadpoolctl.ThreadpoolController().select(user_api="blas").lib_controllers
    return _OneBlasThread()


def on_one_blas_thread(fn, *args):
    """Call ``fn(*args)`` under `single_threaded_blas`.

    This is what a worker process of a parallel fit runs, so that its result is the one the
    fit computes in the parent (which holds the same context), to the bit.

    Parameters
    ----------
    fn : callable
        Function to call.
    *args
        Positional arguments passed to ``fn``.

    Returns
    -------
    object
        What ``fn`` returns.
    """
    with single_threaded_blas():
        return fn(*args)


def busy() -> bool:
    """Check whether the machine has no core to spare.

    It has none when the 1-minute load average is at least the cores less half a core. A
    second OpenBLAS thread then spin-waits for a descheduled partner (a
    40 x 230400 float32 GEMV: ~1.7 ms on one thread, ~12 ms on two at load 4-5 on 2 cores);
    with a core free it halves a memory-bound product (52 against 26 GB/s here).

    Returns
    -------
    bool
        True when the machine is busy; False also where there is no load average.
    """
    try:
        return os.getloadavg()[0] >= available_cores() - 0.5
    except OSError:  # no load average on this platform
        return False
