"""What a run does (`RunSettings`) and how it fails (`StageError`, `OutputError`).

Shared by the stages and the pipeline.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

from common.validation import check_int
from scripts.report.provenance import REPO_ROOT

__all__ = ["COMMITTED_PROTOCOL", "REPORT_DIR", "OutputError", "RunSettings", "StageError"]

REPORT_DIR = "report"
# The frozen protocol's cells as committed with the code: ``topomap run``
# shows them unless told otherwise, so every report carries the spread over dataset seeds.
COMMITTED_PROTOCOL = REPO_ROOT / "docs" / "results" / "data" / "manifold" / "protocol"


@dataclass(frozen=True)
class RunSettings:
    """What ``topomap run`` does; the defaults finish within 10 minutes on 2 cores.

    Parameters
    ----------
    seed : int, default 0
        Seeds the dataset and the servo episodes.
    episodes : int, default 20
        Servo episodes per world, start tier and policy, on the benchmark protocol's ``test``
        split (``servo.task.protocol``; at least 20 in the run and 100 in the headline tables
        of ``topomap servo-eval``).
    policies : tuple of str, default ("servo", "signal")
        Servo policies evaluated (``servo`` first; see ``servo.task.policies.POLICIES``).
    tiers : tuple of str, default ("anywhere",)
        The protocol's start tiers the two controllers (``servo``, ``signal``) run on:
        ``anywhere`` by default (the hard one; 20 episodes of both controllers from both tiers
        and the oracle took ~14 minutes on 2 cores, over the run's 10).
    baseline_tiers : tuple of str, default ("anywhere",)
        The tiers the other policies (oracle, random, greedy) run on.
    videos : int, default 1
        Episode videos per world, of the ``servo`` policy.
    grouping_loop : bool, default False
        Also drive and group a loop through each world (``eval_grouping``).
    jobs : int or None, default None
        Worker processes for the collection (None: one per core).
    protocol : str or None, default None
        A folder written by ``python -m scripts.manifold.protocol --out`` (its
        ``cells/*.json``), whose per-seed errors the report shows; None: the report says how to
        make one. The run does not compute it: ten more datasets and their fits would take
        far longer than the run's 10 minutes on 2 cores.
    """

    seed: int = 0
    episodes: int = 20
    policies: tuple[str, ...] = ("servo", "signal")
    tiers: tuple[str, ...] = ("anywhere",)
    baseline_tiers: tuple[str, ...] = ("anywhere",)
    videos: int = 1
    grouping_loop: bool = False
    jobs: int | None = None
    protocol: str | None = None

    def __post_init__(self):
        """Check the settings, so that a bad one fails before minutes of work."""
        # checked here, not when the stage reads it, so a typo fails before minutes of work
        if self.protocol is not None and not (Path(self.protocol) / "cells").is_dir():
            raise ValueError(
                "protocol must be a folder written by scripts.manifold.protocol (holding "
                f"cells/), got {self.protocol!r}"
            )
        check_int(self.seed, "seed", minimum=0)  # numpy refuses a negative seed
        check_int(self.episodes, "episodes")
        check_int(self.videos, "videos", minimum=0)
        if not self.policies:
            raise ValueError("policies is empty")
        from servo.task import TIERS

        for name in ("tiers", "baseline_tiers"):
            value = getattr(self, name)
            if not value or not set(value) <= set(TIERS):
                raise ValueError(f"{name} must be some of {TIERS}, got {value!r}")


class StageError(RuntimeError):
    """A stage of the run failed; the message names it and how long it ran."""


class OutputError(ValueError):
    """The output folder cannot be created or written."""
