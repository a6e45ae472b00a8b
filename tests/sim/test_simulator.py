import mujoco
import numpy as np
import pytest

from common.geometry import scan_to_points
from scenes.robot import LASER_FORWARD, RADIUS
from sim.camera import CameraConfig
from sim.laser import LaserConfig
from sim.odometry import OdometryConfig
from sim.simulator import Simulator

# Soft contacts let the chassis sink a few centimetres into a wall at full speed.
PENETRATION_TOLERANCE = 0.04


@pytest.fixture(scope="module")
def hallway_sim(worlds):
    sim = Simulator(
        worlds["hallway"], CameraConfig(width=64, height=48), LaserConfig(noise_std=0.0)
    )
    yield sim
    sim.close()


def _beam(cfg: LaserConfig, angle: float) -> int:
    return int(np.argmin(np.abs(cfg.angles - angle)))


@pytest.mark.parametrize(
    ("pose", "angle", "expected"),
    [
        ((8.0, 0.0, 0.0), np.pi / 2, 1.2),  # north wall of the main corridor
        ((8.0, 0.0, 0.0), -np.pi / 2, 1.2),  # south wall
        ((8.0, 0.3, 0.0), -np.pi / 2, 1.5),
        ((17.2, 10.0, np.pi / 2), 0.0, 17.2 - 10.0 - LASER_FORWARD),  # end wall of the left branch
        ((17.2, 10.0, np.pi / 2), -np.pi / 2, 1.2 - 0.45),  # the bench against the east wall
        ((2.0, 0.0, np.pi), 0.0, 2.0 - LASER_FORWARD),  # the corridor's closed end
    ],
)
def test_laser_reads_known_wall_distances(hallway_sim, pose, angle, expected):
    hallway_sim.reset(pose, np.random.default_rng(0))
    ranges = hallway_sim.scan()
    assert ranges.dtype == np.float32
    assert ranges[_beam(hallway_sim.laser.config, angle)] == pytest.approx(expected, abs=1e-4)


def test_beam_without_return_is_inf_and_noise_is_small(hallway_sim):
    hallway_sim.reset((3.0, 0.0, 0.0), np.random.default_rng(0))
    ahead = _beam(hallway_sim.laser.config, 0.0)
    assert np.isinf(hallway_sim.scan()[ahead])  # 31 m of corridor > 20 m max range
    clean = hallway_sim.scan()
    noisy_cfg = LaserConfig(noise_std=0.01)
    hallway_sim.laser.config = noisy_cfg
    try:
        noisy = hallway_sim.scan(np.random.default_rng(1))
    finally:
        hallway_sim.laser.config = LaserConfig(noise_std=0.0)
    hit = np.isfinite(clean)
    assert np.array_equal(hit, np.isfinite(noisy))
    assert 0.005 < np.std(noisy[hit] - clean[hit]) < 0.02
    pts = scan_to_points(clean, hallway_sim.laser.config.angles)
    assert pts.shape == (hit.sum(), 2)


def test_laser_ignores_the_robot(worlds):
    sim = Simulator(worlds["hallway"], None, LaserConfig(fov=2 * np.pi, beams=360, noise_std=0.0))
    sim.reset((8.0, 0.0, 0.0), np.random.default_rng(0))
    r = sim.scan()
    assert np.nanmin(r[np.isfinite(r)]) > RADIUS  # the chassis would be closer


@pytest.mark.parametrize("name", ["hallway", "lawn"])
def test_driving_into_every_wall_stays_in_free_space(worlds, name):
    world = worlds[name]
    free = world.free_space(0.02, inflation=RADIUS - PENETRATION_TOLERANCE)
    sim = Simulator(world, None, None, OdometryConfig.noiseless())
    rng = np.random.default_rng(0)
    starts = [r.waypoints[k] for r in world.routes.values() for k in range(len(r.waypoints))]
    touched = 0
    for start in starts:
        for heading in np.linspace(-np.pi, np.pi, 6, endpoint=False):
            sim.reset((start[0], start[1], heading), rng)
            for _ in range(40):  # 4 s at full speed, then a wiggle along the wall
                touched += sim.step(1.5, 0.0)
                assert free.is_free(sim.pose[:2]), f"robot entered an obstacle at {sim.pose}"
            for _ in range(10):
                sim.step(1.5, 1.5)
                assert free.is_free(sim.pose[:2])
            assert sim.data.warning[mujoco.mjtWarning.mjWARN_BADQACC].number == 0
    assert touched > 10  # the walls were actually hit


