"""The global fix of :class:`~servo.signal_servo.SignalServo`'s observing turn, checked for
consistency across the turn (issue 12, item 2: a wrong or loose fix).

Every few degrees of the turn the image is localised on its own (the best-aligned view of the
clusters eq. 13 ranks first, :meth:`~servo.localise.ImageLocaliser.localise`), which gives a
view and the odometry heading that faces the way it looks. The single best match can be a
look-alike far away (the lawn's mirrored arms, a view 12-46 m off on dev starts). The right
place explains the *other* images of the turn too: their matched views lie near it, and the
headings at which they matched differ by what odometry turned between them, as the map's
relative headings of those views say. :func:`consistent_fix` scores each of the best few
candidates by that support and keeps the best supported (ties: the best match).
"""

from __future__ import annotations

import numpy as np
from scipy.sparse.csgraph import dijkstra

from common.geometry import se2_compose, wrap_angle
from servo.route import RouteGraph


def neighbourhood(routes: RouteGraph, view: int, radius: float) -> dict[int, np.ndarray]:
    """The views within ``radius`` m of route-graph distance of ``view``, each with its pose
    in ``view``'s frame (the graph's sensed transforms chained along shortest paths)."""
    dist, pred = dijkstra(routes.graph, indices=int(view), limit=float(radius),
                          return_predecessors=True)  # fmt: skip
    poses = {int(view): np.zeros(3)}
    for v in np.argsort(dist):  # parents before children: nearer first
        v = int(v)
        if not np.isfinite(dist[v]) or v in poses:
            continue
        p = int(pred[v])
        poses[v] = se2_compose(poses[p], routes.transform[(p, v)])
    return poses


def consistent_fix(samples, routes: RouteGraph, *, candidates: int = 6, radius: float = 4.0,
                   tolerance: float = 0.35, trust: float = 0.9,
                   share: float = 0.5) -> tuple[int, float]:  # fmt: skip
    """The fix (view, odometry heading facing the way it looks) from the turn's ``samples``
    (aligned distance, view, odometry heading), each the best match of one image.

    Each of the ``candidates`` best samples (distance <= ``trust``) is supported by every
    trusted sample of *another* view within ``radius`` m of the candidate's in the graph whose
    heading, relative to the candidate's, agrees within ``tolerance`` rad with that view's
    heading in the candidate's frame; each supporting view counts once, 1 - d / trust at its
    best match. Views matched over a wide range of headings (:func:`_generic`) neither
    stand nor support. The best trusted match stands unless its support is below ``share``
    of the best-supported candidate's, which then wins; with none trusted, the best match."""
    samples = sorted((float(d), int(v), float(h)) for d, v, h in samples)
    if not samples:
        raise ValueError("the turn gave no localisation")
    trusted = [s for s in samples if s[0] <= trust and not _generic(samples, s[1], tolerance)]
    scores = []
    for _, view, heading in trusted[:candidates]:
        poses = neighbourhood(routes, view, radius)
        support: dict[int, float] = {}  # each other view once, at its best match
        for dj, vj, hj in trusted:
            if (vj != view and vj in poses
                    and abs(wrap_angle(hj - heading - poses[vj][2])) < tolerance):  # fmt: skip
                support[vj] = max(support.get(vj, 0.0), 1.0 - dj / trust)
        scores.append(sum(support.values()))
    if not scores:
        return samples[0][1], samples[0][2]
    # the best match stands unless another candidate is much better supported: where the
    # best match is right (the hallway) a better-supported neighbour is often a metre off
    k = int(np.argmax(scores))
    if scores[0] >= share * scores[k]:
        k = 0
    return trusted[k][1], trusted[k][2]


def _generic(samples, view: int, tolerance: float) -> bool:
    """Whether ``view`` is the best match of images more than 2 ``tolerance`` apart in
    heading: a view that matches whichever way the camera looks (open grass, sky) says
    nothing about the place, and its matches would support each other."""
    h = np.array([s[2] for s in samples if s[1] == view])
    if len(h) < 2:
        return False
    spread = np.abs(wrap_angle(h[:, None] - h[None, :])).max()
    return bool(spread > 2.0 * tolerance)
