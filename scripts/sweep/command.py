"""Evaluation sweeps: many worlds, seeds and settings of the servo task, as one table.

They run in parallel on a local process pool or on Ray (``--backend ray``), summarised as one
table.

Every episode runs whole, env and policy together, in a worker
(`scripts.sweep.episode.EpisodeRunner`, on a backend of ``scripts.sweep.backends``), and
is a function of (world, setting, seed, episode index) alone: episode ``i`` of seed ``s`` is
episode ``i`` of ``servo.task.evaluation.evaluate(world, episodes, s)``, so the table is the same on
every backend and any number of workers (its time columns apart). Episodes are scored by
``servo.task.evaluation.run_episode`` and aggregated with its ``summarise``.

Run as ``topomap sweep`` (see ``docs/guides/sweeps.md``).
"""

from __future__ import annotations

import os
import sys
import time
from pathlib import Path

import numpy as np

from common.fileio import write_json
from common.validation import check_int
from scripts.sweep.backends import (
    add_backend_arguments,
    check_backend,
    default_workers,
    open_backend,
)
from scripts.sweep.episode import SETTINGS, sweep_tasks
from scripts.tables import Column, Table

COLUMNS = (  # the table's columns (scripts.tables): one list for markdown, CSV and JSON
    Column("world", "world"),
    Column("setting", "setting"),
    Column("policy", "policy"),
    Column("episodes", "episodes", "d"),
    Column("success_rate", "success", ".2f"),
    Column("spl", "SPL", ".2f"),
    Column("mean_final_distance", "final dist. (m)", ".2f"),
    Column("mean_final_heading_error_deg", "final heading (deg)", ".1f"),
    Column("mean_steps", "steps", ".1f"),
    Column("collisions", "collisions/episode", ".1f"),
    Column("worker_s", "worker time (s)", ".1f"),
)
SWEEP_KEYS = ("backend", "num_envs", "startup_s", "run_s", "episodes_per_min")  # whole-sweep facts
TIME_KEYS = ("worker_s", "act_ms", "wall_s", "pid")  # differ run to run; the rest may not


def parse_seeds(text: str) -> list[int]:
    """Parse seeds: ``"0-3"`` -> [0, 1, 2, 3]; ``"0,2,5-6"`` -> [0, 2, 5, 6].

    Parameters
    ----------
    text : str
        Comma-separated seeds and ranges ``a-b`` (both ends included).

    Returns
    -------
    list of int
        The seeds.

    Raises
    ------
    ValueError
        For a malformed or empty range, or no seeds.
    """
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


def _check(worlds, seeds, settings, policy, episodes_per_seed, max_steps):
    from scenes.families import check_world_name
    from servo.task import POLICIES

    worlds, settings, seeds = list(worlds), list(settings), list(seeds)
    if not worlds:
        raise ValueError("worlds must be a non-empty list of 'hallway', 'lawn' or FAMILY:SEED")
    worlds = [check_world_name(w, "worlds") for w in worlds]
    if not settings or any(s not in SETTINGS for s in settings):
        raise ValueError(
            f"settings must be a non-empty subset of {tuple(SETTINGS)}, got {settings}"
        )
    if policy not in POLICIES:
        raise ValueError(f"policy must be one of {POLICIES}, got {policy!r}")
    if not seeds or any(isinstance(s, bool) or int(s) != s for s in seeds):
        raise ValueError(f"seeds must be a non-empty list of integers, got {seeds}")
    check_int(episodes_per_seed, "episodes_per_seed")
    check_int(max_steps, "max_steps")
    if len(set(worlds)) < len(worlds) or len(set(settings)) < len(settings):
        raise ValueError("worlds and settings must not repeat")
    return worlds, [int(s) for s in seeds], settings


