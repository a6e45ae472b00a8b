"""What a run does (:class:`RunSettings`) and how it fails (:class:`StageError`,
:class:`OutputError`); shared by the stages and the pipeline."""

from __future__ import annotations

from dataclasses import dataclass

from common.validation import check_int

__all__ = ["REPORT_DIR", "OutputError", "RunSettings", "StageError"]

REPORT_DIR = "report"


@dataclass(frozen=True)
class RunSettings:
    """What ``topomap run`` does; the defaults finish within 10 minutes on 2 cores.

    seed : seeds the dataset and the servo episodes.
    episodes : servo episodes per world and policy.
    policies : servo policies evaluated (``servo`` first; see ``servo.evaluate.POLICIES``).
    videos : episode videos per world, of the ``servo`` policy.
    grouping_loop : also drive and group a loop through each world (``eval_grouping``).
    jobs : worker processes for the collection (None: one per core).
    """

    seed: int = 0
    episodes: int = 4
    policies: tuple[str, ...] = ("servo", "oracle", "random")
    videos: int = 1
    grouping_loop: bool = False
    jobs: int | None = None

    def __post_init__(self):
        check_int(self.episodes, "episodes")
        check_int(self.videos, "videos", minimum=0)
        if not self.policies:
            raise ValueError("policies is empty")


class StageError(RuntimeError):
    """A stage of the run failed; the message names it and how long it ran."""


class OutputError(ValueError):
    """The output folder cannot be created or written."""
