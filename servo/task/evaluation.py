"""Closed-loop evaluation: success rate, SPL, final errors, steps and collisions per pair.

The figures are given per manifold pair, with trajectory plots over the top-down map and videos
of chosen episodes.

SPL (Anderson et al. 2018, "On evaluation of embodied navigation agents"):
``mean_i S_i l_i / max(p_i, l_i)`` with l_i the shortest free-space path length from the start
to the target (`GeodesicField`) and p_i the length actually driven.
"""

from __future__ import annotations

import time
from collections import defaultdict
from collections.abc import Sequence
from pathlib import Path

import cv2
import numpy as np

from common.blas import single_threaded_blas
from common.fileio import write_png
from common.validation import check_int
from common.video import write_mp4
from scenes.families import check_world_name, parse_world_name
from servo.geodesic import GeodesicField
from servo.maps import ServoMap, load_or_build
from servo.task.baseline_policies import OraclePolicy
from servo.task.env import ServoEnv
from servo.task.guard import ACT_LIMIT_S, NOT_LOADED, PolicyFailure, call, check_action
from servo.task.interface import PolicyLoadError, Target, is_policy_spec, sensed_map
from servo.task.policies import POLICIES, TRUTH_POLICY
from servo.task.policy_host import builtin_policy
from servo.task.stats import wilson_interval

SIGNAL_LAG = 5  # steps between the two ends of a step pair in the F-vs-distance summary
SIGNAL_MIN_DROP = 0.1  # m of true (geodesic) distance a pair must fall to count
BOUNDARY_MARGIN_S = 5.0  # s the alarm waits beyond a policy process's own time limit


def make_policy(name: str, env: ServoEnv, rng: np.random.Generator, **options):
    """Make the policy ``name`` for ``env``.

    ``name`` is one of
    [`POLICIES`][servo.task.evaluation.POLICIES], or an outside factory ``package.module:factory``
    ([`PolicyFactory`][servo.task.interface.PolicyFactory]), which runs in its own process
    ([`RemotePolicy`][servo.task.remote.RemotePolicy], policy seed 0, no sandbox; raises
    [`PolicyLoadError`][servo.task.interface.PolicyLoadError]). Every policy but the oracle is given
    the map as sensed ([`sensed_map`][servo.task.interface.sensed_map]). ``greedy`` probes toward
    the next waypoint view of the route
    ([`GreedyFProbing`][servo.task.baseline_policies.GreedyFProbing]); ``greedy-target``: the
    earlier variant that probes toward the final target only (labelled as such: its cluster gives no
    signal from another manifold).

    Parameters
    ----------
    name : str
        A policy name of ``POLICIES`` or an outside factory ``package.module:factory``.
    env : ServoEnv
        The env the policy acts in (its map, and its world for the oracle).
    rng : numpy.random.Generator
        The generator a built-in policy draws from.
    **options
        The policy's keyword arguments.

    Returns
    -------
    object
        The policy, with ``reset`` and ``act``.
    """
    check_policy_name(name)
    if is_policy_spec(name):
        from servo.task.remote import RemotePolicy

        return RemotePolicy(name, env.map, params=options)
    if name == "oracle":  # the upper bound: the one policy given the truth
        return OraclePolicy(env.base.world, **options)
    return builtin_policy(name, sensed_map(env.map), rng, **options)


def check_policy_name(name) -> str:
    """Check that ``name`` is one of `POLICIES` or an outside factory.

    ``name`` is returned if it is one of [`POLICIES`][servo.task.evaluation.POLICIES] or has the
    form ``package.module:factory``; else ``ValueError``.

    Parameters
    ----------
    name : str
        The policy name to check.

    Returns
    -------
    str
        ``name`` itself.
    """
    if name in POLICIES or is_policy_spec(name):
        return name
    raise ValueError(f"policy must be one of {POLICIES} or package.module:factory, got {name!r}")


_F_AT_VIEW: dict[tuple[str, int], float] = {}


