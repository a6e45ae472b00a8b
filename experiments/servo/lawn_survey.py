"""Dev measurement: would views recorded across the open lawn give ``SignalServo`` the global fix
it lacks from starts off the one recorded path per arm?

The lawn's diagnoses (docs/guides/servo.md) name a denser map as its remaining remedy. This script
records six survey drives (two lines each across the main lawn and the straight arm, up one side
of the left and right arms and down the other), adds them to a copy of the dataset, builds the
servo map from all nine recordings (the map aligns them by sensing only), and runs ``dev``
episodes on it exactly as ``experiments/servo/signal_servo.py`` does, with the targets and the
``view`` tier's starts kept on the three recorded routes (so the episodes are those of the
committed map).
Dev only, truth printed for diagnosis::

    python -m experiments.servo.lawn_survey collect OUT        # OUT/dataset: out/dataset's +
    surveys python -m experiments.servo.lawn_survey collect OUT --drives return   # or the routes
    driven back python -m experiments.servo.lawn_survey links OUT          # OUT/maps: links between
    recordings python -m experiments.servo.lawn_survey oracle OUT         # OUT/maps-oracle: true
    links only python -m experiments.servo.lawn_survey episodes OUT anywhere 60:90 [--oracle]

``links`` prints, per pair of recordings, the map's sensed links and their error against the
true relative poses. ``oracle`` is an upper bound, not a map the controller could build: it
keeps the links within 1 m / 0.1 rad of the truth and joins the straight arm's surveys to the
straight route by true relative poses (the map joins them to nothing right).
"""

from __future__ import annotations

import argparse
import dataclasses
from pathlib import Path

import numpy as np

import sim  # noqa: F401  (the GL backend before mujoco)
from common.fileio import write_json
from common.geometry import se2_relative, wrap_angle
from scenes.regions import Route
from servo.maps.build import load_or_build, save_map
from servo.task import env as servo_env
from sim import collect, dataset

# Waypoints (m, world frame) through the lawn's free space, clear of its trees and fences.
SURVEY = {
    "lawn-survey-n": [(1.2, 2.3), (14.6, 2.3), (14.6, 5.0), (1.2, 5.0)],
    "lawn-survey-s": [(1.2, -2.3), (14.6, -2.3), (14.6, -5.0), (1.2, -5.0)],
    "lawn-survey-sn": [(23.0, 2.2), (38.0, 2.2), (38.0, 4.8), (23.0, 4.8)],
    "lawn-survey-ss": [(23.0, -2.2), (38.0, -2.2), (38.0, -4.8), (23.0, -4.8)],
    "lawn-survey-l": [(17.2, 7.0), (17.2, 22.0), (20.8, 22.0), (20.8, 7.0)],
    "lawn-survey-r": [(17.2, -7.0), (17.2, -18.5), (20.8, -18.5), (20.8, -7.0)],
}
FRAMES = 120  # ~0.25 m apart on a 30 m drive; stride 2 keeps 60 views per survey
SEED_INDEX = 100  # survey k is seeded by (dataset seed, SEED_INDEX + k), apart from the routes'
# ``--drives return``: each route driven back, arm -> main, as many frames as the
# routes have (every recording drives main -> arm, so a route out of an arm faces no view)
RETURNS = {
    "lawn-survey-back-left": "lawn-left",
    "lawn-survey-back-straight": "lawn-straight",
    "lawn-survey-back-right": "lawn-right",
}


def collect_surveys(out: Path, source: Path, drives: str = "survey") -> Path:
    """``out/dataset``: the source dataset's sequences (linked, not copied) and the extra
    drives: the surveys across the lawn, or (``drives="return"``) the routes driven back."""
    target = out / "dataset"
    target.mkdir(parents=True, exist_ok=True)
    meta = dataset.read_meta(source)
    for entry in meta["sequences"].values():
        link = target / entry["file"]
        if not link.exists():
            link.symlink_to((source / entry["file"]).resolve())
    frames = FRAMES if drives == "survey" else int(meta["settings"]["frames"])
    settings = collect.CollectionSettings(frames=frames)
    world = collect.collection_world("lawn", settings.seed, False, "default")
    extra = (
        SURVEY
        if drives == "survey"
        else {name: world.routes[route].waypoints[::-1] for name, route in RETURNS.items()}
    )
    for k, (name, waypoints) in enumerate(extra.items()):
        world.routes[name] = Route(name, np.asarray(waypoints, float), "survey")
        arrays = collect.collect_sequence(settings, SEED_INDEX + k, "lawn", name)
        digest = dataset.write_sequence(target / f"{name}.npz", arrays)
        meta["sequences"][name] = {
            "file": f"{name}.npz",
            "world": "lawn",
            "frames": frames,
            "sha256": digest,
        }
        print(f"recorded {name}", flush=True)
    write_json(target / dataset.META_FILE, meta)
    return target


