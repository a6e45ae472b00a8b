"""Evaluation sweeps: many worlds, seeds and settings of the servo task, run in parallel in
Gymnasium vector envs across the machine's cores, summarised as one table.

Each (world, setting) batch runs in one ``gymnasium.vector.AsyncVectorEnv`` of ``num_envs``
:class:`~servo.env.ServoEnv` workers, started with the ``spawn`` context (a forked worker hangs
on its first render once the parent has had a GL context). The policies run in the parent, one
per sub-env, on the batched observations. Autoreset is disabled: a sub-env whose episode ends is
reset explicitly (``reset_mask``) with the seed of the next pending episode, so every episode is
a function of (world, setting, seed, episode index) alone, whatever ``num_envs``.

Episode ``i`` of seed ``s`` is seeded as episode ``i`` of ``servo.evaluate.evaluate(world,
episodes, s)``; episodes are scored by the same rules (``servo.evaluate``: success, SPL with the
geodesic shortest path, final errors, steps, collisions) and aggregated with its ``summarise``.

Run as ``topomap sweep`` (see ``docs/sweeps.md``).
"""

from __future__ import annotations

import contextlib
import csv
import io
import json
import os
import tempfile
import time
from functools import partial
from pathlib import Path
from types import SimpleNamespace

import gymnasium as gym
import numpy as np

import sim  # noqa: F401  (headless GL backend before mujoco)

# name -> ServoEnv keyword arguments
SETTINGS: dict[str, dict] = {
    "default": {},
    "randomized": {"randomize": True},
    "no-odometry-noise": {"odometry_noise": False},
    "randomized-no-odometry-noise": {"randomize": True, "odometry_noise": False},
}
COLUMNS = (  # (key, header, format)
    ("world", "world", "{}"),
    ("setting", "setting", "{}"),
    ("policy", "policy", "{}"),
    ("episodes", "episodes", "{}"),
    ("success_rate", "success", "{:.2f}"),
    ("spl", "SPL", "{:.2f}"),
    ("mean_final_distance", "final dist. (m)", "{:.2f}"),
    ("mean_final_heading_error_deg", "final heading (deg)", "{:.1f}"),
    ("mean_steps", "steps", "{:.1f}"),
    ("collisions", "collisions/episode", "{:.1f}"),
    ("wall_s", "wall (s)", "{:.1f}"),
)


def parse_seeds(text: str) -> list[int]:
    """``"0-3"`` -> [0, 1, 2, 3]; ``"0,2,5-6"`` -> [0, 2, 5, 6]."""
    seeds: list[int] = []
    for part in (p.strip() for p in str(text).split(",")):
        if not part:
            continue
        lo, sep, hi = part.partition("-")
        try:
            a = int(lo)
            b = int(hi) if sep else a
        except ValueError:
            raise ValueError(f"seeds must look like 0-3 or 0,2,5, got {text!r}") from None
        if b < a:
            raise ValueError(f"empty seed range {part!r} in {text!r}")
        seeds.extend(range(a, b + 1))
    if not seeds:
        raise ValueError(f"no seeds in {text!r}")
    return seeds


def _check(worlds, seeds, settings, policy, episodes_per_seed, num_envs, max_steps):
    from scenes import WORLDS
    from servo.evaluate import POLICIES

    worlds, settings, seeds = list(worlds), list(settings), list(seeds)
    if not worlds or any(w not in WORLDS for w in worlds):
        raise ValueError(f"worlds must be a non-empty subset of {WORLDS}, got {worlds}")
    if not settings or any(s not in SETTINGS for s in settings):
        raise ValueError(
            f"settings must be a non-empty subset of {tuple(SETTINGS)}, got {settings}"
        )
    if policy not in POLICIES:
        raise ValueError(f"policy must be one of {POLICIES}, got {policy!r}")
    if not seeds or any(isinstance(s, bool) or int(s) != s for s in seeds):
        raise ValueError(f"seeds must be a non-empty list of integers, got {seeds}")
    for name, value in (("episodes_per_seed", episodes_per_seed), ("num_envs", num_envs),
                        ("max_steps", max_steps)):  # fmt: skip
        if isinstance(value, bool) or int(value) != value or value < 1:
            raise ValueError(f"{name} must be an integer >= 1, got {value}")
    if len(set(worlds)) < len(worlds) or len(set(settings)) < len(settings):
        raise ValueError("worlds and settings must not repeat")
    return worlds, [int(s) for s in seeds], settings


