import json

import numpy as np
import pytest

from sim import collect as collect_mod
from sim.camera import CameraConfig
from sim.collect import CollectionSettings, collect_dataset
from sim.dataset import SCHEMA_VERSION, DatasetError, load_dataset

SETTINGS = CollectionSettings(
    worlds=("lawn",), frames=6, seed=3, camera=CameraConfig(width=48, height=36)
)


@pytest.fixture(scope="module")
def small_dataset(tmp_path_factory):
    path = tmp_path_factory.mktemp("ds")
    collect_dataset(path, SETTINGS, jobs=1, progress=False)
    return path


def test_dataset_round_trips(small_dataset):
    ds = load_dataset(small_dataset)
    assert list(ds.sequences) == ["lawn-left", "lawn-straight", "lawn-right"]
    seq = ds.sequences["lawn-left"]
    assert seq.images.shape == (6, 36, 48, 3) and seq.images.dtype == np.uint8
    assert seq.scans.shape == (6, 361) and seq.scans.dtype == np.float32
    assert seq.poses.shape == seq.odometry.shape == (6, 3)
    assert np.all(np.diff(seq.times) > 0)
    # The sequence runs from the lawn into the left branch, and its labels say so.
    assert ds.manifolds[seq.labels[0]] == "lawn" and ds.manifolds[seq.labels[-1]] == "lawn-left"
    train, test = ds.paper_split()
    assert train.sum() == test.sum() == 9
    meta = json.loads((small_dataset / "meta.json").read_text())
    assert meta["schema_version"] == SCHEMA_VERSION and meta["complete"]
    assert meta["settings"]["laser"]["beams"] == 361


def test_same_seed_same_bytes(small_dataset, tmp_path):
    collect_dataset(tmp_path, SETTINGS, jobs=1, progress=False)
    a = json.loads((small_dataset / "meta.json").read_text())["sequences"]
    b = json.loads((tmp_path / "meta.json").read_text())["sequences"]
    assert a == b  # same SHA-256 for every sequence


def test_interrupted_collection_leaves_nothing_half_written_and_resumes(tmp_path, monkeypatch):
    real = collect_mod.collect_sequence
    calls = []

    def flaky(settings, index, world, route, tick=None):
        calls.append(route)
        if route == "lawn-straight":
            raise KeyboardInterrupt
        return real(settings, index, world, route, tick)

    monkeypatch.setattr(collect_mod, "collect_sequence", flaky)
    with pytest.raises(KeyboardInterrupt):
        collect_dataset(tmp_path, SETTINGS, jobs=1, progress=False)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["lawn-left.npz", "meta.json"]
    with pytest.raises(DatasetError, match="incomplete collection"):
        load_dataset(tmp_path)
    first = (tmp_path / "lawn-left.npz").stat().st_mtime_ns
    monkeypatch.setattr(collect_mod, "collect_sequence", real)
    calls.clear()
    collect_dataset(tmp_path, SETTINGS, jobs=1, progress=False)
    assert (tmp_path / "lawn-left.npz").stat().st_mtime_ns == first  # kept, not redone
    assert len(load_dataset(tmp_path).sequences) == 3


def test_other_settings_are_refused_unless_overwrite(small_dataset, tmp_path):
    collect_dataset(tmp_path, SETTINGS, jobs=1, progress=False)
    other = CollectionSettings(
        worlds=("lawn",), frames=5, seed=3, camera=CameraConfig(width=48, height=36)
    )
    with pytest.raises(FileExistsError, match="other settings"):
        collect_dataset(tmp_path, other, jobs=1, progress=False)
    collect_dataset(tmp_path, other, overwrite=True, jobs=1, progress=False)
    assert len(load_dataset(tmp_path).sequences["lawn-right"]) == 5


