import xml.etree.ElementTree as ET

import cv2
import numpy as np
import pytest

from scenes import textures
from scenes.mjcf import SceneBuilder, fmt


def test_fmt_writes_six_significant_digits_space_separated():
    assert fmt((1, 0.5, 1 / 3)) == "1 0.5 0.333333"
    assert fmt(np.array([[1e-7, 2.0]])) == "1e-07 2"


def test_textures_follow_the_generator_and_are_rgb_bytes():
    a = textures.bricks(np.random.default_rng(3), (0.6, 0.3, 0.2))
    b = textures.bricks(np.random.default_rng(3), (0.6, 0.3, 0.2))
    c = textures.bricks(np.random.default_rng(4), (0.6, 0.3, 0.2))
    size = textures.TEXTURE_SIZE
    assert a.shape == (size, size, 3) and a.dtype == np.uint8
    np.testing.assert_array_equal(a, b)
    assert not np.array_equal(a, c)
    noise = textures.fractal_noise(np.random.default_rng(0), size=64)
    assert noise.min() == 0.0 and noise.max() == 1.0
    # PNG bytes hold RGB (OpenCV's BGR order undone on encode)
    decoded = cv2.imdecode(np.frombuffer(textures.encode_png(a), np.uint8), cv2.IMREAD_COLOR)
    np.testing.assert_array_equal(decoded[..., ::-1], a)


def test_builder_names_every_element_once_and_records_solid_footprints():
    sb = SceneBuilder("toy")
    tex = sb.texture("wall_tex", textures.painted(np.random.default_rng(0), (0.8, 0.8, 0.7)))
    mat = sb.material("wall", texture=tex, texrepeat=(2, 1))
    sb.box("wall_a", (1.0, 0.0, 0.5), (1.0, 0.05, 0.5), material=mat)
    sb.box("decal", (1.0, 0.1, 0.5), (0.2, 0.01, 0.2), collide=False)
    assert [f.name for f in sb.footprints] == ["wall_a"]  # only colliding geoms block
    assert set(sb.assets) == {"wall_tex.png"}
    root = ET.fromstring(sb.to_xml())
    geoms = {g.get("name"): g for g in root.iter("geom")}
    assert geoms["decal"].get("contype") == "0" and geoms["wall_a"].get("contype") is None
    assert root.find("asset/material").get("texrepeat") == "2 1"
    with pytest.raises(ValueError, match="duplicate element name 'wall_a'"):
        sb.box("wall_a", (0, 0, 0), (1, 1, 1))