@pytest.mark.parametrize("name", ["hallway", "lawn"])
def test_scripted_drive_has_no_mujoco_warnings(worlds, name):
    sim = Simulator(worlds[name], CameraConfig(width=32, height=24), LaserConfig())
    sim.reset(
        np.r_[worlds[name].routes[f"{name}-left"].waypoints[0], 0.0], np.random.default_rng(0)
    )
    rng = np.random.default_rng(1)
    for _ in range(100):
        sim.step(rng.uniform(-0.5, 1.5), rng.uniform(-1.5, 1.5))
    sim.render()
    sim.scan(rng)
    assert sum(w.number for w in sim.data.warning) == 0
    sim.close()


def test_unicycle_tracks_commands(worlds):
    sim = Simulator(worlds["lawn"], None, None, OdometryConfig.noiseless())
    sim.reset((5.0, 0.0, 0.0), np.random.default_rng(0))
    for _ in range(20):
        sim.step(0.5, 0.0)
    assert sim.pose[0] == pytest.approx(6.0, abs=0.05)
    assert abs(sim.pose[1]) < 0.01
    for _ in range(15):
        sim.step(0.0, 1.0)
    assert sim.pose[2] == pytest.approx(1.5, abs=0.05)
    np.testing.assert_allclose(sim.odometry.pose, sim.pose, atol=1e-9)  # noiseless odometry


def test_noisy_odometry_drifts_plausibly(worlds):
    sim = Simulator(worlds["lawn"], None, None, OdometryConfig())
    sim.reset((2.0, 0.0, 0.0), np.random.default_rng(3))
    for _ in range(200):  # 20 m
        sim.step(1.0, 0.05 * np.sin(sim.time))
    err = np.hypot(*(sim.odometry.pose[:2] - sim.pose[:2]))
    assert 0.0 < err < 3.0


def test_render_larger_than_the_buffer_grows_it(worlds):
    sim = Simulator(worlds["hallway"], CameraConfig(width=800, height=600, depth=True))
    sim.reset((5.0, 0.0, 0.0), np.random.default_rng(0))
    img = sim.render()
    depth = sim.camera.render_depth(sim.data)
    assert img.shape == (600, 800, 3) and img.std() > 5
    assert depth.shape == (600, 800) and 0.5 < np.median(depth) < 40
    sim.close()
    sim.close()


@pytest.mark.parametrize(
    ("factory", "match"),
    [
        (lambda: LaserConfig(fov=0), "laser fov"),
        (lambda: LaserConfig(beams=0), "laser beams"),
        (
            lambda: LaserConfig(beams=100_000_000),
            r"laser beams must be an integer in \[1, 100000\]",
        ),
        (lambda: LaserConfig(max_range=np.inf), "laser max_range"),
        (lambda: CameraConfig(width=0), "camera width"),
        (lambda: OdometryConfig(translation=-1), "odometry translation"),
    ],
)
def test_bad_sensor_settings_are_refused(factory, match):
    with pytest.raises(ValueError, match=match):
        factory()


def test_a_hundred_thousand_beams_is_the_most_and_still_scans(worlds):
    """--beams 10**8 once hung the collection; the cap is far beyond real 2-D lasers (a few
    thousand beams) and a scan at the cap is quick."""
    from sim.laser import MAX_BEAMS

    assert MAX_BEAMS == 100_000
    sim = Simulator(worlds["hallway"], None, LaserConfig(beams=MAX_BEAMS), OdometryConfig(), 0.05)
    sim.reset(np.array([8.0, 0.0, 0.0]), np.random.default_rng(0))
    assert sim.scan().shape == (MAX_BEAMS,)
    sim.close()
