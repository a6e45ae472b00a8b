"""Every mapping task on each family's held-out test worlds beside its canonical world.

The summary gives the gap between the two.

    topomap heldout --worlds 20 --out out/heldout [--jobs 2] [--seeds 0] [--backend ray]

runs one cell (`scripts.heldout.cells`) per world and seed: the family's first ``--worlds``
held-out test worlds (`scenes.families.splits.held_out_worlds`) and its canonical world,
on the sweep's backends (``scripts.sweep.backends``: local processes, or Ray actors on this
machine or a cluster), one task per world and seed. Cells are cached, so a second call with
more worlds computes only the new ones, and a stopped one resumes. The summary
(`scripts.heldout.summary`) is written as ``heldout.json`` and ``heldout.md``.
"""

from __future__ import annotations

import argparse
import os
import sys
from pathlib import Path

from common.fileio import atomic_write_bytes, write_json
from scenes.families import FAMILIES, held_out_worlds
from scripts.heldout.cells import TASKS, run_cell
from scripts.heldout.summary import format_summary, summarise

__all__ = ["CellRunner", "evaluate_heldout", "format_summary", "summarise"]

CANONICAL_EPISODES = 4  # the canonical world's servo episodes, as a multiple of a held-out one's


def plan(families, count: int, seeds) -> list[tuple[str, int]]:
    """List (world, seed) of every cell: each family's canonical world and held-out test worlds.

    Parameters
    ----------
    families : iterable of str
        The families.
    count : int
        Held-out test worlds per family.
    seeds : iterable of int
        Dataset seeds per world.

    Returns
    -------
    list of tuple of (str, int)
        The cells.
    """
    out = []
    for family in families:
        for world in (family, *held_out_worlds(family, count)):
            out += [(world, int(s)) for s in seeds]
    return out


class CellRunner:
    """Run held-out cells in one sweep worker (``scripts.sweep.backends``).

    A task is ``(world, seed, episodes)``; the rest of `scripts.heldout.cells.run_cell`'s
    arguments are the runner's. The process is set to one thread unless ``one_thread`` is
    false (the cells then run in the calling process, whose threads are its own).

    Parameters
    ----------
    out : str or Path
        The evaluation's output folder.
    data_root : str or Path
        The folder of the cells' datasets.
    frames : int
        Frames per sequence.
    tasks : iterable of str
        The tasks of each cell.
    one_thread : bool, default True
        Whether to set the process to one BLAS thread.
    """

    def __init__(self, out, data_root, frames: int, tasks, one_thread: bool = True):
        import sim  # noqa: F401  (headless GL before mujoco in a fresh worker)

        if one_thread:
            from scripts.sweep import configure_worker

            configure_worker()  # the workers share the cores: one BLAS thread each
        self._args = (Path(out), Path(data_root), int(frames), tuple(tasks))

    def run(self, task: tuple) -> dict:
        """Run one cell.

        Parameters
        ----------
        task : tuple of (str, int, int)
            The world, the dataset seed and the servo episodes.

        Returns
        -------
        dict
            The cell of `scripts.heldout.cells.run_cell`.
        """
        world, seed, episodes = task
        out, data_root, frames, tasks = self._args
        return run_cell(world, seed, out, data_root, frames, tasks, episodes)

    def close(self) -> None:
        """Nothing to free (every cell closes its own envs)."""


