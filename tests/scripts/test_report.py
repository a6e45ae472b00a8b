"""The run report: HTML builders on small fake inputs, the pipeline with stub stages, and the
``topomap run`` arguments."""

import json
import re
from pathlib import Path
from types import SimpleNamespace

import numpy as np
import pytest

from scripts import report
from scripts.cli import build_parser
from scripts.cli import main as cli_main
from sim.dataset import Dataset, Sequence

PNG = b"\x89PNG\r\n\x1a\n"


def _grouping_score(frames=10):
    return {
        "frames": frames,
        "groups": 3,
        "purity": 0.95,
        "ari": 0.5,
        "groups_per_manifold": {"hallway": 1, "hallway-left": 2},
        "max_groups_per_manifold": 2,
        "max_groups_touching": 2,
        "max_drift_m": 0.4,
        "seconds": 0.1,
        "meets_targets": True,
    }


GROUPING = {
    "settings": {
        "targets": {"purity_min": 0.9, "max_groups_per_manifold": 3},
        "shown": "odometry+icp",
    },
    "default": {"hallway": {"frames": 10, "sequences": ["a"], "odometry+icp": _grouping_score()}},
    "loop": {},
    "compare": {
        "hallway": {
            "manifold/images": {
                "groups": 2,
                "purity": 0.8,
                "ari": 0.3,
                "max_groups_per_manifold": 1,
                "seconds": 0.2,
            }
        }
    },
    "figures": ["hallway_groups.png"],
}
MANIFOLD = {
    "synthetic": [
        {"set": "spirals_3d", "method": "ours", "error": 0.0, "paper_claim": "ours succeeds"}
    ],
    "real": [
        {
            "sensor": "images",
            "features": "raw pixels",
            "method": "ours",
            "train_error": 0.01,
            "test_error": 0.02,
            "paper_error": 0.0289,
        },
        {
            "sensor": "scans",
            "features": "laser ranges",
            "method": "self-tuning",
            "train_error": 0.3,
            "test_error": 0.4,
            "paper_error": None,
        },
    ],
    "figures": ["manifold/real_labels.png"],
    "timings": {"synthetic": 1.0},
}
_PAIR = {
    "episodes": 2,
    "success_rate": 0.5,
    "success_ci95": [0.09, 0.91],
    "spl": 0.4,
    "final_distance": 0.3,
    "collisions": 0.0,
}
SERVO = {
    "world": "hallway",
    "policy": "servo",
    **_PAIR,
    "successes": 1,
    "final_heading_error_deg": 5.0,
    "steps": 80.0,
    "act_ms": 3.0,
    "reasons": {"success": 1, "timeout": 1},
    "per_pair": {"hallway -> hallway-left": _PAIR},
    "plot": "servo/hallway-servo-trajectories.png",
}
INFO = {
    "command": "topomap run --seed 0",
    "settings": {"seed": 0, "episodes": 2},
    "versions": {"numpy": "2.0"},
    "machine": {"cores (os.cpu_count)": "2"},
    "commit": "abc123",
    "timings": {"dataset": 1.5, "servo": 3.0},
    "total": 4.5,
}


def _all_sections():
    worlds = {
        "topdown": {"hallway": "worlds/hallway_topdown.png"},
        "manifolds": {"hallway": {"image": "worlds/hallway_samples.png", "frames": [["s", 3]]}},
    }
    return [
        report.section_worlds(worlds),
        report.section_manifold(MANIFOLD),
        report.section_grouping(GROUPING, prefix="grouping/"),
        report.section_servo([SERVO], {"hallway/servo": ["servo/hallway-servo-episode0.mp4"]}),
        report.section_reproduce(INFO),
    ]


def test_table_has_a_caption_and_formats_cells():
    html = report.table("Errors <of> things", ("a", "b", "c"), [[0.12345, None, "x&y"]])
    assert "<caption>Errors &lt;of&gt; things</caption>" in html
    assert "<td>0.123</td><td>&ndash;</td><td>x&amp;y</td>" in html
    assert html.count("<th>") == 3


