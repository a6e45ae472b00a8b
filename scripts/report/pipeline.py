"""The run as a registry of named stages.

`STAGES` lists them in order, and `run_pipeline` runs whichever sequence of `Stage` it is
given (by default `STAGES`), so tests pass fake stages instead of patching this module.

Each stage gets the `RunContext` (output folders, settings, the results of the stages
before it) and returns a dict; the pipeline times it, turns a failure into a
`StageError` naming it, builds its section of the page from the dict, and records it in
``report.json``.
"""

from __future__ import annotations

import dataclasses
import json
import os
import tempfile
import time
from collections.abc import Callable, Sequence
from dataclasses import asdict, dataclass, field
from functools import partial
from pathlib import Path
from typing import Any

from common.fileio import atomic_write_bytes, jsonable
from scripts.report.html import build_html, esc, write_report
from scripts.report.provenance import git_commit, machine, versions
from scripts.report.sections import (
    section_grouping,
    section_leaderboards,
    section_manifold,
    section_protocol,
    section_reproduce,
    section_servo,
    section_summary,
    section_worlds,
)
from scripts.report.settings import REPORT_DIR, OutputError, RunSettings, StageError
from scripts.report.stages import (
    stage_grouping,
    stage_leaderboards,
    stage_manifold,
    stage_protocol,
    stage_servo,
    stage_worlds,
)
from scripts.report.summary import summarise_run

__all__ = ["STAGES", "RunContext", "Stage", "replace_runs", "run_pipeline"]

TITLE = "topomap-testbed: run report"


@dataclass
class RunContext:
    """What the stages of one run share; ``results`` fills in as the stages finish.

    Parameters
    ----------
    out : Path
        The output folder, absolute.
    shown : Path
        ``out`` as given, for the page.
    settings : RunSettings
        What the run does.
    progress : bool
        Whether the stages show progress.
    results : dict of str to Any, optional
        The results of the stages finished so far, by stage name.
    """

    out: Path  # absolute
    shown: Path  # ``out`` as given, for the page
    settings: RunSettings
    progress: bool
    results: dict[str, Any] = field(default_factory=dict)

    @property
    def root(self) -> Path:
        """The report's folder: ``<out>/report``."""
        return self.out / REPORT_DIR

    @property
    def data_dir(self) -> Path:
        """The dataset's folder: ``<out>/dataset``."""
        return self.out / "dataset"

    def dir(self, stage: str) -> Path:
        """Return the folder of a stage's files: ``<out>/report/<stage>``.

        Parameters
        ----------
        stage : str
            The stage's name.

        Returns
        -------
        Path
            The folder.
        """
        return self.root / stage

    @property
    def dataset(self):
        """The dataset the ``dataset`` stage loaded."""
        return self.results["dataset"]["dataset"]

    @property
    def worlds(self) -> list[str]:
        """The dataset's worlds, in the order of its sequences."""
        return list(dict.fromkeys(s.world for s in self.dataset.sequences.values()))


@dataclass(frozen=True)
class Stage:
    """One named step of the run.

    Parameters
    ----------
    name : str
        The stage's name.
    run : callable
        The work: a function of the `RunContext` returning a dict (the stage's result).
    section : callable or None, default None
        The page's section of the result (a function of the result and the context); None:
        no section.
    folder : bool, default True
        Whether the stage gets ``<out>/report/<name>/`` (made before any stage runs).
    recorded : bool, default True
        Whether ``report.json`` holds the result.
    saved_as : str or None, default None
        A file the stage writes its result to in its folder; ``report.json`` then holds its
        path instead of the result (after the results held inline).
    describe : callable or None, default None
        Entries the stage adds to the page's settings table (a function of the result and the
        context).
    """

    name: str
    run: Callable[[RunContext], dict]
    section: Callable[[dict, RunContext], str] | None = None
    folder: bool = True
    recorded: bool = True
    saved_as: str | None = None
    describe: Callable[[dict, RunContext], dict[str, str]] | None = None


