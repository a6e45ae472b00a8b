"""One servo map per world for the whole session: built from the default dataset when it is
there (``topomap run`` collects it), else from a small dataset collected into a temp dir."""

from __future__ import annotations

from pathlib import Path

import pytest

DEFAULT_DATASET = Path(__file__).resolve().parents[2] / "out" / "dataset"


@pytest.fixture(scope="session")
def servo_dataset(tmp_path_factory) -> Path:
    from sim.dataset import DatasetError, read_meta

    try:
        if read_meta(DEFAULT_DATASET).get("complete"):
            return DEFAULT_DATASET
    except DatasetError:
        pass
    from sim.collect import CollectionSettings, collect_dataset

    out = tmp_path_factory.mktemp("servo-dataset")
    return collect_dataset(out, CollectionSettings(frames=100), progress=False)


@pytest.fixture(scope="session")
def map_cache(tmp_path_factory) -> Path:
    return tmp_path_factory.mktemp("servo-maps")


@pytest.fixture(scope="session")
def servo_maps(servo_dataset, map_cache):
    from servo.map_store import load_or_build

    return {w: load_or_build(w, servo_dataset, map_cache) for w in ("hallway", "lawn")}