@pytest.mark.parametrize(
    ("value", "text"),
    [
        (0.0289, "0.029"),
        (12.345, "12.35"),
        (132.0, "132.0"),
        (np.bool_(True), "yes"),
        (False, "no"),
        (("servo", "oracle"), "servo, oracle"),
        (None, "&ndash;"),
        (7, "7"),
    ],
)
def test_cells_are_formatted_for_reading(value, text):
    assert report.fmt(value) == text


def test_page_has_every_section_in_its_table_of_contents():
    page = report.build_html("title", _all_sections())
    for anchor in ("worlds", "manifold", "grouping", "servo", "reproduce"):
        assert f'<section id="{anchor}">' in page
        assert f'href="#{anchor}"' in page
    assert page.count("<caption>") >= 9
    # the paper's numbers stand beside ours, None as a dash
    assert "<td>0.020</td><td>0.029</td>" in page
    assert "<td>0.400</td><td>&ndash;</td>" in page
    assert "ours succeeds" in page
    # no external resource
    assert not re.search(r'(src|href)="(https?:)?//', page)


def test_referenced_files_lists_images_and_videos_not_anchors():
    refs = report.referenced_files(report.build_html("t", _all_sections()))
    assert "grouping/hallway_groups.png" in refs
    assert "manifold/real_labels.png" in refs
    assert "servo/hallway-servo-episode0.mp4" in refs
    assert "servo/hallway-servo-trajectories.png" in refs
    assert not [r for r in refs if r.startswith("#")]


def _touch_all(root: Path, page: str) -> None:
    for ref in report.referenced_files(page):
        (root / ref).parent.mkdir(parents=True, exist_ok=True)
        (root / ref).write_bytes(PNG)


def test_write_report_refuses_a_missing_image(tmp_path):
    page = report.build_html("t", _all_sections())
    _touch_all(tmp_path, page)
    (tmp_path / "grouping/hallway_groups.png").unlink()
    with pytest.raises(FileNotFoundError, match="hallway_groups.png"):
        report.write_report(tmp_path, page)
    assert not (tmp_path / report.INDEX).exists()


def test_write_report_is_atomic(tmp_path, monkeypatch):
    page = report.build_html("t", _all_sections())
    _touch_all(tmp_path, page)
    path = report.write_report(tmp_path, page)
    assert path.read_text() == page

    def no_space(src, dst):
        raise OSError("disk full")

    monkeypatch.setattr("os.replace", no_space)
    with pytest.raises(OSError, match="disk full"):
        report.write_report(tmp_path, page.replace("<h1>", "<h1>new "))
    assert path.read_text() == page  # the old report is intact, no temporary file left
    assert sorted(p.name for p in tmp_path.iterdir() if p.is_file()) == [report.INDEX]


def _fake_dataset(world="hallway"):
    from scenes import MANIFOLD_IDS, MANIFOLDS

    n = 8
    poses = np.stack([np.linspace(1.0, 6.0, n), np.zeros(n), np.zeros(n)], axis=1)
    labels = np.array([MANIFOLD_IDS[world]] * 5 + [MANIFOLD_IDS[f"{world}-left"]] * 3, np.int16)
    angles = np.linspace(-np.pi / 2, np.pi / 2, 9, dtype=np.float32)
    seq = Sequence(
        name=f"{world}-left",
        world=world,
        images=np.full((n, 24, 32, 3), 128, np.uint8),
        scans=np.full((n, 9), 2.0, np.float32),
        angles=angles,
        poses=poses,
        odometry=poses,
        commands=np.zeros((n, 2)),
        labels=labels,
        times=np.arange(n, dtype=float),
    )
    return Dataset(Path("fake"), {"manifolds": list(MANIFOLDS)}, {seq.name: seq})


