"""The servo task of a held-out cell.

A servo map is built from the cell's own dataset, then the benchmark protocol's test episodes
run for both controllers and both start tiers.

Each world's map comes from its own recordings (``servo.maps.build_map``, default settings, K
the world's manifold count), so nothing of the canonical worlds' maps is reused. The episodes
are the protocol's (``servo.task.protocol``: seeds from the split and the world, episode ``i``
on the ``i``-th ordered pair of manifolds), chosen by `spread_by_junctions` so that a few
episodes per world reach targets 1, 2 and 3 junctions away in turn rather than only the main
manifold's neighbours (the protocol's first pairs all start on the main manifold). Every
controller and tier meets the same episodes, so the records can be paired; each keeps the
junctions between its start and target manifold, by which the summary breaks success down.
"""

from __future__ import annotations

from servo.task import TIERS

__all__ = ["SERVO_POLICIES", "servo_task", "spread_by_junctions"]

SERVO_POLICIES = ("servo", "signal")  # the laser+image controller, the camera-only one
SERVO_SPLIT = "test"
KEEP = (
    "episode",
    "seed",
    "start_manifold",
    "target_manifold",
    "junctions",
    "success",
    "reason",
    "spl",
    "steps",
    "collisions",
    "final_distance",
)


def spread_by_junctions(pairs: list[tuple[str, str]], junctions, episodes: int) -> list[int]:
    """Choose the indices of ``episodes`` of ``pairs``, spread over junction counts.

    Junction counts are taken in turn (1, 2, 3 or more, 1, ...; a count the world lacks is
    skipped), each count's pairs in the protocol's order. When every pair is taken, the
    protocol's next episodes (pair ``i mod P``) follow.

    Parameters
    ----------
    pairs : list of tuple of (str, str)
        The protocol's ordered manifold pairs, episode ``i`` on pair ``i``.
    junctions : callable
        ``junctions(a, b)``: the junctions between manifolds ``a`` and ``b``.
    episodes : int
        How many episodes.

    Returns
    -------
    list of int
        The episode indices.
    """
    by: dict[int, list[int]] = {}
    for i, (a, b) in enumerate(pairs):
        by.setdefault(min(junctions(a, b), 3), []).append(i)
    order, queues = [], [by[j] for j in sorted(by)]
    while len(order) < min(episodes, len(pairs)):
        for q in queues:
            if q and len(order) < episodes:
                order.append(q.pop(0))
    return order + list(range(len(pairs), len(pairs) + episodes - len(order)))


def servo_task(data, world, episodes: int) -> dict:
    """Run ``episodes`` test episodes per controller and start tier in ``world``.

    The episodes run on a map built from ``data`` and are chosen by `spread_by_junctions`.

    Parameters
    ----------
    data : Dataset
        The cell's dataset.
    world : scenes.World
        The built world.
    episodes : int
        Episodes per controller and start tier.

    Returns
    -------
    dict
        The map's size and one record per episode (`KEEP`'s fields, plus ``policy`` and
        ``tier``).
    """
    from servo.maps import build_map
    from servo.task import Protocol, manifold_pairs, run_protocol

    m = build_map(data, world.name)
    pairs = manifold_pairs(m.true_labels, m.manifold_names)
    indices = spread_by_junctions(pairs, world.junctions_between, episodes)
    records = []
    for policy in SERVO_POLICIES:
        for tier in TIERS:
            protocol = Protocol(world.name, tier, SERVO_SPLIT)
            r = run_protocol(
                protocol, m, episodes, policy, workers=1, progress=False, indices=indices
            )
            for e in r["episodes_detail"]:
                records.append({"policy": policy, "tier": tier, **{k: e.get(k) for k in KEEP}})
    return {
        "episodes": int(episodes),
        "split": SERVO_SPLIT,
        "map_views": len(m.true_labels),
        "indices": indices,
        "records": records,
    }