def test_truncated_or_foreign_datasets_are_refused(small_dataset, tmp_path):
    import shutil

    shutil.copytree(small_dataset, tmp_path / "d")
    d = tmp_path / "d"
    path = d / "lawn-right.npz"
    path.write_bytes(path.read_bytes()[:1000])
    with pytest.raises(DatasetError, match="truncated or modified"):
        load_dataset(d)
    with pytest.raises(DatasetError, match="cannot be read"):
        load_dataset(d, verify=False)
    meta = json.loads((d / "meta.json").read_text())
    meta["schema_version"] = SCHEMA_VERSION + 1
    (d / "meta.json").write_text(json.dumps(meta))
    with pytest.raises(DatasetError, match="schema version"):
        load_dataset(d)
    with pytest.raises(DatasetError, match="meta.json is missing"):
        load_dataset(tmp_path / "nowhere")


def test_bad_collection_settings():
    with pytest.raises(ValueError, match="worlds must be .hallway. or .lawn."):
        CollectionSettings(worlds=("moon",))
    with pytest.raises(ValueError, match="frames must be an integer >= 2"):
        CollectionSettings(frames=1)


def test_cli_collect_refuses_and_reports(tmp_path, capsys):
    from scripts.cli import main

    args = [
        "collect",
        "--world",
        "lawn",
        "--out",
        str(tmp_path),
        "--frames",
        "3",
        "--jobs",
        "1",
        "--width",
        "32",
        "--height",
        "24",
    ]
    assert main(args) == 0
    assert (
        main(["collect", "--world", "lawn", "--out", str(tmp_path), "--frames", "4", "--jobs", "1"])
        == 2
    )
    assert "other settings" in capsys.readouterr().err
    with pytest.raises(SystemExit):
        main(["collect", "--world", "moon", "--out", str(tmp_path)])


@pytest.mark.parametrize(
    ("change", "match"),
    [
        (lambda e: e.update(file="../../etc/passwd.npz"), "plain file name"),
        (lambda e: e.update(file="/tmp/x.npz"), "plain file name"),
        (lambda e: e.pop("sha256"), "must have the fields"),
        (lambda e: e.update(frames=-3), "frames; expected >= 0"),
        (lambda e: e.update(frames="10"), "frames; expected >= 0"),
        (lambda e: e.update(world="../x"), "has the world"),
    ],
)
def test_a_crafted_meta_is_refused(small_dataset, tmp_path, change, match):
    import shutil

    d = tmp_path / "d"
    shutil.copytree(small_dataset, d)
    meta = json.loads((d / "meta.json").read_text())
    change(next(iter(meta["sequences"].values())))
    (d / "meta.json").write_text(json.dumps(meta))
    with pytest.raises(DatasetError, match=match):
        load_dataset(d)


def test_runs_hand_out_what_the_mapping_methods_take(small_dataset):
    from common.geometry import scan_to_points

    ds = load_dataset(small_dataset)
    runs = ds.runs("lawn")
    assert runs.names == ["lawn-left", "lawn-straight", "lawn-right"]
    assert len(runs) == 18 and runs.groups.tolist() == [0] * 6 + [1] * 6 + [2] * 6
    assert runs.max_range == ds.max_range == SETTINGS.laser.max_range
    seq = ds.sequences["lawn-straight"]
    np.testing.assert_array_equal(runs.odometry[6:12], seq.odometry)
    np.testing.assert_array_equal(runs.poses[6:12], seq.poses)
    np.testing.assert_array_equal(runs.labels, ds.concat("labels"))
    assert runs.images.shape == (18, 36, 48, 3) and runs.ranges.shape == (18, 361)
    np.testing.assert_allclose(runs.scans[7], scan_to_points(seq.scans[1], seq.angles))
    with pytest.raises(ValueError, match=r"no sequence in world 'hallway'.*\['lawn'\]"):
        ds.runs("hallway")


def test_runs_leave_out_readings_at_the_datasets_max_range(small_dataset):
    ds = load_dataset(small_dataset)
    seq = ds.sequences["lawn-left"]
    seq.scans[0, :3] = [np.inf, SETTINGS.laser.max_range, 1.0]  # no return reported two ways
    runs = ds.runs("lawn")
    kept = np.isfinite(seq.scans[0]) & (seq.scans[0] < SETTINGS.laser.max_range)
    assert len(runs.scans[0]) == kept.sum() and kept[2] and not kept[:2].any()


