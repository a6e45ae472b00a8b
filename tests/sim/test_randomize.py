"""Per-episode appearance randomisation changes what the camera sees, both ways, and undoes."""

import numpy as np
import pytest

import sim  # noqa: F401  (registers the envs)
from sim.camera import CameraConfig
from sim.env import NavigationEnv
from sim.randomize import AppearanceRandomizer

SMALL = CameraConfig(width=64, height=48)
POSE = {"hallway": (5.0, 0.0, 0.0), "lawn": (5.0, 0.0, 0.0)}


class FixedDraw:
    """A stand-in Generator whose uniform draws are pinned (low, mid or high of each range)."""

    def __init__(self, where: float):
        self.where = where

    def uniform(self, low, high, size=None):
        value = low + self.where * (high - low)
        return value if size is None else np.full(size, value)


def _image(env: NavigationEnv, where: float | None) -> np.ndarray:
    env.reset(seed=0, options={"pose": POSE[env.world.name]})
    env._randomizer.apply(None if where is None else FixedDraw(where))
    return env.sim.render().astype(float)


@pytest.mark.parametrize("world", ["hallway", "lawn"])
def test_light_gain_darkens_and_brightens_the_image(world):
    env = NavigationEnv(world, camera=SMALL, sensors=("image",))
    plain, dark, bright = _image(env, None), _image(env, 0.0), _image(env, 1.0)
    # gain 0.55 with tint -0.12 / gain 1.45 with tint +0.12: an additive draw clipped to [0, 1]
    # moved these images by < 1 grey level where the gain was above 1
    assert dark.mean() < plain.mean() - 5
    assert bright.mean() > plain.mean() + 3
    np.testing.assert_array_equal(_image(env, None), plain)  # restored exactly
    env.close()


def test_material_colours_keep_their_brightest_channel_and_the_headlight_moves():
    env = NavigationEnv("hallway", camera=SMALL, sensors=("image",))
    model = env.sim.model
    base_rgba, base_head = model.mat_rgba.copy(), model.vis.headlight.ambient.copy()
    r = AppearanceRandomizer(model)
    r.apply(np.random.default_rng(3))
    rgb = model.mat_rgba[:, :3]
    base = base_rgba[:, :3]
    assert np.all(rgb <= base + 1e-6) and np.all(rgb >= 0.85 * base - 1e-6)
    assert np.all(np.isclose(rgb, base, rtol=1e-6).any(axis=1))  # the top channel is kept
    assert np.ptp(rgb, axis=1).max() > 0.01  # a hue shift, not a uniform dimming
    assert not np.allclose(model.vis.headlight.ambient, base_head)
    r.apply(None)
    np.testing.assert_array_equal(model.mat_rgba, base_rgba)
    np.testing.assert_array_equal(model.vis.headlight.ambient, base_head)
    env.close()
