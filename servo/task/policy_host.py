"""The policy's own process: ``python -m servo.task.policy_host FD``.

It is given a connected socket (file descriptor ``FD``) and nothing else: the evaluator sends
the map as sensed (`map_message`: plain arrays and JSON, no path, neutral names), the
policy's spec, params and seed; then per episode the target (its view index and image) and per
step the observation, and reads back the action. The env, its ``info``, the geodesic field
and the evaluator's state never exist in this process (decision record 073). Messages are
``servo.task.wire``'s, in both directions; the evaluator checks what comes back.

Also here: `builtin_policy`, the one place our controllers are made from a sensed map,
in the evaluator's process or in this one.
"""

from __future__ import annotations

import socket
import sys

import numpy as np

from mapping import persistence
from mapping.features import ImageFeatures
from mapping.manifold import ManifoldClustering
from scenes import NO_MANIFOLD
from servo.maps import MapSettings, ServoMap
from servo.task import wire
from servo.task.interface import (
    PolicyLoadError,
    Target,
    is_policy_spec,
    make_outside_policy,
    reseed,
)

MAP_ARRAYS = (
    "images",
    "features",
    "scans",
    "angles",
    "poses",
    "sequence",
    "frame",
    "clusters",
    "edges",
    "edge_transforms",
)
MAX_TO_POLICY = 4 << 30  # bytes of one message to the policy (the map is the largest)
BUILTIN = ("servo", "signal", "greedy", "greedy-target", "random")  # all but the oracle
# observation entries the same at every step of an episode: sent with its first act only
EPISODE_CONSTANT = ("target_image", "target_scan", "target_scan_valid")


def builtin_policy(name: str, m: ServoMap, rng: np.random.Generator, **options):
    """Make our controller ``name`` (one of `BUILTIN`) on the sensed map ``m``.

    Parameters
    ----------
    name : str
        One of `BUILTIN`.
    m : ServoMap
        The sensed map.
    rng : numpy.random.Generator
        The generator of the random policy.
    **options
        The controller's keyword arguments.

    Returns
    -------
    object
        The policy, with ``reset`` and ``act``.
    """
    if name == "servo":
        from servo.laser_image import ManifoldServo

        return ManifoldServo(m, world=m.world, **options)
    if name == "signal":
        from servo.camera_only import SignalServo

        return SignalServo(m, world=m.world, **options)
    from servo.task.baseline_policies import GreedyFProbing, RandomPolicy

    if name == "greedy":
        return GreedyFProbing(m, **options)
    if name == "greedy-target":
        return GreedyFProbing(m, waypoints=False, **options)
    if name == "random":
        return RandomPolicy(rng, **options)
    raise ValueError(f"policy must be one of {BUILTIN}, got {name!r}")


def map_message(m: ServoMap) -> tuple[dict, dict[str, np.ndarray]]:
    """Return the values and arrays that carry the sensed map ``m`` to the policy's process.

    ``m`` is the map as sensed (``interface.sensed_map``); the message holds its sensed arrays
    and fitted estimators, nothing of the truth.

    Parameters
    ----------
    m : ServoMap
        The sensed map.

    Returns
    -------
    values : dict
        The JSON-able values.
    arrays : dict of str to ndarray
        The arrays.
    """
    c_meta, c_arrays = persistence.dump(m.clustering, "clustering")
    f_meta, f_arrays = persistence.dump(m.image_features, "image_features")
    values = {
        "world": m.world,
        "key": m.key,
        "max_range": float(m.max_range),
        "sequence_names": list(m.sequence_names),
        "settings": m.settings.to_json(),
        "clustering": c_meta,
        "image_features": f_meta,
    }
    return values, {**{k: getattr(m, k) for k in MAP_ARRAYS}, **c_arrays, **f_arrays}


