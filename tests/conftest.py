"""Shared fixtures. Importing ``sim`` first chooses the headless GL backend.

The default dataset is collected once per session into a temp dir, and the servo maps are built
from it, so every test sees the same data on every machine, whatever lies in out/. A skip that
is not on the list in ``tests/skip_policy.py`` fails the run."""

from pathlib import Path

import pytest

import sim  # noqa: F401  (must come before anything imports mujoco)
from scenes import build_world
from sim.datahome import DataHomeError, radish_log
from tests.skip_policy import (  # noqa: F401  (hooks: a skip not on the list fails the run)
    pytest_configure,
    pytest_runtest_logreport,
    pytest_sessionfinish,
    pytest_terminal_summary,
)


def radish_or_skip(name: str) -> Path:
    """The Radish log ``name`` from the folder ``TOPOMAP_RADISH`` names, or skip the test with
    the reason (the variable unset, or the folder without the file)."""
    try:
        return radish_log(name)
    except DataHomeError as err:
        pytest.skip(str(err))


@pytest.fixture(scope="session")
def aces_log() -> Path:
    """The ACES log (``aces-corrected.log.gz``), or a skip naming ``TOPOMAP_RADISH``."""
    return radish_or_skip("aces-corrected.log.gz")


@pytest.fixture(scope="session")
def csail_log() -> Path:
    """The CSAIL log (``csail-corrected.log.gz``), or a skip naming ``TOPOMAP_RADISH``."""
    return radish_or_skip("csail-corrected.log.gz")


@pytest.fixture(scope="session")
def worlds():
    return {name: build_world(name) for name in ("hallway", "lawn")}


@pytest.fixture(scope="session")
def default_dataset(tmp_path_factory):
    """The default 900-frame dataset (both worlds, seed 0), collected once per session (~25 s
    on 2 cores): the data of the paper reproductions and of the servo map."""
    from sim.collect import CollectionSettings, collect_dataset
    from sim.dataset import load_dataset

    directory = tmp_path_factory.mktemp("default_dataset")
    collect_dataset(directory, CollectionSettings(), progress=False)
    return load_dataset(directory)


@pytest.fixture(scope="session")
def servo_dataset(default_dataset) -> Path:
    return default_dataset.path


@pytest.fixture(scope="session")
def map_cache(tmp_path_factory) -> Path:
    return tmp_path_factory.mktemp("servo-maps")


@pytest.fixture(scope="session")
def servo_maps(servo_dataset, map_cache):
    from servo.maps.build import load_or_build

    return {w: load_or_build(w, servo_dataset, map_cache) for w in ("hallway", "lawn")}


@pytest.fixture(scope="session")
def generated_servo_map(tmp_path_factory):
    """(map, cache folder) of the generated world ``lawn:3``: 8 frames per route (the default
    camera, as ``ServoEnv`` renders), small features, about 10 s."""
    from servo.maps import MapSettings, load_or_build
    from sim.collect import CollectionSettings, collect_dataset

    data = tmp_path_factory.mktemp("generated-data")
    collection = CollectionSettings(worlds=("lawn:3",), frames=8)
    collect_dataset(data, collection, jobs=1, progress=False)
    cache = tmp_path_factory.mktemp("generated-maps")
    settings = MapSettings(stride=1, min_cluster_size=3, image_size=(16, 12))
    return load_or_build("lawn:3", data, cache, settings, progress=False), cache


ACES_SLICE = Path(__file__).parent / "data" / "radish" / "aces-every-third-scan.log.gz"


@pytest.fixture(scope="session")
def aces_slice_log() -> Path:
    """Every third scan of the ACES log, shipped with the tests (``tests/data/radish/``): the
    real-log tests that need no full log run on it on a fresh clone, with no variable set."""
    assert ACES_SLICE.is_file(), f"{ACES_SLICE} is missing: it ships with the tests"
    return ACES_SLICE
