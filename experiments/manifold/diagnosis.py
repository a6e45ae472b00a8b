"""Where manifold clustering loses on the image datasets: the tree or the merge, and the space.

For one dataset seed and one feature set (raw pixels, the paper's, or HSV histograms) on the
paper's split (even frames):

* every combine rule and the printed eq. 9 / eq. 12 variants of ``ManifoldClustering``, each
  with its error, the purity of the recursive split's leaves (before any combining) and the
  *majority-merge bound*: the error when every leaf is given its majority manifold, the best
  that any combining of these leaves can reach. A pure tree with a bad error blames the merge;
  an impure tree blames the split or the space;
* the space itself: for each frame the distance to its nearest frame of the same manifold and
  to its nearest frame of any other manifold. Where the second is often the smaller, no
  neighbourhood-graph method can follow the manifolds (the 1-NN disagreement rate says how
  often).

* with ``--by-junction``: where the errors are, by the frame's distance to its world's
  junction centre (the labels switch there), for ours and scikit-learn's 10-NN graph.

Usage::

    python -m experiments.manifold.diagnosis --data ROOT/m-data-0 --features raw --out out/diag.json
    python -m experiments.manifold.diagnosis --figure out/distances.png --data ... (distance figure)
"""

from __future__ import annotations

import argparse
import itertools
import json
from pathlib import Path

import numpy as np

from common.fileio import atomic_write_bytes
from mapping import ManifoldClustering, clustering_error, purity
from mapping.distances import squared_distances
from mapping.metrics import best_matching, majority_merge_error
from scripts.manifold.protocol import FEATURES, K, Q

#: name -> ManifoldClustering settings of each variant (the default first)
VARIANTS = {
    "default (spectral combination)": {},
    "combine=separability": {"combine": "separability"},
    "combine=merge": {"combine": "merge"},
    "combine=cut": {"combine": "cut"},
    "eq. 9 as printed": {"omega_sign": "printed"},
    "eq. 12 as printed": {"seed_rule": "printed"},
}


def knn_leaf_merge(X: np.ndarray, leaves: np.ndarray, n_clusters: int, k: int = 10) -> np.ndarray:
    """A candidate combine rule, measured here only: join the leaves along the kNN graph.

    The leaf graph's weight between leaves a and b is the number of symmetrised k-nearest-
    neighbour edges between their points, divided by ``sqrt(|a| |b|)``; scikit-learn's
    ``SpectralClustering(affinity="precomputed")`` cuts it into ``n_clusters`` groups. Returns
    each point's group.
    """
    from sklearn.cluster import SpectralClustering
    from sklearn.neighbors import kneighbors_graph

    A = kneighbors_graph(X, k)
    A = ((A + A.T) > 0).astype(np.float64)
    C = np.unique(leaves).size
    onehot = np.zeros((len(leaves), C))
    onehot[np.arange(len(leaves)), np.unique(leaves, return_inverse=True)[1]] = 1.0
    W = onehot.T @ (A @ onehot)
    sizes = onehot.sum(axis=0)
    W /= np.sqrt(np.outer(sizes, sizes))
    np.fill_diagonal(W, 0.0)
    groups = SpectralClustering(n_clusters, affinity="precomputed", random_state=0).fit_predict(W)
    return groups[np.unique(leaves, return_inverse=True)[1]]


def embedding_leaf_merge(
    X: np.ndarray, leaves: np.ndarray, n_clusters: int, k: int = 10, seed: int = 0
) -> np.ndarray:
    """A second candidate combine rule, measured here only: the leaves as must-link groups in
    scikit-learn's kNN spectral embedding.

    The symmetrised k-NN connectivity graph of all points (as ``SpectralClustering(affinity=
    "nearest_neighbors")`` builds it) is embedded in ``n_clusters`` dimensions
    (``sklearn.manifold.spectral_embedding``); each leaf is the mean of its points' embedding,
    and k-means weighted by leaf size groups the leaves. Returns each point's group; the
    points of one leaf always share it.
    """
    from sklearn.cluster import KMeans
    from sklearn.manifold import spectral_embedding
    from sklearn.neighbors import kneighbors_graph

    A = kneighbors_graph(X, k, include_self=False)
    A = 0.5 * (A + A.T)
    E = spectral_embedding(A, n_components=n_clusters, drop_first=False, random_state=seed)
    ids, inverse = np.unique(leaves, return_inverse=True)
    sizes = np.bincount(inverse).astype(np.float64)
    means = np.zeros((ids.size, n_clusters))
    np.add.at(means, inverse, E)
    means /= sizes[:, None]
    km = KMeans(n_clusters, n_init=10, random_state=seed)
    return km.fit_predict(means, sample_weight=sizes)[inverse]


