"""How a grouping is scored against the ground-truth manifolds, and the four-way comparison.

The scores are purity, ARI, groups per manifold and the targets; the comparison runs both
methods on both sensors. Used by ``scripts.grouping.evaluate``.
"""

from __future__ import annotations

import time

import numpy as np

from mapping.features import ColorHistogramFeatures, ScanFeatures
from mapping.grouping import (
    ObservationGraphPartitioner,
    default_n_neighbors,
    knn_gaussian_affinity,
)
from mapping.manifold import ManifoldClustering
from mapping.metrics import adjusted_rand_index, contingency_matrix, purity
from sim.runs import Runs

__all__ = ["TARGETS", "compare_methods", "meets_targets", "score_groups", "unscored"]

# The targets: groups mix manifolds by at most 10 %, no manifold in more than 3 groups.
TARGETS = {"purity_min": 0.9, "max_groups_per_manifold": 3}
MC_MIN_CLUSTER_SIZE = 35  # Q of docs/guides/manifold-clustering.md on the same sequences


def score_groups(truth: np.ndarray, labels: np.ndarray, names) -> dict:
    """Score groups against ground-truth manifold ids.

    Frames on no manifold (-1) are left out.

    ``groups_per_manifold``: for each manifold, the groups whose majority manifold it is (every
    group counts for exactly one manifold; frames of a group that belong elsewhere are what
    ``purity`` charges). ``groups_touching``: the stricter count of groups holding any frame of
    the manifold, which also counts a group that takes a few frames across a boundary.

    Parameters
    ----------
    truth : ndarray of shape (n,)
        Each frame's manifold id, -1 for none.
    labels : ndarray of shape (n,)
        Each frame's group.
    names : sequence of str
        The manifold of each id (the recordings' ``manifold_names``, a dataset's
        ``manifolds``).

    Returns
    -------
    dict
        ``frames``, ``groups``, ``purity``, ``ari``, ``groups_per_manifold`` and
        ``groups_touching`` (by manifold name) and their maxima.
    """
    truth = np.asarray(truth, dtype=int)
    labels = np.asarray(labels, dtype=int)
    on = truth >= 0
    truth, labels = truth[on], labels[on]
    manifolds = np.unique(truth)
    groups = np.unique(labels)
    # The contingency matrix purity is computed from: rows manifolds, columns groups.
    majority = manifolds[contingency_matrix(truth, labels).argmax(axis=0)]
    per = {names[m]: int(np.sum(majority == m)) for m in manifolds}
    touching = {names[m]: len(np.unique(labels[truth == m])) for m in manifolds}
    return {
        "frames": int(on.sum()),
        "groups": len(groups),
        "purity": purity(truth, labels),
        "ari": adjusted_rand_index(truth, labels),
        "groups_per_manifold": per,
        "max_groups_per_manifold": max(per.values()),
        "groups_touching": touching,
        "max_groups_touching": max(touching.values()),
    }


def meets_targets(score: dict) -> bool:
    """Check a score against ``TARGETS``.

    Parameters
    ----------
    score : dict
        A score of ``score_groups``.

    Returns
    -------
    bool
        Whether its purity is at least ``purity_min`` and no manifold has more than
        ``max_groups_per_manifold`` groups.
    """
    return (
        score["purity"] >= TARGETS["purity_min"]
        and score["max_groups_per_manifold"] <= TARGETS["max_groups_per_manifold"]
    )


# --------------------------------------------------------------------------- grouping


def unscored(frames: int, labels: np.ndarray) -> dict:
    """Return the keys of `score_groups` for groups that cannot be scored (no ground truth).

    Parameters
    ----------
    frames : int
        The number of frames.
    labels : ndarray of shape (n,)
        Each frame's group.

    Returns
    -------
    dict
        The counts, and None for every score.
    """
    keys = ("purity", "ari", "max_groups_per_manifold", "max_groups_touching")
    return {
        "frames": frames,
        "groups": len(np.unique(labels)),
        **dict.fromkeys(keys),
        "groups_per_manifold": {},
        "groups_touching": {},
        "scored": "no ground-truth labels",
    }


def compare_methods(runs: Runs, scan_model: ObservationGraphPartitioner, scan_score: dict):
    """Run both methods on both sensors of one world (the four-way table).

    - partition x scans: ``scan_model`` (already fitted; its pose variant is recorded).
    - partition x images: ``affinity="precomputed"`` on ``knn_gaussian_affinity`` of the images
      (k = ceil(sqrt(n)) neighbours, sigma = median k-th-neighbour distance).
    - manifold clustering x scans / images: ``ManifoldClustering(K, Q)`` with K the number of
      ground-truth manifolds of the world (without ground truth: the number of groups the scan
      partition found) and Q = min(35, n // (2K)).

    Each entry holds its ``labels`` (one per frame) beside the scores. Drives without a camera
    (``runs.images`` None) give the two rows on scans only.

    Parameters
    ----------
    runs : Runs
        The world's recordings.
    scan_model : ObservationGraphPartitioner
        The partitioner already fitted on the scans.
    scan_score : dict
        Its score, with the pose variant under ``poses``.

    Returns
    -------
    dict
        ``{"method/sensor": entry}``: the brief scores, time and ``labels`` of each.
    """

    def score(labels):
        if runs.has_ground_truth:
            return score_groups(runs.labels, labels, runs.manifold_names)
        return unscored(len(runs), labels)

    out = {
        "partition/scans": {
            **_brief(scan_score),
            "poses": scan_score["poses"],
            "labels": scan_model.labels_,
        }
    }
    features = {"scans": ScanFeatures(max_range=runs.max_range).fit_transform(runs.ranges)}
    if runs.images is not None:  # a laser-only robot: the methods on images have no input
        # The image features that reproduce the paper's image result
        # (docs/guides/manifold-clustering.md).
        features["images"] = _partition_images(runs, score, out)
    if runs.has_ground_truth:
        k = len(np.unique(runs.labels[runs.labels >= 0]))
    else:
        k = scan_model.n_groups_
    q = max(1, min(MC_MIN_CLUSTER_SIZE, len(runs) // (2 * k)))
    for sensor, X in features.items():
        start = time.perf_counter()
        labels = ManifoldClustering(n_clusters=k, min_cluster_size=q).fit(X).labels_
        out[f"manifold/{sensor}"] = {
            **_brief(score(labels), time.perf_counter() - start),
            "K": k,
            "Q": q,
            "labels": labels,
        }
    return out


def _partition_images(runs: Runs, score, out: dict) -> np.ndarray:
    """Partition the images' colour histograms by min-Ncut into ``out``; return them."""
    images = ColorHistogramFeatures().fit_transform(runs.images)
    start = time.perf_counter()
    W, sigma = knn_gaussian_affinity(images)
    labels = ObservationGraphPartitioner(affinity="precomputed").fit(W).labels_
    out["partition/images"] = {
        **_brief(score(labels), time.perf_counter() - start),
        "n_neighbors": default_n_neighbors(len(runs)),
        "sigma": sigma,
        "labels": labels,
    }
    return images


def _brief(score: dict, seconds: float | None = None) -> dict:
    keys = ("groups", "purity", "ari", "max_groups_per_manifold", "groups_per_manifold")
    out = {k: score[k] for k in keys}
    out["seconds"] = score.get("seconds") if seconds is None else seconds
    return out