def map_from_message(values: dict, arrays: dict[str, np.ndarray]) -> ServoMap:
    """Rebuild a sensed map from its message: the inverse of `map_message`.

    The map's true poses are NaN and true labels ``NO_MANIFOLD``, its arrays read-only.

    Parameters
    ----------
    values : dict
        The message's values.
    arrays : dict of str to ndarray
        The message's arrays.

    Returns
    -------
    ServoMap
        The sensed map.
    """
    clustering = persistence.load(ManifoldClustering, values["clustering"], arrays, "clustering")
    image_features = persistence.load(
        ImageFeatures, values["image_features"], arrays, "image_features"
    )
    n = len(arrays["clusters"])
    poses, labels = np.full((n, 3), np.nan), np.full(n, NO_MANIFOLD, np.int64)
    poses.flags.writeable = labels.flags.writeable = False
    return ServoMap(
        world=str(values["world"]),
        key=str(values["key"]),
        max_range=float(values["max_range"]),
        sequence_names=[str(s) for s in values["sequence_names"]],
        settings=MapSettings.from_json(values["settings"]),
        clustering=clustering,
        image_features=image_features,
        true_poses=poses,
        true_labels=labels,
        manifold_names=(),
        world_digest=None,
        **{k: arrays[k] for k in MAP_ARRAYS},
    )


def _make(values: dict, arrays: dict):
    spec, params = values["spec"], dict(values["params"])
    rng = np.random.default_rng(int(values["policy_seed"]))
    m = map_from_message(values["map"], arrays)
    if is_policy_spec(spec):
        return make_outside_policy(spec, m, rng, **params), rng
    try:
        return builtin_policy(spec, m, rng, **params), None  # ours keep one generator
    except Exception as err:
        raise PolicyLoadError(f"policy {spec!r}: {type(err).__name__}: {err}") from err


def _error(sock, stage: str, err: BaseException) -> None:
    detail = f"{stage} raised {type(err).__name__}: {err}"
    wire.send(sock, wire.encode("error", {"stage": stage, "detail": detail[:2000]}))


def serve(sock: socket.socket) -> None:
    """Answer the evaluator's messages on ``sock`` until it says ``close`` or goes away.

    Parameters
    ----------
    sock : socket.socket
        The socket connected to the evaluator.
    """
    policy = rng = None
    kept: dict = {}  # the episode's constant observation entries, as first sent
    while True:
        try:
            kind, values, arrays = wire.decode(wire.receive(sock, MAX_TO_POLICY), MAX_TO_POLICY)
        except wire.Closed:
            return
        if kind == "close":
            return
        if kind == "init":
            try:
                policy, rng = _make(values, arrays)
            except PolicyLoadError as err:
                wire.send(sock, wire.encode("error", {"stage": "load", "detail": str(err)}))
                continue
            wire.send(sock, wire.encode("ready"))
        elif kind == "reset":
            kept.clear()
            if rng is not None:
                reseed(rng, int(values["episode_seed"]), int(values["policy_seed"]))
            try:
                policy.reset(Target(int(values["view"]), arrays["image"]))
            except Exception as err:
                _error(sock, "reset", err)
                continue
            wire.send(sock, wire.encode("done"))
        elif kind == "act":
            observation = {k: np.array(v) for k, v in arrays.items()}
            kept.update({k: observation[k] for k in EPISODE_CONSTANT if k in observation})
            observation.update({k: kept[k] for k in values.get("same", []) if k in kept})
            try:
                action = policy.act(observation)
            except Exception as err:
                _error(sock, "act", err)
                continue
            wire.send(sock, _action_message(action, getattr(policy, "waypoint_", None)))


def _action_message(action, waypoint) -> bytes:
    waypoint = int(waypoint) if isinstance(waypoint, int | np.integer) else None
    try:
        a = np.asarray(action, dtype=np.float64)
    except (TypeError, ValueError):
        return wire.encode("action", {"invalid": repr(action)[:200], "waypoint": waypoint})
    return wire.encode("action", {"waypoint": waypoint}, {"action": a})


def main(argv: list[str] | None = None) -> int:
    """Serve on the inherited socket whose descriptor is the one argument.

    Parameters
    ----------
    argv : list of str, optional
        The arguments; ``sys.argv[1:]`` when not given.

    Returns
    -------
    int
        The exit status: 0, or 2 for a wrong usage.
    """
    argv = sys.argv[1:] if argv is None else argv
    if len(argv) != 1 or not argv[0].isdigit():
        print("usage: python -m servo.task.policy_host FD", file=sys.stderr)
        return 2
    sock = socket.socket(fileno=int(argv[0]))
    try:
        serve(sock)
    finally:
        sock.close()
    return 0


if __name__ == "__main__":
    sys.exit(main())