def variant_rows(X: np.ndarray, y: np.ndarray, variants=VARIANTS) -> list[dict]:
    """Error, leaf count, leaf purity and majority-merge bound of each variant on (X, y)."""
    rows = []
    for name, settings in variants.items():
        model = ManifoldClustering(K, Q, **settings).fit(X)
        rows.append(
            {
                "variant": name,
                "error": clustering_error(y, model.labels_),
                "leaves": int(model.leaf_labels_.max() + 1),
                "leaf_purity": purity(y, model.leaf_labels_),
                "majority_merge_error": majority_merge_error(y, model.leaf_labels_),
                "knn_leaf_merge_error": clustering_error(
                    y, knn_leaf_merge(X, model.leaf_labels_, K)
                ),
            }
        )
    return rows


def neighbour_distances(X: np.ndarray, y: np.ndarray) -> dict[str, np.ndarray]:
    """Per frame: distance to its nearest other frame of the same manifold (``within``) and to
    its nearest frame of another manifold (``between``)."""
    D = np.sqrt(squared_distances(X))
    np.fill_diagonal(D, np.inf)
    same = y[:, None] == y[None, :]
    within = np.where(same, D, np.inf).min(axis=1)
    between = np.where(~same, D, np.inf).min(axis=1)
    return {"within": within, "between": between}


def space_summary(X: np.ndarray, y: np.ndarray) -> dict:
    """1-NN disagreement (nearest frame on another manifold) and median distance ratio."""
    d = neighbour_distances(X, y)
    return {
        "nn_other_manifold": float(np.mean(d["between"] < d["within"])),
        "median_between_over_within": float(np.median(d["between"] / d["within"])),
    }


JUNCTION_BANDS = (0.0, 2.0, 5.0, 10.0, np.inf)  # m from the junction's centre


def junction_centre(world) -> np.ndarray:
    """The one point every manifold region of ``world`` has as a vertex: the junction's
    centre, where the labels switch from the main manifold to a branch."""
    common = None
    for region in world.manifolds.regions:
        points = {tuple(np.round(p, 9)) for p in np.asarray(region.polygon, float)}
        common = points if common is None else common & points
    if not common or len(common) != 1:
        raise ValueError(f"{world.name}: the manifold regions share {len(common or ())} vertices")
    return np.array(next(iter(common)))


def junction_distances(data_dir: Path) -> np.ndarray:
    """Distance (m) of each even (map-building) frame's true position to its world's junction
    centre, in ``load_split``'s order."""
    from scenes import build_world
    from sim.dataset import load_dataset

    data = load_dataset(data_dir)
    seqs = list(data.sequences.values())
    centres = {w: junction_centre(build_world(w)) for w in {s.world for s in seqs}}
    d = np.concatenate([np.linalg.norm(s.poses[:, :2] - centres[s.world], axis=1) for s in seqs])
    return d[data.paper_split()[0]]


def errors_by_band(y, pred, distance, bands=JUNCTION_BANDS) -> list[dict]:
    """Per band of ``distance``: its frames and the fraction of them misassigned, under the
    best matching of clusters to manifolds over all frames (the one ``clustering_error``
    scores, so the bands' errors weighted by their frames sum to it)."""
    y, pred, distance = np.asarray(y), np.asarray(pred), np.asarray(distance)
    match = best_matching(y, pred)
    wrong = np.array(
        [match.get(c, None) != t for c, t in zip(pred.tolist(), y.tolist(), strict=True)]
    )
    rows = []
    for lo, hi in itertools.pairwise(bands):
        inside = (distance >= lo) & (distance < hi)
        rows.append(
            {
                "from_m": float(lo),
                "to_m": None if np.isinf(hi) else float(hi),
                "frames": int(inside.sum()),
                "error": float(wrong[inside].mean()) if inside.any() else None,
            }
        )
    return rows