def test_stage_worlds_writes_one_image_per_world_and_manifold(tmp_path):
    result = report.stage_worlds(_fake_dataset(), tmp_path / "worlds", tmp_path)
    assert list(result["topdown"]) == ["hallway"]
    assert list(result["manifolds"]) == ["hallway", "hallway-left"]
    assert result["manifolds"]["hallway-left"]["frames"] == [
        ["hallway-left", 5],
        ["hallway-left", 6],
        ["hallway-left", 7],
    ]
    images = [*result["topdown"].values(), *(m["image"] for m in result["manifolds"].values())]
    for rel in [*images, result["sheet"]]:
        assert (tmp_path / rel).read_bytes()[:8] == PNG
    import cv2

    row = cv2.imread(str(tmp_path / result["manifolds"]["hallway"]["image"]))
    assert row.shape == (24, 3 * 32 + 24, 3)  # three frames and a square map crop


def _fake_stages(fail: str | None = None, **runs):
    """The default stages with fake work injected (no patching): the fake dataset, and each
    evaluation returning the tests' result and writing the files its section links to; the
    ``worlds`` stage runs for real. ``fail`` names a stage that raises; ``runs`` replace more."""
    from sim.collect import CollectionSettings

    dataset = _fake_dataset()

    def stage(name, result, files):
        def run(ctx):
            if name == fail:
                raise RuntimeError("boom")
            for f in files:
                (ctx.root / f).parent.mkdir(parents=True, exist_ok=True)
                (ctx.root / f).write_bytes(PNG)
            return result

        return run

    fakes = {
        "dataset": stage(
            "dataset", {"dataset": dataset, "collection": CollectionSettings(seed=0)}, []
        ),
        "manifold": stage("manifold", MANIFOLD, MANIFOLD["figures"]),
        "grouping": stage("grouping", GROUPING, ["grouping/hallway_groups.png"]),
        "servo": stage("servo", {"results": [SERVO], "videos": {}}, [SERVO["plot"]]),
    }
    return report.replace_runs(report.STAGES, **{**fakes, **runs})


def test_run_pipeline_writes_a_complete_report(tmp_path):
    settings = report.RunSettings(seed=3, episodes=2)
    index = report.run_pipeline(tmp_path, settings, progress=False, stages=_fake_stages())
    assert index == tmp_path / "report" / report.INDEX
    page = index.read_text()
    for ref in report.referenced_files(page):
        assert (index.parent / ref).is_file(), ref
    data = json.loads((index.parent / "report.json").read_text())
    assert data["info"]["settings"]["seed"] == 3
    assert data["info"]["settings"]["dataset"].endswith("(1 sequences, 8 frames)")
    stages = {"dataset", "worlds", "manifold", "seeds", "grouping", "servo", "leaderboards"}
    assert set(data["info"]["timings"]) == stages
    assert "numpy" in data["info"]["versions"]
    assert list(data) == ["summary", "worlds", "manifold", "seeds", "servo", "grouping", "info"]
    assert [line["task"].split(" (")[0] for line in data["summary"]] == [
        "manifold clustering",
        "observation grouping",
        "servo: ManifoldServo",
    ]
    assert page.index('<section id="summary">') < page.index('<section id="worlds">')
    assert data["seeds"] == {"source": None, "rows": []}  # no --protocol: said, not computed
    assert "Not part of this run" in page and "topomap run --protocol DIR" in page
    assert data["grouping"] == "grouping/grouping.json"
    assert "<h2>Reproducing this report</h2>" in page
    # the committed leaderboards, read and not run: ours beside outside methods on each task
    assert page.index('<section id="servo">') < page.index('<section id="leaderboards">')
    assert "HDBSCAN" in page and "DBSCAN" in page and "nearest_view_homing" in page


def test_the_leaderboards_section_ranks_the_committed_files_per_task():
    from scripts.report.provenance import REPO_ROOT
    from scripts.report.sections import section_leaderboards
    from scripts.report.stages import stage_leaderboards

    result = stage_leaderboards()
    assert result["missing"] is None
    assert [b["task"] for b in result["boards"]] == ["manifold", "grouping", "servo"]
    for board in result["boards"]:
        methods = {row[1] for _, _, rows in board["tables"] for row in rows}
        assert len(methods) >= 3, (board["task"], methods)  # ours and at least two outside
        assert all((REPO_ROOT / f).is_file() for f in board["files"])
    servo = result["boards"][2]["tables"][0]
    assert servo[1][5].startswith("paired vs servo") and servo[2][1][5] == "reference"
    html = section_leaderboards(result)
    assert html.count("<table>") == sum(len(b["tables"]) for b in result["boards"])