def test_schema_1_still_reads_and_ground_truth_flag_is_checked(small_dataset, tmp_path):
    import shutil

    d = tmp_path / "d"
    shutil.copytree(small_dataset, d)
    meta = json.loads((d / "meta.json").read_text())
    assert meta["ground_truth"] is True
    old = {k: v for k, v in meta.items() if k != "ground_truth"} | {"schema_version": 1}
    (d / "meta.json").write_text(json.dumps(old))
    assert load_dataset(d).has_ground_truth
    (d / "meta.json").write_text(json.dumps({**old, "schema_version": 2}))
    with pytest.raises(DatasetError, match="'ground_truth' must be true or false"):
        load_dataset(d)
    (d / "meta.json").write_text(json.dumps({**meta, "ground_truth": False}))
    with pytest.raises(DatasetError, match=r"holds \['poses', 'labels'\] but meta.json says"):
        load_dataset(d)


def test_arrays_of_the_wrong_shape_are_refused(small_dataset, tmp_path):
    import shutil

    from sim.dataset import file_sha256, load_sequence, write_sequence

    d = tmp_path / "d"
    shutil.copytree(small_dataset, d)
    meta = json.loads((d / "meta.json").read_text())
    name, entry = next(iter(meta["sequences"].items()))
    with np.load(d / entry["file"]) as f:
        arrays = {k: f[k] for k in f.files}
    for key, bad, match in [
        ("poses", arrays["poses"][:, :2], r"poses has shape .*expected \(frames, 3\)"),
        ("angles", arrays["angles"][:-1], "scans have .* beams but angles has"),
        ("images", arrays["images"][..., 0], r"expected \(frames, \*, \*, 3\)"),
    ]:
        write_sequence(d / entry["file"], {**arrays, key: bad})
        with pytest.raises(DatasetError, match=match):
            load_sequence(d, name, {**entry, "sha256": file_sha256(d / entry["file"])})


def test_a_file_is_not_a_dataset_folder(tmp_path):
    (tmp_path / "f").write_text("x")
    with pytest.raises(DatasetError, match="is a file, not a dataset folder"):
        load_dataset(tmp_path / "f")
    with pytest.raises(FileExistsError, match="is a file; give a folder"):
        collect_dataset(tmp_path / "f", CollectionSettings(frames=2), progress=False)
    assert (tmp_path / "f").read_text() == "x"


def test_teleop_jitter_off_drives_the_same_pass_for_every_seed(tmp_path):
    from dataclasses import replace

    from sim.teleop import TeleopConfig

    assert TeleopConfig().scaled(1.0) == TeleopConfig()  # the default dataset is unchanged
    poses = {}
    for jitter in (0.0, 1.0):
        for seed in (3, 4):
            settings = replace(SETTINGS, seed=seed, teleop=TeleopConfig().scaled(jitter))
            path = tmp_path / f"{jitter}-{seed}"
            collect_dataset(path, settings, jobs=1, progress=False)
            poses[jitter, seed] = load_dataset(path).concat("poses")
    np.testing.assert_allclose(poses[0.0, 3], poses[0.0, 4], atol=1e-9)
    assert not np.allclose(poses[1.0, 3], poses[1.0, 4])  # jitter on: two seeds, two passes
    with pytest.raises(ValueError, match="teleop jitter must be a finite number >= 0"):
        TeleopConfig().scaled(-1.0)


def test_cli_teleop_jitter_is_checked(capsys):
    from scripts.cli import main

    with pytest.raises(SystemExit):
        main(["collect", "--world", "lawn", "--out", "x", "--teleop-jitter", "-1"])
    assert "--teleop-jitter" in capsys.readouterr().err


