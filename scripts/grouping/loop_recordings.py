"""A longer drive through a world for the grouping evaluation.

The main manifold, then every branch in turn, coming back to the junction between branches
(main -> left -> back -> straight -> back -> right).

The loop is driven by the dataset's own machinery (``sim.collect.collect_sequence`` with the
scripted teleop) on a route built from the world's three branch routes, so the driver, sensors
and odometry noise are those of the default dataset. It is cached as one ``.npz`` (the
dataset's format) next to a small JSON of the settings that made it, and never written into a
dataset directory.
"""

from __future__ import annotations

from dataclasses import replace
from pathlib import Path

import numpy as np

from common.fileio import UnreadableJSON, read_json, write_json
from scenes import names
from scenes.families import parse_world_name
from scenes.regions import Route
from sim import dataset as ds
from sim.collect import CollectionSettings, collect_sequence, collection_world

__all__ = ["LOOP_INDEX", "collect_loop", "has_loop", "loop_frames", "loop_route"]

# Seeds sequences after the default dataset's (world * branches + branch < 100), so the loop
# never reuses the random streams of a default sequence.
LOOP_INDEX = 100
# Lateral offset of a U-turn at a branch's end: the route goes up one side and comes back on
# the other, so pure pursuit turns along an arc instead of facing a target straight behind.
U_TURN_OFFSET = 0.35  # m; fits the narrowest corridor (2.4 m) with the robot's radius


def has_loop(world: str) -> bool:
    """Check whether ``world`` has a loop.

    A canonical world does (one junction whose three branch routes `loop_route` joins); a
    generated world's tree of junctions has none yet, and a name that is no world has none.

    Parameters
    ----------
    world : str
        A world's name.

    Returns
    -------
    bool
        Whether it has a loop.
    """
    try:
        return parse_world_name(world).canonical
    except (TypeError, ValueError):
        return False


def loop_name(world: str) -> str:
    """Name the loop of ``world``.

    Parameters
    ----------
    world : str
        A world's name.

    Returns
    -------
    str
        ``"<world>-loop"``.
    """
    return f"{world}-loop"


def loop_route(world) -> Route:
    """Build the loop of ``world`` from its three branch routes.

    Every branch route starts at the same point on the main manifold and ends at the far end
    of its branch; the junction is where the straight route passes the left branch's axis.

    Parameters
    ----------
    world : scenes.World
        The world.

    Returns
    -------
    Route
        The loop, named by ``loop_name``.
    """
    routes = [world.routes[names.manifold_name(world.name, b)] for b in names.BRANCHES]
    start = routes[0].waypoints[0]
    ends = [r.waypoints[-1] for r in routes]
    junction = np.array([ends[0][0], start[1]])  # left branch axis meets the main axis
    points = [start, junction]
    for k, end in enumerate(ends):
        direction = (end - junction) / np.linalg.norm(end - junction)
        normal = np.array([-direction[1], direction[0]])
        if k == len(ends) - 1:  # the last branch is driven to its end
            points.append(end)
            break
        points += [end + U_TURN_OFFSET * normal, end - U_TURN_OFFSET * normal, junction]
    return Route(loop_name(world.name), np.asarray(points, float), "loop")


def loop_frames(world, route: Route, frames_per_route: int) -> int:
    """Count the frames for the loop at the default dataset's spacing.

    The spacing is ``frames_per_route`` frames over the length of the world's straight route.

    Parameters
    ----------
    world : scenes.World
        The world.
    route : Route
        The loop (``loop_route``).
    frames_per_route : int
        Frames of each default sequence.

    Returns
    -------
    int
        Frames of the loop, at least 2.
    """
    straight = world.routes[names.manifold_name(world.name, "straight")]
    return max(2, round(frames_per_route * route.length / straight.length))


def collect_loop(
    world_name: str,
    cache_dir: str | Path,
    *,
    frames: int | None = None,
    settings: CollectionSettings | None = None,
    tick=None,
) -> ds.Sequence:
    """Drive (or load from ``cache_dir``) the loop through ``world_name``.

    Parameters
    ----------
    world_name : str
        A canonical world.
    cache_dir : str or Path
        The folder of the cached loops, created if missing.
    frames : int, optional
        Frames along the loop; by default the default dataset's spacing (``loop_frames``).
    settings : CollectionSettings, optional
        Sensors, noise, driver and seed (default: the default dataset's). The loop of seed ``s``
        is deterministic; it is re-collected when the settings or frames differ from the cache.
    tick : callable, optional
        Called with 1 after each frame (a progress bar's ``update``).

    Returns
    -------
    Sequence
        The loop's sequence (``sim.dataset``).
    """
    if not isinstance(world_name, str) or not has_loop(world_name):
        raise ValueError(f"world_name must be a canonical world {names.WORLDS}, got {world_name!r}")
    settings = settings or CollectionSettings(worlds=(world_name,))
    world = collection_world(world_name, settings.seed, settings.randomize, settings.appearance)
    route = loop_route(world)
    frames = loop_frames(world, route, settings.frames) if frames is None else frames
    settings = replace(settings, frames=frames)  # validates frames
    cache_dir = Path(cache_dir)
    cache_dir.mkdir(parents=True, exist_ok=True)
    name = route.name
    meta_path = cache_dir / f"{name}.json"
    key = {"settings": settings.to_json(), "waypoints": route.waypoints.tolist()}
    if meta_path.is_file():
        try:  # a cache: anything unreadable or foreign in it is collected again
            meta = read_json(meta_path)
            if isinstance(meta, dict) and meta.get("key") == key:
                ds.check_entry(meta_path, name, meta.get("entry"))
                return ds.load_sequence(cache_dir, name, meta["entry"])
        except (UnreadableJSON, ds.DatasetError):
            pass
    # collect_sequence looks routes up in the (cached) world by name; the loop is one more
    # route of that world, added under a name no default sequence uses.
    world.routes[name] = route
    index = LOOP_INDEX + names.WORLDS.index(world_name)
    arrays = collect_sequence(settings, index, world_name, name, tick)
    entry = {"file": f"{name}.npz", "world": world_name, "frames": frames}
    entry["sha256"] = ds.write_sequence(cache_dir / entry["file"], arrays)
    write_json(meta_path, {"key": key, "entry": entry})
    return ds.load_sequence(cache_dir, name, entry)