def test_without_the_committed_files_the_leaderboards_section_says_so(tmp_path):
    from scripts.report.sections import section_leaderboards
    from scripts.report.stages import stage_leaderboards

    result = stage_leaderboards(tmp_path)
    assert result["boards"] == [] and "no committed result files" in result["missing"]
    assert "no committed result files" in section_leaderboards(result)


def test_a_failing_stage_fails_the_run_and_names_the_stage(tmp_path):
    stages = _fake_stages(fail="grouping", worlds=lambda ctx: {"topdown": {}, "manifolds": {}})
    with pytest.raises(report.StageError, match=r"stage 'grouping' failed .*RuntimeError: boom"):
        report.run_pipeline(tmp_path, progress=False, stages=stages)
    assert not (tmp_path / "report" / report.INDEX).exists()


def test_the_pipeline_runs_the_stages_it_is_given_in_order(tmp_path, capsys):
    """A registry of other stages: each gets its folder and its section, in the given order,
    and sees the results of the stages before it."""
    dataset_stage = _fake_stages()[0]
    seen = []

    def note(ctx):
        seen.append(sorted(ctx.results))
        (ctx.dir("notes") / "a.png").write_bytes(PNG)
        return {"worlds": ctx.worlds}

    stages = [
        report.Stage("notes", note, section=lambda r, ctx: report.section("notes", "Notes")),
        dataset_stage,
        report.Stage("after", lambda ctx: {"n": len(ctx.results)}, folder=False, recorded=False),
    ]
    with pytest.raises(report.StageError, match="stage 'notes' failed .*KeyError"):
        report.run_pipeline(tmp_path / "a", progress=False, stages=stages)  # no dataset yet
    stages = [stages[1], stages[0], stages[2]]
    index = report.run_pipeline(tmp_path / "b", progress=True, stages=stages)
    assert seen == [[], ["dataset"]]
    page = index.read_text()
    assert page.index('<section id="notes">') < page.index('<section id="reproduce">')
    assert '<section id="worlds">' not in page
    data = json.loads((index.parent / "report.json").read_text())
    assert list(data) == ["summary", "notes", "info"] and data["notes"] == {"worlds": ["hallway"]}
    assert data["summary"] == [] and '<section id="summary">' not in page  # no task of its own
    assert list(data["info"]["timings"]) == ["dataset", "notes", "after"]
    assert sorted(p.name for p in index.parent.iterdir()) == ["index.html", "notes", "report.json"]
    out = capsys.readouterr().out
    assert out.index("== stage dataset") < out.index("== stage notes") < out.index("== stage after")


def _protocol_folder(path: Path, errors: dict[str, dict[int, float]]) -> Path:
    """A folder as ``scripts.manifold.protocol`` writes it: one cell per seed, with the test
    error of each method given as {method: {seed: error}}."""
    (path / "cells").mkdir(parents=True)
    seeds = sorted({seed for by_seed in errors.values() for seed in by_seed})
    for seed in seeds:
        rows = [{"method": m, "test_error": e[seed]} for m, e in errors.items() if seed in e]
        cell = {"condition": "hard", "features": "hsv", "seed": seed, "rows": rows}
        (path / "cells" / f"hard-hsv-{seed}.json").write_text(json.dumps(cell))
    return path


def _row(page: str, method: str) -> list[str]:
    """The cells of ``method``'s row in the page's first table that has one."""
    match = re.search(rf"<tr><td>{re.escape(method)}</td>(.*?)</tr>", page)
    assert match, method
    return re.findall(r"<td>(.*?)</td>", match.group(1))