def replace_runs(stages: Sequence[Stage], **runs: Callable[[RunContext], dict]) -> tuple:
    """Return ``stages`` with the ``run`` of the named ones replaced.

    Parameters
    ----------
    stages : sequence of Stage
        The stages.
    **runs : callable
        The new ``run`` of each stage, by stage name.

    Returns
    -------
    tuple of Stage
        The stages.

    Raises
    ------
    KeyError
        For a name that is not a stage's.
    """
    unknown = set(runs) - {s.name for s in stages}
    if unknown:
        raise KeyError(f"no stages {sorted(unknown)} in {[s.name for s in stages]}")
    return tuple(dataclasses.replace(s, run=runs[s.name]) if s.name in runs else s for s in stages)


# --------------------------------------------------------------------------- default stages


def collect(ctx: RunContext) -> dict:
    """Collect the default dataset into ``<out>/dataset`` (reused when present) and load it.

    Parameters
    ----------
    ctx : RunContext
        The run.

    Returns
    -------
    dict
        ``dataset``: the loaded dataset; ``collection``: its collection settings.
    """
    from sim.collect import CollectionSettings, collect_dataset
    from sim.dataset import load_dataset

    collection = CollectionSettings(seed=ctx.settings.seed)
    collect_dataset(ctx.data_dir, collection, jobs=ctx.settings.jobs, progress=ctx.progress)
    return {"dataset": load_dataset(ctx.data_dir), "collection": collection}


def describe_dataset(result: dict, ctx: RunContext) -> dict[str, str]:
    """Describe the dataset for the page's settings table: its folder, size and settings.

    Parameters
    ----------
    result : dict
        The result of `collect`.
    ctx : RunContext
        The run.

    Returns
    -------
    dict of str to str
        The ``dataset`` and ``collection`` entries.
    """
    dataset = result["dataset"]
    return {
        "dataset": f"{ctx.shown / 'dataset'} ({len(dataset.sequences)} sequences, "
        f"{sum(len(s) for s in dataset.sequences.values())} frames)",
        "collection": json.dumps(result["collection"].to_json(), sort_keys=True),
    }


STAGES: tuple[Stage, ...] = (
    Stage("dataset", collect, folder=False, recorded=False, describe=describe_dataset),
    Stage(
        "worlds",
        lambda ctx: stage_worlds(ctx.dataset, ctx.dir("worlds"), ctx.root),
        section=lambda result, ctx: section_worlds(result),
    ),
    Stage(
        "manifold",
        lambda ctx: stage_manifold(ctx.data_dir, ctx.dir("manifold"), ctx.root, ctx.progress),
        section=lambda result, ctx: section_manifold(result),
    ),
    Stage(
        "seeds",
        lambda ctx: stage_protocol(ctx.settings.protocol),
        section=lambda result, ctx: section_protocol(result),
        folder=False,
    ),
    Stage(
        "grouping",
        lambda ctx: stage_grouping(ctx.dataset, ctx.dir("grouping"), ctx.settings, ctx.progress),
        section=lambda result, ctx: section_grouping(result, prefix="grouping/"),
        saved_as="grouping.json",
    ),
    Stage(
        "servo",
        lambda ctx: stage_servo(
            ctx.data_dir,
            ctx.worlds,
            ctx.dir("servo"),
            ctx.root,
            ctx.settings,
            ctx.out / "servo-maps",
            ctx.progress,
        ),
        section=lambda result, ctx: section_servo(result["results"], result["videos"]),
    ),
    Stage(
        "leaderboards",
        lambda ctx: stage_leaderboards(),
        section=lambda result, ctx: section_leaderboards(result),
        folder=False,
        recorded=False,
    ),
)
"""The stages of ``topomap run``, in order (see `scripts.report`)."""


# --------------------------------------------------------------------------- the run