def signal_toward(m: ServoMap, image: np.ndarray, view: int) -> float:
    """Return F^j(k) of eq. 13 toward stored view ``view``, relative to F at the view.

    F is taken in the view's cluster and divided by F at the view itself (1 at the view, 0 where
    the cluster gives no signal).

    Parameters
    ----------
    m : ServoMap
        The map holding the view, its cluster and its features.
    image : ndarray of shape (H, W, 3)
        The camera image.
    view : int
        The stored view's index.

    Returns
    -------
    float
        F toward the view, divided by F at the view.
    """
    c = int(m.clusters[view])
    key = (m.key, int(view))
    # one BLAS thread whatever the load (as ServoEnv's reward): the episode's record of F
    # must not change in its last bits with mapping.validation.busy
    with single_threaded_blas():
        if key not in _F_AT_VIEW:
            f = m.clustering.signal(m.features[view][None], c, int(view))[0]
            _F_AT_VIEW[key] = max(float(f), 1e-12)
        x = m.image_features.transform(np.asarray(image)[None]).astype(np.float32)
        return float(m.clustering.signal(x, c, int(view))[0]) / _F_AT_VIEW[key]


def episode_seeds(seed: int, episodes: int) -> list[int]:
    """Return the episodes' seeds, derived from ``seed``.

    Episode ``i``'s seed is the ``i``-th child of ``SeedSequence(seed)``, so a run is
    reproducible and a longer run extends a shorter one.

    Parameters
    ----------
    seed : int
        The run's seed.
    episodes : int
        The number of episodes.

    Returns
    -------
    list of int
        One seed per episode.
    """
    return [int(s.generate_state(1)[0]) for s in np.random.SeedSequence(seed).spawn(episodes)]


def run_episode(
    env: ServoEnv,
    policy,
    seed: int,
    options: dict | None = None,
    frames=None,
    *,
    truth: bool = False,
    act_limit_s: float = ACT_LIMIT_S,
    load_error: str | None = None,
) -> dict:
    """Run one episode and return its record.

    The record is `score_episode`'s; video frames are appended to ``frames`` if given.

    The policy is given the target as a [`Target`][servo.task.interface.Target] and the env's
    observations only: ``policy.reset(target)``, ``policy.act(observation)``. With ``truth``
    (the oracle, by name), the env's info too: ``reset(target, info)``, ``act(observation,
    info)``. A policy that raises, gives an action that is not two finite numbers inside the
    action space, or takes over ``act_limit_s`` for a call ends the episode as a failure with
    that reason (``servo.task.guard``); ``load_error``: the policy could not be made, and the
    episode fails so at once.

    Parameters
    ----------
    env : ServoEnv
        The env to run the episode in.
    policy : object
        The policy, with ``reset`` and ``act`` (None where ``load_error`` is given).
    seed : int
        The episode's seed, passed to ``env.reset``.
    options : dict, optional
        The reset's options.
    frames : list, optional
        A list the video frames (camera view beside the top-down map) are appended to.
    truth : bool, default False
        Give the policy the env's info too (the oracle).
    act_limit_s : float, default ACT_LIMIT_S
        Seconds a policy call may take.
    load_error : str, optional
        Why the policy could not be made; the episode then fails at once.

    Returns
    -------
    dict
        The episode's record (`score_episode`).
    """
    obs, info = env.reset(seed=seed, options=options)
    field = GeodesicField(env.base.world, info["target_pose"])
    shortest = field.distance(info["pose"][:2])
    if not np.isfinite(shortest):
        raise ValueError(f"episode {seed}: the target is unreachable from the start {info['pose']}")
    # poses copied: an env may update its info's arrays in place
    infos = [{**info, "pose": np.array(info["pose"])}]
    act_time, f_waypoint, true_dist = [], [], [shortest]
    low, high = env.action_space.low.astype(np.float64), env.action_space.high.astype(np.float64)
    failure = None
    try:
        if load_error is not None:
            raise PolicyFailure(NOT_LOADED, load_error)
        view = int(info["target_view"])
        target = Target(view, env.map.images[view])
        extra = (info,) if truth else ()
        limit = act_limit_s
        if hasattr(policy, "limit_s"):  # in its own process: the boundary keeps the time
            policy.limit_s, limit = act_limit_s, act_limit_s + BOUNDARY_MARGIN_S
        call(policy.reset, target, *extra, limit=limit)
        while True:
            t0 = time.perf_counter()
            action = call(policy.act, obs, *extra, limit=limit)
            act_time.append(time.perf_counter() - t0)
            check_action(action, low, high)
            waypoint = getattr(policy, "waypoint_", None)
            obs, _, terminated, truncated, info = env.step(action)
            extra = (info,) if truth else ()
            infos.append({**info, "pose": np.array(info["pose"])})
            true_dist.append(field.distance(info["pose"][:2]))
            f_waypoint.append(
                np.nan if waypoint is None else signal_toward(env.map, obs["image"], waypoint)
            )
            if frames is not None:
                frames.append(
                    np.concatenate([obs["image"], _fit(env.render(), obs["image"])], axis=1)
                )
            if terminated or truncated:
                break
    except PolicyFailure as err:
        failure = err
    return score_episode(seed, infos, shortest, true_dist, act_time, f_waypoint, failure)


