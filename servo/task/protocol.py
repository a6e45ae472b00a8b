"""The servo benchmark protocol: start tiers, splits, episode sets and a parallel runner.

The tiers and splits are named, the episode sets deterministic, and the runner works over the
machine's cores (success rates carry the Wilson intervals of `servo.task.stats`).

Tiers
    ``view``: today's starts, within 0.4 m and 17 deg of a stored view of the start manifold
    (``ServoEnv``'s own sampling). ``anywhere``: uniform over the start manifold's free space
    (at least 0.45 m from obstacles, ``NavigationEnv.sample_pose``), any heading: global
    localisation then has no near-duplicate stored image.
Splits
    ``dev`` for tuning, ``test`` for reporting; their episode seeds come from disjoint
    ``SeedSequence`` spawn keys, so no test episode is ever seen while tuning.
Episode ``i``
    start -> target manifold pair ``i mod P`` of the world's ordered pairs of distinct
    manifolds that hold stored views (the main corridor / lawn included, as start and as
    target), so every pair gets its share; the target view is drawn uniformly on the target
    manifold, the start as the tier says, all from episode ``i``'s seed.
"""

from __future__ import annotations

import os
import tempfile
import warnings
from concurrent.futures import ProcessPoolExecutor
from dataclasses import asdict, dataclass
from multiprocessing import get_context
from pathlib import Path

import numpy as np

from common.cores import available_cores, spawn_problem
from common.validation import check_finite, check_int, check_keys
from scenes import WORLDS
from scenes.families import check_world_name, parse_world_name
from servo.task.worker import close_worker, init_worker, isolation_of, param_names, run_spec
from sim.collect_worlds import label_space

TIERS = ("view", "anywhere")
SPLITS = ("dev", "test")
PROTOCOL_ENTROPY = 0x5E2F0_12  # the benchmark's root seed; never changed


@dataclass(frozen=True)
class Protocol:
    """One cell of the servo benchmark: a world, a start tier, a split and the env settings.

    Episode ``i`` of a protocol is the same on every machine: its seed comes from the split and
    the world only (so tiers and settings share episodes), and it goes from the ``i mod P``-th of
    the world's ordered pairs of manifolds to the next (see the module's description).

    Parameters
    ----------
    world : str
        The world: ``"hallway"``, ``"lawn"`` or a generated one, ``FAMILY:SEED``
        (``"hallway:0"`` is stored as ``"hallway"``).
    tier : {"view", "anywhere"}, default "view"
        Where episodes start: near a stored view of the start manifold, or anywhere in its free
        space with any heading.
    split : {"dev", "test"}, default "dev"
        ``dev`` for tuning, ``test`` for reporting (disjoint seeds).
    randomize : bool, default False
        Lights and colours drawn anew each episode.
    odometry_noise : bool, default True
        Odometry with random-walk drift.
    max_steps : int, default 600
        Steps per episode.

    Attributes
    ----------
    world, tier, split, randomize, odometry_noise, max_steps
        The parameters (the object is frozen).

    Examples
    --------
    >>> import numpy as np
    >>> from scenes import MANIFOLD_IDS
    >>> from servo.task import Protocol, episode_specs
    >>> protocol = Protocol("lawn", tier="anywhere", split="test")
    >>> labels = np.array([MANIFOLD_IDS["lawn"], MANIFOLD_IDS["lawn-left"]])
    >>> [(s.index, s.start_manifold, s.target_manifold) for s in episode_specs(protocol, labels, 3)]
    [(0, 'lawn', 'lawn-left'), (1, 'lawn-left', 'lawn'), (2, 'lawn', 'lawn-left')]
    >>> Protocol("lawn", tier="somewhere")
    Traceback (most recent call last):
        ...
    ValueError: tier must be one of ('view', 'anywhere'), got 'somewhere'

    See Also
    --------
    servo.run_protocol : Runs a protocol's episodes in parallel and summarises them.
    servo.task.episode_specs : Its deterministic episodes.
    """

    world: str
    tier: str = "view"
    split: str = "dev"
    randomize: bool = False
    odometry_noise: bool = True
    max_steps: int = 600

    def __post_init__(self):
        """Check the fields and store the world's canonical name."""
        object.__setattr__(self, "world", check_world_name(self.world))
        if self.tier not in TIERS:
            raise ValueError(f"tier must be one of {TIERS}, got {self.tier!r}")
        if self.split not in SPLITS:
            raise ValueError(f"split must be one of {SPLITS}, got {self.split!r}")
        check_int(self.max_steps, "max_steps")


