"""The servo task in a generated world: ServoEnv and the protocol take ``FAMILY:SEED``."""

import numpy as np
import pytest

from scenes import build_world
from servo.maps import MapError
from servo.task.env import ServoEnv
from servo.task.protocol import Protocol, episode_specs, protocol_spawn_key


def test_servo_env_in_a_generated_world(generated_servo_map):
    m, _ = generated_servo_map
    world = build_world("lawn:3")
    env = ServoEnv("lawn:3", m, max_steps=5)
    leaves = list(world.routes)
    _, info = env.reset(seed=0, options={"start_manifold": "lawn:3", "target_manifold": leaves[0]})
    assert info["start_manifold"] == "lawn:3" and info["target_manifold"] == leaves[0]
    assert info["junctions"] == world.junctions_between("lawn:3", leaves[0]) >= 1
    _, reward, _, _, info = env.step(np.array([0.3, 0.0]))
    assert np.isfinite(reward) and info["target_manifold"] == leaves[0]
    with pytest.raises(ValueError, match="manifolds of the 'lawn:3' world"):
        env.reset(seed=0, options={"target_manifold": "lawn-left"})
    env.close()
    with pytest.raises(MapError, match="fitted on the 'lawn:3' world"):
        ServoEnv("lawn:4", m)
    with pytest.raises(ValueError, match="contradicts the env id"):
        ServoEnv("hallway:3", m, registered_world="lawn")


def test_protocol_names_and_spawn_keys(generated_servo_map):
    m, _ = generated_servo_map
    # the canonical worlds' episodes keep their keys; a generated world's cannot meet them
    assert protocol_spawn_key(Protocol("hallway")) == (0, 0)
    assert protocol_spawn_key(Protocol("lawn", split="test")) == (1, 1)
    assert Protocol("lawn:0").world == "lawn"
    worlds = ("hallway", "lawn", "hallway:1", "lawn:1", "lawn:2")
    keys = {protocol_spawn_key(Protocol(w, split=s)) for w in worlds for s in ("dev", "test")}
    assert len(keys) == 10
    specs = episode_specs(Protocol("lawn:3"), m.true_labels, 4, m.manifold_names)
    assert {s.start_manifold for s in specs} <= set(m.manifold_names)
    for bad in ("maze:3", "hallway:x", "hallway:-1", 3):
        with pytest.raises(ValueError, match="FAMILY:SEED"):
            Protocol(bad)
