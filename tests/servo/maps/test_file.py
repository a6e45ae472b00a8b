"""A servo map file is untrusted input: tampered, truncated, foreign or crafted files are refused
with a MapError naming the file, and nothing in a file can make the loader run code."""

import json
import pickle
import shutil
import warnings
from pathlib import Path

import numpy as np
import pytest

from servo.maps import build as map_store
from servo.maps.build import MapError, load_or_build
from servo.maps.file import FORMAT_VERSION, load_map, meta_digest, save_map


@pytest.fixture(scope="module")
def saved(servo_maps, tmp_path_factory) -> Path:
    return save_map(servo_maps["hallway"], tmp_path_factory.mktemp("saved-map"))


@pytest.fixture
def copy(saved, tmp_path) -> Path:
    """A private copy of the saved map to damage; returns its .json path."""
    for suffix in (".json", ".npz"):
        shutil.copy(saved.with_suffix(suffix), tmp_path / saved.with_suffix(suffix).name)
    return tmp_path / saved.name


def _edit(path: Path, change, rehash: bool = True) -> None:
    """Change the description; by default as an attacker who knows the format would, with its
    checksum recomputed, so that the checks behind the checksum are what is tested."""
    meta = json.loads(path.read_text())
    change(meta)
    if rehash:
        meta["meta_sha256"] = meta_digest(meta)
    path.write_text(json.dumps(meta))


class _Exploit:
    """Unpickling this creates a marker file: proof that code from a file ran."""

    marker: Path

    def __reduce__(self):
        return (Path.touch, (self.marker,))


def test_a_crafted_map_cannot_run_code(copy, tmp_path):
    marker = tmp_path / "pwned"
    _Exploit.marker = marker
    payload = tmp_path / "payload.npy"
    payload.write_bytes(pickle.dumps(_Exploit()))

    def craft(meta):
        # The attack on the old loader: a "record class" that names a callable of a trusted
        # module, with fields that make it unpickle the attacker's file.
        meta["clustering"]["records"]["_models"] = {
            "class": "mapping.manifold.kernel:np.load",
            "items": [{"file": {"value": str(payload)}, "allow_pickle": {"value": True}}],
        }

    _edit(copy, craft)
    allowed = r"allowed: \['ClusterModel', 'GraphClusterModel'\]"
    with pytest.raises(MapError, match="record class .*" + allowed):
        load_map(copy)
    assert not marker.exists()
    # and the same through the first generation's layout ("lists" of "class" paths)
    _edit(copy, lambda m: m["clustering"].update(lists=m["clustering"].pop("records")))
    with pytest.raises(MapError, match="exactly the keys"):
        load_map(copy)
    assert not marker.exists()


@pytest.mark.parametrize(
    ("change", "match"),
    [
        (lambda m: m.update(version=FORMAT_VERSION + 1), "format version"),
        (lambda m: m.update(format="something-else"), "format must be"),
        (lambda m: m.update(world="mars"), "world must be 'hallway', 'lawn' or FAMILY:SEED"),
        (lambda m: m.update(world="hallway:0"), "world must be 'hallway', 'lawn' or FAMILY"),
        (lambda m: m.update(world_digest="x"), "world_digest must be 64 hex digits"),
        (lambda m: m.update(manifolds=[1]), "manifolds must be a list of names"),
        (lambda m: m.update(extra=1), "exactly the keys"),
        (lambda m: m["settings"].update(stride="2"), "settings.stride must be an integer"),
        (lambda m: m["clustering"]["params"].update(evil=1), "params must have exactly"),
        (lambda m: m["clustering"].update({"class": "ImageFeatures"}), "is a 'ImageFeatures'"),
        (lambda m: m["clustering"]["fitted"].update(fit={"value": 1}), "not a fitted attribute"),
        (lambda m: m["clustering"]["fitted"].update(__class__={"value": 1}), "not a fitted"),
        (lambda m: m["clustering"]["fitted"].update(x_={"array": "/etc/passwd"}), "does not hold"),
        (lambda m: m["clustering"]["fitted"].update(x_={"code": "1"}), "must be {'array'"),
        (lambda m: m["probe"].reverse() or m["probe"].append(99), "do not reproduce"),
    ],
)
def test_a_tampered_description_is_refused(copy, change, match):
    _edit(copy, change)
    with pytest.raises(MapError, match=match) as err:
        load_map(copy)
    assert str(copy.parent) in str(err.value) or copy.name in str(err.value)


