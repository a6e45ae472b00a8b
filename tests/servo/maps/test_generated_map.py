"""Servo maps of generated worlds: the world's name and floor plan in the key and the file,
the prior K from the world, and a map of one world refused in another."""

import json

import numpy as np
import pytest

from scenes import build_world
from servo.maps import MapError, load_map
from servo.maps.types import prior_clusters
from servo.task.interface import sensed_map

WORLD = "lawn:3"  # the map of the session fixture generated_servo_map


def test_generated_servo_map_records_world_and_floor_plan(generated_servo_map):
    m, cache = generated_servo_map
    world = build_world(WORLD)
    assert m.world == WORLD and m.world_digest == world.digest
    assert m.manifold_names == world.manifold_names
    assert prior_clusters(WORLD) == len(world.manifold_names) and prior_clusters("lawn") == 4
    assert set(m.true_manifold(v) for v in range(len(m))) <= set(world.manifold_names) | {None}
    (json_path,) = cache.glob("*.json")
    assert json_path.name.startswith("lawn-3-")  # no ':' in a file name
    meta = json.loads(json_path.read_text())
    assert meta["world"] == WORLD and meta["world_digest"] == world.digest
    loaded = load_map(json_path, world=WORLD)
    np.testing.assert_array_equal(loaded.true_labels, m.true_labels)
    assert loaded.manifold_names == m.manifold_names


def test_generated_servo_map_refused_in_another_world(generated_servo_map):
    m, cache = generated_servo_map
    (json_path,) = cache.glob("*.json")
    with pytest.raises(MapError, match=r"'lawn:3' world .*not of the 'lawn:4' world"):
        load_map(json_path, world="lawn:4")
    with pytest.raises(MapError, match="fitted on the 'lawn:3' world .* the 'lawn' world"):
        m.check_world("lawn")
    with pytest.raises(ValueError, match="FAMILY:SEED"):
        load_map(json_path, world="lawn:x")


def test_sensed_generated_servo_map_hides_the_layout(generated_servo_map):
    m, _ = generated_servo_map
    seen = sensed_map(m)
    assert seen.manifold_names == () and seen.world_digest is None
    assert np.all(seen.true_labels == -1) and seen.true_manifold(0) is None
