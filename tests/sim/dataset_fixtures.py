"""A tiny valid dataset written without the simulator, for tests of the dataset reader."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np

from sim.dataset import FORMAT_NAME, SCHEMA_VERSION, write_sequence

FRAMES = 5
MANIFOLDS = ["lawn", "lawn-left"]


def sequence_arrays(frames: int = FRAMES) -> dict[str, np.ndarray]:
    """Valid arrays of one sequence (ground truth included)."""
    t = np.arange(frames, dtype=np.float64) * 0.1
    poses = np.stack([t, 0.5 * t, 0.1 * t], axis=1)
    return {
        "images": np.full((frames, 4, 6, 3), 100, np.uint8),
        "scans": np.tile(np.array([1.0, 2.0, np.inf, 3.0], np.float32), (frames, 1)),
        "angles": np.linspace(-np.pi / 2, np.pi / 2, 4).astype(np.float32),
        "poses": poses,
        "odometry": poses + 0.01,
        "commands": np.tile([0.5, 0.1], (frames, 1)),
        "labels": (np.arange(frames) >= 3).astype(np.int16),
        "times": t,
    }


def write_dataset(directory: Path, arrays: dict | None = None, **meta_changes) -> Path:
    """A complete dataset of one sequence ``"lawn-left"`` in ``directory``: ``arrays`` replace
    the valid ones, ``meta_changes`` the keys of ``meta.json``."""
    directory.mkdir(parents=True, exist_ok=True)
    data = sequence_arrays() if arrays is None else arrays
    digest = write_sequence(directory / "lawn-left.npz", data)
    frames = len(data["times"]) if "times" in data else FRAMES
    meta = {
        "format": FORMAT_NAME,
        "schema_version": SCHEMA_VERSION,
        "ground_truth": True,
        "complete": True,
        "settings": {"laser": {"max_range": 10.0}},
        "manifolds": MANIFOLDS,
        "sequences": {
            "lawn-left": {
                "file": "lawn-left.npz",
                "world": "lawn",
                "frames": frames,
                "sha256": digest,
            }
        },
    }
    meta.update(meta_changes)
    (directory / "meta.json").write_text(json.dumps(meta))
    return directory