# Success-rate targets per (policy, tier, randomize), each to be met in every world, as the
# servo guide states them (docs/guides/servo.md, "Targets"); a cell not listed has none.
SUCCESS_TARGETS = {
    ("servo", "anywhere", False): 0.95,
    ("servo", "anywhere", True): 0.95,
    ("signal", "view", False): 0.95,
    ("signal", "anywhere", False): 0.80,
    ("signal", "anywhere", True): 0.75,
}


@dataclass(frozen=True)
class EpisodeSpec:
    """One episode of a [`Protocol`][servo.task.protocol.Protocol].

    The episode is given by its index, seed and manifold pair.

    Parameters
    ----------
    index : int
        Position in the protocol's episode list.
    seed : int
        The episode's seed (``ServoEnv.reset(seed=...)``).
    start_manifold, target_manifold : str
        Where it starts and the manifold of its target view.

    Attributes
    ----------
    index, seed, start_manifold, target_manifold
        The parameters (the object is frozen).

    Examples
    --------
    >>> import numpy as np
    >>> from scenes import MANIFOLD_IDS
    >>> from servo.task import Protocol, episode_specs
    >>> labels = np.array([MANIFOLD_IDS["hallway"], MANIFOLD_IDS["hallway-left"]])
    >>> spec = episode_specs(Protocol("hallway"), labels, 1)[0]
    >>> spec.index, spec.start_manifold, spec.target_manifold, isinstance(spec.seed, int)
    (0, 'hallway', 'hallway-left', True)

    See Also
    --------
    servo.task.episode_specs : The episodes of a protocol.
    servo.task.reset_options : The env's reset options of an episode.
    """

    index: int
    seed: int
    start_manifold: str
    target_manifold: str


def manifold_pairs(true_labels: np.ndarray, names: tuple[str, ...]) -> list[tuple[str, str]]:
    """Return the ordered pairs of distinct manifolds that both hold stored views.

    Parameters
    ----------
    true_labels : ndarray of shape (n,)
        The views' evaluation labels, indices into ``names`` (negative: on no manifold).
    names : tuple of str
        The manifolds' names (the map's ``manifold_names``).

    Returns
    -------
    list of (str, str)
        The (start, target) pairs.
    """
    present = [names[i] for i in np.unique(true_labels) if i >= 0]
    return [(a, b) for a in present for b in present if a != b]


def episode_specs(
    protocol: Protocol, true_labels: np.ndarray, episodes: int, names: tuple[str, ...] | None = None
) -> list[EpisodeSpec]:
    """Return the first ``episodes`` episodes of ``protocol``'s split.

    A longer set extends a shorter one. Seeds depend on the split and the world only, so tiers
    and settings share episodes.

    Parameters
    ----------
    protocol : Protocol
        The benchmark cell.
    true_labels : ndarray of shape (n,)
        The map's views' evaluation labels, indices into ``names``.
    episodes : int
        The number of episodes.
    names : tuple of str, optional
        The manifolds ``true_labels`` index (the map's ``manifold_names``); None: those of a
        dataset of the protocol's world (`sim.collect_worlds.label_space`).

    Returns
    -------
    list of EpisodeSpec
        The episodes.
    """
    check_int(episodes, "episodes")
    names = tuple(label_space((protocol.world,))) if names is None else names
    pairs = manifold_pairs(true_labels, names)
    if not pairs:
        raise ValueError("the map needs stored views on at least two manifolds")
    root = np.random.SeedSequence(
        PROTOCOL_ENTROPY,
        spawn_key=protocol_spawn_key(protocol),
    )
    seeds = [int(s.generate_state(1)[0]) for s in root.spawn(int(episodes))]
    return [EpisodeSpec(i, s, *pairs[i % len(pairs)]) for i, s in enumerate(seeds)]