def score_episode(
    seed: int,
    infos: Sequence[dict],
    shortest: float,
    true_distance: Sequence[float],
    act_s: Sequence[float],
    signal_waypoint: Sequence[float],
    failure: PolicyFailure | None = None,
) -> dict:
    """Build an episode's record from what it produced, with no env or policy.

    Parameters
    ----------
    seed : int
        The episode's seed.
    infos : sequence of dict
        The reset's info, then every step's.
    shortest : float
        The shortest free-space path length from the start to the target (m).
    true_distance : sequence of float
        The true (geodesic) distance to the target at every info (m).
    act_s : sequence of float
        The policy's seconds per act.
    signal_waypoint : sequence of float
        F^j(k) toward the policy's waypoint view after every step (NaN: none).
    failure : PolicyFailure, optional
        The policy ended the episode: a failure whatever the pose, with its reason, and
        ``failure`` its detail.

    Returns
    -------
    dict
        The record: success, reason, SPL, path lengths, final errors, steps, collisions, act
        time, the trail and F along it.
    """
    if len(infos) < (1 if failure is not None else 2):
        raise ValueError(f"infos must hold the reset's and at least one step's, got {len(infos)}")
    last = infos[-1]
    p = last["path_length"]
    success = bool(last["success"]) and failure is None
    trail = np.array([np.asarray(i["pose"], dtype=float) for i in infos])
    return {
        "seed": int(seed),
        "start_manifold": last["start_manifold"],
        "target_manifold": last["target_manifold"],
        "junctions": last.get("junctions"),  # between the two manifolds (ServoEnv's info)
        "target_view": int(last["target_view"]),
        "success": success,
        "reason": last["reason"] if failure is None else failure.reason,
        "spl": float(success * shortest / max(p, shortest, 1e-9)),
        "shortest_path": float(shortest),
        "path_length": float(p),
        "final_distance": float(last["distance"]),
        "final_heading_error_deg": float(np.rad2deg(last["heading_error"])),
        "steps": len(infos) - 1,
        "collisions": sum(int(i["collision"]) for i in infos[1:]),
        "act_ms": float(1e3 * np.mean(act_s)) if len(act_s) else float("nan"),
        "trail": trail,
        "target_pose": np.asarray(last["target_pose"]),
        "start_pose": trail[0].copy(),
        # F along the trajectory: toward the target and the policy's waypoint view
        # (NaN: the policy has none), and the true geodesic distance to the target per step.
        "signal_target": np.array([float(i["signal"]) for i in infos]),
        "signal_waypoint": np.asarray(signal_waypoint, dtype=float),
        "true_distance": np.asarray(true_distance, dtype=float),
        **({} if failure is None else {"failure": failure.detail}),
    }


def _fit(top: np.ndarray, image: np.ndarray) -> np.ndarray:
    h = image.shape[0]
    w = round(top.shape[1] * h / top.shape[0])
    return cv2.resize(top, (w, h), interpolation=cv2.INTER_AREA)


