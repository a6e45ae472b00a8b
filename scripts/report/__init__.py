"""The end-to-end run behind ``topomap run``: collect, evaluate, and write one HTML report.

    topomap run [--out out] [--seed 0] [--episodes 4] [--baselines oracle,random]
                [--protocol DIR]

(``python -m scripts.report`` takes the same arguments.) Stages (the registry
`STAGES`, each writing into its own folder of ``<out>/report/``,
each timed; a failing stage stops the run with `StageError` naming it):

1. ``worlds``: a top-down view per world with the dataset's trajectories, and per manifold
   sample camera frames beside the laser scan drawn on the map (``worlds/``);
2. ``manifold``: the manifold-clustering reproduction (``scripts.manifold.reproduce``):
   synthetic and real tables with the paper's numbers beside ours, and its figures;
3. ``seeds``: the manifold clustering's error on every dataset seed of the frozen protocol
   (``scripts.manifold.protocol``), read from the folder given as ``--protocol`` (not
   computed by the run: it would take far longer than 10 minutes); without one, how to make it;
4. ``grouping``: the observation grouping (``scripts.grouping.evaluate``): tables, laser groups,
   local maps, topological graph and weights;
5. ``servo``: closed-loop servoing (``servo.task.evaluation``) per world, the servo policy and the
   baselines: results per manifold pair, trajectories on the map, episode videos.

``index.html`` opens with a summary (`summary`: one line per task, its
headline number and interval against its target), references the PNGs and H.264 MP4s beside
it by relative paths (no external resource; the videos play in the page) and ends with what is
needed to reproduce it: settings, seed, versions, commit, machine and timings.
``report.json`` holds every number, the summary first. The HTML is built by small functions
(``section_*``) of plain dicts, so each can be tested on fake inputs.

Modules: `html` (escaping, tables, figures, the page),
`sections` (one builder per section), `summary`
(the summary's lines), `drawing` and
`stages` (the stages' work), `provenance` (versions,
machine, commit), `settings` (`RunSettings`, the errors) and
`pipeline` (the stage registry and `run_pipeline`, which takes the
stages as an argument: tests pass fake ones).
"""

from scripts.report.drawing import laser_crop, manifold_samples, sample_sheet
from scripts.report.html import (
    INDEX,
    STYLE,
    build_html,
    esc,
    figure,
    fmt,
    referenced_files,
    section,
    table,
    video,
    write_report,
)
from scripts.report.pipeline import STAGES, RunContext, Stage, replace_runs, run_pipeline
from scripts.report.provenance import VERSION_PACKAGES, git_commit, machine, versions
from scripts.report.sections import (
    PAPER,
    section_grouping,
    section_manifold,
    section_protocol,
    section_reproduce,
    section_servo,
    section_summary,
    section_worlds,
)
from scripts.report.settings import (
    COMMITTED_PROTOCOL,
    REPORT_DIR,
    OutputError,
    RunSettings,
    StageError,
)
from scripts.report.stages import (
    stage_grouping,
    stage_manifold,
    stage_protocol,
    stage_servo,
    stage_worlds,
)
from scripts.report.summary import summarise_run

__all__ = [
    "COMMITTED_PROTOCOL",
    "INDEX",
    "PAPER",
    "REPORT_DIR",
    "STAGES",
    "STYLE",
    "VERSION_PACKAGES",
    "OutputError",
    "RunContext",
    "RunSettings",
    "Stage",
    "StageError",
    "build_html",
    "esc",
    "figure",
    "fmt",
    "git_commit",
    "laser_crop",
    "machine",
    "manifold_samples",
    "referenced_files",
    "replace_runs",
    "run_pipeline",
    "sample_sheet",
    "section",
    "section_grouping",
    "section_manifold",
    "section_protocol",
    "section_reproduce",
    "section_servo",
    "section_summary",
    "section_worlds",
    "stage_grouping",
    "stage_manifold",
    "stage_protocol",
    "stage_servo",
    "stage_worlds",
    "summarise_run",
    "table",
    "versions",
    "video",
    "write_report",
]
