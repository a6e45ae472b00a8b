"""The loaded dataset, as [`sim.dataset.load_dataset`][sim.dataset.loading.load_dataset] returns it.

[`Sequence`][sim.dataset.model.Sequence] holds one drive's arrays and
[`Dataset`][sim.dataset.model.Dataset] the ``meta.json`` and the sequences.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from sim.dataset.schema import GROUND_TRUTH, SENSORS, DatasetError, MissingSensorError
from sim.runs import Runs


@dataclass
class Sequence:
    """One recorded sequence (one drive) of a dataset, its arrays indexed by frame.

    The arrays and their units are those of the dataset format (the module's description).

    Parameters
    ----------
    name, world : str
        The sequence's name (e.g. ``"lawn-left"``) and the world (place) it was recorded in.
    images, scans, angles, odometry, commands, times : ndarray
        The arrays of the dataset format, in its units (the module's description); ``images``
        is None in a dataset without a camera, ``scans`` and ``angles`` without a laser.
    poses, labels : ndarray or None, default None
        The true poses and manifold ids; None without ground truth.
    depth : ndarray or None, default None
        Metric depth, when collected with depth.

    Attributes
    ----------
    name, world, images, scans, angles, odometry, commands, times, poses, labels, depth
        The parameters.

    Examples
    --------
    >>> import sim  # headless rendering, chosen before anything imports mujoco
    >>> from sim.collect import CollectionSettings, collect_dataset
    >>> from sim.dataset import load_dataset
    >>> data = collect_dataset("lawn-40", CollectionSettings(worlds=("lawn",), frames=40),
    ...                        jobs=1, progress=False)  # three drives of 40 frames, ~10 s
    >>> ds = load_dataset(data)
    >>> sequence = ds.sequences["lawn-left"]
    >>> len(sequence), sequence.images.shape, sequence.scans.shape
    (40, (40, 240, 320, 3), (40, 361))

    See Also
    --------
    sim.dataset.Dataset : The sequences of a dataset.
    """

    name: str
    world: str
    images: np.ndarray | None  # None without a camera
    scans: np.ndarray | None  # None without a laser
    angles: np.ndarray | None
    odometry: np.ndarray
    commands: np.ndarray
    times: np.ndarray
    poses: np.ndarray | None = None  # None without ground truth
    labels: np.ndarray | None = None  # None without ground truth
    depth: np.ndarray | None = None

    def __len__(self) -> int:
        """Return the number of frames."""
        return len(self.times)


@dataclass
class Dataset:
    """A loaded dataset: its ``meta.json`` and its sequences by name.

    Made by [`load_dataset`][sim.dataset.loading.load_dataset], which verifies every file's
    checksum.

    Parameters
    ----------
    path : Path
        The dataset's directory.
    meta : dict
        The parsed ``meta.json``.
    sequences : dict of str to Sequence
        The sequences, in ``meta`` order.

    Attributes
    ----------
    path, meta, sequences
        The parameters.
    manifolds : list of str
        The manifolds' names (label ``i`` is ``manifolds[i]``).
    has_ground_truth : bool
        True poses and manifold labels are recorded (simulated data, not imported logs).
    has_camera : bool
        Camera images are recorded (false for a laser-only import).
    has_laser : bool
        Laser scans are recorded (false for a camera-only import).
    max_range : float or None
        The laser's range from the settings, m.
    worlds : list of str
        The worlds of the sequences, in order of first appearance.

    Examples
    --------
    >>> import sim  # headless rendering, chosen before anything imports mujoco
    >>> from sim.collect import CollectionSettings, collect_dataset
    >>> from sim.dataset import load_dataset
    >>> data = collect_dataset("lawn-40", CollectionSettings(worlds=("lawn",), frames=40),
    ...                        jobs=1, progress=False)  # three drives of 40 frames, ~10 s
    >>> ds = load_dataset(data)
    >>> list(ds.sequences), ds.worlds
    (['lawn-left', 'lawn-straight', 'lawn-right'], ['lawn'])
    >>> train, test = ds.paper_split()
    >>> ds.concat("images")[train].shape, int(test.sum())
    ((60, 240, 320, 3), 60)

    See Also
    --------
    sim.dataset.load_dataset : Reads and verifies a dataset.
    sim.collect.collect_dataset : Records one.
    sim.readers.import_rosbags : Imports a robot's ROS bags as one.
    """

    path: Path
    meta: dict
    sequences: dict[str, Sequence]

    @property
    def manifolds(self) -> list[str]:
        """The manifolds' names: label ``i`` is ``manifolds[i]``."""
        return list(self.meta["manifolds"])

    @property
    def has_ground_truth(self) -> bool:
        """True poses and manifold labels are recorded (simulated data; not imported logs)."""
        return bool(self.meta.get("ground_truth", True))

    @property
    def has_camera(self) -> bool:
        """Camera images are recorded (false for a dataset imported without a camera)."""
        return bool(self.meta.get("camera", True))

    @property
    def has_laser(self) -> bool:
        """Laser scans are recorded (false for a dataset imported without a laser)."""
        return bool(self.meta.get("laser", True))

    def require(self, sensor: str, needed_by: str) -> None:
        """Raise an error unless ``sensor`` was recorded.

        The error is a [`MissingSensorError`][sim.dataset.schema.MissingSensorError] naming this
        dataset, ``sensor`` and ``needed_by``.

        Parameters
        ----------
        sensor : {"camera", "laser"}
            The sensor needed.
        needed_by : str
            What needs it, for the message.
        """
        if sensor not in SENSORS:
            raise ValueError(f"sensor must be one of {list(SENSORS)}, got {sensor!r}")
        if not (self.has_camera if sensor == "camera" else self.has_laser):
            raise MissingSensorError(self.path, sensor, needed_by)

    @property
    def max_range(self) -> float | None:
        """The laser's maximum range (m) from the settings; readings at or beyond it are no return.

        None when the settings do not say (or there is no laser).
        """
        value = (self.meta.get("settings", {}).get("laser") or {}).get("max_range")
        return None if value is None else float(value)

    @property
    def worlds(self) -> list[str]:
        """The worlds (places) of the sequences, in order of first appearance."""
        return list(dict.fromkeys(s.world for s in self.sequences.values()))

    def concat(self, field: str, names: list[str] | None = None) -> np.ndarray:
        """Concatenate the array ``field`` over sequences (in ``meta`` order, or ``names``).

        Parameters
        ----------
        field : str
            An array of the dataset format (``"images"``, ``"scans"``, ``"poses"``, ...).
        names : list of str, optional
            The sequences, in order; all of them in ``meta`` order when None.

        Returns
        -------
        ndarray
            The sequences' arrays joined along the frame axis.
        """
        names = list(self.sequences) if names is None else names
        if field in GROUND_TRUTH and not self.has_ground_truth:
            raise DatasetError(f"{self.path} has no ground truth: no {field!r} to concatenate")
        for sensor, fields in SENSORS.items():
            if field in fields:
                self.require(sensor, f"concatenating {field!r} (the methods on {fields[0]})")
        return np.concatenate([getattr(self.sequences[n], field) for n in names])

    def runs(self, world: str) -> Runs:
        """Gather every sequence (drive) of ``world``, in the form the mapping methods take.

        See `Runs`; no-return beams (``inf``, and readings at or beyond the dataset's
        [`max_range`][sim.dataset.model.Dataset.max_range]) are left out of the scan points. Needs
        the laser ([`MissingSensorError`][sim.dataset.schema.MissingSensorError] without one).

        Parameters
        ----------
        world : str
            The world whose sequences are taken.

        Returns
        -------
        Runs
            The drives of ``world``, with manifold names when there is ground truth.
        """
        self.require("laser", "the observation grouping (the drives' scans, Dataset.runs)")
        sequences = [s for s in self.sequences.values() if s.world == world]
        if not sequences:
            raise ValueError(
                f"{self.path} has no sequence in world {world!r}: it has {self.worlds}"
            )
        names = self.meta.get("manifolds") if self.has_ground_truth else None
        return Runs.from_sequences(sequences, self.max_range, names)

    def paper_split(self) -> tuple[np.ndarray, np.ndarray]:
        """Split the frames into the paper's train and test halves.

        Every second frame of each sequence builds the map (frames 0, 2, 4, ...) and the others
        test it, as in the paper.

        Returns
        -------
        train, test : ndarray of bool
            Masks over [`concat`][sim.dataset.model.Dataset.concat] order.
        """
        train = np.concatenate([np.arange(len(s)) % 2 == 0 for s in self.sequences.values()])
        return train, ~train