def _map_path(servo_map, cache: Path, scratch: Path) -> Path:
    """A saved copy of the map for the workers to load (the cache's own file when it is there)."""
    from servo.map_file import map_paths
    from servo.map_store import save_map

    cached, _ = map_paths(cache, servo_map.world, servo_map.key)
    return cached if cached.is_file() else save_map(servo_map, scratch)


def _unbatch(infos: dict, i: int) -> dict:
    """Sub-env ``i``'s info from a vector env's batched info dict."""
    out = {}
    for k, v in infos.items():
        if k.startswith("_"):
            continue
        mask = infos.get(f"_{k}")
        if mask is not None and not mask[i]:
            continue
        out[k] = _unbatch(v, i) if isinstance(v, dict) else v[i]
    return out


class _Replay:
    """Stands in for the env in ``servo.evaluate.run_episode`` to replay a
    finished episode from its infos, so that it is scored by that function itself."""

    def __init__(self, world, infos: list[dict]):
        self.base = SimpleNamespace(world=world)
        self._infos = infos

    def reset(self, seed=None, options=None):
        self._k = 0
        return None, self._infos[0]

    def step(self, action):
        self._k += 1
        return None, 0.0, self._k == len(self._infos) - 1, False, self._infos[self._k]


# the policy of a replay: its actions are already done
_DONE = SimpleNamespace(reset=lambda *args: None, act=lambda *args: np.zeros(2, np.float32))


def _score(world, seed: int, episode: int, reset_seed: int, infos: list[dict], act_s: list):
    """The ``servo.evaluate.run_episode`` record of a finished episode (reset info, then one info
    per step), with the sweep's seed and episode index and the policy's measured time."""
    from servo.evaluate import run_episode

    r = run_episode(_Replay(world, infos), _DONE, reset_seed)
    r.update(seed=int(seed), episode=int(episode), reset_seed=int(reset_seed),
             act_ms=float(1e3 * np.mean(act_s)), start_pose=r["trail"][0].tolist())  # fmt: skip
    return r


class SweepEnv(gym.Env):
    """One vector-env worker: a :class:`~servo.env.ServoEnv` per (world, setting), built on
    first use, chosen by the ``world`` and ``setting`` reset options (the other options go to
    the ServoEnv). One worker serves a whole sweep, so processes, imports and maps are loaded
    once, not once per batch.

    ``maps``: ``{world: path of a saved ServoMap}``; ``first``: the (world, setting) built at
    once (for the spaces).
    """

    def __init__(self, maps: dict, first: tuple[str, str], max_steps: int = 600):
        self._paths, self._max_steps = dict(maps), int(max_steps)
        self._maps: dict = {}
        self._envs: dict = {}
        self._env = self._get(*first)
        self.observation_space = self._env.observation_space
        self.action_space = self._env.action_space
        self.metadata = self._env.metadata

    def _get(self, world: str, setting: str):
        from servo.env import ServoEnv
        from servo.map_store import load_map

        if (world, setting) not in self._envs:
            if world not in self._maps:
                self._maps[world] = load_map(self._paths[world])
            self._envs[world, setting] = ServoEnv(
                world, self._maps[world], max_steps=self._max_steps, **SETTINGS[setting]
            )
        return self._envs[world, setting]

    def reset(self, *, seed=None, options=None):
        options = dict(options or {})
        self._env = self._get(options.pop("world"), options.pop("setting"))
        return self._env.reset(seed=seed, options=options)

    def step(self, action):
        return self._env.step(action)

    def close(self):
        for env in self._envs.values():
            env.close()
        self._envs.clear()


