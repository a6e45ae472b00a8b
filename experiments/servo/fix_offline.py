"""Offline check of SignalServo's global fix: for the dev ``anywhere`` starts,
record the observing turn (the env stepped with the controller's turn command, odometry and
images as the controller sees them) and score candidate fix methods by the distance from the
true start to the fix view's true position. Truth is used here for scoring only.

    python -m experiments.servo.fix_offline record --world lawn --episodes 24 --data D --maps M
    --out F.npz python -m experiments.servo.fix_offline score F.npz [F2.npz ...] --data D --maps M

The ``consistent`` method (`consistent_fix`: the turn's best match checked against the turn's
other images) lost to the contrast fix here and closed loop (docs/decisions/055 and 076);
it lives here only.
"""

from __future__ import annotations

import argparse

import numpy as np
from scipy.sparse.csgraph import dijkstra

from common.fileio import atomic_path
from common.geometry import se2_compose, wrap_angle

_KEYS = ("world", "features", "odometry", "truth", "start", "target")


def record(world: str, episodes: int, data, maps, out: str) -> None:
    """Step the env through the observing turn at each dev ``anywhere`` start; save the
    feature vectors, odometry and true poses of every step to ``out`` (.npz)."""
    import sim  # noqa: F401  (GL backend first)
    from servo.camera_only.config import SignalServoConfig
    from servo.localise import ImageLocaliser
    from servo.maps.build import load_or_build
    from servo.task.env import ServoEnv
    from servo.task.protocol import Protocol, episode_specs, reset_options
    from sim.simulator import CONTROL_DT

    m = load_or_build(world, data, maps)
    env = ServoEnv(world, m, max_steps=10_000)
    loc = ImageLocaliser(m)
    c = SignalServoConfig()
    specs = episode_specs(Protocol(world, "anywhere", "dev"), m.true_labels, episodes)
    steps = int(np.ceil(2 * np.pi / (c.turn_rate * CONTROL_DT))) + 1
    feats, odos, truth, starts, targets = [], [], [], [], []
    for spec in specs:
        obs, info = env.reset(seed=spec.seed, options=reset_options(env, spec, "anywhere"))
        f, o, t = [], [], []
        for _ in range(steps):
            f.append(loc.features(obs["image"]))
            o.append(obs["odometry"])
            t.append(info["pose"])
            obs, _, _, _, info = env.step(np.array([0.0, c.turn_rate], np.float32))
        feats.append(f)
        odos.append(o)
        truth.append(t)
        starts.append(t[0])
        targets.append(info["target_view"])
        print(spec.index, np.round(t[0], 2), flush=True)
    env.close()
    with atomic_path(out) as tmp, open(tmp, "wb") as f:  # nothing half-written on disk
        np.savez_compressed(
            f,
            world=world,
            features=np.array(feats, np.float32),
            odometry=np.array(odos),
            truth=np.array(truth),
            start=np.array(starts),
            target=np.array(targets),
        )


def load_recording(path) -> dict:
    """A file written by `record`, read as untrusted input: the known arrays only (no
    pickles), a known world, and one turn (T, d) features and (T, 3) odometry per start."""
    try:
        with np.load(path, allow_pickle=False) as z:
            rec = {k: z[k] for k in _KEYS}
    except (OSError, ValueError, KeyError) as err:
        raise ValueError(
            f"path {str(path)!r} is not a recording of fix_offline record "
            f"(an .npz with {', '.join(_KEYS)}): {err}"
        ) from err
    import sim  # noqa: F401  (GL backend first)
    from scenes import WORLDS

    world = str(rec["world"])
    if world not in WORLDS:
        raise ValueError(
            f"recording {str(path)!r}: world must be one of {sorted(WORLDS)}, got {world!r}"
        )
    n = len(rec["start"])
    feats, odo = rec["features"], rec["odometry"]
    if not (
        feats.ndim == 3
        and odo.ndim == 3
        and odo.shape[2] == 3
        and len(feats) == len(odo) == n
        and feats.shape[1] == odo.shape[1]
        and rec["start"].shape[1:] == (3,)
        and np.isfinite(odo).all()
        and np.isfinite(rec["start"]).all()
    ):
        raise ValueError(
            f"recording {str(path)!r}: expected features (S, T, d), odometry "
            f"(S, T, 3) and start (S, 3), finite; got {feats.shape}, "
            f"{odo.shape}, {rec['start'].shape}"
        )
    rec["world"] = world
    return rec


def neighbourhood(routes, view: int, radius: float) -> dict[int, np.ndarray]:
    """The views within ``radius`` m of route-graph distance of ``view``, each with its pose
    in ``view``'s frame (the graph's sensed transforms chained along shortest paths).
    """
    dist, pred = dijkstra(
        routes.graph, indices=int(view), limit=float(radius), return_predecessors=True
    )
    poses = {int(view): np.zeros(3)}
    for v in np.argsort(dist):  # parents before children: nearer first
        v = int(v)
        if not np.isfinite(dist[v]) or v in poses:
            continue
        p = int(pred[v])
        poses[v] = se2_compose(poses[p], routes.transform[(p, v)])
    return poses