def test_the_report_shows_the_error_of_every_seed_from_a_protocol_folder(tmp_path):
    errors = {
        "ours": {0: 0.03, 1: 0.2, 2: 0.1, 3: 0.15},
        "scikit-learn kNN (k=10)": {0: 0.12, 1: 0.05, 3: 0.07},  # seed 2 not run
    }
    folder = _protocol_folder(tmp_path / "proto", errors)
    settings = report.RunSettings(protocol=str(folder))
    index = report.run_pipeline(tmp_path / "out", settings, progress=False, stages=_fake_stages())
    page = index.read_text()
    assert page.index('<section id="manifold">') < page.index('<section id="seeds">')
    assert "condition hard, features hsv" in page and str(folder) in page
    # dev seed, seeds 1-3, min / median / max of the fresh seeds, then the mean and interval
    ours = _row(page, "ours")
    assert ours[:7] == ["0.030", "0.200", "0.100", "0.150", "0.100", "0.150", "0.200"]
    assert ours[7].startswith("0.150 [")
    knn = _row(page, "scikit-learn kNN (k=10)")
    assert knn[:7] == ["0.120", "0.050", "&ndash;", "0.070", "0.050", "0.060", "0.070"]
    data = json.loads((index.parent / "report.json").read_text())
    by_method = {r["method"]: r for r in data["seeds"]["rows"]}
    assert by_method["ours"]["seeds"] == [1, 2, 3] and by_method["ours"]["dev_error"] == 0.03


def test_a_protocol_folder_is_checked(tmp_path, capsys):
    with pytest.raises(ValueError, match="protocol must be a folder written by"):
        report.RunSettings(protocol=str(tmp_path / "nope"))
    assert cli_main(["run", "--protocol", str(tmp_path / "nope"), "--quiet"]) == 2
    assert "protocol must be a folder" in capsys.readouterr().err
    (tmp_path / "empty" / "cells").mkdir(parents=True)
    with pytest.raises(ValueError, match="holds no cells"):
        report.stage_protocol(tmp_path / "empty")
    bad = _protocol_folder(tmp_path / "bad", {"ours": {1: 1.5}})
    with pytest.raises(ValueError, match=r"hard-hsv-1.json: not a protocol cell .*test_error"):
        report.stage_protocol(bad)


def test_replace_runs_refuses_an_unknown_stage():
    with pytest.raises(KeyError, match="teleport"):
        report.replace_runs(report.STAGES, teleport=lambda ctx: {})
    assert report.replace_runs(report.STAGES) == report.STAGES


def test_python_dash_m_takes_the_run_arguments():
    import subprocess
    import sys

    root = Path(__file__).resolve().parents[2]
    out = subprocess.run(
        [sys.executable, "-m", "scripts.report", "--help"],
        cwd=root,
        capture_output=True,
        text=True,
        timeout=120,
    )
    assert out.returncode == 0, out.stderr
    assert "--episodes" in out.stdout and "--baselines" in out.stdout


@pytest.mark.parametrize(
    ("kwargs", "match"),
    [
        ({"episodes": 0}, "episodes"),
        ({"videos": -1}, "videos"),
        ({"policies": ()}, "policies"),
        ({"seed": -1}, "seed must be an integer >= 0, got -1"),
    ],
)
def test_run_settings_refuse_bad_values(kwargs, match):
    with pytest.raises(ValueError, match=match):
        report.RunSettings(**kwargs)


# --------------------------------------------------------------------------- topomap run


def test_run_arguments_default_and_custom():
    args = build_parser().parse_args(["run"])
    assert (args.out, args.seed, args.episodes, args.baselines) == (
        "out",
        0,
        20,
        ("signal",),
    )
    args = build_parser().parse_args(
        ["run", "--out", "x", "--seed", "7", "--episodes", "2", "--baselines", "greedy,random"]
    )
    assert (args.out, args.seed, args.episodes, args.baselines) == ("x", 7, 2, ("greedy", "random"))


@pytest.mark.parametrize(
    "argv", [["run", "--episodes", "0"], ["run", "--baselines", "teleport"], ["run", "--jobs", "0"]]
)
def test_run_refuses_bad_arguments(argv, capsys):
    with pytest.raises(SystemExit) as exit_info:
        build_parser().parse_args(argv)
    assert exit_info.value.code == 2
    assert "error" in capsys.readouterr().err