def test_an_edited_description_fails_its_checksum(copy):
    _edit(copy, lambda m: m["clustering"]["params"].update(n_clusters=2), rehash=False)
    with pytest.raises(MapError, match="meta_sha256 does not match"):
        load_map(copy)


def test_tampered_and_truncated_arrays_are_refused(copy):
    npz = copy.with_suffix(".npz")
    data = bytearray(npz.read_bytes())
    data[len(data) // 2] ^= 0xFF
    npz.write_bytes(bytes(data))
    with pytest.raises(MapError, match="truncated or modified"):
        load_map(copy)
    npz.write_bytes(bytes(data[: len(data) // 3]))
    with pytest.raises(MapError, match="truncated or modified"):
        load_map(copy)
    npz.unlink()
    with pytest.raises(MapError, match="arrays .* is missing"):
        load_map(copy)


def test_arrays_that_disagree_are_refused_even_with_a_matching_checksum(copy, servo_maps):
    """A file written by other code (checksum recomputed) with inconsistent shapes."""
    from sim.dataset import write_sequence

    npz = copy.with_suffix(".npz")
    with np.load(npz) as f:
        arrays = {k: f[k] for k in f.files}
    arrays["poses"] = arrays["poses"][:-1]
    digest = write_sequence(npz, arrays)
    _edit(copy, lambda m: m.update(sha256=digest))
    with pytest.raises(MapError, match="poses has shape"):
        load_map(copy)
    arrays["poses"] = np.full((len(arrays["clusters"]), 3), np.nan)
    _edit(copy, lambda m: m.update(sha256=write_sequence(npz, arrays)))
    with pytest.raises(MapError, match="poses position holds NaN"):
        load_map(copy)


def test_bad_json_and_another_world_are_refused(copy):
    with pytest.raises(MapError, match="of the 'hallway' world .*, not of the 'lawn' world"):
        load_map(copy, world="lawn")
    copy.write_text("{not json")
    with pytest.raises(MapError, match="not JSON"):
        load_map(copy)
    copy.write_text("[1, 2]")
    with pytest.raises(MapError, match="must be an object"):
        load_map(copy)
    with pytest.raises(MapError, match="no servo map at"):
        load_map(copy.with_name("nothing.json"))


def test_load_or_build_rebuilds_a_damaged_cache(servo_dataset, servo_maps, tmp_path):
    cache = tmp_path / "cache"
    path = save_map(servo_maps["lawn"], cache)
    path.with_suffix(".npz").write_bytes(b"PK\x03\x04 truncated")
    with pytest.warns(RuntimeWarning, match="rebuilding the servo map: .*truncated or modified"):
        rebuilt = load_or_build("lawn", servo_dataset, cache)
    np.testing.assert_array_equal(rebuilt.clusters, servo_maps["lawn"].clusters)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        load_map(path, "lawn")  # the cache is whole again


def test_the_cache_key_covers_the_code_that_builds_a_map(servo_dataset, monkeypatch, tmp_path):
    from servo.maps.types import MapSettings
    from sim.dataset import read_meta

    meta, settings = read_meta(servo_dataset), MapSettings()
    sources = map_store._key_sources()
    names = {name for name, _ in sources}
    assert {
        "mapping/scan_matching/icp_alignment.py",
        "mapping/features/images.py",
        "mapping/persistence.py",
        "mapping/manifold/clustering.py",
        "mapping/manifold/kernel.py",
        "servo/maps/build.py",
        "servo/maps/file.py",
        "sim/dataset/loading.py",
        "sim/dataset/schema.py",
    } <= names
    key = map_store.map_key(meta, "hallway", settings)
    extra = tmp_path / "topology.py"
    extra.write_text("# one more line of code\n")
    monkeypatch.setattr(map_store, "_key_sources", lambda: [*sources, ("topology.py", extra)])
    assert map_store.map_key(meta, "hallway", settings) != key


@pytest.mark.parametrize("what", ["world", "dataset", "cache"])
def test_load_or_build_names_a_bad_argument(servo_dataset, tmp_path, what):
    a_file = tmp_path / "a-file"
    a_file.write_text("x")
    kwargs = {"world": "hallway", "dataset": servo_dataset, "cache": tmp_path / "c"}
    kwargs[what] = "mars" if what == "world" else a_file
    with pytest.raises(ValueError, match=f"{what} must be"):
        load_or_build(**kwargs)
    assert not (tmp_path / "c").exists()


def test_json_nested_past_the_parser_is_a_map_error_and_the_cache_is_rebuilt(
    servo_dataset, tmp_path
):
    """100 000 '[' make json.loads raise RecursionError: a MapError, so load_or_build
    rebuilds the map instead of failing."""
    from servo.maps.file import map_paths
    from servo.maps.types import MapSettings
    from sim.dataset import read_meta

    cache = tmp_path / "cache"
    cache.mkdir()
    # where load_or_build looks (the key of the code as it is now)
    key = map_store.map_key(read_meta(servo_dataset), "lawn", MapSettings())
    path, _ = map_paths(cache, "lawn", key)
    path.write_text("[" * 100_000)
    with pytest.raises(MapError, match="not JSON"):
        load_map(path)
    with pytest.warns(RuntimeWarning, match="rebuilding the servo map: .*not JSON"):
        rebuilt = load_or_build("lawn", servo_dataset, cache)
    assert load_map(path, "lawn").key == rebuilt.key == key  # the cache is whole again


def _forge(copy: Path, name: str, change) -> None:
    """Rewrite one array of the map, with both checksums recomputed (as other code would)."""
    from sim.dataset import write_sequence

    npz = copy.with_suffix(".npz")
    with np.load(npz) as f:
        arrays = {k: f[k] for k in f.files}
    arrays[name] = change(arrays[name].copy())
    _edit(copy, lambda m: m.update(sha256=write_sequence(npz, arrays)))


@pytest.mark.parametrize(
    ("name", "change", "match"),
    [
        ("true_labels", lambda a: np.full_like(a, 99), r"true_labels must lie in \[-1, 8\)"),
        ("true_labels", lambda a: np.full_like(a, -2), r"true_labels must lie in \[-1, 8\)"),
        ("clusters", lambda a: np.full_like(a, 999), r"clusters must lie in \[0, \d+\)"),
        ("scans", lambda a: np.full_like(a, np.nan), "scans holds NaN"),
        ("scans", lambda a: np.full_like(a, -1.0), "negative scans"),
        ("scans", lambda a: np.full_like(a, -np.inf), "negative scans"),
    ],
)
def test_impossible_content_is_refused_even_with_matching_checksums(copy, name, change, match):
    """Labels outside the manifolds, clusters the clustering does not have and NaN or negative
    ranges would fail only at first use (IndexError, "need at least one array to
    concatenate"): refused on load."""
    _forge(copy, name, change)
    with pytest.raises(MapError, match=match):
        load_map(copy)


def test_no_return_ranges_are_allowed(copy):
    """+inf is how a scan stores no return: not refused with the NaN and negative ranges."""
    _forge(copy, "scans", lambda a: np.where(np.arange(a.shape[1]) % 2, np.inf, a))
    assert np.isinf(load_map(copy).scans).any()


@pytest.mark.parametrize("world", ["mars", 3, ""])
def test_an_unknown_world_argument_is_named(copy, world):
    with pytest.raises(
        ValueError, match=r"world must be 'hallway' or 'lawn'.*FAMILY:SEED"
    ) as caught:
        load_map(copy, world=world)
    assert not isinstance(caught.value, MapError)  # an argument error, not a damaged file
