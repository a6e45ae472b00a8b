"""The servo task of a held-out cell: a servo map built from the cell's own dataset, then the
benchmark protocol's test episodes for both controllers and both start tiers.

Each world's map comes from its own recordings (``servo.maps.build_map``, default settings, K
the world's manifold count), so nothing of the canonical worlds' maps is reused. Episode ``i``
of a (world, tier) is the protocol's (``servo.task.protocol``: its seeds from the split and the
world, pairs of manifolds in turn), so every policy meets the same starts and targets and the
records can be paired. Each record keeps the junctions between its start and target manifold,
by which the summary breaks success down.
"""

from __future__ import annotations

from servo.task.protocol import TIERS

__all__ = ["SERVO_POLICIES", "servo_task"]

SERVO_POLICIES = ("servo", "signal")  # the laser+image controller, the camera-only one
SERVO_SPLIT = "test"
KEEP = ("episode", "seed", "start_manifold", "target_manifold", "junctions", "success", "reason",
        "spl", "steps", "collisions", "final_distance")  # fmt: skip


def servo_task(data, world: str, episodes: int) -> dict:
    """Run ``episodes`` test episodes per controller and start tier in ``world`` on a map built
    from ``data`` (the cell's dataset); returns the map's size and one record per episode
    (:data:`KEEP`'s fields, plus ``policy`` and ``tier``)."""
    from servo.maps import build_map
    from servo.task import Protocol, run_protocol

    m = build_map(data, world)
    records = []
    for policy in SERVO_POLICIES:
        for tier in TIERS:
            protocol = Protocol(world, tier, SERVO_SPLIT)
            r = run_protocol(protocol, m, episodes, policy, workers=1, progress=False)
            for e in r["episodes_detail"]:
                records.append({"policy": policy, "tier": tier, **{k: e.get(k) for k in KEEP}})
    return {
        "episodes": int(episodes),
        "split": SERVO_SPLIT,
        "map_views": len(m.true_labels),
        "records": records,
    }