def junction_rows(X: np.ndarray, y: np.ndarray, distance: np.ndarray) -> dict[str, list[dict]]:
    """``errors_by_band`` of ours (default settings) and of scikit-learn's 10-NN spectral
    clustering, the protocol's first baseline."""
    from mapping.baselines.label_free import KNNSpectralClustering

    models = {
        "ours": ManifoldClustering(K, Q),
        "scikit-learn kNN (k=10)": KNNSpectralClustering(K, n_neighbors=10),
    }
    return {name: errors_by_band(y, m.fit(X).labels_, distance) for name, m in models.items()}


def load_split(data_dir: Path, features: str) -> tuple[np.ndarray, np.ndarray]:
    """Features and labels of the even (map-building) frames of a dataset."""
    from sim.dataset import load_dataset

    data = load_dataset(data_dir)
    train, _ = data.paper_split()
    images = data.concat("images")[train]
    X = FEATURES[features][1]().fit_transform(images)
    return X, data.concat("labels")[train]


def plot_distances(panels: dict[str, tuple[np.ndarray, np.ndarray]], path: Path) -> Path:
    """Histograms of the within / between nearest-neighbour distances, one panel per space."""
    from scripts.grouping.plots import agg_pyplot, save_figure

    plt = agg_pyplot()
    fig, axes = plt.subplots(1, len(panels), figsize=(5 * len(panels), 3.6), squeeze=False)
    for ax, (name, (X, y)) in zip(axes[0], panels.items(), strict=True):
        d = neighbour_distances(X, y)
        scale = np.median(d["within"])
        bins = np.linspace(0, np.percentile(d["between"] / scale, 99), 40)
        ax.hist(d["within"] / scale, bins, alpha=0.6, label="nearest frame, same manifold")
        ax.hist(d["between"] / scale, bins, alpha=0.6, label="nearest frame, other manifold")
        s = space_summary(X, y)
        ax.set_title(
            f"{name}: nearest frame on another manifold {s['nn_other_manifold']:.0%}", fontsize=8
        )
        ax.set_xlabel("distance / median within-manifold NN distance", fontsize=8)
        ax.legend(fontsize=7)
    fig.tight_layout()
    return save_figure(fig, path)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--data", type=Path, nargs="+", required=True, help="dataset folders")
    parser.add_argument("--features", nargs="+", choices=tuple(FEATURES), default=["raw"])
    parser.add_argument("--out", type=Path, default=None, help="JSON of the variant rows")
    parser.add_argument("--figure", type=Path, default=None, help="distance histogram PNG")
    parser.add_argument("--no-variants", action="store_true", help="only the space summary")
    parser.add_argument("--default-only", action="store_true", help="only the default variant")
    parser.add_argument(
        "--by-junction", action="store_true", help="errors by distance to the junction's centre"
    )
    args = parser.parse_args(argv)
    result, panels = [], {}
    for data_dir in args.data:
        for features in args.features:
            X, y = load_split(data_dir, features)
            entry = {"data": str(data_dir), "features": features, **space_summary(X, y)}
            if not args.no_variants:
                first = dict(list(VARIANTS.items())[:1])
                entry["variants"] = variant_rows(X, y, first if args.default_only else VARIANTS)
            if args.by_junction:
                entry["by_junction"] = junction_rows(X, y, junction_distances(data_dir))
            result.append(entry)
            panels[f"{features}, {data_dir.name}"] = (X, y)
            print(json.dumps(entry, indent=1), flush=True)
    if args.out is not None:
        atomic_write_bytes(args.out, (json.dumps(result, indent=2) + "\n").encode())
    if args.figure is not None:
        print(f"wrote {plot_distances(panels, args.figure)}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