def run_batch(
    envs, world, setting: str, seeds: list[int], episodes_per_seed: int, policies: list, bar=None
) -> list[dict]:
    """All episodes of one (world, setting) on the vector env ``envs`` (of :class:`SweepEnv`),
    one policy per sub-env; returns the records in (seed, episode) order."""
    from servo.evaluate import episode_seeds

    n = envs.num_envs
    queue = [(s, e, r) for s in seeds for e, r in enumerate(episode_seeds(s, episodes_per_seed))]
    pending = list(reversed(queue))
    records: dict[tuple[int, int], dict] = {}
    running: list[dict | None] = [None] * n
    obs = None

    def start(mask: np.ndarray) -> None:
        nonlocal obs
        mask = mask.copy()
        mask[np.flatnonzero(mask)[len(pending) :]] = False  # more free envs than episodes
        todo = {int(i): pending.pop() for i in np.flatnonzero(mask)}
        obs, infos = envs.reset(
            seed=[int(todo[i][2]) if i in todo else None for i in range(n)],
            options={"reset_mask": mask, "world": world.name, "setting": setting},
        )
        for i, (s, e, r) in todo.items():
            info = _unbatch(infos, i)
            pol = policies[i]
            if hasattr(pol, "rng"):  # the random baseline: its own stream per episode
                pol.rng = np.random.default_rng(r)
            pol.reset(info["target_view"], info)
            running[i] = {"key": (s, e, r), "infos": [info], "act": []}

    start(np.ones(n, np.bool_))
    while any(r is not None for r in running):
        actions = np.zeros((n, 2), np.float32)  # idle sub-envs (none left to run) stand still
        for i, run in enumerate(running):
            if run is not None:
                t0 = time.perf_counter()
                actions[i] = policies[i].act({k: v[i] for k, v in obs.items()}, run["infos"][-1])
                run["act"].append(time.perf_counter() - t0)
        obs, _, terminated, truncated, infos = envs.step(actions)
        done = np.zeros(n, np.bool_)
        for i, run in enumerate(running):
            if run is None:
                continue
            run["infos"].append(_unbatch(infos, i))
            if terminated[i] or truncated[i]:
                s, e, r = run["key"]
                records[s, e] = _score(world, s, e, r, run["infos"], run["act"])
                running[i], done[i] = None, True
                if bar is not None:
                    bar.update(1)
        if done.any() and pending:
            start(done)
    return [records[s, e] for s, e, _ in queue]


def summarise_batch(records: list[dict]) -> dict:
    """One table row's numbers: ``servo.evaluate.summarise`` plus means over all episodes."""
    from servo.evaluate import summarise

    s = summarise(records)
    return {
        "episodes": s["episodes"],
        "success_rate": s["success_rate"],
        "spl": s["spl"],
        "mean_final_distance": float(np.mean([r["final_distance"] for r in records])),
        "mean_final_heading_error_deg": float(
            np.mean([r["final_heading_error_deg"] for r in records])
        ),
        "mean_steps": float(np.mean([r["steps"] for r in records])),
        "collisions": s["collisions"],
        "act_ms": s["act_ms"],
        "reasons": s["reasons"],
        "episodes_detail": s["episodes_detail"],
    }