def consistent_fix(
    samples,
    routes,
    *,
    candidates: int = 6,
    radius: float = 4.0,
    tolerance: float = 0.35,
    trust: float = 0.9,
    share: float = 0.5,
) -> tuple[int, float]:
    """The fix (view, odometry heading facing the way it looks) from the turn's ``samples``
    (aligned distance, view, odometry heading), each the best match of one image.

    Each of the ``candidates`` best samples (distance <= ``trust``) is supported by every
    trusted sample of *another* view within ``radius`` m of the candidate's in the graph whose
    heading, relative to the candidate's, agrees within ``tolerance`` rad with that view's
    heading in the candidate's frame; each supporting view counts once, 1 - d / trust at its
    best match. Views matched over a wide range of headings (`_generic`) neither
    stand nor support. The best trusted match stands unless its support is below ``share``
    of the best-supported candidate's, which then wins; with none trusted, the best match.
    """
    samples = sorted((float(d), int(v), float(h)) for d, v, h in samples)
    if not samples:
        raise ValueError("the turn gave no localisation")
    trusted = [s for s in samples if s[0] <= trust and not _generic(samples, s[1], tolerance)]
    scores = []
    for _, view, heading in trusted[:candidates]:
        poses = neighbourhood(routes, view, radius)
        support: dict[int, float] = {}  # each other view once, at its best match
        for dj, vj, hj in trusted:
            if (
                vj != view
                and vj in poses
                and abs(wrap_angle(hj - heading - poses[vj][2])) < tolerance
            ):
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
    nothing about the place, and its matches would support each other.
    """
    h = np.array([s[2] for s in samples if s[1] == view])
    if len(h) < 2:
        return False
    spread = np.abs(wrap_angle(h[:, None] - h[None, :])).max()
    return bool(spread > 2.0 * tolerance)


# -- methods: each takes (localiser, routes, features (T, d), odometry (T, 3)) -> view -------
def _samples(loc, feats, odo, every=2, top=2):
    out = []
    for k in range(1, len(feats)):
        if (k + 1) % every == 0:
            view, yaw, d = loc.localise(feats[k], top=top)
            out.append((d, view, float(odo[k][2] + yaw)))
    return out


def m_single(loc, routes, feats, odo):
    return min(_samples(loc, feats, odo))[1]


def m_consistent(loc, routes, feats, odo):
    return consistent_fix(_samples(loc, feats, odo), routes)[0]


def m_contrast(loc, routes, feats, odo, far=0.6):
    from servo.camera_only.turn_global_fix import contrast_fix

    idx = [k for k in range(1, len(feats)) if (k + 1) % 2 == 0]
    rows = [loc.align(feats[k]) for k in idx]
    d = np.array([r[0] for r in rows])
    y = np.array([r[1] for r in rows])
    return contrast_fix(d, y, odo[idx, 2], far=far)[0]


def methods():
    return {"single": m_single, "consistent": m_consistent, "contrast": m_contrast}


def score(paths: list[str], data, maps, only: list[str] | None = None) -> None:
    """Print each method's fix error (m, fix view's true position to the true start)."""
    from servo.localise import ImageLocaliser
    from servo.maps.build import load_or_build
    from servo.route import RouteGraph

    for path in paths:
        z = load_recording(path)
        world = z["world"]
        m = load_or_build(world, data, maps, progress=False)
        loc, routes = ImageLocaliser(m), RouteGraph(m)
        start = z["start"]
        near = np.array([np.hypot(*(m.true_poses[:, :2] - s[:2]).T).min() for s in start])
        table = {"nearest view": near}
        for name, fn in methods().items():
            if only and name not in only:
                continue
            err = []
            for f, o, s in zip(z["features"], z["odometry"], start, strict=True):
                v = fn(loc, routes, f, o)
                err.append(float(np.hypot(*(m.true_poses[v, :2] - s[:2]))))
            table[name] = np.array(err)
        print(f"== {world} ({len(start)} starts)")
        for name, e in table.items():
            print(
                f"{name:>14}: median {np.median(e):5.2f} m, within 2 m {np.mean(e <= 2):4.0%}"
                f"  | {' '.join(f'{x:.0f}' for x in e)}"
            )


if __name__ == "__main__":
    p = argparse.ArgumentParser()
    p.add_argument("cmd", choices=["record", "score"])
    p.add_argument("paths", nargs="*")
    p.add_argument("--world", default="lawn")
    p.add_argument("--episodes", type=int, default=24)
    p.add_argument("--data", help="dataset folder (default: the data home's)")
    p.add_argument("--maps", help="servo map cache (default: the data home's)")
    p.add_argument("--out")
    p.add_argument("--only", nargs="*")
    args = p.parse_args()
    if args.cmd == "record":
        record(args.world, args.episodes, args.data, args.maps, args.out)
    else:
        score(args.paths, args.data, args.maps, args.only)
