"""Held-out evaluation (``topomap heldout``).

Every mapping task on test worlds the methods were never tuned on, beside the canonical world of
each family.
"""

from scripts.heldout.cells import TASKS, run_cell
from scripts.heldout.evaluate import build_parser as heldout_parser
from scripts.heldout.evaluate import evaluate_heldout, format_summary, summarise
from scripts.heldout.evaluate import run as run_heldout

__all__ = [
    "TASKS",
    "evaluate_heldout",
    "format_summary",
    "heldout_parser",
    "run_cell",
    "run_heldout",
    "summarise",
]
