import json

import numpy as np
import pytest

from servo.maps.build import MapError, load_map, load_or_build, save_map


def test_save_load_round_trip_keeps_predict_and_signal(servo_maps, tmp_path):
    m = servo_maps["hallway"]
    loaded = load_map(save_map(m, tmp_path))
    X = m.features[::7]
    np.testing.assert_array_equal(loaded.clustering.predict(X), m.clustering.predict(X))
    np.testing.assert_array_equal(loaded.clustering.predict_proba(X), m.clustering.predict_proba(X))
    for j in range(m.n_clusters):
        target = int(np.flatnonzero(m.clusters == j)[0])
        np.testing.assert_array_equal(
            loaded.clustering.signal(X, j, target), m.clustering.signal(X, j, target)
        )
    np.testing.assert_array_equal(
        loaded.image_features.transform(m.images[:3]), m.image_features.transform(m.images[:3])
    )
    np.testing.assert_array_equal(loaded.edges, m.edges)
    assert loaded.world == m.world and loaded.key == m.key


def test_saved_map_holds_no_pickle(servo_maps, tmp_path):
    path = save_map(servo_maps["lawn"], tmp_path)
    meta = json.loads(path.read_text())
    assert meta["world"] == "lawn"
    with np.load(path.with_suffix(".npz"), allow_pickle=False) as npz:
        assert all(npz[k].dtype != object for k in npz.files)


def test_cache_is_reused(servo_dataset, map_cache, servo_maps):
    files = sorted(map_cache.glob("hallway-*.npz"))
    assert len(files) == 1
    mtime = files[0].stat().st_mtime_ns
    again = load_or_build("hallway", servo_dataset, map_cache)
    assert again.key == servo_maps["hallway"].key
    assert files[0].stat().st_mtime_ns == mtime


def test_view_graph_connects_every_branch(servo_maps):
    from scipy import sparse
    from scipy.sparse.csgraph import connected_components

    for m in servo_maps.values():
        n = len(m)
        g = sparse.coo_matrix((np.ones(len(m.edges)), tuple(m.edges.T)), shape=(n, n))
        assert connected_components(g, directed=False)[0] == 1
        assert m.manifold_graph.any(axis=1).all()


@pytest.mark.parametrize("bad", [-1, 10_000, 1.5, True, "3"])
def test_bad_view_index_is_named(servo_maps, bad):
    with pytest.raises(MapError, match="target"):
        servo_maps["hallway"].check_view(bad, "target")


def test_map_of_another_world_is_refused(servo_maps):
    from servo.laser_image.controller import ManifoldServo
    from servo.task.env import ServoEnv

    with pytest.raises(MapError, match="fitted on the 'hallway' world"):
        ServoEnv("lawn", servo_maps["hallway"])
    with pytest.raises(MapError, match="fitted on the 'lawn' world"):
        ManifoldServo(servo_maps["lawn"], world="hallway")


def test_links_between_recordings_agree_with_the_truth(servo_maps):
    """The recordings are joined by sensing only; the truth checks it."""
    from common.geometry import se2_relative

    for m in servo_maps.values():
        a, b = m.edges.T
        cross = m.sequence[a] != m.sequence[b]
        assert cross.sum() >= 20  # the recordings share their main corridor / lawn
        for (i, j), t in zip(m.edges[cross], m.edge_transforms[cross], strict=True):
            truth = se2_relative(m.true_poses[i], m.true_poses[j])
            assert np.hypot(*(truth[:2] - t[:2])) < 0.2


def test_map_does_not_depend_on_where_odometry_starts(servo_dataset):
    """Each recording's odometry starts at its own origin in the map: moving one recording's
    odometry by any rigid transform (the dataset's starts at the true pose) changes nothing."""
    import dataclasses

    from common.geometry import se2_compose
    from servo.maps.build import build_map
    from sim.dataset import load_dataset

    ds = load_dataset(servo_dataset)
    names = [n for n, s in ds.sequences.items() if s.world == "hallway"]
    base = build_map(ds, "hallway")
    moved = dict(ds.sequences)
    for k, name in enumerate(names):
        s = moved[name]
        offset = np.array([7.0 * (k + 1), -3.0 * k, 0.9 * k - 1.3])
        moved[name] = dataclasses.replace(s, odometry=se2_compose(offset, s.odometry))
    other = build_map(dataclasses.replace(ds, sequences=moved), "hallway")
    np.testing.assert_array_equal(other.edges, base.edges)
    np.testing.assert_allclose(other.edge_transforms, base.edge_transforms, atol=1e-6)
    np.testing.assert_allclose(other.poses, base.poses, atol=1e-6)
    assert np.abs(other.poses[other.frame == 0]).max() < 1e-9  # each starts at its origin


def test_map_does_not_depend_on_the_truth(servo_dataset, servo_maps):
    """The true labels and poses are kept for the evaluation only: scrambling them (another
    manifold per frame, poses anywhere) leaves every sensed array, the clusters and the key."""
    import dataclasses

    from servo.maps.build import build_map
    from sim.dataset import load_dataset

    ds = load_dataset(servo_dataset)
    rng = np.random.default_rng(5)
    scrambled = dict(ds.sequences)
    for name, s in ds.sequences.items():
        if s.world == "lawn":
            labels = rng.integers(4, 8, len(s)).astype(s.labels.dtype)  # any lawn manifold
            poses = s.poses + rng.normal(0, 5, s.poses.shape)
            scrambled[name] = dataclasses.replace(s, labels=labels, poses=poses)
    m = build_map(dataclasses.replace(ds, sequences=scrambled), "lawn")
    base = servo_maps["lawn"]
    assert not np.array_equal(m.true_labels, base.true_labels)
    assert not np.allclose(m.true_poses, base.true_poses)
    for f in dataclasses.fields(base):
        if f.name in ("true_poses", "true_labels", "clustering", "image_features"):
            continue
        a, b = getattr(m, f.name), getattr(base, f.name)
        if isinstance(a, np.ndarray):
            np.testing.assert_array_equal(a, b, err_msg=f.name)
        else:
            assert a == b, f.name
    x = base.features[:20]
    np.testing.assert_array_equal(m.clustering.predict(x), base.clustering.predict(x))


def test_the_number_of_clusters_is_a_stated_setting(servo_dataset):
    from servo.maps import MapSettings, map_key
    from servo.maps.types import prior_clusters
    from sim.dataset import read_meta

    assert prior_clusters("hallway") == prior_clusters("lawn") == 4
    assert MapSettings().clusters_for("lawn") == 4 and MapSettings().clusters_for("robot") == 2
    assert MapSettings(n_clusters=3).clusters_for("lawn") == 3
    meta = read_meta(servo_dataset)
    keys = {map_key(meta, "lawn", MapSettings(n_clusters=k)) for k in (None, 3, 5)}
    assert len(keys) == 3  # the key records K
    with pytest.raises(ValueError, match="n_clusters must be an integer >= 2"):
        MapSettings(n_clusters=1)
    d = MapSettings().to_json()
    d.pop("n_clusters")  # a file written before K was a setting
    assert MapSettings.from_json(d) == MapSettings()
    with pytest.raises(ValueError, match="settings.n_clusters"):
        MapSettings.from_json({**d, "n_clusters": True})
