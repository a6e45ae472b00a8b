"""Figures of an observation grouping, like Blanco et al.'s Figures 3 and 5.

Each function draws one panel into a matplotlib ``Axes`` (so callers compose and save figures
as they like): the scans and trajectory coloured by group over a background, every local map
in its own frame, the weight matrix sorted by group with the partitions drawn on it (Fig. 3f),
and the topological graph. ``save_figure`` writes a PNG atomically. Matplotlib must already use
a non-interactive backend (``matplotlib.use("Agg")``); ``agg_pyplot`` does that.
"""

from __future__ import annotations

import io
import itertools
from collections.abc import Callable, Sequence
from pathlib import Path

import numpy as np

from common.fileio import atomic_write_bytes
from common.geometry import transform_points
from mapping.grouping import TopologicalMap

__all__ = [
    "agg_pyplot",
    "draw_groups",
    "draw_local_maps",
    "draw_topology",
    "draw_weights",
    "group_colour",
    "save_figure",
    "write_figures",
    "write_grouping_figures",
]


def agg_pyplot():
    """Return ``matplotlib.pyplot`` on the Agg backend (no display needed).

    Returns
    -------
    module
        ``matplotlib.pyplot``.
    """
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt


def group_colour(k: int):
    """Pick a distinct colour per group (tab20, cycling; tab10's pairs would look alike).

    Parameters
    ----------
    k : int
        The group.

    Returns
    -------
    tuple of float
        The RGBA colour.
    """
    import matplotlib

    return matplotlib.colormaps["tab20"]((2 * k + k // 10) % 20)


def save_figure(fig, path: str | Path, dpi: int = 110) -> Path:
    """Write ``fig`` as a PNG at ``path`` atomically and close it.

    Parameters
    ----------
    fig : matplotlib.figure.Figure
        The figure.
    path : str or Path
        Where to write.
    dpi : int, default 110
        Resolution.

    Returns
    -------
    Path
        ``path``.
    """
    buf = io.BytesIO()
    fig.savefig(buf, format="png", dpi=dpi)
    agg_pyplot().close(fig)
    atomic_write_bytes(path, buf.getvalue())
    return Path(path)


def draw_groups(
    ax,
    scans: Sequence[np.ndarray],
    poses: np.ndarray,
    labels: np.ndarray,
    *,
    every: int = 1,
    arrows: bool = True,
    point_size: float = 0.3,
) -> None:
    """Draw scan points (placed with ``poses``) and the trajectory, coloured by group (Fig. 5a).

    Parameters
    ----------
    ax : matplotlib.axes.Axes
        The axis to draw into.
    scans : sequence of ndarray
        Each scan's points in the laser frame.
    poses : ndarray of shape (n, 3)
        The scans' poses (x, y, heading).
    labels : ndarray of shape (n,)
        Each scan's group.
    every : int, default 1
        Draw every ``every``-th scan (not the trajectory), to keep dense sequences legible.
    arrows : bool, default True
        Draw the poses as heading arrows, else as dots.
    point_size : float, default 0.3
        Marker size of the scan points.
    """
    colours = [group_colour(int(k)) for k in labels]
    for i in range(0, len(scans), every):
        pts = transform_points(poses[i], scans[i])
        ax.scatter(pts[:, 0], pts[:, 1], s=point_size, color=colours[i], alpha=0.35, linewidths=0)
    if arrows:
        ax.quiver(
            poses[:, 0],
            poses[:, 1],
            np.cos(poses[:, 2]),
            np.sin(poses[:, 2]),
            color=colours,
            scale=40,
            width=0.004,
            zorder=3,
        )
    else:
        ax.scatter(poses[:, 0], poses[:, 1], s=6, color=colours, zorder=3)
    ax.set_aspect("equal")


def draw_local_maps(axes, local_maps: Sequence[np.ndarray], labels: np.ndarray) -> None:
    """Draw one local map per axis, in its own frame (triangle: the frame origin; Fig. 5c-h).

    Axes beyond the number of maps are blanked.

    Parameters
    ----------
    axes : array of matplotlib.axes.Axes
        The axes, one per map.
    local_maps : sequence of ndarray
        Each group's points in its own frame.
    labels : ndarray of shape (n,)
        Each scan's group (counted in each map's title).
    """
    for k, ax in enumerate(np.ravel(axes)):
        ax.set_axis_off()
        if k >= len(local_maps):
            continue
        pts = local_maps[k]
        ax.scatter(pts[:, 0], pts[:, 1], s=0.3, color=group_colour(k), linewidths=0)
        ax.plot(0, 0, "k^", ms=5)
        ax.set_aspect("equal")
        ax.set_title(f"local map {k}: {np.sum(labels == k)} scans", fontsize=8)


def draw_weights(ax, W, labels: np.ndarray, title: str = "weights, sorted by group") -> None:
    """Draw the weight matrix sorted by group, each group's block as a dotted square (Fig. 3f).

    Rows and columns are sorted by group; entries are shown on a 0..1 grey scale.

    Parameters
    ----------
    ax : matplotlib.axes.Axes
        The axis to draw into.
    W : ndarray or sparse matrix of shape (n, n)
        The weights.
    labels : ndarray of shape (n,)
        Each scan's group; scans of a negative label are left out.
    title : str, default "weights, sorted by group"
        The axis title.
    """
    import matplotlib.patches as mpatches

    W = W.toarray() if hasattr(W, "toarray") else np.asarray(W)
    keep = labels >= 0
    order = np.flatnonzero(keep)[np.argsort(labels[keep], kind="stable")]
    ax.imshow(W[np.ix_(order, order)], cmap="gray_r", vmin=0, vmax=1, interpolation="nearest")
    edges = np.concatenate([[0], np.cumsum(np.bincount(labels[keep]))]) - 0.5
    for a, b in itertools.pairwise(edges):
        ax.add_patch(mpatches.Rectangle((a, a), b - a, b - a, fill=False, ls=":", color="r"))
    ax.set_title(title, fontsize=9)


def draw_topology(
    ax,
    topology: TopologicalMap,
    background: Callable[[object], None] | None = None,
) -> None:
    """Draw the topological map: nodes at the local-map frames, arcs between them.

    Arcs are solid where the trajectory crosses between the groups, dashed where only their
    scans overlap; width grows with the number of scan pairs averaged into the arc's
    transformation.

    Parameters
    ----------
    ax : matplotlib.axes.Axes
        The axis to draw into.
    topology : TopologicalMap
        The map.
    background : callable, optional
        ``background(ax)`` draws the map underneath.
    """
    if background is not None:
        background(ax)
    frames = topology.frames
    for arc in topology.arcs:
        a, b = frames[arc.source], frames[arc.target]
        style = "-" if "trajectory" in arc.via else "--"
        ax.plot([a[0], b[0]], [a[1], b[1]], style, color="0.2", lw=1 + np.log1p(arc.n_pairs) / 2)
    for k, f in enumerate(frames):
        ax.scatter(f[0], f[1], s=220, color=group_colour(k), edgecolors="k", zorder=3)
        ax.text(f[0], f[1], str(k), ha="center", va="center", fontsize=8, zorder=4)
    ax.set_aspect("equal")


def write_grouping_figures(
    out_dir: str | Path,
    tag: str,
    scans: Sequence[np.ndarray],
    model,
    background: Callable[[object], None] | None = None,
    caption: str = "",
    every: int = 2,
) -> list[Path]:
    """Write the four figures of one fitted ``ObservationGraphPartitioner``.

    Groups over the map, local maps, weights and topology, as ``{tag}_groups.png``,
    ``_local_maps``, ``_weights`` and ``_topology`` in ``out_dir``.

    Parameters
    ----------
    out_dir : str or Path
        The output directory.
    tag : str
        The figures' name prefix and title.
    scans : sequence of ndarray
        Each scan's points in the laser frame.
    model : ObservationGraphPartitioner
        The fitted partitioner.
    background : callable, optional
        ``background(ax)`` draws the map under the groups and the topology.
    caption : str, default ""
        Added to the title of the groups figure.
    every : int, default 2
        Draw every ``every``-th scan in the groups figure.

    Returns
    -------
    list of Path
        The four files written.
    """
    plt = agg_pyplot()
    out_dir = Path(out_dir)
    written = []
    fig, ax = plt.subplots(figsize=(8, 7))
    if background is not None:
        background(ax)
    draw_groups(ax, scans, model.poses_, model.labels_, every=every, arrows=False, point_size=1.5)
    title = f"{tag}: {len(scans)} scans in {model.n_groups_} groups (colour = group{caption})"
    ax.set_title(title, fontsize=9)
    fig.tight_layout()
    written.append(save_figure(fig, out_dir / f"{tag}_groups.png"))

    cols = min(4, model.n_groups_)
    rows = int(np.ceil(model.n_groups_ / cols))
    fig, axes = plt.subplots(rows, cols, figsize=(2.6 * cols, 2.6 * rows), squeeze=False)
    draw_local_maps(axes, model.local_maps_, model.labels_)
    fig.tight_layout()
    written.append(save_figure(fig, out_dir / f"{tag}_local_maps.png"))

    fig, ax = plt.subplots(figsize=(5, 4.6))
    draw_weights(ax, model.affinity_matrix_, model.labels_, f"{tag}: SSO weights by group")
    fig.tight_layout()
    written.append(save_figure(fig, out_dir / f"{tag}_weights.png"))

    fig, ax = plt.subplots(figsize=(7, 6))
    draw_topology(ax, model.topology_, background)
    ax.set_title(f"{tag}: topological map (solid: trajectory, dashed: overlap)", fontsize=9)
    fig.tight_layout()
    written.append(save_figure(fig, out_dir / f"{tag}_topology.png"))
    return written


def write_figures(out_dir: Path, tag: str, runs, model) -> list[Path]:
    """Write the figures of one grouping of a ``sim.runs.Runs`` (`write_grouping_figures`).

    The background is the map of the true manifolds for a simulated world of ours (none for an
    imported dataset).

    Parameters
    ----------
    out_dir : Path
        The output directory.
    tag : str
        The figures' name prefix and title.
    runs : sim.runs.Runs
        The recordings grouped.
    model : ObservationGraphPartitioner
        The partitioner fitted on them.

    Returns
    -------
    list of Path
        The four files written.
    """
    draw_map = _map_background(runs.world) if runs.has_ground_truth else None
    caption = "; background: true manifolds" if draw_map is not None else ""
    return write_grouping_figures(out_dir, tag, runs.scans, model, draw_map, caption)


def _map_background(world_name: str) -> Callable[[object], None] | None:
    """Make a function drawing the top-down map of one of our worlds into an axis.

    None for a world that is not ours (an imported dataset).
    """
    from scenes import build_world
    from scenes.families import parse_world_name

    try:
        parse_world_name(world_name)
    except ValueError:
        return None
    from sim.topdown import TopDownView

    view = TopDownView(build_world(world_name), max_size=900)
    h, w = view.size
    extent = (
        view.origin[0],
        view.origin[0] + w / view.scale,
        view.origin[1] - h / view.scale,
        view.origin[1],
    )
    background = view.draw()

    def draw_map(ax):
        ax.imshow(background, extent=extent, alpha=0.55)

    return draw_map
