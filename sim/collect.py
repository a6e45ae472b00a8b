"""Scripted-teleop data collection, written as a resumable dataset (see `sim.dataset`).

The paper's 6 sequences (3 per world: main manifold, then left / straight / right); a
generated world (``FAMILY:SEED``) records one sequence per route (`sim.collect_worlds`).

Frames are taken at equal steps of progress along the route, so every sequence covers its
whole route with the requested number of frames whatever the driver's speed jitter; the
recorded ``times`` show the resulting uneven timing.
"""

from __future__ import annotations

import multiprocessing as mp
import os
import shutil
import warnings
from concurrent.futures import ProcessPoolExecutor
from dataclasses import asdict, dataclass, field
from functools import lru_cache
from pathlib import Path

import numpy as np

from common.cores import spawn_problem
from common.fileio import write_json
from scenes import World, build_world, names
from scenes.appearance import check_appearance_mode
from sim import dataset as ds
from sim.camera import CameraConfig
from sim.collect_worlds import (
    check_worlds,
    label_lookup,
    label_space,
    randomisation_key,
    sequence_entropy,
    sequence_file,
    world_sequences,
)
from sim.laser import LaserConfig
from sim.odometry import OdometryConfig
from sim.simulator import Simulator
from sim.teleop import ScriptedTeleop, TeleopConfig

DEFAULT_FRAMES = 150  # per sequence, as the paper
TELEOP_CONTROL_DT = 0.05  # s: fine enough that frames land within ~3 cm of their progress mark
END_MARGIN = 0.3  # m: the last frame is taken this short of the route's end
# A sequence is held in memory whole until it is written, once per worker process. The paper's
# 150 frames of 320x240 take 35 MB; these bounds refuse settings that would exhaust memory or
# run for days before anything is written (10^9 frames once failed after meta.json was written).
MAX_FRAMES = 100_000  # per sequence: past ~10^3 frames they repeat poses; ~15 min at 120/s
MAX_SEQUENCE_BYTES = 4 * 2**30  # the arrays of one sequence (images, depth, scans, poses, ...)


@dataclass(frozen=True)
class CollectionSettings:
    """Everything that determines a dataset's bytes (stored in its ``meta.json``).

    Parameters
    ----------
    worlds : tuple of str, default ("hallway", "lawn")
        The worlds to record, each named once: a canonical world (three teleop routes, one
        per branch) or a generated one, ``FAMILY:SEED`` (one route per leaf manifold);
        ``"hallway:0"`` is stored as ``"hallway"``.
    frames : int, default 150
        Frames per recording (the paper's count); at least 2.
    seed : int, default 0
        Seed of the teleop's jitter, the odometry's drift and the sensors' noise.
    randomize : bool, default False
        Draw the lights and colours from the world's randomisation table.
    appearance : {"default", "hard"}, default "default"
        ``"hard"`` worlds give every branch the main manifold's materials
        ([`scenes.build_world`][scenes.registry.build_world]).
    camera : CameraConfig, optional
        The camera; default ``CameraConfig()``.
    laser : LaserConfig, optional
        The laser; default ``LaserConfig()``.
    odometry : OdometryConfig, optional
        The odometry's drift; default ``OdometryConfig()``.
    teleop : TeleopConfig, optional
        The scripted driver; default ``TeleopConfig()``.

    Attributes
    ----------
    worlds, frames, seed, randomize, appearance, camera, laser, odometry, teleop
        The parameters (the object is frozen).

    Examples
    --------
    >>> from sim.collect import CollectionSettings
    >>> settings = CollectionSettings(worlds=("lawn",), frames=40, seed=3)
    >>> settings.to_json()["worlds"], settings.to_json()["frames"]
    (['lawn'], 40)
    >>> CollectionSettings(frames=1)
    Traceback (most recent call last):
        ...
    ValueError: frames must be an integer >= 2, got 1

    See Also
    --------
    sim.collect.collect_dataset : Records a dataset with these settings.
    sim.dataset.load_dataset : Reads it back.
    """

    worlds: tuple[str, ...] = names.WORLDS
    frames: int = DEFAULT_FRAMES
    seed: int = 0
    randomize: bool = False
    appearance: str = "default"
    camera: CameraConfig = field(default_factory=CameraConfig)
    laser: LaserConfig = field(default_factory=LaserConfig)
    odometry: OdometryConfig = field(default_factory=OdometryConfig)
    teleop: TeleopConfig = field(default_factory=TeleopConfig)

    def __post_init__(self):
        """Check the settings; ``ValueError`` names the first that is invalid."""
        object.__setattr__(self, "worlds", check_worlds(self.worlds))
        if int(self.frames) != self.frames or self.frames < 2:
            raise ValueError(f"frames must be an integer >= 2, got {self.frames}")
        check_sequence_size(self.frames, self.camera, self.laser)
        if int(self.seed) != self.seed or self.seed < 0:
            raise ValueError(f"seed must be an integer >= 0, got {self.seed}")
        check_appearance_mode(self.appearance)

    def to_json(self) -> dict:
        """Return the settings as ``meta.json`` stores them.

        ``appearance`` is written only when it is not ``"default"``: datasets made before the
        option existed are default ones, and so keep their bytes, stay resumable and compare
        equal (a missing key means default).

        Returns
        -------
        dict
            The settings as JSON values.
        """
        d = asdict(self)
        d["worlds"] = list(self.worlds)
        d["teleop"]["start_jitter"] = list(self.teleop.start_jitter)
        if self.appearance == "default":
            del d["appearance"]
        return d

    def sequences(self) -> list[tuple[int, str, str]]:
        """List the sequences to record as (stable index, world, route name).

        The index seeds the sequence, so collecting one world gives the same sequences as
        collecting all (see `sim.collect_worlds.world_sequences`).

        Returns
        -------
        list of tuple of (int, str, str)
            One entry per sequence, in the dataset's order.
        """
        return [s for w in self.worlds for s in world_sequences(w)]

    def manifolds(self) -> list[str]:
        """Return the dataset's manifold names, which its labels index.

        See `sim.collect_worlds.label_space`.

        Returns
        -------
        list of str
            The names; label ``i`` is the ``i``-th.
        """
        return label_space(self.worlds)


