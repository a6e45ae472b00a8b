"""What a servo map needs from a dataset, stated once and checked before a map is built.

A map compares a scan with the stored views' scans over beam shifts of up to
`PROFILE_SHIFT` beams each way, so a scan needs more beams than
two such shifts (`MIN_BEAMS`), and the overlap of a shifted scan with a stored one is
never empty. The clustering splits the stored views into ``K`` manifolds
([`clusters_for`][servo.maps.types.MapSettings.clusters_for]) of at least ``min_cluster_size`` views
each, so the world's sequences must give ``K * min_cluster_size`` stored views (every
``stride``-th frame of each sequence). A dataset that cannot give either is refused with a
[`DatasetError`][sim.dataset.schema.DatasetError] naming the dataset and what to collect instead,
not with an error of numpy or of the clustering deep inside the build.
"""

from __future__ import annotations

import math

from servo.maps.scan_profile import PROFILE_SHIFT
from servo.maps.types import MapSettings
from sim.dataset import Dataset, DatasetError

__all__ = ["MIN_BEAMS", "check_needs", "views_needed"]

MIN_BEAMS = 2 * PROFILE_SHIFT + 1  # a shift of PROFILE_SHIFT each way leaves a scan's middle


def views_needed(world: str, settings: MapSettings) -> int:
    """Return the number of stored views the map of ``world`` needs: ``K * min_cluster_size``.

    Parameters
    ----------
    world : str
        The world's name.
    settings : MapSettings
        The map's settings (K by ``clusters_for``, and ``min_cluster_size``).

    Returns
    -------
    int
        The number of stored views.
    """
    return settings.clusters_for(world) * settings.min_cluster_size


def check_needs(dataset: Dataset, world: str, names: list[str], settings: MapSettings) -> None:
    """Raise [`DatasetError`][sim.dataset.schema.DatasetError] when a dataset cannot give a map.

    That is when the sequences ``names`` of ``dataset`` (those of ``world``) have fewer than
    `MIN_BEAMS` beams or give fewer stored views than `views_needed`; the error names the
    shortfall and the frames per sequence to collect.

    Parameters
    ----------
    dataset : Dataset
        The dataset the map is to be built from.
    world : str
        The world's name.
    names : list of str
        The names of the dataset's sequences of ``world``.
    settings : MapSettings
        The map's settings.
    """
    beams = len(dataset.sequences[names[0]].angles)
    if beams < MIN_BEAMS:
        raise DatasetError(
            f"{dataset.path}: the scans have {beams} beams; a servo map compares scans over "
            f"shifts of up to {PROFILE_SHIFT} beams each way, so it needs at least {MIN_BEAMS} "
            "beams per scan: record with a laser of more beams (e.g. 361, half a degree apart "
            "over 180 degrees)"
        )
    stride = settings.stride
    views = sum(math.ceil(len(dataset.sequences[n]) / stride) for n in names)
    need = views_needed(world, settings)
    if views < need:
        k, q = settings.clusters_for(world), settings.min_cluster_size
        frames = math.ceil(need / len(names)) * stride
        raise DatasetError(
            f"{dataset.path}: the {len(names)} sequences of world {world!r} give {views} stored "
            f"views (one frame in {stride}), but a map of {k} manifolds of at least {q} views "
            f"each needs {need}: collect at least {frames} frames per sequence (topomap collect "
            "--frames), or build with a smaller MapSettings.min_cluster_size or stride"
        )