def signal_agreement(records: list[dict], lag: int = SIGNAL_LAG) -> dict:
    """Measure how often F^j(k) toward the target rises as the true distance falls.

    This is the paper's premise (Section II-G), checked over step pairs ``lag`` apart whose
    geodesic distance to the target fell by at least ``SIGNAL_MIN_DROP``.

    Parameters
    ----------
    records : list of dict
        Episode records (`score_episode`).
    lag : int, default SIGNAL_LAG
        Steps between the two ends of a pair.

    Returns
    -------
    dict
        ``rises`` (share where F rose), ``flat_zero`` (share where F was 0 at both ends: no
        signal, e.g. on another manifold), ``pairs`` and ``lag``; the shares are None without
        pairs.
    """
    rises = zero = pairs = 0
    for r in records:
        f, d = r.get("signal_target"), r.get("true_distance")
        if f is None or len(f) <= lag:
            continue
        fall = d[:-lag] - d[lag:] >= SIGNAL_MIN_DROP
        df = f[lag:] - f[:-lag]
        both_zero = (f[lag:] == 0) & (f[:-lag] == 0)
        pairs += int(fall.sum())
        rises += int((fall & (df > 0)).sum())
        zero += int((fall & both_zero).sum())
    return {
        "pairs": pairs,
        "rises": rises / pairs if pairs else None,
        "flat_zero": zero / pairs if pairs else None,
        "lag": lag,
    }


def summarise(records: list[dict]) -> dict:
    """Aggregate episode records, overall and per (start manifold, target manifold).

    The summary holds success with its Wilson 95% interval, and F along the trajectories
    (`signal_agreement`).

    Parameters
    ----------
    records : list of dict
        Episode records (`score_episode`).

    Returns
    -------
    dict
        The overall figures, with ``act_ms``, ``signal``, ``per_pair`` and ``episodes_detail``
        (the records without their arrays but the start pose).
    """

    def agg(rs):
        ok = [r for r in rs if r["success"]]
        return {
            "episodes": len(rs),
            "successes": len(ok),
            "success_rate": len(ok) / len(rs),
            "success_ci95": list(wilson_interval(len(ok), len(rs))),
            "spl": float(np.mean([r["spl"] for r in rs])),
            "final_distance": float(np.median([r["final_distance"] for r in rs])),
            "final_heading_error_deg": float(np.median([r["final_heading_error_deg"] for r in rs])),
            "steps": float(np.mean([r["steps"] for r in ok])) if ok else None,
            "collisions": float(np.mean([r["collisions"] for r in rs])),
            "reasons": {
                k: sum(r["reason"] == k for r in rs) for k in sorted({str(r["reason"]) for r in rs})
            },
        }

    pairs = defaultdict(list)
    for r in records:
        pairs[f"{r['start_manifold']} -> {r['target_manifold']}"].append(r)
    out = agg(records)
    timed = [r["act_ms"] for r in records if np.isfinite(r["act_ms"])]
    out["act_ms"] = float(np.mean(timed)) if timed else None
    out["signal"] = signal_agreement(records)
    out["per_pair"] = {k: agg(v) for k, v in sorted(pairs.items())}
    out["episodes_detail"] = [
        {
            k: (v.tolist() if isinstance(v, np.ndarray) and k == "start_pose" else v)
            for k, v in r.items()
            if not isinstance(v, np.ndarray) or k == "start_pose"
        }
        for r in records
    ]
    return out


def plot_trajectories(world, records: list[dict], path: Path, limit: int = 24) -> Path:
    """Draw the trails over the top-down map of ``world`` and write it as a PNG.

    Green: succeeded, red: failed; targets as outlines.

    Parameters
    ----------
    world : scenes.World
        The world whose top-down map is drawn.
    records : list of dict
        Episode records (`score_episode`).
    path : Path
        The PNG file to write.
    limit : int, default 24
        The number of records drawn (the first ones).

    Returns
    -------
    Path
        The file written.
    """
    from sim.topdown import TopDownView

    view = TopDownView(world, max_size=720)
    img = view.draw()
    for r in records[:limit]:
        colour = (30, 150, 40) if r["success"] else (210, 30, 30)
        pts = np.round(view.to_pixels(r["trail"][:, :2])).astype(np.int32)
        cv2.polylines(img, [pts], False, colour, 2, cv2.LINE_AA)
        cv2.circle(img, tuple(int(v) for v in pts[0]), 4, (0, 0, 0), -1)
        view.draw_robot(img, r["target_pose"], colour, outline_only=True)
    return write_png(path, img)