def protocol_spawn_key(protocol: Protocol) -> tuple[int, ...]:
    """Return the spawn key of a protocol's episode seeds.

    The key is ``(split, world)`` for a canonical world (its published episodes),
    ``(split, 2 + family, seed)`` for a generated one, which no canonical key equals.

    Parameters
    ----------
    protocol : Protocol
        The benchmark cell.

    Returns
    -------
    tuple of int
        The spawn key.
    """
    world = parse_world_name(protocol.world)
    family = WORLDS.index(world.family)
    if world.canonical:
        return (SPLITS.index(protocol.split), family)
    return (SPLITS.index(protocol.split), len(WORLDS) + family, world.seed)


def reset_options(env, spec: EpisodeSpec, tier: str) -> dict:
    """Return the ``ServoEnv.reset`` options of one episode.

    The ``anywhere`` tier's pose is drawn from the episode's seed.

    Parameters
    ----------
    env : ServoEnv
        The env (its base env draws the ``anywhere`` pose).
    spec : EpisodeSpec
        The episode.
    tier : {"view", "anywhere"}
        The start tier.

    Returns
    -------
    dict
        The reset options.
    """
    if tier == "view":
        return {"start_manifold": spec.start_manifold, "target_manifold": spec.target_manifold}
    if tier == "anywhere":
        rng = np.random.default_rng(np.random.SeedSequence(spec.seed, spawn_key=(1,)))
        pose = env.base.sample_pose(rng, spec.start_manifold)
        return {"pose": pose, "target_manifold": spec.target_manifold}
    raise ValueError(f"tier must be one of {TIERS}, got {tier!r}")


# -- the runner (one env and policy per worker process: servo.task.worker) ----------------------
def _check_indices(indices) -> list[int]:
    """Return ``indices`` as a list of distinct integers >= 0, or raise a ValueError."""
    if isinstance(indices, str | bytes) or not hasattr(indices, "__iter__"):
        raise ValueError(f"indices must be a list of distinct integers >= 0, got {indices!r}")
    out = list(indices)
    if (
        not out
        or len(set(out)) < len(out)
        or not all(
            isinstance(i, int | np.integer) and not isinstance(i, bool) and i >= 0 for i in out
        )
    ):
        raise ValueError(f"indices must be a list of distinct integers >= 0, got {indices!r}")
    return [int(i) for i in out]