def test_hard_appearance_is_recorded_and_drives_the_same_pass(small_dataset, tmp_path):
    from dataclasses import replace

    hard = replace(SETTINGS, appearance="hard")
    collect_dataset(tmp_path / "hard", hard, jobs=1, progress=False)
    meta = json.loads((tmp_path / "hard" / "meta.json").read_text())
    assert meta["settings"]["appearance"] == "hard"
    # a default dataset's meta has no key (its bytes are those of datasets made before the
    # option), and the two settings are not the same collection
    assert "appearance" not in json.loads((small_dataset / "meta.json").read_text())["settings"]
    with pytest.raises(FileExistsError, match="other settings"):
        collect_dataset(tmp_path / "hard", SETTINGS, jobs=1, progress=False)
    a, b = load_dataset(small_dataset), load_dataset(tmp_path / "hard")
    np.testing.assert_array_equal(a.concat("poses"), b.concat("poses"))  # same drives
    assert not np.array_equal(a.concat("images"), b.concat("images"))  # other looks


def test_bad_appearance_is_refused(capsys):
    from scripts.cli import main

    with pytest.raises(ValueError, match=r"appearance must be one of \('default', 'hard'\)"):
        CollectionSettings(appearance="easy")
    with pytest.raises(SystemExit):
        main(["collect", "--world", "lawn", "--out", "x", "--appearance", "easy"])
    err = capsys.readouterr().err
    assert "--appearance" in err and "'hard'" in err


@pytest.mark.parametrize(
    ("meta", "match"),
    [
        ("[1, 2]", "must hold a JSON object, got a list"),
        ("[" * 100_000, "not valid JSON"),  # deeper than the parser's stack: RecursionError
        (b"\xff\xfe", "not valid JSON"),
        ({"sequences": None}, "'sequences' must be an object"),
        ({"sequences": "drop"}, "the key 'sequences' .* is missing"),
        ({"settings": []}, "'settings' must be an object"),
        ({"settings": {"laser": 20.0}}, r"'settings\.laser' must be an object"),
        (
            {"settings": {"laser": {"max_range": "20"}}},
            r"max_range' must be a number of metres in \(0, 10000\]",
        ),
        (
            {"settings": {"laser": {"max_range": float("nan")}}},
            "max_range' must be a number of metres",
        ),
        ({"manifolds": [1, 2]}, "'manifolds' must be a list of names"),
        ({"complete": "yes"}, "'complete' must be true or false"),
    ],
)
def test_a_tampered_meta_is_a_dataset_error(small_dataset, tmp_path, meta, match):
    """meta.json as untrusted input: a list, JSON nested past the parser's stack, or a key the
    code reads that is missing or of another form is a DatasetError naming the file, never an
    AttributeError, KeyError (servo.maps.build.map_key reads 'sequences') or RecursionError."""
    import shutil

    from sim.dataset import read_meta

    d = tmp_path / "d"
    shutil.copytree(small_dataset, d)
    if isinstance(meta, dict):
        good = json.loads((d / "meta.json").read_text())
        change = {k: v for k, v in meta.items() if v != "drop"}
        meta = json.dumps({k: v for k, v in good.items() if k not in meta} | change)
    path = d / "meta.json"
    path.write_bytes(meta if isinstance(meta, bytes) else meta.encode())
    with pytest.raises(DatasetError, match=match) as caught:
        read_meta(d)
    assert str(path) in str(caught.value)


def test_a_meta_without_laser_settings_cannot_build_a_map(small_dataset, tmp_path):
    import shutil

    from servo.maps.build import build_map

    shutil.copytree(small_dataset, tmp_path / "d")
    meta = json.loads((tmp_path / "d" / "meta.json").read_text())
    del meta["settings"]["laser"]
    (tmp_path / "d" / "meta.json").write_text(json.dumps(meta))
    with pytest.raises(DatasetError, match="no settings.laser.max_range"):
        build_map(tmp_path / "d", "lawn")