@contextlib.contextmanager
def _one_thread_each(num_envs: int):
    """With several workers, each renders in its own thread and runs single-threaded BLAS (the
    processes are the parallelism; more threads would only contend for the cores)."""
    saved = dict(os.environ)
    if num_envs > 1:
        for k in ("LP_NUM_THREADS", "OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
            os.environ.setdefault(k, "0" if k == "LP_NUM_THREADS" else "1")
    try:
        yield
    finally:
        os.environ.clear()
        os.environ.update(saved)


def run_sweep(
    worlds,
    seeds,
    settings=("default",),
    policy: str = "servo",
    episodes_per_seed: int = 1,
    num_envs: int | None = None,
    progress: bool = True,
    *,
    max_steps: int = 600,
    maps: dict | None = None,
    dataset: str | os.PathLike | None = None,
    cache: str | os.PathLike | None = None,
) -> list[dict]:
    """Run ``episodes_per_seed`` episodes per seed in every (world, setting); one row each.

    ``settings`` are names of :data:`SETTINGS`. ``num_envs`` (default ``os.cpu_count()``)
    sub-envs, in worker processes started once for the whole sweep. ``maps``: ``{world:
    ServoMap}`` to use, else the cached map of each world (``servo.map_store.load_or_build(world,
    dataset, cache)``; None: the data home's, see ``sim.datahome``). Rows: the columns of
    :data:`COLUMNS` plus ``act_ms``, ``reasons``, ``num_envs``, ``startup_s`` (starting the
    workers, once per sweep, in no row's ``wall_s``) and ``episodes_detail``.
    """
    from gymnasium.vector import AsyncVectorEnv, AutoresetMode
    from threadpoolctl import threadpool_limits
    from tqdm.auto import tqdm

    from scenes import build_world
    from servo.evaluate import make_policy
    from servo.map_store import load_or_build
    from sim.datahome import maps_dir

    num_envs = (os.cpu_count() or 1) if num_envs is None else num_envs
    worlds, seeds, settings = _check(
        worlds, seeds, settings, policy, episodes_per_seed, num_envs, max_steps
    )
    cache = maps_dir() if cache is None else cache  # the data home's, as load_or_build's
    maps = {w: (maps or {}).get(w) or load_or_build(w, dataset, cache) for w in worlds}
    n = min(num_envs, len(seeds) * episodes_per_seed)
    rows = []
    with (
        tempfile.TemporaryDirectory(prefix="topomap-sweep-") as scratch,
        tqdm(
            total=len(worlds) * len(settings) * len(seeds) * episodes_per_seed,
            desc=f"sweep {policy}",
            unit="episode",
            disable=not progress,
        ) as bar,
    ):
        paths = {w: str(_map_path(m, Path(cache), Path(scratch))) for w, m in maps.items()}
        make = partial(SweepEnv, paths, (worlds[0], settings[0]), max_steps)
        t0 = time.perf_counter()
        with _one_thread_each(n):
            envs = AsyncVectorEnv(
                [make] * n, context="spawn", autoreset_mode=AutoresetMode.DISABLED
            )
        startup = time.perf_counter() - t0
        limit = threadpool_limits(1) if n > 1 else contextlib.nullcontext()
        try:
            with limit:  # the parent's controllers: single-threaded beside the workers
                for world in worlds:
                    env_world = build_world(world)
                    # make_policy reads env.map and env.base.world only: no simulator in the parent
                    proxy = SimpleNamespace(map=maps[world], base=SimpleNamespace(world=env_world))
                    policies = [
                        make_policy(policy, proxy, np.random.default_rng(0)) for _ in range(n)
                    ]
                    for setting in settings:
                        bar.set_postfix_str(f"{world}/{setting}")
                        t0 = time.perf_counter()
                        records = run_batch(envs, env_world, setting, seeds, episodes_per_seed,
                                            policies, bar)  # fmt: skip
                        row = {"world": world, "setting": setting, "policy": policy}
                        row.update(summarise_batch(records))
                        row.update(wall_s=time.perf_counter() - t0, num_envs=n, startup_s=startup)
                        rows.append(row)
        finally:
            envs.close()
    return rows


def _cell(fmt: str, value) -> str:
    return "-" if value is None else fmt.format(value)


def to_markdown(rows: list[dict], meta: dict) -> str:
    head = "| " + " | ".join(h for _, h, _ in COLUMNS) + " |"
    rule = "|" + "|".join("---" for _ in COLUMNS) + "|"
    body = ["| " + " | ".join(_cell(f, r[k]) for k, _, f in COLUMNS) + " |" for r in rows]
    footer = (
        f"\n{meta['cores']} cores, num_envs {meta['num_envs']} (starting the workers: "
        f"{meta['startup_s']:.1f} s), seeds {meta['seeds']}, "
        f"{meta['episodes_per_seed']} episodes per seed, max_steps {meta['max_steps']}, "
        f"total wall {meta['wall_s']:.1f} s"
    )
    return "\n".join([head, rule, *body]) + "\n" + footer + "\n"


def to_csv(rows: list[dict]) -> str:
    buf = io.StringIO()
    w = csv.writer(buf, lineterminator="\n")
    w.writerow([k for k, _, _ in COLUMNS])
    for r in rows:
        w.writerow([r[k] for k, _, _ in COLUMNS])
    return buf.getvalue()


def write_table(rows: list[dict], out: str | os.PathLike, meta: dict) -> dict[str, Path]:
    """``sweep.md``, ``sweep.csv`` and ``sweep.json`` (rows, episodes and ``meta``) in ``out``,
    each written atomically."""
    from scenes.fileio import atomic_write_bytes

    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    texts = {
        "md": to_markdown(rows, meta),
        "csv": to_csv(rows),
        "json": json.dumps({"meta": meta, "rows": rows}, indent=2) + "\n",
    }
    paths = {}
    for ext, text in texts.items():
        paths[ext] = out / f"sweep.{ext}"
        atomic_write_bytes(paths[ext], text.encode())
    return paths


def sweep_meta(rows: list[dict], seeds, episodes_per_seed: int, max_steps: int, wall_s: float):
    """The footer's facts: what was swept, on how many cores and workers, in how long."""
    return {
        "worlds": list(dict.fromkeys(r["world"] for r in rows)),
        "settings": list(dict.fromkeys(r["setting"] for r in rows)),
        "policy": rows[0]["policy"],
        "seeds": list(seeds),
        "episodes_per_seed": episodes_per_seed,
        "max_steps": max_steps,
        "cores": os.cpu_count(),
        "num_envs": rows[0]["num_envs"],
        "startup_s": rows[0]["startup_s"],
        "wall_s": wall_s,
    }


# -- command line (``topomap sweep``) ---------------------------------------------------------
def cmd_sweep(args) -> int:
    from scenes import WORLDS

    worlds = WORLDS if args.world == "all" else (args.world,)
    seeds = parse_seeds(args.seeds)
    settings = [s.strip() for s in args.settings.split(",") if s.strip()]
    num_envs = args.jobs or os.cpu_count() or 1
    t0 = time.perf_counter()
    rows = run_sweep(
        worlds,
        seeds,
        settings,
        policy=args.policy,
        episodes_per_seed=args.episodes_per_seed,
        num_envs=num_envs,
        progress=not args.quiet,
        max_steps=args.max_steps,
        dataset=args.data,
        cache=args.maps,
    )
    meta = sweep_meta(rows, seeds, args.episodes_per_seed, args.max_steps, time.perf_counter() - t0)
    paths = write_table(rows, args.out, meta)
    print(paths["md"].read_text(), end="")
    print(f"wrote {', '.join(str(p) for p in paths.values())}")
    return 0


def add_parser(sub, default_out: str = "out"):
    """Add the ``sweep`` subcommand to the ``topomap`` parser's subparsers."""
    from scenes import WORLDS
    from scripts.args import positive_int as positive
    from servo.evaluate import POLICIES

    s = sub.add_parser(
        "sweep", help="evaluation sweep over worlds, seeds and settings, in parallel"
    )
    s.add_argument("--world", choices=(*WORLDS, "all"), default="all")
    s.add_argument("--seeds", default="0-3", help="e.g. 0-3 or 0,2,5 (default 0-3)")
    s.add_argument(
        "--settings",
        default="default",
        help=f"comma-separated, from {', '.join(SETTINGS)} (default: default)",
    )
    s.add_argument("--episodes-per-seed", type=positive, default=2)
    s.add_argument("--policy", choices=POLICIES, default="servo")
    s.add_argument("--max-steps", type=positive, default=600, help="episode time limit (steps)")
    s.add_argument("--jobs", type=positive, default=None, help="envs per batch (default: cores)")
    s.add_argument("--data", default=f"{default_out}/dataset", help="dataset the maps come from")
    s.add_argument("--maps", default=f"{default_out}/servo-maps", help="servo map cache")
    s.add_argument("--out", default=f"{default_out}/sweep", help="where the table is written")
    s.add_argument("--quiet", action="store_true", help="no progress bar")
    s.set_defaults(func=cmd_sweep)
    return s