def test_cmd_run_passes_settings_and_reports_a_failed_stage(tmp_path, monkeypatch, capsys):
    seen = {}

    def fake_pipeline(out, settings, *, progress, command):
        seen.update(out=out, settings=settings, progress=progress, command=command)
        raise report.StageError("stage 'servo' failed after 1.0 s: RuntimeError: no map")

    monkeypatch.setattr(report, "run_pipeline", fake_pipeline)
    argv = ["run", "--out", str(tmp_path), "--seed", "5", "--episodes", "3", "--quiet"]
    assert cli_main([*argv, "--baselines", "servo,oracle", "--videos", "0"]) == 1
    s = seen["settings"]
    assert (s.seed, s.episodes, s.policies, s.videos) == (5, 3, ("servo", "oracle"), 0)
    assert seen["out"] == str(tmp_path) and seen["progress"] is False
    assert "--seed 5" in seen["command"] and "--baselines oracle" in seen["command"]
    assert "topomap run: stage 'servo' failed" in capsys.readouterr().err


def test_cmd_run_refuses_bad_settings_without_a_traceback(monkeypatch, capsys):
    assert cli_main(["run", "--videos", "-2", "--quiet"]) == 2
    assert "videos must be an integer >= 0" in capsys.readouterr().err


def test_cmd_run_refuses_a_negative_seed_before_making_any_folder(tmp_path, capsys):
    """--seed -1 once failed the dataset stage with a traceback, leaving out/report behind."""
    out = tmp_path / "out"
    with pytest.raises(SystemExit) as exit_:  # argparse's own refusal, exit 2
        cli_main(["run", "--seed", "-1", "--out", str(out), "--quiet"])
    assert exit_.value.code == 2
    err = capsys.readouterr().err
    assert "--seed: expected an integer >= 0" in err and "Traceback" not in err
    assert not out.exists()


def test_cmd_run_explains_a_dataset_of_other_settings(monkeypatch, capsys):
    def fake_pipeline(out, settings, *, progress, command):
        try:
            raise FileExistsError("out/dataset already holds a dataset collected with other")
        except FileExistsError as err:
            raise report.StageError("stage 'dataset' failed") from err

    monkeypatch.setattr(report, "run_pipeline", fake_pipeline)
    assert cli_main(["run", "--seed", "9", "--quiet"]) == 2
    err = capsys.readouterr().err
    assert "already holds a dataset" in err and "give another --out" in err
    assert "Traceback" not in err


def _stub_internals(monkeypatch):
    """Stub what the stages call (not the stages): the stages' own path handling runs as in a
    real run, each stub writing its files where the real function would."""
    dataset = _fake_dataset()
    monkeypatch.setattr("sim.collect.collect_dataset", lambda *a, **k: None)
    monkeypatch.setattr("sim.dataset.load_dataset", lambda *a, **k: dataset)

    def reproduce(data_dir, out_dir, progress=True):
        (Path(out_dir) / "real_labels.png").write_bytes(PNG)
        return {**MANIFOLD, "figures": ["real_labels.png"]}

    def evaluate_grouping(dataset, out_dir, loop=False, progress=True):
        (Path(out_dir) / "hallway_groups.png").write_bytes(PNG)
        return GROUPING

    def evaluate(world, episodes, seed, policy="servo", *, out=None, videos=0, **kw):
        plot = Path(out) / f"{world}-{policy}-trajectories.png"  # as given: here relative
        plot.write_bytes(PNG)
        for i in range(videos):
            (Path(out) / f"{world}-{policy}-episode{i}.mp4").write_bytes(b"mp4")
        return {**SERVO, "world": world, "policy": policy, "plot": str(plot)}

    monkeypatch.setattr("scripts.manifold.reproduce.reproduce", reproduce)
    monkeypatch.setattr("scripts.grouping.evaluate.evaluate_grouping", evaluate_grouping)

    def run_protocol(protocol, servo_map, episodes, policy="servo", *, plot=None, **kw):
        Path(plot).write_bytes(PNG)
        return {
            **SERVO,
            "world": protocol.world,
            "policy": policy,
            "tier": protocol.tier,
            "split": protocol.split,
            "plot": str(plot),
        }

    monkeypatch.setattr("servo.task.evaluation.evaluate", evaluate)
    monkeypatch.setattr("servo.task.protocol.run_protocol", run_protocol)
    monkeypatch.setattr(
        "servo.maps.build.load_or_build", lambda *a, **k: SimpleNamespace(key="0123456789abcdef")
    )