def evaluate_heldout(
    out: Path,
    families=FAMILIES,
    count: int = 20,
    seeds=(0,),
    frames: int = 150,
    tasks=TASKS,
    jobs: int | None = None,
    data_root: Path | None = None,
    progress: bool = True,
    *,
    episodes: int = 3,
    backend: str = "local",
    address: str | None = None,
) -> dict:
    """Run (or resume) every cell of `plan` on ``backend``, then summarise them.

    The summary (`summarise`) is written to ``out/heldout.json`` and ``out/heldout.md``.

    Parameters
    ----------
    out : Path
        The output folder.
    families : iterable of str, default FAMILIES
        The families.
    count : int, default 20
        Held-out test worlds per family.
    seeds : iterable of int, default (0,)
        Dataset seeds per world.
    frames : int, default 150
        Frames per drive.
    tasks : sequence of str, default TASKS
        The tasks of each cell.
    jobs : int or None, default None
        Workers; None: the cores (never more than the cells).
    data_root : Path or None, default None
        The folder of the cells' datasets; None: ``out/data``.
    progress : bool, default True
        Whether to show a progress bar.
    episodes : int, default 3
        Servo episodes per controller and start tier in a held-out world (the canonical
        world gets `CANONICAL_EPISODES` times as many).
    backend : str, default "local"
        The sweep backend (``scripts.sweep.backends``).
    address : str or None, default None
        The Ray cluster's address, for the Ray backend.

    Returns
    -------
    dict
        The summary.
    """
    from tqdm.auto import tqdm

    from scripts.sweep import open_backend

    out = Path(out)
    data_root = out / "data" if data_root is None else Path(data_root)
    cells = plan(families, count, seeds)
    tasks_ = [(w, s, episodes * (CANONICAL_EPISODES if ":" not in w else 1)) for w, s in cells]
    jobs = max(1, min(jobs or os.cpu_count() or 1, len(tasks_)))
    results = []
    bar = tqdm(total=len(tasks_), desc="held-out cells", unit="cell", disable=not progress)
    with open_backend(backend, jobs, address) as workers:
        workers.start_runner(CellRunner, out, data_root, frames, tuple(tasks))
        for _, cell in workers.run(tasks_):
            results.append(cell)
            bar.update(1)
    bar.close()
    summary = summarise(results, frames=frames)
    write_json(out / "heldout.json", {"summary": summary, "cells": results})
    atomic_write_bytes(out / "heldout.md", format_summary(summary).encode())
    return summary


def build_parser(parser: argparse.ArgumentParser | None = None) -> argparse.ArgumentParser:
    """Declare the options of ``topomap heldout``.

    Parameters
    ----------
    parser : argparse.ArgumentParser or None, default None
        The parser to declare them on; None makes a new one.

    Returns
    -------
    argparse.ArgumentParser
        The parser.
    """
    from scripts.args import positive_int
    from scripts.sweep import add_backend_arguments

    p = parser or argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--families", nargs="+", choices=FAMILIES, default=list(FAMILIES))
    p.add_argument(
        "--worlds",
        type=positive_int,
        default=20,
        help="held-out test worlds per family (default 20)",
    )
    p.add_argument("--seeds", type=int, nargs="+", default=[0], help="dataset seeds per world")
    p.add_argument("--frames", type=positive_int, default=150, help="frames per drive")
    p.add_argument("--tasks", nargs="+", choices=TASKS, default=list(TASKS))
    p.add_argument(
        "--episodes",
        type=positive_int,
        default=3,
        help="servo episodes per controller and start tier in each held-out world (default 3: "
        "targets 1, 2 and 3+ junctions away; the canonical world gets "
        f"{CANONICAL_EPISODES}x as many)",
    )
    p.add_argument("--jobs", type=positive_int, default=None, help="workers (default: the cores)")
    add_backend_arguments(p)
    p.add_argument("--out", type=Path, default=Path("out/heldout"))
    p.add_argument("--data", type=Path, default=None, help="dataset folder (default OUT/data)")
    return p


def run(args) -> int:
    """Run the held-out evaluation and print its summary.

    Parameters
    ----------
    args : argparse.Namespace
        The parsed options of ``topomap heldout``.

    Returns
    -------
    int
        The exit status: 0, or 2 when the backend is not there.
    """
    if any(s < 0 for s in args.seeds):
        raise SystemExit("topomap heldout: --seeds must be integers >= 0")
    try:
        summary = evaluate_heldout(
            args.out,
            args.families,
            args.worlds,
            args.seeds,
            args.frames,
            args.tasks,
            args.jobs,
            args.data,
            episodes=args.episodes,
            backend=args.backend,
            address=args.address,
        )
    except (ConnectionError, ImportError) as err:  # no cluster there, or no Ray: say so, briefly
        print(f"topomap heldout: {err}", file=sys.stderr)
        return 2
    print(format_summary(summary), end="")
    print(f"wrote {args.out / 'heldout.json'} and {args.out / 'heldout.md'}")
    return 0


def main(argv=None) -> int:
    """Run the held-out evaluation from the command line.

    Parameters
    ----------
    argv : list of str or None, default None
        The arguments; None reads ``sys.argv[1:]``.

    Returns
    -------
    int
        The exit status.
    """
    return run(build_parser().parse_args(argv))


if __name__ == "__main__":
    raise SystemExit(main())