def frame_bytes(camera: CameraConfig, laser: LaserConfig) -> int:
    """Count the bytes one frame adds to a sequence's arrays.

    See [`collect_sequence`][sim.collect.collect_sequence]: the RGB image, the depth image when
    recorded, the scan, and pose, odometry, command, label, time.

    Parameters
    ----------
    camera : CameraConfig
        The camera (its size and whether it records depth).
    laser : LaserConfig
        The laser (its beam count).

    Returns
    -------
    int
        Bytes per frame.
    """
    pixels = camera.height * camera.width
    return pixels * 3 + pixels * 4 * bool(camera.depth) + laser.beams * 4 + 3 * 3 * 8 + 2 + 8


def check_sequence_size(frames: int, camera: CameraConfig, laser: LaserConfig) -> None:
    """Refuse ``frames`` per sequence above `MAX_FRAMES`, or whose arrays are too big.

    Too big: more than `MAX_SEQUENCE_BYTES` of memory with these camera and laser settings.
    Either raises ``ValueError``.

    Parameters
    ----------
    frames : int
        Frames per sequence.
    camera : CameraConfig
        The camera.
    laser : LaserConfig
        The laser.
    """
    if frames > MAX_FRAMES:
        raise ValueError(f"frames must be an integer in [2, {MAX_FRAMES}], got {frames}")
    size = frames * frame_bytes(camera, laser) + laser.beams * 4
    if size > MAX_SEQUENCE_BYTES:
        most = (MAX_SEQUENCE_BYTES - laser.beams * 4) // frame_bytes(camera, laser)
        depth = " and depth" * bool(camera.depth)
        raise ValueError(
            f"frames must be at most {most} for {camera.width}x{camera.height} images{depth} "
            f"and {laser.beams} beams (a sequence is held in memory whole: {size / 2**30:.1f} "
            f"GiB, over the {MAX_SEQUENCE_BYTES / 2**30:.0f} GiB limit), got {frames}"
        )


@lru_cache(maxsize=4)
def collection_world(name: str, seed: int, randomize: bool, appearance: str = "default") -> World:
    """Build the world a collection of ``seed`` drives in, once per process.

    The world is canonical, or (``randomize``) the randomised draw of that seed and world, in
    the ``appearance`` mode.

    Parameters
    ----------
    name : str
        The world's name.
    seed : int
        The collection's seed.
    randomize : bool
        Draw the lights and colours from the world's randomisation table.
    appearance : str, default "default"
        The appearance mode.

    Returns
    -------
    scenes.World
        The world.
    """
    rng = np.random.default_rng(randomisation_key(name, seed)) if randomize else None
    return build_world(name, rng, appearance)