def test_run_with_the_default_relative_out_links_every_file(tmp_path, monkeypatch, capsys):
    """`topomap run` as the README gives it (default ``--out out``), from a fresh working
    directory: the page's links resolve from the report folder, not the working directory."""
    _stub_internals(monkeypatch)
    monkeypatch.chdir(tmp_path)
    assert cli_main(["run", "--quiet"]) == 0
    index = tmp_path / "out" / "report" / report.INDEX
    refs = report.referenced_files(index.read_text())
    assert any(r.endswith(".mp4") for r in refs) and any("manifold/" in r for r in refs)
    for ref in refs:
        assert not Path(ref).is_absolute() and not ref.startswith("out/"), ref
        assert (index.parent / ref).is_file(), ref
    assert "report:" in capsys.readouterr().out


@pytest.mark.parametrize("kind", ["file", "under a file"])
def test_run_refuses_an_output_folder_it_cannot_write(tmp_path, capsys, kind):
    (tmp_path / "f").write_text("not a folder")
    out = tmp_path / "f" if kind == "file" else tmp_path / "f" / "out"
    assert cli_main(["run", "--out", str(out), "--quiet"]) == 2
    err = capsys.readouterr().err
    assert "--out must be a folder this user can write" in err and "Traceback" not in err
    assert (tmp_path / "f").read_text() == "not a folder"


def test_check_report_finds_missing_and_outside_links(tmp_path, capsys):
    from scripts.check_report import main, problems

    (tmp_path / "a.png").write_bytes(PNG)
    figures = [report.figure(f, f) for f in ("a.png", "b.png", "../x.png")]
    page = report.build_html("t", [report.section("s", "S", *figures)])
    (tmp_path.parent / "x.png").write_bytes(PNG)
    index = tmp_path / report.INDEX
    index.write_text(page)
    assert problems(index) == [
        "../x.png: not a path inside " + str(tmp_path.resolve()),
        "b.png: missing",
    ]
    assert main([str(index)]) == 1
    assert "b.png: missing" in capsys.readouterr().err
    assert problems(tmp_path / "nope.html") == [f"{tmp_path / 'nope.html'} does not exist"]
    (tmp_path / "b.png").write_bytes(PNG)
    index.write_text(page.replace("../x.png", "a.png"))
    assert main([str(index)]) == 0


def test_protocol_provenance_is_shown_and_checked(tmp_path):
    folder = _protocol_folder(tmp_path / "proto", {"ours": {0: 0.03, 1: 0.2}})
    (folder / "meta.json").write_text(json.dumps({"command": "python -m x <b>", "commit": "abc"}))
    result = report.stage_protocol(folder)
    assert result["made"] == {"command": "python -m x <b>", "commit": "abc"}
    page = report.section_protocol(result)
    assert "command: python -m x &lt;b&gt;" in page and "commit: abc" in page
    (folder / "meta.json").write_text(json.dumps({"command": ["not", "a", "string"]}))
    with pytest.raises(ValueError, match="meta.json: must be a JSON object of strings"):
        report.stage_protocol(folder)
    (folder / "meta.json").write_text("[" * 100_000)  # RecursionError before: no ValueError
    with pytest.raises(ValueError, match="meta.json: not JSON"):
        report.stage_protocol(folder)


def test_run_shows_the_committed_protocol_cells_unless_told_not_to():
    from scripts.cli import _protocol_folder as chosen
    from scripts.report.settings import COMMITTED_PROTOCOL

    committed = chosen("committed")
    assert committed == (
        str(COMMITTED_PROTOCOL) if (COMMITTED_PROTOCOL / "cells").is_dir() else None
    )
    assert chosen("none") is None and chosen("some/dir") == "some/dir"
    if committed is not None:  # the repository's own cells pass the report's checks
        result = report.stage_protocol(committed)
        assert result["source"] == "docs/results/data/manifold/protocol" and result["rows"]