def summarise_batch(records: list[dict]) -> dict:
    """Summarise one table row's episodes: ``servo.task.evaluation.summarise`` plus means.

    The means are over all episodes.

    Parameters
    ----------
    records : list of dict
        The row's episode records.

    Returns
    -------
    dict
        The row's numbers: episodes, success rate, SPL, mean final distance, heading error
        and steps, collisions, ``act_ms``, ``reasons`` and ``episodes_detail``.
    """
    from servo.task import summarise

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
    backend: str = "local",
    address: str | None = None,
) -> list[dict]:
    """Run ``episodes_per_seed`` episodes per seed in every (world, setting); one row each.

    The workers are started once for the whole sweep.

    Parameters
    ----------
    worlds : iterable of str
        The worlds.
    seeds : iterable of int
        The seeds.
    settings : iterable of str, default ("default",)
        Names of `SETTINGS`.
    policy : str, default "servo"
        A name of ``servo.task.POLICIES``.
    episodes_per_seed : int, default 1
        Episodes of each seed.
    num_envs : int, optional
        Workers (default: the cores this process may use).
    progress : bool, default True
        Whether to show a progress bar.
    max_steps : int, default 600
        The episodes' step limit.
    maps : dict, optional
        ``{world: ServoMap}`` to use, else the cached map of each world
        (``servo.maps.build.load_or_build(world, dataset, cache)``).
    dataset : str or os.PathLike, optional
        The dataset the maps are built from.
    cache : str or os.PathLike, optional
        The map cache; None: the data home's, see ``sim.datahome``.
    backend : str, default "local"
        `BACKENDS`: ``local`` processes or ``ray`` actors.
    address : str, optional
        An existing Ray cluster's address, else a local Ray instance.

    Returns
    -------
    list of dict
        One row per (world, setting): the columns of `COLUMNS` (``worker_s``: the row's
        episodes' wall time summed over the workers) plus ``act_ms``, ``reasons``,
        ``episodes_detail`` and the sweep's ``backend``, ``num_envs``, ``startup_s``
        (starting the workers), ``run_s`` (running every episode) and ``episodes_per_min``
        (throughput over ``run_s``).
    """
    from tqdm.auto import tqdm

    from servo.maps import load_or_build
    from sim.datahome import maps_dir

    num_envs = default_workers() if num_envs is None else num_envs
    worlds, seeds, settings = _check(worlds, seeds, settings, policy, episodes_per_seed, max_steps)
    check_backend(backend, num_envs, address)
    tasks = sweep_tasks(worlds, settings, seeds, episodes_per_seed)
    n = min(num_envs, len(tasks))
    records: list = [None] * len(tasks)
    # the backend first: a missing Ray or an unreachable cluster fails before maps are built
    with open_backend(backend, n, address) as workers:
        cache = maps_dir() if cache is None else cache  # the data home's, as load_or_build's
        maps = {w: (maps or {}).get(w) or load_or_build(w, dataset, cache) for w in worlds}
        t0 = time.perf_counter()
        workers.start(maps, policy, max_steps)
        t1 = time.perf_counter()
        with tqdm(
            total=len(tasks), desc=f"sweep {policy}", unit="episode", disable=not progress
        ) as bar:
            for i, record in workers.run(tasks):
                records[i] = record
                bar.update(1)
        t2 = time.perf_counter()
        n = workers.workers  # fewer where none could start (a script piped to Python)
    sweep = {
        "backend": backend,
        "num_envs": n,
        "startup_s": t1 - t0,
        "run_s": t2 - t1,
        "episodes_per_min": 60.0 * len(tasks) / (t2 - t1),
    }
    rows = []
    for world in worlds:
        for setting in settings:
            rs = [
                r
                for r, t in zip(records, tasks, strict=True)
                if (t.world, t.setting) == (world, setting)
            ]
            row = {"world": world, "setting": setting, "policy": policy}
            row.update(summarise_batch(rs), worker_s=float(sum(r["wall_s"] for r in rs)), **sweep)
            rows.append(row)
    return rows


def sweep_table(rows: list[dict], meta: dict) -> Table:
    """Build the sweep's table under `COLUMNS`, with what was swept and how fast as a note.

    Parameters
    ----------
    rows : list of dict
        The rows of `run_sweep`.
    meta : dict
        The facts of `sweep_meta`.

    Returns
    -------
    Table
        The table.
    """
    footer = (
        f"{meta['cores']} cores, backend {meta['backend']}, num_envs {meta['num_envs']} "
        f"(starting the workers: {meta['startup_s']:.1f} s), seeds {meta['seeds']}, "
        f"{meta['episodes_per_seed']} episodes per seed, max_steps {meta['max_steps']}, "
        f"total wall {meta['wall_s']:.1f} s, throughput {meta['episodes_per_min']:.1f} "
        f"episodes/min on {meta['num_envs']} workers (episodes only: {meta['run_s']:.1f} s)"
    )
    return Table.of(COLUMNS, rows, notes=[footer])


def write_table(rows: list[dict], out: str | os.PathLike, meta: dict) -> dict[str, Path]:
    """Write ``sweep.md``, ``sweep.csv`` and ``sweep.json`` in ``out``, each atomically.

    The markdown and CSV hold `sweep_table`; the JSON every row with its episodes, and
    ``meta``.

    Parameters
    ----------
    rows : list of dict
        The rows of `run_sweep`.
    out : str or os.PathLike
        The output folder.
    meta : dict
        The facts of `sweep_meta`.

    Returns
    -------
    dict
        ``{"md": Path, "csv": Path, "json": Path}``.
    """
    out = Path(out)
    paths = sweep_table(rows, meta).write(out / "sweep", kinds=("md", "csv"))
    paths["json"] = out / "sweep.json"
    write_json(paths["json"], {"meta": meta, "rows": rows}, finite=True)
    return paths