def collect_sequence(
    settings: CollectionSettings, index, world_name: str, route_name: str, tick=None
) -> dict[str, np.ndarray]:
    """Drive one route and record ``settings.frames`` frames; return the sequence's arrays.

    Parameters
    ----------
    settings : CollectionSettings
        The collection's settings.
    index : int
        The sequence's seeding index
        ([`CollectionSettings.sequences`][sim.collect.CollectionSettings.sequences]).
    world_name : str
        The world to drive in.
    route_name : str
        The route of that world to drive.
    tick : callable, optional
        Called with 1 after each frame recorded (progress).

    Returns
    -------
    dict of str to ndarray
        The arrays of the dataset format (`sim.dataset`).
    """
    world = collection_world(world_name, settings.seed, settings.randomize, settings.appearance)
    entropy = sequence_entropy(settings.seed, index)
    teleop_rng, noise_rng, odo_rng = np.random.default_rng(entropy).spawn(3)
    labels = label_lookup(settings.worlds, world.manifold_ids, world_name)
    sim = Simulator(world, settings.camera, settings.laser, settings.odometry, TELEOP_CONTROL_DT)
    try:
        teleop = ScriptedTeleop(world, world.routes[route_name], settings.teleop, teleop_rng)
        sim.reset(teleop.start_pose(), odo_rng)
        n = settings.frames
        marks = np.linspace(0.0, teleop.route.length - END_MARGIN, n)
        cam, las = settings.camera, settings.laser
        out = {
            "images": np.zeros((n, cam.height, cam.width, 3), np.uint8),
            "scans": np.zeros((n, las.beams), np.float32),
            "angles": las.angles.astype(np.float32),
            "poses": np.zeros((n, 3)),
            "odometry": np.zeros((n, 3)),
            "commands": np.zeros((n, 2)),
            "labels": np.zeros(n, np.int16),
            "times": np.zeros(n),
        }
        if cam.depth:
            out["depth"] = np.zeros((n, cam.height, cam.width), np.float32)
        budget = int(8 * teleop.route.length / (settings.teleop.speed * sim.control_dt)) + 200
        k = 0
        for _ in range(budget):
            command = teleop.command(sim.pose, sim.control_dt)
            while k < n and teleop.progress >= marks[k]:
                out["images"][k] = sim.render()
                if cam.depth:
                    out["depth"][k] = sim.camera.render_depth(sim.data)
                out["scans"][k] = sim.scan(noise_rng)
                out["poses"][k] = sim.pose
                out["odometry"][k] = sim.odometry.pose
                out["commands"][k] = command
                out["labels"][k] = labels[world.manifold_at(sim.pose[:2])]
                out["times"][k] = sim.time
                k += 1
                if tick is not None:
                    tick(1)
            if k == n:
                return out
            sim.step(*command)
        raise ValueError(_stall_message(route_name, teleop, budget, settings.teleop))
    finally:
        sim.close()


def _stall_message(route_name: str, teleop: ScriptedTeleop, steps: int, config) -> str:
    """Say why a sequence could not be collected: the driver stalled short of the route's end.

    Its jitter makes that likelier (``TeleopConfig.scaled``).
    """
    return (
        f"teleop on {route_name} stalled at {teleop.progress:.1f} m of "
        f"{teleop.route.length:.1f} m after {steps} steps; the teleop jitter (speed "
        f"{config.speed_jitter:g}, turn {config.turn_jitter:g}, wander "
        f"{config.lateral_wander:g}) may be too large for this route: collect with a smaller "
        "--teleop-jitter or another seed"
    )


# -- parallel collection ---------------------------------------------------------------------
_QUEUE = None


def _init_worker(queue) -> None:
    global _QUEUE
    _QUEUE = queue


def _collect_to_file(
    settings: CollectionSettings, index: int, world: str, route: str, directory: str
) -> tuple[str, dict]:
    ticks = [0]

    def tick(k):
        ticks[0] += k
        if _QUEUE is not None and ticks[0] % 10 == 0:
            _QUEUE.put(10)

    arrays = collect_sequence(settings, index, world, route, tick)
    if _QUEUE is not None:
        _QUEUE.put(ticks[0] % 10)
    file = sequence_file(route)
    digest = ds.write_sequence(Path(directory) / file, arrays)
    return route, {"file": file, "world": world, "frames": settings.frames, "sha256": digest}


def _base_meta(settings: CollectionSettings) -> dict:
    return {
        "format": ds.FORMAT_NAME,
        "schema_version": ds.SCHEMA_VERSION,
        "ground_truth": True,
        "settings": settings.to_json(),
        "manifolds": settings.manifolds(),
        "sequences": {},
        "complete": False,
    }