def run_protocol(
    protocol: Protocol,
    servo_map,
    episodes: int,
    policy="servo",
    *,
    workers: int | None = None,
    policy_options: dict | None = None,
    progress: bool = True,
    plot: str | os.PathLike | None = None,
    policy_seed: int = 0,
    act_limit_s: float | None = None,
    indices=None,
    isolate: bool | None = None,
    sandbox: bool | None = None,
    hide=(),
) -> dict:
    """Run the first ``episodes`` episodes of ``protocol`` and summarise them.

    The summary is ``servo.task.evaluation.summarise``'s: success with its Wilson 95% interval,
    SPL, final errors, steps, collisions, failure reasons, per start -> target pair, F along the
    trajectories.

    Parameters
    ----------
    protocol : Protocol
        The benchmark cell to run.
    servo_map : ServoMap, str or path
        The map, or the path of a saved one (workers load it by path).
    episodes : int
        The number of episodes, the first of the protocol's list.
    policy : str or callable, default "servo"
        One of ``servo.task.POLICIES`` or an outside factory ``package.module:factory``
        (``servo.task.PolicyFactory``, or the factory itself if it is a module-level function;
        its module is imported in each worker, running its code as ``python -m`` would), made
        with ``policy_options`` as its params and a generator that is set anew for every
        episode from the episode's seed and ``policy_seed`` (``servo.task.interface.reseed``;
        ours keep one generator per worker, ``default_rng(policy_seed)``).
    workers : int, optional
        Processes (spawned, each with its own env and policy); default: the cores this process
        may use; 1 runs in this process.
    policy_options : dict, optional
        The policy's params.
    progress : bool, default True
        Show a progress bar.
    plot : str or path, optional
        Write the trails over the world's top-down map there
        (``servo.task.evaluation.plot_trajectories``; the result's ``plot``).
    policy_seed : int, default 0
        The run's policy seed.
    act_limit_s : float, optional
        Seconds a policy's call may take before its episode fails (default
        ``servo.task.guard.ACT_LIMIT_S``).
    indices : sequence of int, optional
        Run these episodes of the protocol's list instead (distinct integers >= 0;
        ``episodes`` is then ignored), each the same episode as in a run of the first ones.
    isolate : bool, optional
        Run the policy in its own process (``servo.task.remote.RemotePolicy``); None: an
        outside policy does (always: ``False`` is refused for one), ours run in the worker.
    sandbox : bool, optional
        Run that process in a sandbox (``servo.task.remote.sandbox_tool``) with the map's
        folder, ``hide`` and the data home emptied; None: where the platform has one; True:
        refused where it has none.
    hide : sequence of str or path, default ()
        Further folders the sandbox empties (the datasets, say).

    Returns
    -------
    dict
        The summary, with the protocol's fields, ``policy``, ``workers``, ``policy_params``,
        ``policy_seed`` and ``isolation`` (``process``, ``sandboxed``, ``sandbox``); ``source``
        (the digest of an outside policy's module) and ``plot`` where they apply.
    """
    from tqdm.auto import tqdm

    from servo.maps import ServoMap, load_map, save_map
    from servo.task.evaluation import check_policy_name, summarise
    from servo.task.interface import is_policy_spec

    if not isinstance(protocol, Protocol):
        raise TypeError(f"protocol must be a Protocol, got {type(protocol).__name__}")
    if callable(policy):  # a factory object: by its import path, which every worker imports
        policy = f"{policy.__module__}:{policy.__qualname__}"
    check_policy_name(policy)
    policy_seed = check_int(policy_seed, "policy_seed", minimum=0)
    if act_limit_s is not None and not check_finite(act_limit_s, "act_limit_s") > 0:
        raise ValueError(f"act_limit_s must be a number > 0, got {act_limit_s!r}")
    params = check_keys(policy_options, param_names(policy_options), "policy_options")
    isolation = isolation_of(policy, isolate, sandbox)
    workers = available_cores() if workers is None else int(workers)
    if workers < 1:
        raise ValueError(f"workers must be >= 1, got {workers}")
    with tempfile.TemporaryDirectory(prefix="servo-protocol-") as tmp:
        if isinstance(servo_map, ServoMap):
            m = servo_map
            map_path = str(save_map(m, tmp))
        elif isinstance(servo_map, str | os.PathLike):
            map_path = str(Path(servo_map))
            m = load_map(map_path, protocol.world)
        else:
            raise TypeError(
                f"servo_map must be a ServoMap or a saved map's path, got "
                f"{type(servo_map).__name__}"
            )
        m.check_world(protocol.world)
        if indices is None:
            specs = episode_specs(protocol, m.true_labels, episodes, m.manifold_names)
        else:
            indices = _check_indices(indices)
            specs = episode_specs(protocol, m.true_labels, max(indices) + 1, m.manifold_names)
            specs = [specs[i] for i in indices]
        isolation["hide"] = [str(Path(map_path).parent), *(str(h) for h in hide)]
        args = (
            protocol,
            map_path,
            policy,
            params,
            policy_seed,
            act_limit_s,
            isolation,
            reset_options,
        )
        name = f"servo {protocol.world}/{protocol.tier}/{protocol.split}/{policy}"
        bar = tqdm(total=len(specs), disable=not progress, desc=name)
        records = []
        problem = spawn_problem() if workers > 1 else None
        if problem:
            warnings.warn(
                f"running the episodes in this process, not in {workers} workers: {problem}",
                stacklevel=2,
            )
            workers = 1
        if workers == 1:
            init_worker(*args)
            try:
                for s in specs:
                    records.append(run_spec(s))
                    bar.update()
            finally:
                close_worker()
        else:
            ctx = get_context("spawn")  # no forked MuJoCo / GL state
            with ProcessPoolExecutor(
                workers, mp_context=ctx, initializer=init_worker, initargs=args
            ) as pool:
                for r in pool.map(run_spec, specs):
                    records.append(r)
                    bar.update()
        bar.close()
    result = summarise(records)
    where = {k: isolation[k] for k in ("process", "sandboxed", "sandbox")}
    result.update(
        asdict(protocol),
        policy=policy,
        workers=workers,
        policy_params=params,
        policy_seed=policy_seed,
        isolation=where,
    )
    if is_policy_spec(policy):  # provenance: the digest of the module's source
        from common.user_modules import source_digest

        result["source"] = source_digest(policy.split(":", 1)[0])
    if plot is not None:
        from scenes import build_world
        from servo.task.evaluation import plot_trajectories

        result["plot"] = str(plot_trajectories(build_world(protocol.world), records, Path(plot)))
    return result
