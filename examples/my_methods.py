r"""Templates of an outside method for each benchmark: copy one, put your method in ``fit``.

Clustering (``topomap manifold-eval``): ``fit(X)`` on the training frames' features, then
``labels_``; ``predict(X)`` for the test frames is optional (without it, each test frame
takes the cluster of its nearest training frame, and the result file says so)::

    topomap manifold-eval --root ROOT --out OUT --method examples.my_methods:MyClusterer \\
        --param n_init=4 --baselines
    topomap leaderboard OUT --reference ours

Grouping (``topomap group-eval --method``): ``fit(scans, poses)`` (optionally ``groups=``, the
drive of each scan), then ``labels_``, one group per scan::

    topomap group-eval --method examples.my_methods:MyGrouping --param length=5.0 \\
        --data ROOT/m-data-1 --data ROOT/m-data-2 --out OUT
    topomap group-eval --method examples.my_methods:MyGrouping --carmen LOG --out OUT

Run from the repository root: the module is imported like ``python -m`` would import it, so
its top-level code runs.
"""

from __future__ import annotations

import numpy as np
from sklearn.cluster import KMeans


class MyClusterer:
    """K-means on the features: the smallest clusterer the protocol takes.

    Parameters
    ----------
    n_clusters : int, default 8
        The protocol passes its K (8 manifolds) because the constructor takes ``n_clusters``.
    n_init : int, default 4
        K-means restarts.
    random_state : int, default 0
        Seed of the restarts (same seed, same result).
    """

    def __init__(self, n_clusters: int = 8, n_init: int = 4, random_state: int = 0):
        self.n_clusters = n_clusters
        self.n_init = n_init
        self.random_state = random_state

    def fit(self, X):
        """Cluster the training frames' features ``X``, shape (n, d)."""
        self.model_ = KMeans(
            self.n_clusters, n_init=self.n_init, random_state=self.random_state
        ).fit(X)
        self.labels_ = self.model_.labels_
        return self

    def predict(self, X):
        """Return the cluster of each test frame's features in ``X``."""
        return self.model_.predict(X)


class MyGrouping:
    """A new group every ``length`` metres driven, and at every new drive.

    Parameters
    ----------
    length : float, default 5.0
        Metres of travel per group.
    """

    def __init__(self, length: float = 5.0):
        self.length = length

    def fit(self, scans, poses, groups=None):
        """Group the scans by the distance travelled along ``poses``."""
        poses = np.asarray(poses, dtype=float)
        travelled = np.concatenate([[0.0], np.cumsum(np.hypot(*np.diff(poses[:, :2], axis=0).T))])
        labels = np.floor(travelled / self.length).astype(int)
        if groups is not None:  # never one group across two drives
            starts = np.flatnonzero(np.diff(np.asarray(groups)) != 0) + 1
            labels = labels + np.searchsorted(starts, np.arange(len(poses)), side="right")
        self.labels_ = np.unique(labels, return_inverse=True)[1]
        return self