def evaluate(
    world: str,
    episodes: int,
    seed: int,
    policy: str = "servo",
    *,
    randomize: bool = False,
    odometry_noise: bool = True,
    cross_manifold: bool = True,
    max_steps: int = 600,
    servo_map: ServoMap | None = None,
    home: str | Path | None = None,
    out: str | Path | None = None,
    videos: int = 0,
    progress: bool = True,
) -> dict:
    """Run ``episodes`` servo episodes in ``world`` and summarise them.

    The summary is [`summarise`][servo.task.evaluation.summarise]'s.

    ``policy``: one of [`POLICIES`][servo.task.evaluation.POLICIES] or an outside factory
    ``package.module:factory`` ([`make_policy`][servo.task.evaluation.make_policy]; one that cannot
    be made fails every episode with the reason). Episode ``i`` is seeded with the ``i``-th child of
    ``SeedSequence(seed)``, so a run is reproducible and a longer run extends a shorter one. With
    ``out``, writes ``<world>-<policy>-trajectories.png`` and ``videos`` H.264 MP4s of the first
    episodes (``common.video.write_mp4``: the camera view beside the top-down map). Without
    ``servo_map``, the world's map is loaded from (or built in) the data home ``home`` (see
    ``sim.datahome``: the argument, then ``TOPOMAP_HOME``, then the per-user cache).

    Parameters
    ----------
    world : str
        The world's name.
    episodes : int
        The number of episodes.
    seed : int
        The run's seed.
    policy : str, default "servo"
        A policy name or an outside factory ``package.module:factory``.
    randomize : bool, default False
        Lights and colours drawn anew each episode.
    odometry_noise : bool, default True
        Odometry with random-walk drift.
    cross_manifold : bool, default True
        Targets on another manifold than the start.
    max_steps : int, default 600
        Steps per episode.
    servo_map : ServoMap, optional
        The map; loaded or built when not given.
    home : str or Path, optional
        The data home the map is loaded from or built in.
    out : str or Path, optional
        The folder the plot and videos are written to.
    videos : int, default 0
        The number of first episodes written as videos (with ``out``).
    progress : bool, default True
        Show progress bars.

    Returns
    -------
    dict
        The summary, with the run's settings (and ``plot``, the plot's path, with ``out``).
    """
    from tqdm.auto import tqdm

    check_int(episodes, "episodes")
    check_policy_name(policy)
    world = check_world_name(world)
    servo_map = servo_map or load_or_build(world, home=home, progress=progress)
    env = ServoEnv(
        world,
        servo_map,
        max_steps=max_steps,
        cross_manifold=cross_manifold,
        randomize=randomize,
        odometry_noise=odometry_noise,
        render_mode="rgb_array" if videos else None,
    )
    seeds = episode_seeds(seed, episodes)
    pol, load_error = None, None
    try:
        pol = make_policy(policy, env, np.random.default_rng(seed))
    except PolicyLoadError as err:
        load_error = str(err)
    stem = f"{parse_world_name(world).file_stem}-{policy.replace(':', '.')}"
    records = []
    try:
        for i, s in enumerate(
            tqdm(seeds, desc=f"servo-eval {world}/{policy}", disable=not progress)
        ):
            frames = [] if out is not None and i < videos else None
            records.append(
                run_episode(
                    env, pol, s, frames=frames, truth=policy == TRUTH_POLICY, load_error=load_error
                )
            )
            if frames:
                write_mp4(Path(out) / f"{stem}-episode{i}.mp4", frames)
        result = summarise(records)
        if out is not None:
            result["plot"] = str(
                plot_trajectories(env.base.world, records, Path(out) / f"{stem}-trajectories.png")
            )
    finally:
        env.close()
        if hasattr(pol, "close"):
            pol.close()
    result.update(
        world=world, policy=policy, seed=seed, randomize=randomize, odometry_noise=odometry_noise
    )
    return result
