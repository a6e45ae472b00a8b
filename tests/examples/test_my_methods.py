"""The templates of ``examples/my_methods.py`` run through both benchmarks' loaders."""

import numpy as np

from scripts.leaderboard import OutsideMethod


def test_the_clusterer_template_takes_the_protocols_k_and_predicts():
    method = OutsideMethod("examples.my_methods:MyClusterer", ("fit",), {"n_init": 2})
    model = method.make(n_clusters=3)
    X = np.concatenate([np.random.default_rng(0).normal(c, 0.1, (20, 2)) for c in (0, 5, 10)])
    model.fit(X)
    assert model.n_clusters == 3 and len(np.unique(model.labels_)) == 3
    assert (model.predict(X) == model.labels_).all()


def test_the_grouping_template_cuts_by_distance_and_drive():
    method = OutsideMethod("examples.my_methods:MyGrouping", ("fit",), {"length": 1.0})
    poses = np.column_stack([np.linspace(0, 3.5, 8), np.zeros(8), np.zeros(8)])
    model = method.make().fit([None] * 8, poses, groups=[0] * 4 + [1] * 4)
    # 0.5 m apart: two scans per metre; the second drive starts a group of its own
    assert model.labels_.tolist() == [0, 0, 1, 1, 2, 2, 3, 3]
    model.fit([None] * 8, poses, groups=[0] * 3 + [1] * 5)
    assert model.labels_.tolist() == [0, 0, 1, 2, 3, 3, 4, 4]
