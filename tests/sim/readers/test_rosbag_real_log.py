"""A real log round trip: the first scans of the Radish ACES log (Carmen) written as ROS 1, ROS 2
SQLite and ROS 2 MCAP bags by rosbags' own writers, laser and odometry only and with a camera,
imported: the ranges bit-equal, the odometry equal, the same groups as the log itself."""

import dataclasses

import numpy as np
import pytest

from common.geometry import scan_to_points
from mapping import ObservationGraphPartitioner
from sim.dataset import load_dataset
from sim.readers.carmen import read_carmen
from sim.readers.rosbag import ImportSettings, import_rosbags
from tests.sim.readers.rosbag_fixtures import IMAGE, ODOM, SCAN, Drive, write_bag

SCANS = 60
WITH_CAMERA = ImportSettings(SCAN, IMAGE, ODOM, min_travel=0.0, odom_max_gap=60.0)
LASER_ONLY = dataclasses.replace(WITH_CAMERA, image_topic=None)


@pytest.fixture(scope="module")
def aces(aces_log):
    log = read_carmen(aces_log)
    return log, slice(0, SCANS)


def _drive(log, part, camera: bool) -> Drive:
    t = log.timestamps[part] - log.timestamps[0] + 0.5
    n = len(t)
    images = (np.arange(n)[:, None, None, None] * 4 % 256 * np.ones((1, 4, 6, 3))).astype(np.uint8)
    return Drive(
        t_scan=t,
        ranges=log.ranges[part],
        angles=log.angles,
        t_image=t if camera else t[:0],
        images=images if camera else images[:0],
        t_odom=t,
        poses=log.odometry[part],
        velocities=np.zeros((n, 2)),
        range_max=log.max_range,
    )


def _groups(scans, odometry):
    return ObservationGraphPartitioner().fit(scans, odometry).labels_


@pytest.mark.parametrize("camera", [False, True])
@pytest.mark.parametrize(("ros", "mcap"), [(1, False), (2, False), (2, True)])
def test_a_real_log_round_trips_through_every_bag_format(aces, tmp_path, ros, mcap, camera):
    log, part = aces
    bag = write_bag(
        tmp_path / ("aces.bag" if ros == 1 else "aces"),
        _drive(log, part, camera),
        ros=ros,
        mcap=mcap,
    )
    settings = WITH_CAMERA if camera else LASER_ONLY
    data = load_dataset(import_rosbags([bag], tmp_path / "data", settings, progress=False))
    seq = data.sequences["aces"]
    assert len(seq) == SCANS and data.has_camera == camera and data.max_range == log.max_range
    source = log.ranges[part].astype(np.float32)
    returned = source < log.max_range  # Carmen logs the maximum for a beam without a return
    np.testing.assert_array_equal(seq.scans[returned], source[returned])  # bit-equal
    assert np.isinf(seq.scans[~returned]).all()
    np.testing.assert_allclose(seq.odometry, log.odometry[part], atol=1e-9)
    if camera:
        assert seq.images.shape == (SCANS, 4, 6, 3)
    runs = data.runs("robot")
    ours = [scan_to_points(r, log.angles, log.max_range) for r in log.ranges[part]]
    groups = _groups(runs.scans, runs.odometry)
    np.testing.assert_array_equal(groups, _groups(ours, log.odometry[part]))
    assert len(np.unique(groups)) > 1  # 8 stretches of corridor