def sweep_meta(rows: list[dict], seeds, episodes_per_seed: int, max_steps: int, wall_s: float):
    """Gather the footer's facts: what was swept, where, on how many cores, how fast.

    What was swept, on which backend, how many cores and workers, in how long, and the
    throughput (episodes per minute of running episodes).

    Parameters
    ----------
    rows : list of dict
        The rows of `run_sweep`.
    seeds : iterable of int
        The seeds.
    episodes_per_seed : int
        Episodes of each seed.
    max_steps : int
        The episodes' step limit.
    wall_s : float
        The sweep's wall time in seconds.

    Returns
    -------
    dict
        The facts.
    """
    return {
        "worlds": list(dict.fromkeys(r["world"] for r in rows)),
        "settings": list(dict.fromkeys(r["setting"] for r in rows)),
        "policy": rows[0]["policy"],
        "seeds": list(seeds),
        "episodes_per_seed": episodes_per_seed,
        "max_steps": max_steps,
        "cores": os.cpu_count(),
        **{k: rows[0][k] for k in SWEEP_KEYS},
        "wall_s": wall_s,
    }


# -- command line (``topomap sweep``) ---------------------------------------------------------
def cmd_sweep(args) -> int:
    """Run ``topomap sweep``: the sweep, its table printed and written.

    Parameters
    ----------
    args : argparse.Namespace
        The command line of `add_parser`.

    Returns
    -------
    int
        The exit status: 0, or 2 where Ray is missing or no cluster answers.
    """
    from scripts.args import worlds as world_names

    worlds = world_names(args.world)
    seeds = parse_seeds(args.seeds)
    settings = [s.strip() for s in args.settings.split(",") if s.strip()]
    t0 = time.perf_counter()
    try:
        rows = _run_from_args(args, worlds, seeds, settings)
    except (ConnectionError, ImportError) as err:  # no cluster there, or no Ray: say so, briefly
        print(f"topomap sweep: {err}", file=sys.stderr)
        return 2
    meta = sweep_meta(rows, seeds, args.episodes_per_seed, args.max_steps, time.perf_counter() - t0)
    paths = write_table(rows, args.out, meta)
    print(paths["md"].read_text(), end="")
    print(f"wrote {', '.join(str(p) for p in paths.values())}")
    return 0


def _run_from_args(args, worlds, seeds, settings) -> list[dict]:
    return run_sweep(
        worlds,
        seeds,
        settings,
        policy=args.policy,
        episodes_per_seed=args.episodes_per_seed,
        num_envs=args.jobs,
        progress=not args.quiet,
        max_steps=args.max_steps,
        dataset=args.data,
        cache=args.maps,
        backend=args.backend,
        address=args.address,
    )


def add_parser(sub, default_out: str = "out"):
    """Add the ``sweep`` subcommand to the ``topomap`` parser's subparsers.

    Parameters
    ----------
    sub : argparse._SubParsersAction
        The subparsers action.
    default_out : str, default "out"
        The folder the default paths are under.

    Returns
    -------
    argparse.ArgumentParser
        The new parser.
    """
    from scripts.args import WORLD_HELP, world_choice
    from scripts.args import positive_int as positive
    from servo.task import POLICIES

    s = sub.add_parser(
        "sweep", help="evaluation sweep over worlds, seeds and settings, in parallel"
    )
    s.add_argument("--world", type=world_choice, default="all", metavar="WORLD", help=WORLD_HELP)
    s.add_argument("--seeds", default="0-3", help="e.g. 0-3 or 0,2,5 (default 0-3)")
    s.add_argument(
        "--settings",
        default="default",
        help=f"comma-separated, from {', '.join(SETTINGS)} (default: default)",
    )
    s.add_argument("--episodes-per-seed", type=positive, default=2)
    s.add_argument("--policy", choices=POLICIES, default="servo")
    s.add_argument("--max-steps", type=positive, default=600, help="episode time limit (steps)")
    s.add_argument("--jobs", type=positive, default=None, help="workers (default: the cores)")
    add_backend_arguments(s)
    s.add_argument("--data", default=f"{default_out}/dataset", help="dataset the maps come from")
    s.add_argument("--maps", default=f"{default_out}/servo-maps", help="servo map cache")
    s.add_argument("--out", default=f"{default_out}/sweep", help="where the table is written")
    s.add_argument("--quiet", action="store_true", help="no progress bar")
    s.set_defaults(func=cmd_sweep)
    return s