def collect_dataset(
    directory: str | os.PathLike,
    settings: CollectionSettings | None = None,
    overwrite: bool = False,
    jobs: int | None = None,
    progress: bool = True,
) -> Path:
    """Collect (or resume) a dataset in ``directory``.

    An existing dataset with the same settings is resumed (finished sequences are kept, as
    their bytes would be the same); one with other settings is refused unless ``overwrite``.

    Parameters
    ----------
    directory : path-like
        The dataset's folder; created if missing.
    settings : CollectionSettings, optional
        What to record; default ``CollectionSettings()``.
    overwrite : bool, default False
        Replace a dataset of other settings (or an unreadable one) there.
    jobs : int, optional
        Worker processes; default the machine's cores, at most one per sequence left.
    progress : bool, default True
        Show a progress bar.

    Returns
    -------
    Path
        ``directory``.
    """
    from tqdm.auto import tqdm

    settings = settings or CollectionSettings()
    directory = Path(directory)
    if directory.exists() and not directory.is_dir():
        raise FileExistsError(f"{directory} is a file; give a folder for the dataset")
    directory.mkdir(parents=True, exist_ok=True)
    meta = _base_meta(settings)
    if (directory / ds.META_FILE).exists():
        old = _old_meta(directory, overwrite)
        if old is not None and old.get("settings") == meta["settings"] and not overwrite:
            meta["sequences"] = {
                k: v
                for k, v in old["sequences"].items()
                if (directory / v["file"]).is_file()
                and ds.file_sha256(directory / v["file"]) == v["sha256"]
            }
        elif not overwrite:
            raise FileExistsError(
                f"{directory} already holds a dataset collected with other settings; pass "
                "overwrite=True (--overwrite) to replace it, or choose another directory"
            )
        else:
            _remove_dataset(directory, old)
    todo = [s for s in settings.sequences() if s[2] not in meta["sequences"]]
    write_json(directory / ds.META_FILE, meta)
    bar = tqdm(
        total=len(todo) * settings.frames,
        unit="frame",
        desc=f"collect {directory.name}",
        disable=not progress,
    )
    jobs = max(1, min(jobs or os.cpu_count() or 1, len(todo) or 1))
    problem = spawn_problem() if jobs > 1 else None
    if problem:
        warnings.warn(f"collecting in this process, not in {jobs} workers: {problem}", stacklevel=2)
        jobs = 1
    try:
        if jobs == 1:
            for index, world, route in todo:
                name, entry = _collect_to_file_inline(settings, index, world, route, directory, bar)
                meta["sequences"][name] = entry
                write_json(directory / ds.META_FILE, meta)
        else:
            ctx = mp.get_context("spawn")  # never fork a process that may hold a GL context
            queue = ctx.Queue()
            with ProcessPoolExecutor(
                jobs, mp_context=ctx, initializer=_init_worker, initargs=(queue,)
            ) as pool:
                futures = [
                    pool.submit(_collect_to_file, settings, i, w, r, str(directory))
                    for i, w, r in todo
                ]
                pending = set(futures)
                while pending:
                    for f in [f for f in pending if f.done()]:
                        pending.discard(f)
                        name, entry = f.result()
                        meta["sequences"][name] = entry
                        write_json(directory / ds.META_FILE, meta)
                    _drain(queue, bar, timeout=0.2)
                _drain(queue, bar, timeout=0.0)
    finally:
        bar.close()
    # Sequences in the canonical order, whatever order the workers finished in.
    meta["sequences"] = {r: meta["sequences"][r] for _, _, r in settings.sequences()}
    meta["complete"] = True
    write_json(directory / ds.META_FILE, meta)
    return directory


def _old_meta(directory: Path, overwrite: bool) -> dict | None:
    """Read the dataset metadata already in ``directory``.

    None where it cannot be read and ``overwrite`` replaces it, else FileExistsError saying
    why it cannot be read.
    """
    try:
        return ds.read_meta(directory)
    except ds.DatasetError as err:
        if overwrite:
            return None
        raise FileExistsError(
            f"{directory} holds a {ds.META_FILE} that cannot be read ({err}); pass "
            "overwrite=True (--overwrite) to replace it, or choose another directory"
        ) from err


def _collect_to_file_inline(settings, index, world, route, directory, bar):
    arrays = collect_sequence(settings, index, world, route, bar.update)
    file = sequence_file(route)
    digest = ds.write_sequence(directory / file, arrays)
    return route, {"file": file, "world": world, "frames": settings.frames, "sha256": digest}


def _drain(queue, bar, timeout: float) -> None:
    import queue as queue_mod

    try:
        while True:
            bar.update(queue.get(timeout=timeout) if timeout else queue.get_nowait())
    except queue_mod.Empty:
        pass


def _remove_dataset(directory: Path, meta: dict | None) -> None:
    files = [v["file"] for v in (meta or {}).get("sequences", {}).values()]
    for f in files + [ds.META_FILE]:
        (directory / f).unlink(missing_ok=True)
    for leftover in directory.glob(".*.tmp"):
        leftover.unlink() if leftover.is_file() else shutil.rmtree(leftover)
