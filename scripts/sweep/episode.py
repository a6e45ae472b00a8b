"""One sweep episode, env and policy together, in whatever process runs it.

The unit of work that every sweep backend (``scripts.sweep.backends``: a local process pool,
Ray actors) hands to its workers.

An episode is a function of (world, setting, seed, episode index) alone: the env is reset with
the seed ``servo.task.evaluation.episode_seeds(seed, ...)[episode]`` (as episode ``episode`` of
``servo.task.evaluation.evaluate(world, ..., seed)``) and the policy is built afresh for it, the
random baseline's generator seeded with the same reset seed. Nothing carries over from an earlier
episode in the same worker, so the table is the same on every backend and any number of workers.
Episodes are run and scored by ``servo.task.evaluation.run_episode`` itself.
"""

from __future__ import annotations

import os
import time
from dataclasses import dataclass

import sim  # noqa: F401  (headless GL backend before mujoco, in every worker process)

# name -> ServoEnv keyword arguments
SETTINGS: dict[str, dict] = {
    "default": {},
    "randomized": {"randomize": True},
    "no-odometry-noise": {"odometry_noise": False},
    "randomized-no-odometry-noise": {"randomize": True, "odometry_noise": False},
}


@dataclass(frozen=True)
class EpisodeTask:
    """Which episode: the sweep's (world, setting) row, its seed and the episode's index.

    Parameters
    ----------
    world : str
        The world.
    setting : str
        A name of ``SETTINGS``.
    seed : int
        The seed.
    episode : int
        The episode's index within the seed.
    """

    world: str
    setting: str
    seed: int
    episode: int


def sweep_tasks(worlds, settings, seeds, episodes_per_seed: int) -> list[EpisodeTask]:
    """List every episode of a sweep, in table order: world, setting, seed, episode.

    Parameters
    ----------
    worlds : iterable of str
        The worlds.
    settings : iterable of str
        The settings, of ``SETTINGS``.
    seeds : iterable of int
        The seeds.
    episodes_per_seed : int
        Episodes of each seed.

    Returns
    -------
    list of EpisodeTask
        The episodes.
    """
    return [
        EpisodeTask(w, s, int(seed), e)
        for w in worlds
        for s in settings
        for seed in seeds
        for e in range(episodes_per_seed)
    ]


# One thread per worker: Mesa renders in the calling thread, BLAS and OpenMP run single-threaded.
# The workers are the parallelism, one per core (a Ray actor asks for one CPU); more threads only
# contend for the cores (docs/guides/sweeps.md, "Measured"). Set in a worker's environment before it
# starts (libraries read them on loading), and again by configure_worker.
ONE_THREAD = {
    "LP_NUM_THREADS": "0",
    "OMP_NUM_THREADS": "1",
    "OPENBLAS_NUM_THREADS": "1",
    "MKL_NUM_THREADS": "1",
}


def configure_worker() -> None:
    """Run this worker on one core (`ONE_THREAD`), where the process was started without it.

    Mesa reads ``LP_NUM_THREADS`` at the first GL context (envs are built lazily, after this),
    and ``threadpoolctl`` limits the BLAS and OpenMP pools already loaded.
    """
    from threadpoolctl import threadpool_limits

    os.environ.update(ONE_THREAD)
    threadpool_limits(1)


class EpisodeRunner:
    """Runs sweep episodes in one worker.

    It keeps one ``ServoEnv`` per (world, setting), built on first use, so a worker pays for
    imports, maps and renderers once per sweep.

    Parameters
    ----------
    maps : dict
        ``{world: ServoMap}``.
    policy : str
        A name of ``servo.task.policies.POLICIES``.
    max_steps : int
        The episodes' step limit.
    one_thread : bool, default True
        Set the process to one thread (`configure_worker`); false where the episodes run in
        the calling process, whose threads are its own.
    """

    def __init__(self, maps: dict, policy: str, max_steps: int, one_thread: bool = True):
        if one_thread:
            configure_worker()
        self._maps = dict(maps)
        self._policy, self._max_steps = policy, int(max_steps)
        self._envs: dict = {}

    def _env(self, world: str, setting: str):
        from servo.task import ServoEnv

        if (world, setting) not in self._envs:
            self._envs[world, setting] = ServoEnv(
                world, self._maps[world], max_steps=self._max_steps, **SETTINGS[setting]
            )
        return self._envs[world, setting]

    def run(self, task: EpisodeTask) -> dict:
        """Run the episode ``task``.

        Parameters
        ----------
        task : EpisodeTask
            The episode.

        Returns
        -------
        dict
            ``servo.task.evaluation.run_episode``'s record of ``task``, plus its ``seed``,
            ``episode``, ``reset_seed``, the worker's process id (``pid``) and the episode's
            wall time ``wall_s``.
        """
        import numpy as np

        from servo.task import TRUTH_POLICY, episode_seeds, make_policy, run_episode

        t0 = time.perf_counter()
        env = self._env(task.world, task.setting)
        reset_seed = episode_seeds(task.seed, task.episode + 1)[task.episode]
        policy = make_policy(self._policy, env, np.random.default_rng(reset_seed))
        record = run_episode(env, policy, reset_seed, truth=self._policy == TRUTH_POLICY)
        record.update(
            seed=task.seed,
            episode=task.episode,
            reset_seed=reset_seed,
            pid=os.getpid(),
            wall_s=time.perf_counter() - t0,
        )
        return record

    def close(self) -> None:
        """Free the renderers; safe to call twice."""
        for env in self._envs.values():
            env.close()
        self._envs.clear()
