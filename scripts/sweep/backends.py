"""Where a sweep's episodes run: ``local`` processes or ``ray`` actors.

``local`` is a pool of spawned processes on this machine; ``ray`` Ray actors, on a local Ray
instance or an existing cluster (``scripts.sweep.ray_backend``).

Every backend's workers run whole episodes, env and policy together, through
`scripts.sweep.episode.EpisodeRunner`, so both give the same records for the same tasks.
A backend is used as ``with open_backend(name, workers, address) as b:`` then
``b.start(maps, policy, max_steps)`` and ``for i, record in b.run(tasks): ...`` (records as they
complete, with their task's index). Other units of work use the same workers through
``b.start_runner(factory, *args)``: each worker holds ``factory(*args)`` (an object with
``run(task)`` and ``close()``, whose ``one_thread`` keyword says whether it may set its process
to one thread), as the held-out evaluation's cells do (``scripts.heldout``).
"""

from __future__ import annotations

import os
import warnings
from collections.abc import Iterator
from concurrent.futures import ProcessPoolExecutor, as_completed
from contextlib import contextmanager
from multiprocessing import get_context

from common.cores import available_cores, spawn_problem
from common.validation import check_int
from scripts.sweep.episode import ONE_THREAD, EpisodeRunner
from scripts.sweep.ray_backend import RayBackend, parse_address  # imports Ray only when used

BACKENDS = ("local", "ray")

_RUNNER: list[EpisodeRunner] = []  # the pool worker's runner (one per process)


def _init_pool_worker(factory, args: tuple) -> None:
    _RUNNER.append(factory(*args))


def _run_in_pool(task) -> dict:
    return _RUNNER[0].run(task)


class LocalBackend:
    """A pool of ``workers`` spawned processes, each an `EpisodeRunner`.

    The processes are spawned because a forked worker hangs on its first render once the
    parent has had a GL context. Each has its own copy of the maps (pickled from this
    process's, already checked: loading and re-checking the saved files in every worker took
    longer than the episodes of a small sweep).

    Where no worker process can start (a script piped to Python: ``common.cores.spawn_problem``)
    the episodes run one after another in the calling process, with a warning saying why, and
    ``workers`` becomes 1; the records are the same (each episode depends on its task alone).

    Parameters
    ----------
    workers : int
        The number of worker processes.
    """

    name = "local"

    def __init__(self, workers: int):
        self.workers = int(workers)
        self._pool: ProcessPoolExecutor | None = None
        self._runner: EpisodeRunner | None = None  # the calling process's, when none can start

    def start(self, maps: dict, policy: str, max_steps: int) -> None:
        """Start the workers, each an `EpisodeRunner` of ``maps``, ``policy`` and ``max_steps``.

        Parameters
        ----------
        maps : dict
            ``{world: ServoMap}``.
        policy : str
            A name of ``servo.task.policies.POLICIES``.
        max_steps : int
            The episodes' step limit.
        """
        self.start_runner(EpisodeRunner, dict(maps), policy, int(max_steps))

    def start_runner(self, factory, *args) -> None:
        """Start the workers, each holding ``factory(*args)``; its ``run`` gets the tasks.

        Parameters
        ----------
        factory : callable
            Makes a worker's runner (with ``run(task)`` and ``close()``); takes the
            ``one_thread`` keyword.
        *args
            The factory's arguments.
        """
        problem = spawn_problem()
        if problem:
            warnings.warn(
                f"sweeping in this process, not in {self.workers} worker processes: {problem}",
                RuntimeWarning,
                stacklevel=3,
            )
            self.workers = 1
            # the caller's thread settings stay its own: one thread is for a pool's workers
            self._runner = factory(*args, one_thread=False)
            return
        self._pool = ProcessPoolExecutor(
            self.workers,
            mp_context=get_context("spawn"),
            initializer=_init_pool_worker,
            initargs=(factory, args),
        )
        # start the processes now (a spawned pool starts them all on its first task), so that
        # their start-up counts as the sweep's start-up on both backends; they inherit
        # ONE_THREAD from the environment they are started in
        saved = dict(os.environ)
        os.environ.update(ONE_THREAD)
        try:
            for f in [self._pool.submit(os.getpid) for _ in range(self.workers)]:
                f.result()
        finally:
            os.environ.clear()
            os.environ.update(saved)

    def run(self, tasks: list) -> Iterator[tuple[int, dict]]:
        """Run ``tasks`` on the workers, yielding each record as it completes.

        Parameters
        ----------
        tasks : list
            The tasks, each for the runners' ``run``.

        Yields
        ------
        index : int
            The task's index in ``tasks``.
        record : dict
            Its record.
        """
        if self._runner is not None:
            for i, task in enumerate(tasks):
                yield i, self._runner.run(task)
            return
        futures = {self._pool.submit(_run_in_pool, t): i for i, t in enumerate(tasks)}
        for f in as_completed(futures):
            yield futures[f], f.result()

    def close(self) -> None:
        """Stop the workers (or close the in-process runner); safe to call twice."""
        if self._runner is not None:
            self._runner.close()
            self._runner = None
        if self._pool is not None:
            self._pool.shutdown(cancel_futures=True)
            self._pool = None


def check_backend(backend: str, workers, address) -> None:
    """Check a backend's settings before anything is started.

    Bad settings raise ValueError naming the parameter and the expected form.

    Parameters
    ----------
    backend : str
        One of ``BACKENDS``.
    workers : int
        The number of workers.
    address : str or None
        A Ray cluster's ``host:port`` (``ray`` only).
    """
    if backend not in BACKENDS:
        raise ValueError(f"backend must be one of {BACKENDS}, got {backend!r}")
    check_int(workers, "num_envs")
    if address is not None and backend != "ray":
        raise ValueError(f"address is for the ray backend only, got backend {backend!r}")
    if address is not None and (not isinstance(address, str) or not address.strip()):
        raise ValueError(f"address must be a Ray cluster's host:port, got {address!r}")
    if address is not None:
        parse_address(address)  # its form, before anything is started


@contextmanager
def open_backend(backend: str, workers: int, address: str | None = None):
    """Open the backend ``backend`` with ``workers`` workers, closed on leaving the block.

    Closing stops its workers and shuts down a Ray instance it started.

    Parameters
    ----------
    backend : str
        One of ``BACKENDS``.
    workers : int
        The number of workers.
    address : str, optional
        An existing Ray cluster's address (``ray`` only); by default a local Ray instance.

    Yields
    ------
    LocalBackend or RayBackend
        The backend, not started yet.
    """
    check_backend(backend, workers, address)
    if backend == "ray":
        b = RayBackend(workers, address)  # fails here if Ray is missing or address unreachable
    else:
        b = LocalBackend(workers)
    try:
        yield b
    finally:
        b.close()


def add_backend_arguments(parser) -> None:
    """Add ``--backend`` and ``--address`` to an argparse ``parser``.

    They are the options of every command that runs its tasks on these backends.

    Parameters
    ----------
    parser : argparse.ArgumentParser
        The parser.
    """
    parser.add_argument(
        "--backend",
        choices=BACKENDS,
        default="local",
        help="local: processes on this machine; ray: Ray actors (pip install ray)",
    )
    parser.add_argument(
        "--address",
        default=None,
        help="an existing Ray cluster's address (host:port or ray://host:port); "
        "default: start a local Ray instance",
    )


def default_workers() -> int:
    """Return the cores this process may use.

    Returns
    -------
    int
        The number of cores.
    """
    return available_cores()
