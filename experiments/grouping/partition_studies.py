"""Studies of the observation grouping on synthetic office scans: the association and
threshold variants, the grouping under odometry noise, and the figures of the docs.

    python -m experiments.grouping.partition_studies --experiments  # assoc and noise tables
    python -m experiments.grouping.partition_studies --plots        # docs/img/grouping_*.png

The data are ``bench.bench_partition.office_data``'s synthetic offices.
"""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np

from bench.bench_partition import DELTA, DENSE_STEP, STEP, office_data
from mapping.grouping import (
    ObservationGraphPartitioner,
    recursive_ncut_partition,
    sensed_space_overlap,
    simulate_odometry,
)
from mapping.metrics import adjusted_rand_index, purity

IMG = Path(__file__).resolve().parents[2] / "docs" / "img"


def _score(world, poses_true, labels) -> str:
    truth = world.region_labels(poses_true)
    per_region = [len(np.unique(labels[truth == k])) for k in range(world.n_rooms + 1)]
    return (
        f"{labels.max() + 1:>3} groups  purity {purity(truth, labels):.3f}  "
        f"ARI {adjusted_rand_index(truth, labels):+.3f}  groups per room <= "
        f"{max(per_region[:-1])}, corridor {per_region[-1]}"
    )


def experiment_assoc() -> None:
    print("\n## assoc x laplacian, threshold 1 (office, 4 rooms)")
    for step in (STEP, DENSE_STEP):
        world, scans, poses = office_data(4, step)
        print(f"step {step} m, {len(scans)} scans")
        for assoc in ("mrpt", "paper"):
            for lap in ("normalized", "unnormalized"):
                m = ObservationGraphPartitioner(assoc=assoc, laplacian=lap).fit(scans, poses)
                print(f"  assoc={assoc:<5} laplacian={lap:<12} {_score(world, poses, m.labels_)}")
    print("\n## threshold sweep (office, 4 rooms, step 1.17): groups / purity")
    world, scans, poses = office_data(4, STEP)
    W = sensed_space_overlap(scans, poses, DELTA, sparse=True)
    truth = world.region_labels(poses)
    for assoc in ("mrpt", "paper"):
        cells = []
        for thr in (0.05, 0.1, 0.2, 0.3, 0.5, 0.7, 1.0, 1.2, 1.5):
            labels, _ = recursive_ncut_partition(W, thr, assoc=assoc)
            cells.append(f"{thr}:{labels.max() + 1}/{purity(truth, labels):.2f}")
        print(f"  {assoc:<5} " + "  ".join(cells))
    print("\n## uniform clique of 30 nodes, off-diagonal weight w: groups at threshold 1")
    for w in (0.2, 0.5, 0.9, 1.0):
        W = np.full((30, 30), w)
        np.fill_diagonal(W, 1.0)
        groups = [recursive_ncut_partition(W, assoc=a)[0].max() + 1 for a in ("mrpt", "paper")]
        print(f"  w={w}: mrpt {groups[0]} group(s), paper {groups[1]} group(s)")


def experiment_noise(seeds: int = 5) -> None:
    print("\n## odometry noise (office, 4 rooms, step 1.17), mean over seeds")
    print("  sigma_t sigma_r | no ICP: groups purity ARI drift | ICP: groups purity ARI drift")
    world, scans, poses = office_data(4, STEP)
    truth = world.region_labels(poses)
    for sig_t, sig_r in ((0.0, 0.0), (0.02, 0.01), (0.05, 0.02), (0.1, 0.05), (0.2, 0.1)):
        cols = []
        for icp_on in (False, True):
            stats = []
            for seed in range(seeds):
                odo = simulate_odometry(poses, np.random.default_rng(seed), sig_t, sig_r)
                m = ObservationGraphPartitioner(scan_matching=icp_on).fit(scans, odo)
                drift = np.hypot(*(m.poses_[:, :2] - poses[:, :2]).T).max()
                lab = m.labels_
                stats.append(
                    (lab.max() + 1, purity(truth, lab), adjusted_rand_index(truth, lab), drift)
                )
            g, p, a, d = np.mean(stats, axis=0)
            cols.append(f"{g:5.1f} {p:.3f} {a:+.3f} {d:5.2f} m")
        print(f"  {sig_t:<7} {sig_r:<7} | {cols[0]} | {cols[1]}")


def make_plots() -> None:
    from scripts.grouping import plots as gp

    plt = gp.agg_pyplot()
    IMG.mkdir(parents=True, exist_ok=True)
    world, scans, poses = office_data(4, STEP)
    m = ObservationGraphPartitioner(scan_matching=False).fit(scans, poses)

    def walls(ax, colour="0.6"):
        for s in world.segments:
            ax.plot(s[[0, 2]], s[[1, 3]], color=colour, lw=0.8)

    fig, ax = plt.subplots(figsize=(9, 3.6))
    walls(ax)
    gp.draw_groups(ax, scans, poses, m.labels_)
    ax.set_title(f"77 scans grouped into {m.n_groups_} local maps (colour = group)")
    fig.tight_layout()
    gp.save_figure(fig, IMG / "grouping_trajectory.png")

    fig, ax = plt.subplots(figsize=(4.6, 4.2))
    gp.draw_weights(ax, m.affinity_matrix_, m.labels_, "SSO weights, scans sorted by group")
    fig.tight_layout()
    gp.save_figure(fig, IMG / "grouping_weights.png")

    cols = 4
    rows = int(np.ceil(m.n_groups_ / cols))
    fig, axes = plt.subplots(rows, cols, figsize=(10, 2.6 * rows), squeeze=False)
    gp.draw_local_maps(axes, m.local_maps_, m.labels_)
    fig.tight_layout()
    gp.save_figure(fig, IMG / "grouping_local_maps.png")

    fig, ax = plt.subplots(figsize=(9, 3.4))
    gp.draw_topology(ax, m.topology_, lambda ax: walls(ax, "0.85"))
    ax.set_title("topological map: nodes at local-map frames; solid: trajectory, dashed: overlap")
    fig.tight_layout()
    gp.save_figure(fig, IMG / "grouping_topology.png")

    odo = simulate_odometry(poses, np.random.default_rng(0), 0.05, 0.02)
    fig, axes = plt.subplots(1, 2, figsize=(11, 3.2))
    for ax, icp_on in zip(axes, (False, True), strict=True):
        mm = ObservationGraphPartitioner(scan_matching=icp_on).fit(scans, odo)
        gp.draw_groups(ax, scans, mm.poses_, mm.labels_, arrows=False)
        name = "odometry + ICP" if icp_on else "odometry only"
        ax.set_title(f"{name}: {mm.n_groups_} groups", fontsize=10)
    fig.tight_layout()
    gp.save_figure(fig, IMG / "grouping_noise.png")
    print(f"figures written to {IMG}")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--experiments", action="store_true", help="assoc and noise tables")
    parser.add_argument("--plots", action="store_true", help="write docs/img/grouping_*.png")
    args = parser.parse_args()
    if args.experiments:
        experiment_assoc()
        experiment_noise()
    if args.plots:
        make_plots()
    if not (args.experiments or args.plots):
        parser.print_help()


if __name__ == "__main__":
    main()