def link_errors(m) -> None:
    """Per pair of recordings: the map's links and their error against the truth."""
    rows: dict[tuple[str, str], list] = {}
    for (a, b), t in zip(m.edges, m.edge_transforms, strict=True):
        if m.sequence[a] == m.sequence[b]:
            continue
        true = se2_relative(m.true_poses[a], m.true_poses[b])
        key = (m.sequence_names[m.sequence[a]], m.sequence_names[m.sequence[b]])
        rows.setdefault(key, []).append(
            (np.hypot(*(t[:2] - true[:2])), abs(wrap_angle(t[2] - true[2])))
        )
    print("| recordings | links | median error (m) | largest (m) | median yaw error (rad) |")
    print("|---|---|---|---|---|")
    for (a, b), e in rows.items():
        e = np.array(e)
        print(
            f"| {a} - {b} | {len(e)} | {np.median(e[:, 0]):.2f} | {e[:, 0].max():.2f} "
            f"| {np.median(e[:, 1]):.3f} |"
        )


def oracle_map(m):
    """The map with only the links the truth confirms, and the straight arm's surveys (or
    the routes' return drives) joined to their route by true relative poses (an upper bound
    on what linking could do)."""
    edges, transforms = [], []
    for (a, b), t in zip(m.edges, m.edge_transforms, strict=True):
        true = se2_relative(m.true_poses[a], m.true_poses[b])
        if m.sequence[a] == m.sequence[b] or (
            np.hypot(*(t[:2] - true[:2])) < 1.0 and abs(wrap_angle(t[2] - true[2])) < 0.1
        ):
            edges.append((int(a), int(b)))
            transforms.append(t)
    # joined by truth: the straight arm's surveys, or each route's return drive
    joined = {"lawn-survey-sn": "lawn-straight", "lawn-survey-ss": "lawn-straight", **RETURNS}
    for name, route_name in joined.items():
        if name not in m.sequence_names:
            continue
        route = np.flatnonzero(m.sequence == m.sequence_names.index(route_name))
        for i in np.flatnonzero(m.sequence == m.sequence_names.index(name))[::2]:
            d = np.hypot(*(m.true_poses[route, :2] - m.true_poses[i, :2]).T)
            if d.min() < 4.0:
                j = int(route[np.argmin(d)])
                edges.append((j, int(i)))
                transforms.append(se2_relative(m.true_poses[j], m.true_poses[i]))
    return dataclasses.replace(
        m, edges=np.array(edges, np.int64), edge_transforms=np.array(transforms, np.float64)
    )


def keep_tasks_on_routes() -> None:
    """Targets and ``view``-tier starts on the recorded routes' views only, as on the map
    without surveys (the surveys come last, so the routes' views keep their indices)."""
    views_on, candidates = servo_env.ServoEnv._views_on, servo_env.ServoEnv._candidates

    def on_route(env) -> np.ndarray:
        survey = np.array(["survey" in n for n in env.map.sequence_names])
        return ~survey[env.map.sequence]

    def _views_on(self, manifold):
        views = views_on(self, manifold)
        return views[on_route(self)[views]]

    def _candidates(self, ok, options, what):
        return candidates(self, ok & on_route(self), options, what)

    servo_env.ServoEnv._views_on = _views_on
    servo_env.ServoEnv._candidates = _candidates


def main(argv=None) -> None:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("command", choices=["collect", "links", "oracle", "episodes"])
    p.add_argument("out", type=Path)
    p.add_argument("tier", nargs="?", default="anywhere")
    p.add_argument("episodes", nargs="?", default="60:90", help="LO:HI of the dev split")
    p.add_argument("--oracle", action="store_true", help="episodes on OUT/maps-oracle")
    p.add_argument("--config", default="{}", help="SignalServoConfig fields as JSON")
    p.add_argument("--data", type=Path, default=Path("out/dataset"), help="the routes' dataset")
    p.add_argument(
        "--drives",
        choices=["survey", "return"],
        default="survey",
        help="collect: the surveys across the lawn, or the routes driven back",
    )
    a = p.parse_args(argv)
    data, maps = a.out / "dataset", a.out / "maps"
    if a.command == "collect":
        collect_surveys(a.out, a.data, a.drives)
        return
    m = load_or_build("lawn", dataset=data, cache=maps)
    if a.command == "links":
        link_errors(m)
    elif a.command == "oracle":
        save_map(oracle_map(m), a.out / "maps-oracle")
    else:
        import signal_servo_dev

        keep_tasks_on_routes()
        maps = a.out / "maps-oracle" if a.oracle else maps
        signal_servo_dev.main(
            [
                "lawn",
                a.tier,
                a.episodes,
                "--config",
                a.config,
                "--data",
                str(data),
                "--maps",
                str(maps),
            ]
        )


if __name__ == "__main__":
    main()