@dataclass
class _Timer:
    progress: bool = True
    timings: dict[str, float] = field(default_factory=dict)

    def run(self, name: str, fn: Callable[[], dict]) -> dict:
        """Run one stage, timed; any exception becomes a StageError naming the stage."""
        start = time.perf_counter()
        if self.progress:
            print(f"== stage {name}", flush=True)
        try:
            result = fn()
        except Exception as err:
            seconds = time.perf_counter() - start
            raise StageError(
                f"stage {name!r} failed after {seconds:.1f} s: {type(err).__name__}: {err}"
            ) from err
        self.timings[name] = time.perf_counter() - start
        if self.progress:
            print(f"== stage {name}: {self.timings[name]:.1f} s", flush=True)
        return result


def run_pipeline(
    out: str | os.PathLike,
    settings: RunSettings | None = None,
    *,
    progress: bool = True,
    command: str = "topomap run",
    stages: Sequence[Stage] = STAGES,
) -> Path:
    """Run ``stages`` in order and write ``<out>/report/index.html``.

    By default the stages are `STAGES`: collect the default dataset into ``<out>/dataset``,
    reused when present, then the four stages into ``<out>/report/<stage>/``.

    Parameters
    ----------
    out : str or os.PathLike
        The output folder.
    settings : RunSettings or None, default None
        What the run does; None: the defaults.
    progress : bool, default True
        Whether to print the stages and show progress.
    command : str, default "topomap run"
        The command line the page records.
    stages : sequence of Stage, default STAGES
        The stages.

    Returns
    -------
    Path
        The page, ``<out>/report/index.html``.

    Raises
    ------
    StageError
        If any stage fails (naming the stage).
    OutputError
        If ``out`` cannot be written.
    """
    settings = settings or RunSettings()
    shown = Path(out)
    # Absolute from here on: the page links its files relative to the report folder, whatever
    # the working directory.
    ctx = RunContext(out=shown.resolve(), shown=shown, settings=settings, progress=progress)
    root = ctx.root
    try:
        for d in [ctx.dir(s.name) for s in stages if s.folder] or [root]:
            d.mkdir(parents=True, exist_ok=True)
        probe = tempfile.NamedTemporaryFile(dir=root, prefix=".write-test-")
        probe.close()
    except OSError as err:
        raise OutputError(
            f"out must be a folder this user can write ({shown}): {type(err).__name__}: {err}"
        ) from err
    timer = _Timer(progress)
    start = time.perf_counter()
    load_at_start = os.getloadavg()
    for stage in stages:
        ctx.results[stage.name] = timer.run(stage.name, partial(stage.run, ctx))
    described = {}
    for stage in stages:
        if stage.describe is not None:
            described.update(stage.describe(ctx.results[stage.name], ctx))
    info = {
        "command": command,
        "settings": {**asdict(settings), **described},
        "versions": versions(),
        "machine": {
            **machine(),
            "load average (1, 5, 15 min) at start": ", ".join(f"{x:.1f}" for x in load_at_start),
            "load average (1, 5, 15 min) at end": ", ".join(f"{x:.1f}" for x in os.getloadavg()),
        },
        "commit": git_commit(),
        "timings": timer.timings,
        "total": time.perf_counter() - start,
    }
    sections = [s.section(ctx.results[s.name], ctx) for s in stages if s.section is not None]
    summary = summarise_run(ctx.results)
    page = build_html(
        TITLE,
        [*sections, section_reproduce(info)],
        summary=(section_summary(summary) if summary else "")
        + f"<p>Seed {settings.seed}; written in {info['total']:.0f} s on "
        f"{esc(info['machine']['cores (os.cpu_count)'])} cores.</p>",
    )
    recorded = [s for s in stages if s.recorded]
    report = {"summary": summary}
    report.update({s.name: ctx.results[s.name] for s in recorded if s.saved_as is None})
    report.update({s.name: f"{s.name}/{s.saved_as}" for s in recorded if s.saved_as is not None})
    report["info"] = info
    atomic_write_bytes(
        root / "report.json", (json.dumps(jsonable(report), indent=1) + "\n").encode()
    )
    return write_report(root, page)
