"""What a servo map needs from a dataset (beams, frames per manifold), refused before the build
with a DatasetError naming the dataset and what to collect, not a numpy broadcast error in
``profile_distances`` or the clustering's n_clusters * min_cluster_size."""

import numpy as np
import pytest

from servo.maps import MapSettings, build_map
from servo.maps.needs import MIN_BEAMS, views_needed
from servo.maps.scan_profile import PROFILE_SHIFT, profile_distances
from sim.dataset import DatasetError, load_dataset
from tests.sim.dataset_fixtures import sequence_arrays, write_dataset


def _dataset(tmp_path, beams: int, frames: int):
    arrays = sequence_arrays(frames)
    arrays["scans"] = np.full((frames, beams), 2.0, np.float32)
    arrays["angles"] = np.linspace(-np.pi / 2, np.pi / 2, beams).astype(np.float32)
    return load_dataset(write_dataset(tmp_path / "d", arrays))


def test_the_needs_are_stated():
    assert MIN_BEAMS == 2 * PROFILE_SHIFT + 1 == 141
    assert views_needed("lawn", MapSettings()) == 4 * 8
    assert views_needed("lawn", MapSettings(n_clusters=3, min_cluster_size=5)) == 15


def test_a_dataset_of_too_few_beams_is_refused_naming_the_need(tmp_path):
    ds = _dataset(tmp_path, beams=61, frames=5)
    with pytest.raises(DatasetError, match=r"61 beams; .* needs at least 141 beams") as err:
        build_map(ds, "lawn")
    assert str(ds.path) in str(err.value)


def test_a_dataset_of_too_few_frames_is_refused_naming_what_to_collect(tmp_path):
    ds = _dataset(tmp_path, beams=MIN_BEAMS, frames=20)
    with pytest.raises(
        DatasetError,
        match=r"give 10 stored views \(one frame in 2\), but a map of 4 manifolds of at least 8 "
        r"views each needs 32: collect at least 64 frames per sequence",
    ) as err:
        build_map(ds, "lawn")
    assert str(ds.path) in str(err.value)
    with pytest.raises(DatasetError, match="collect at least 24 frames per sequence"):
        build_map(ds, "lawn", MapSettings(stride=1, min_cluster_size=6))


def test_profile_distances_names_a_shift_longer_than_the_scan():
    with pytest.raises(ValueError, match="a scan of 61 beams cannot be shifted by up to 70"):
        profile_distances(np.ones((2, 61)), np.ones(61), 0.01)
    best, _ = profile_distances(np.ones((2, MIN_BEAMS)), np.ones(MIN_BEAMS), 0.01)
    assert best.tolist() == [0.0, 0.0]


def test_a_dataset_without_the_world_is_refused_naming_it(tmp_path):
    from servo.maps import load_or_build
    from servo.maps.types import MapError

    data = write_dataset(tmp_path / "d")
    with pytest.raises(MapError, match=r"/d: the dataset has no sequence of world 'hallway'"):
        load_or_build("hallway", data, tmp_path / "maps", progress=False)
