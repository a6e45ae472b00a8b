"""Held-out evaluation: every mapping task on test worlds the methods were never tuned on,
beside the canonical world of each family (``topomap heldout``)."""

from scripts.heldout.cells import TASKS, run_cell
from scripts.heldout.evaluate import evaluate_heldout, summarise

__all__ = ["TASKS", "evaluate_heldout", "run_cell", "summarise"]