def test_frames_that_do_not_fit_in_memory_are_refused_up_front():
    """--frames 10**9 once ran 43 s, wrote meta.json, then died allocating 210 TiB; 10**5
    frames of 320x240 would hold 23 GB per sequence: both are refused by the settings."""
    assert collect_mod.MAX_SEQUENCE_BYTES <= 8 * 2**30
    with pytest.raises(ValueError, match=r"frames must be an integer in \[2, 100000\], got 10*"):
        CollectionSettings(frames=10**9)
    with pytest.raises(ValueError, match=r"frames must be at most 18\d\d\d for 320x240 images"):
        CollectionSettings(frames=100_000)
    with pytest.raises(ValueError, match=r"frames must be at most \d+ for 4096x4096 images and"):
        CollectionSettings(frames=150, camera=CameraConfig(width=4096, height=4096, depth=True))
    assert CollectionSettings(frames=10_000).frames == 10_000  # generous for the usual size


def test_cli_collect_refuses_too_many_frames_before_writing(tmp_path, capsys):
    from scripts.cli import main

    out = tmp_path / "big"
    argv = ["collect", "--world", "hallway", "--out", str(out), "--frames", "1000000000"]
    assert main([*argv, "--jobs", "1"]) == 2
    assert "frames must be an integer in [2, 100000]" in capsys.readouterr().err
    assert not (out / "meta.json").exists()


def test_an_unreadable_meta_is_reported_as_unreadable(tmp_path, capsys):
    """A corrupt meta.json is not "a dataset collected with other settings": the error says
    the file cannot be read and why; --overwrite still replaces it."""
    from dataclasses import replace

    from scripts.cli import main

    (tmp_path / "meta.json").write_text("{oops")
    with pytest.raises(FileExistsError, match="meta.json that cannot be read .*not valid JSON"):
        collect_dataset(tmp_path, SETTINGS, jobs=1, progress=False)
    argv = ["collect", "--world", "lawn", "--out", str(tmp_path), "--frames", "2", "--jobs", "1"]
    assert main(argv) == 2
    err = capsys.readouterr().err
    assert "cannot be read" in err and "other settings" not in err
    assert (tmp_path / "meta.json").read_text() == "{oops"
    tiny = replace(SETTINGS, frames=2, camera=CameraConfig(width=8, height=6))
    collect_dataset(tmp_path, tiny, overwrite=True, jobs=1, progress=False)
    assert load_dataset(tmp_path).meta["complete"]


def test_teleop_jitter_is_capped_where_the_driver_still_finishes(capsys):
    from scripts.cli import main
    from sim.teleop import MAX_JITTER, TeleopConfig

    assert MAX_JITTER == 2.0 and TeleopConfig().scaled(2.0).speed_jitter == pytest.approx(0.24)
    with pytest.raises(ValueError, match=r"teleop jitter must be at most 2.0 .*got 3.5"):
        TeleopConfig().scaled(3.5)
    argv = ["collect", "--world", "hallway", "--out", "x", "--frames", "3", "--jobs", "1"]
    assert main([*argv, "--teleop-jitter", "10"]) == 2
    assert "teleop jitter must be at most 2.0" in capsys.readouterr().err


def test_a_stalled_drive_is_a_value_error_naming_the_teleop_jitter(monkeypatch):
    """Were the driver to stall all the same, the collection says so in one line (exit 2 on
    the command line) rather than with a RuntimeError's traceback."""
    from dataclasses import replace

    from sim.teleop import ScriptedTeleop, TeleopConfig

    monkeypatch.setattr(ScriptedTeleop, "command", lambda self, pose, dt: (0.0, 0.0))
    # a fast nominal speed makes the step budget short: 200 and a few steps
    settings = replace(SETTINGS, frames=2, teleop=TeleopConfig(speed=1000.0))
    with pytest.raises(ValueError, match=r"teleop on lawn-left stalled .*teleop-jitter"):
        collect_mod.collect_sequence(settings, 3, "lawn", "lawn-left")
