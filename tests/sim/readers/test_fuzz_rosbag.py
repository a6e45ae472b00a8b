"""Fuzzing the ROS bag importer: truncated and byte-flipped ROS 1 bags and ROS 2 SQLite files
give a RosbagImportError or a valid dataset, never rosbags' ReaderError, apsw's CorruptError, a
KeyError or a hang; bags of values no robot records are refused with the bound they break."""

import dataclasses
import shutil
import warnings

import numpy as np
import pytest

from sim.dataset import load_dataset
from sim.readers.rosbag import ImportSettings, RosbagImportError, import_rosbags
from tests.sim.readers.fuzzing import budget, flipped, truncated
from tests.sim.readers.rosbag_fixtures import IMAGE, ODOM, SCAN, write_bag
from tests.sim.readers.test_rosbag import TINY, _refused, _tiny_drive

CASE_BUDGET_S = 5.0


@pytest.mark.parametrize("ros", [1, 2])
def test_damaged_bags_give_an_import_error_or_a_valid_dataset(tmp_path, ros):
    rng = np.random.default_rng(20 + ros)
    base = write_bag(tmp_path / ("base.bag" if ros == 1 else "base"), _tiny_drive(), ros=ros)
    source = base if ros == 1 else next(base.glob("*.db3"))
    data = source.read_bytes()
    outcomes = {"refused": 0, "read": 0}
    for case in range(40):
        damaged = truncated(data, rng) if case % 2 else flipped(data, rng, int(rng.integers(1, 4)))
        if ros == 1:
            bag = tmp_path / f"case{case}.bag"
            bag.write_bytes(damaged)
        else:
            bag = tmp_path / f"case{case}"
            shutil.copytree(base, bag)
            (bag / source.name).write_bytes(damaged)
        out = tmp_path / f"out{case}"
        with budget(CASE_BUDGET_S), warnings.catch_warnings():
            warnings.simplefilter("ignore")  # rosbags warns of some damage, then reads on
            try:
                import_rosbags([bag], out, TINY, progress=False)
            except RosbagImportError as err:
                assert bag.name in str(err), err
                outcomes["refused"] += 1
                continue
        seq = load_dataset(out).sequences[bag.stem]
        assert np.isfinite(seq.odometry).all() and not np.isnan(seq.scans).any()
        outcomes["read"] += 1
    assert outcomes["refused"] > 0


@pytest.mark.parametrize(
    ("changes", "match"),
    [
        ({"poses": np.array([[0.0, 0.0, 3.0], [1e300, 0.0, -3.0]])}, r"odometry pose position"),
        ({"velocities": np.array([[1e9, 0.5], [3.0, 0.5]])}, "odometry velocity"),
        ({"range_max": 1e5}, r"range_max must be in \(0, 10000\] m, got 100000.0"),
        ({"ranges": np.full((3, 5), np.nan)}, "no beam of any of the 2 frames has a return"),
    ],
)
def test_values_no_robot_records_are_refused(tmp_path, changes, match):
    _refused(tmp_path, _tiny_drive(**changes), match=match)


def test_a_zero_quaternion_is_refused(tmp_path, monkeypatch):
    from tests.sim.readers import rosbag_fixtures

    real = rosbag_fixtures.odom_msg

    def zero_rotation(ts, ros1, ns, pose, velocity):
        msg = real(ts, ros1, ns, pose, velocity)
        q = msg.pose.pose.orientation
        q.x = q.y = q.z = q.w = 0.0
        return msg

    monkeypatch.setattr(rosbag_fixtures, "odom_msg", zero_rotation)
    _refused(tmp_path, _tiny_drive(), match="orientation quaternion is .* of length 0")


def test_range_min_above_range_max_is_refused(tmp_path, monkeypatch):
    from tests.sim.readers import rosbag_fixtures

    real = rosbag_fixtures.scan_msg

    def inverted(*args, **kwargs):
        msg = real(*args, **kwargs)
        msg.range_min = msg.range_max + 1.0
        return msg

    monkeypatch.setattr(rosbag_fixtures, "scan_msg", inverted)
    _refused(tmp_path, _tiny_drive(), match="range_min .* is not below range_max")


def test_settings_without_a_camera_still_need_a_laser():
    laser_only = dataclasses.replace(ImportSettings(SCAN, IMAGE, ODOM), image_topic=None)
    assert laser_only.image_topic is None
    with pytest.raises(ValueError, match="scan_topic and image_topic are both None"):
        dataclasses.replace(laser_only, scan_topic=None)


def test_a_ros1_bag_without_its_suffix_says_to_rename_it(tmp_path):
    bag = write_bag(tmp_path / "drive.bag", _tiny_drive(), ros=1)
    renamed = bag.rename(tmp_path / "drive")
    _refused(tmp_path, renamed, match=r"a ROS 1 bag, but without the .bag suffix.*drive.bag")
