"""The synthetic office the scan-matching tests align scans of."""

import numpy as np
import pytest

from mapping.grouping import office_path, office_world, raycast


@pytest.fixture(scope="module")
def office():
    world = office_world()
    poses = office_path(world, step=0.5)
    scans = raycast(world.segments, poses, range_noise=0.005, rng=np.random.default_rng(1))
    return world, scans, poses
