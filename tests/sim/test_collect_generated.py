"""Collecting generated worlds (``FAMILY:SEED``): names, labels, meta, determinism."""

import json

import numpy as np
import pytest

from scenes import build_world, names
from sim.camera import CameraConfig
from sim.collect import CollectionSettings, collect_dataset
from sim.collect_worlds import label_lookup, randomisation_key, world_sequences
from sim.dataset import load_dataset

SMALL = CameraConfig(width=32, height=24)
SETTINGS = CollectionSettings(worlds=("lawn:3",), frames=6, seed=1, camera=SMALL)


@pytest.fixture(scope="module")
def generated(tmp_path_factory):
    path = tmp_path_factory.mktemp("gen")
    collect_dataset(path, SETTINGS, jobs=1, progress=False)
    return path


def test_generated_dataset_names_labels_and_meta(generated):
    world = build_world("lawn:3")
    data = load_dataset(generated)
    assert list(data.sequences) == list(world.routes)
    assert data.manifolds == list(world.manifold_names)
    meta = json.loads((generated / "meta.json").read_text())
    assert meta["settings"]["worlds"] == ["lawn:3"]
    for name, seq in data.sequences.items():
        assert meta["sequences"][name]["file"] == name.replace(":", "-") + ".npz"
        assert ":" not in meta["sequences"][name]["file"] and seq.world == "lawn:3"
        # The labels are the world's own: the start on the main manifold, the end on the leaf.
        assert data.manifolds[seq.labels[0]] == "lawn:3"
        assert data.manifolds[seq.labels[-1]] == name
        np.testing.assert_array_equal(seq.labels, world.manifold_at(seq.poses[:, :2]))


def test_generated_dataset_same_bytes_twice(generated, tmp_path):
    collect_dataset(tmp_path, SETTINGS, jobs=1, progress=False)
    assert (tmp_path / "meta.json").read_bytes() == (generated / "meta.json").read_bytes()
    for f in generated.glob("*.npz"):
        assert (tmp_path / f.name).read_bytes() == f.read_bytes()


def test_mixed_worlds_label_space_and_mapping(tmp_path):
    # A canonical world beside a generated one: the label space is their manifolds in turn,
    # and the canonical lawn's ids (4..7) are mapped to the list's indices (0..3).
    settings = CollectionSettings(worlds=("lawn", "hallway:3"), frames=3, camera=SMALL)
    generated = build_world("hallway:3").manifold_names
    lawn = tuple(m for m in names.MANIFOLDS if m.startswith("lawn"))
    assert settings.manifolds() == [*lawn, *generated]
    assert settings.sequences()[0][:3] == (3, "lawn", "lawn-left")
    ids = {m: 4 + i for i, m in enumerate(lawn)}  # the canonical lawn's ids
    table = label_lookup(settings.worlds, ids, "lawn")
    assert [table[ids[m]] for m in lawn] == [0, 1, 2, 3] and table[-1] == -1
    table = label_lookup(settings.worlds, build_world("hallway:3").manifold_ids, "hallway:3")
    assert list(table[: len(generated)]) == list(range(4, 4 + len(generated)))


def test_sequence_indices_stay_apart():
    canonical = CollectionSettings().sequences()
    assert [s[0] for s in canonical] == list(range(6))
    assert [s[2] for s in canonical] == [
        names.manifold_name(w, b) for w in names.WORLDS for b in names.BRANCHES
    ]
    generated = world_sequences("hallway:3") + world_sequences("lawn:3")
    keys = [tuple(np.atleast_1d(i)) for i, _, _ in canonical + generated]
    assert len(set(keys)) == len(keys)
    assert randomisation_key("lawn", 4) == [4, 1001]
    assert randomisation_key("lawn:3", 4) != randomisation_key("hallway:3", 4)


def test_world_names_normalised_and_refused():
    assert CollectionSettings(worlds=("hallway:0", "lawn:2")).worlds == ("hallway", "lawn:2")
    assert CollectionSettings(worlds=["lawn"]).worlds == ("lawn",)
    for bad in [("maze:3",), ("hallway:x",), ("hallway:-1",), (3,), (), "hallway", None]:
        with pytest.raises(ValueError, match="worlds must be"):
            CollectionSettings(worlds=bad)
    with pytest.raises(ValueError, match="each world once"):
        CollectionSettings(worlds=("hallway", "hallway:0"))
