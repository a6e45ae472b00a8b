"""The end-to-end run behind ``topomap run``: collect, evaluate, and write one HTML report.

    topomap run [--out out] [--seed 0] [--episodes 4] [--baselines oracle,random]

Stages (each a function below, each writing into its own folder of ``<out>/report/``, each
timed; a failing stage stops the run with :class:`StageError` naming it):

1. ``worlds``: a top-down view per world with the dataset's trajectories, and per manifold
   sample camera frames beside the laser scan drawn on the map (``worlds/``);
2. ``manifold``: the manifold-clustering reproduction (``scripts.reproduce_manifold``):
   synthetic and real tables with the paper's numbers beside ours, and its figures;
3. ``grouping``: the observation grouping (``scripts.eval_grouping``): tables, laser groups,
   local maps, topological graph and weights;
4. ``servo``: closed-loop servoing (``servo.evaluate``) per world, the servo policy and the
   baselines: results per manifold pair, trajectories on the map, episode videos.

``index.html`` references the PNGs and mp4s beside it by relative paths (no external
resource) and ends with what is needed to reproduce it: settings, seed, versions, commit,
machine and timings. ``report.json`` holds every number. The HTML is built by small functions
(``section_*``) of plain dicts, so each can be tested on fake inputs.
"""

from __future__ import annotations

import html
import json
import os
import platform
import re
import subprocess
import tempfile
import time
from collections.abc import Callable, Iterable, Sequence
from dataclasses import asdict, dataclass, field
from pathlib import Path

import numpy as np

from scenes.fileio import atomic_write_bytes

__all__ = [
    "OutputError",
    "RunSettings",
    "StageError",
    "build_html",
    "referenced_files",
    "run_pipeline",
    "write_report",
]

REPORT_DIR = "report"
INDEX = "index.html"
VERSION_PACKAGES = ("mujoco", "gymnasium", "numpy", "scipy", "opencv-python-headless", "tqdm")
PAPER = {
    "manifold": "Grudic & Mulligan, topological mapping with visual manifolds",
    "grouping": "Blanco et al., observation grouping by sensed-space overlap",
}


@dataclass(frozen=True)
class RunSettings:
    """What ``topomap run`` does; the defaults finish within 10 minutes on 2 cores.

    seed : seeds the dataset and the servo episodes.
    episodes : servo episodes per world and policy.
    policies : servo policies evaluated (``servo`` first; see ``servo.evaluate.POLICIES``).
    videos : episode videos per world, of the ``servo`` policy.
    grouping_loop : also drive and group a loop through each world (``eval_grouping``).
    jobs : worker processes for the collection (None: one per core).
    """

    seed: int = 0
    episodes: int = 4
    policies: tuple[str, ...] = ("servo", "oracle", "random")
    videos: int = 1
    grouping_loop: bool = False
    jobs: int | None = None

    def __post_init__(self):
        if int(self.episodes) != self.episodes or self.episodes < 1:
            raise ValueError(f"episodes must be an integer >= 1, got {self.episodes}")
        if int(self.videos) != self.videos or self.videos < 0:
            raise ValueError(f"videos must be an integer >= 0, got {self.videos}")
        if not self.policies:
            raise ValueError("policies is empty")


class StageError(RuntimeError):
    """A stage of the run failed; the message names it and how long it ran."""


class OutputError(ValueError):
    """The output folder cannot be created or written."""


# --------------------------------------------------------------------------- HTML pieces


def esc(value) -> str:
    return html.escape(str(value), quote=True)


def fmt(value, digits: int = 3) -> str:
    """A table cell: floats to ``digits`` decimals below 10 (fewer above: 12.35, 123.5), None
    as a dash, booleans as yes / no, lists comma-separated."""
    if value is None:
        return "&ndash;"
    if isinstance(value, bool | np.bool_):
        return "yes" if value else "no"
    if isinstance(value, float | np.floating):
        size = abs(float(value))
        return f"{value:.{max(0, digits - (size >= 10) - (size >= 100))}f}"
    if isinstance(value, list | tuple):
        return esc(", ".join(map(str, value)))
    return esc(value)


def table(caption: str, header: Sequence[str], rows: Iterable[Sequence]) -> str:
    """An HTML table with a caption; cells go through :func:`fmt`."""
    head = "".join(f"<th>{esc(h)}</th>" for h in header)
    body = "\n".join("<tr>" + "".join(f"<td>{fmt(c)}</td>" for c in row) + "</tr>" for row in rows)
    return (
        f"<table>\n<caption>{esc(caption)}</caption>\n<thead><tr>{head}</tr></thead>\n"
        f"<tbody>\n{body}\n</tbody>\n</table>"
    )


def figure(src: str, caption: str) -> str:
    """An image by relative path, with a caption; clicking opens it full size."""
    src = esc(Path(src).as_posix())
    return (
        f'<figure><a href="{src}"><img src="{src}" alt="{esc(caption)}"></a>'
        f"<figcaption>{esc(caption)}</figcaption></figure>"
    )


def section(anchor: str, title: str, *parts: str) -> str:
    return (
        f'<section id="{esc(anchor)}">\n<h2>{esc(title)}</h2>\n' + "\n".join(parts) + "\n</section>"
    )


def _rel(path, root: Path) -> str:
    """``path`` relative to the report root (paths may come absolute or relative to it)."""
    p = Path(path)
    return (p.resolve().relative_to(root.resolve()) if p.is_absolute() else p).as_posix()


# --------------------------------------------------------------------------- sections


def section_worlds(result: dict) -> str:
    """``result``: {"topdown": {world: path}, "manifolds": {manifold: {"image", "frames"}}}
    (paths relative to the report's root)."""
    parts = [
        "<p>Top-down views: manifold regions in colour, obstacles dark, the dataset's true "
        "trajectories on them. Per manifold: three camera frames spread over its stretch of "
        "the route and, right, a 16 m square of the map around the robot at the middle frame "
        "with its laser scan (red: every 8th ray and every hit).</p>",
        '<div class="row">',
        *(figure(p, f"{w}: top-down view and trajectories") for w, p in result["topdown"].items()),
        "</div>",
    ]
    for name, entry in result["manifolds"].items():
        frames = ", ".join(f"{s} #{i}" for s, i in entry["frames"])
        parts.append(figure(entry["image"], f"{name}: frames {frames}; laser on the map"))
    return section("worlds", "The worlds", *parts)


def section_manifold(result: dict) -> str:
    """``result`` of ``scripts.reproduce_manifold.reproduce`` (paths relative to the root)."""
    synthetic = table(
        "Synthetic sets: clustering error, ours beside the paper's claim",
        ("set", "method", "error", "paper"),
        ([r["set"], r["method"], r["error"], r.get("paper_claim")] for r in result["synthetic"]),
    )
    real = table(
        "Simulated image and laser sequences: clustering error on the map (train: every "
        "second frame) and on the other frames (test), beside the paper's",
        ("sensor", "features", "method", "train error", "test error", "paper"),
        (
            [
                r["sensor"],
                r["features"],
                r["method"],
                r["train_error"],
                r.get("test_error"),
                r.get("paper_error"),
            ]
            for r in result["real"]
        ),
    )
    figs = [figure(p, Path(p).stem.replace("_", " ")) for p in result.get("figures", [])]
    return section(
        "manifold",
        f"Manifold clustering ({PAPER['manifold']})",
        "<p>Error: the fraction of points in the wrong cluster after the best matching of "
        "clusters to true manifolds. See docs/manifold-clustering.md for the choices made "
        "where the paper is ambiguous.</p>" + _no_labels_note(result),
        synthetic,
        real,
        '<div class="row">',
        *figs,
        "</div>",
    )


def section_grouping(result: dict, prefix: str = "") -> str:
    """``result`` of ``scripts.eval_grouping.evaluate_grouping``; figures under ``prefix``."""
    rows = []
    for part in ("default", "loop"):
        for world, entry in result.get(part, {}).items():
            for variant, s in entry.items():
                if isinstance(s, dict):
                    per = " / ".join(str(v) for v in s["groups_per_manifold"].values())
                    tag = f"{world}-loop" if part == "loop" else world
                    rows.append(
                        [
                            tag,
                            variant,
                            s["frames"],
                            s["groups"],
                            s["purity"],
                            s["ari"],
                            per,
                            s["max_drift_m"],
                            s["seconds"],
                            s["meets_targets"],
                        ]
                    )
    targets = result.get("settings", {}).get("targets", {})
    purity_min, max_groups = targets.get("purity_min"), targets.get("max_groups_per_manifold")
    parts = [
        "<p>Each world's three sequences are grouped together in one observation graph; groups "
        f"are scored against the true manifolds. Targets: purity &ge; "
        f"{fmt(purity_min, 2)}, at most {fmt(max_groups)} "
        "groups per manifold. See docs/observation-grouping.md.</p>" + _no_labels_note(result),
        table(
            "Laser observation grouping per world and pose source",
            (
                "case",
                "poses",
                "frames",
                "groups",
                "purity",
                "ARI",
                "groups per manifold",
                "max drift (m)",
                "time (s)",
                "targets met",
            ),
            rows,
        ),
    ]
    compare = [
        [
            world,
            name,
            s["groups"],
            s["purity"],
            s["ari"],
            s["max_groups_per_manifold"],
            s["seconds"],
        ]
        for world, entries in result.get("compare", {}).items()
        for name, s in entries.items()
    ]
    if compare:
        parts.append(
            table(
                "Both methods on both sensors (method / sensor)",
                (
                    "world",
                    "method / sensor",
                    "groups",
                    "purity",
                    "ARI",
                    "max groups per manifold",
                    "time (s)",
                ),
                compare,
            )
        )
    parts.append('<div class="row">')
    for name in result.get("figures", []):
        parts.append(figure(f"{prefix}{name}", Path(name).stem.replace("_", " ")))
    parts.append("</div>")
    return section("grouping", f"Observation grouping ({PAPER['grouping']})", *parts)


def _no_labels_note(result: dict) -> str:
    """A note for results of a dataset without ground truth (imported from a robot's log)."""
    if result.get("ground_truth", True):
        return ""
    return (
        "<p><strong>No ground-truth labels</strong> in this dataset (imported from a robot's "
        "log): the methods ran and their clusters and figures are here, but nothing can be "
        "scored (&ndash;).</p>"
    )


def section_servo(results: Sequence[dict], videos: dict[str, list[str]]) -> str:
    """``results``: ``servo.evaluate.evaluate`` dicts (with ``plot`` relative to the root);
    ``videos``: per "world/policy", video paths relative to the root."""
    summary = table(
        "Closed-loop servoing per world and policy (final distance and heading error: median)",
        (
            "world",
            "policy",
            "episodes",
            "success rate",
            "SPL",
            "final distance (m)",
            "heading error (deg)",
            "steps (successes)",
            "collisions",
            "act (ms)",
            "end reasons",
        ),
        (
            [
                r["world"],
                r["policy"],
                r["episodes"],
                r["success_rate"],
                r["spl"],
                r["final_distance"],
                r["final_heading_error_deg"],
                r["steps"],
                r["collisions"],
                r["act_ms"],
                ", ".join(f"{k}: {v}" for k, v in r.get("reasons", {}).items()),
            ]
            for r in results
        ),
    )
    pairs = table(
        "Per manifold pair (start -> target)",
        (
            "world",
            "policy",
            "start -> target",
            "episodes",
            "success rate",
            "SPL",
            "final distance (m)",
            "collisions",
        ),
        (
            [
                r["world"],
                r["policy"],
                pair,
                s["episodes"],
                s["success_rate"],
                s["spl"],
                s["final_distance"],
                s["collisions"],
            ]
            for r in results
            for pair, s in r["per_pair"].items()
        ),
    )
    parts = [
        "<p>Each episode starts the robot somewhere on the map and gives it a stored view to "
        "reach; success is ending near that view's pose. SPL weighs success by the shortest "
        "free-space path over the path driven. Baselines: the oracle (follows the shortest "
        "route with the true pose: the upper bound), random commands (the lower bound), and "
        "greedy probing of the servo signal when asked for. See docs/servo.md.</p>",
        summary,
        pairs,
        '<div class="row">',
    ]
    for r in results:
        if r.get("plot"):
            parts.append(
                figure(
                    r["plot"],
                    f"{r['world']} / {r['policy']}: trails (green: success, red: "
                    "failure), targets as outlines",
                )
            )
    parts.append("</div>")
    links = [
        f'<li>{esc(key)}: <a href="{esc(v)}">{esc(Path(v).name)}</a></li>'
        for key, paths in videos.items()
        for v in paths
    ]
    if links:
        parts += [
            "<p>Episode videos (camera view beside the top-down map; MPEG-4, if the browser "
            "does not play them, open them with a video player):</p>",
            "<ul>",
            *links,
            "</ul>",
        ]
    return section("servo", "Closed-loop servoing", *parts)


def section_reproduce(info: dict) -> str:
    """``info``: {"command", "settings", "versions", "machine", "commit", "timings", "total"}."""
    rows = [[k, v] for k, v in info["settings"].items()]
    timings = [[k, v] for k, v in info["timings"].items()] + [["total", info["total"]]]
    return section(
        "reproduce",
        "Reproducing this report",
        f"<p>Command: <code>{esc(info['command'])}</code> at commit "
        f"<code>{esc(info.get('commit') or 'unknown')}</code> (uncommitted changes are not "
        "recorded).</p>",
        table("Settings", ("setting", "value"), rows),
        table("Versions", ("package", "version"), info["versions"].items()),
        table("Machine", ("what", "value"), info["machine"].items()),
        table("Stage timings (s)", ("stage", "seconds"), timings),
    )


STYLE = """
body { font-family: sans-serif; max-width: 1200px; margin: 1em auto; padding: 0 1em; }
table { border-collapse: collapse; margin: 1em 0; font-size: 0.9em; }
caption { text-align: left; font-weight: bold; padding: 0.3em 0; }
th, td { border: 1px solid #bbb; padding: 0.2em 0.5em; text-align: left; }
th { background: #eee; }
figure { display: inline-block; margin: 0.5em; vertical-align: top; }
figure img { max-width: 560px; max-height: 420px; border: 1px solid #ccc; }
figcaption { font-size: 0.85em; max-width: 560px; }
"""


def build_html(title: str, sections: Sequence[str], summary: str = "") -> str:
    """The whole page: a table of contents of the sections, then the sections."""
    toc = "".join(
        f'<li><a href="#{a}">{t}</a></li>'
        for a, t in (
            re.search(r'<section id="([^"]+)">\n<h2>([^<]*)</h2>', s).groups() for s in sections
        )
    )
    return (
        f'<!DOCTYPE html>\n<html lang="en">\n<head>\n<meta charset="utf-8">\n'
        f"<title>{esc(title)}</title>\n<style>{STYLE}</style>\n</head>\n<body>\n"
        f"<h1>{esc(title)}</h1>\n{summary}\n<ul>{toc}</ul>\n"
        + "\n".join(sections)
        + "\n</body>\n</html>\n"
    )


def referenced_files(page: str) -> list[str]:
    """The local files an HTML page references (``src`` and ``href`` that are not anchors)."""
    refs = re.findall(r'(?:src|href)="([^"#][^"]*)"', page)
    return sorted({html.unescape(r) for r in refs})


def write_report(root: str | os.PathLike, page: str) -> Path:
    """Write ``index.html`` atomically after checking every file it references is in ``root``."""
    root = Path(root)
    missing = [r for r in referenced_files(page) if "://" in r or not (root / r).is_file()]
    if missing:
        raise FileNotFoundError(f"the report references files that are not in {root}: {missing}")
    path = root / INDEX
    atomic_write_bytes(path, page.encode())
    return path


# --------------------------------------------------------------------------- stages


def _save_png(path: Path, rgb: np.ndarray) -> Path:
    import cv2

    ok, buf = cv2.imencode(".png", np.ascontiguousarray(rgb[..., ::-1]))
    if not ok:
        raise RuntimeError(f"could not encode {path}")
    path.parent.mkdir(parents=True, exist_ok=True)
    atomic_write_bytes(path, buf.tobytes())
    return path


def _manifold_samples(dataset) -> dict[int, tuple]:
    """Per manifold id: (sequence, three frame indices spread over the frames on it, at 1/6,
    1/2 and 5/6) from the sequence with the most frames on it."""
    best: dict[int, tuple] = {}
    for seq in dataset.sequences.values():
        for m in np.unique(seq.labels[seq.labels >= 0]):
            idx = np.flatnonzero(seq.labels == m)
            if len(idx) > len(best.get(int(m), (None, []))[1]):
                best[int(m)] = (seq, idx)
    return {
        m: (seq, [int(idx[len(idx) * k // 6]) for k in (1, 3, 5)])
        for m, (seq, idx) in sorted(best.items())
    }


def laser_crop(view, pose, scan, angles, trail, size: int, half_m: float = 8.0) -> np.ndarray:
    """A ``size`` x ``size`` square of the map, ``2 half_m`` metres wide, centred on the robot,
    with its trail, its laser rays (every 8th) and hits in red."""
    import cv2

    img = view.draw(pose=pose, trail=trail)
    ok = np.isfinite(scan)
    a = pose[2] + np.asarray(angles)[ok]
    hits = pose[:2] + np.asarray(scan)[ok, None] * np.stack([np.cos(a), np.sin(a)], axis=1)
    c = np.round(view.to_pixels(pose[:2])).astype(int)
    px = np.round(view.to_pixels(hits)).astype(int)
    for p in px[::8]:
        cv2.line(img, tuple(c), tuple(p), (240, 120, 120), 1, cv2.LINE_AA)
    for p in px:
        cv2.circle(img, tuple(p), 2, (220, 20, 20), -1)
    view._robot(img, pose, (30, 30, 30))
    half = int(half_m * view.scale)
    img = cv2.copyMakeBorder(img, half, half, half, half, cv2.BORDER_CONSTANT, value=(60,) * 3)
    crop = img[c[1] : c[1] + 2 * half, c[0] : c[0] + 2 * half]
    return cv2.resize(crop, (size, size), interpolation=cv2.INTER_AREA)


def stage_worlds(dataset, out_dir: Path, root: Path) -> dict:
    """Top-down views with trajectories, and per manifold camera frames beside the laser."""
    import cv2

    from scenes import MANIFOLDS, build_world
    from sim.topdown import TopDownView

    views, result, rows = {}, {"topdown": {}, "manifolds": {}}, {}
    for seq in dataset.sequences.values():
        if seq.world not in views:
            views[seq.world] = TopDownView(build_world(seq.world), max_size=640)
    for world, view in views.items():
        img = view.draw()
        for seq in dataset.sequences.values():
            if seq.world == world:
                pts = np.round(view.to_pixels(seq.poses[:, :2])).astype(np.int32)
                cv2.polylines(img, [pts], False, (40, 40, 200), 2, cv2.LINE_AA)
        path = _save_png(out_dir / f"{world}_topdown.png", img)
        result["topdown"][world] = _rel(path, root)
    for m, (seq, frames) in _manifold_samples(dataset).items():
        h, middle = seq.images.shape[1], frames[1]
        crop = laser_crop(
            views[seq.world], seq.poses[middle], seq.scans[middle], seq.angles, seq.poses, h
        )
        row = np.concatenate([seq.images[i] for i in frames] + [crop], axis=1)
        path = _save_png(out_dir / f"{MANIFOLDS[m]}_samples.png", row)
        result["manifolds"][MANIFOLDS[m]] = {
            "image": _rel(path, root),
            "frames": [[seq.name, i] for i in frames],
        }
        rows.setdefault(seq.world, []).append((MANIFOLDS[m], row))
    result["sheet"] = _rel(_save_png(out_dir / "samples.png", sample_sheet(rows)), root)
    return result


def sample_sheet(rows: dict[str, list[tuple[str, np.ndarray]]], scale: float = 0.5) -> np.ndarray:
    """The manifolds' sample rows at ``scale``, one column per world, each row labelled."""
    import cv2

    columns = []
    for named in rows.values():
        labelled = []
        for name, row in named:
            small = cv2.resize(row, None, fx=scale, fy=scale, interpolation=cv2.INTER_AREA)
            cv2.rectangle(small, (0, 0), (8 + 8 * len(name), 18), (255, 255, 255), -1)
            cv2.putText(
                small, name, (4, 13), cv2.FONT_HERSHEY_SIMPLEX, 0.45, (0, 0, 0), 1, cv2.LINE_AA
            )
            labelled.append(small)
        columns.append(np.concatenate(labelled, axis=0))
    height = max(c.shape[0] for c in columns)
    padded = [
        np.pad(c, ((0, height - c.shape[0]), (0, 6), (0, 0)), constant_values=255) for c in columns
    ]
    return np.concatenate(padded, axis=1)[:, :-6]


def stage_manifold(dataset_dir: Path, out_dir: Path, root: Path, progress: bool) -> dict:
    from scripts.reproduce_manifold import reproduce

    result = reproduce(dataset_dir, out_dir, progress=progress)
    result = dict(result)
    result["figures"] = [_rel(out_dir / p, root) for p in result.get("figures", [])]
    return result


def stage_grouping(dataset, out_dir: Path, settings: RunSettings, progress: bool) -> dict:
    from scripts.eval_grouping import evaluate_grouping

    return evaluate_grouping(dataset, out_dir, loop=settings.grouping_loop, progress=progress)


def stage_servo(
    data_dir: Path,
    worlds: Sequence[str],
    out_dir: Path,
    root: Path,
    settings: RunSettings,
    maps_dir: Path,
    progress: bool,
) -> dict:
    from servo.evaluate import evaluate
    from servo.map_store import load_or_build

    results, videos = [], {}
    for world in worlds:
        servo_map = load_or_build(world, dataset=data_dir, cache=maps_dir)
        for policy in settings.policies:
            n_videos = settings.videos if policy == settings.policies[0] else 0
            r = evaluate(
                world,
                settings.episodes,
                settings.seed,
                policy=policy,
                servo_map=servo_map,
                out=out_dir,
                videos=n_videos,
                progress=progress,
            )
            if r.get("plot"):
                r["plot"] = _rel(r["plot"], root)
            results.append(r)
            found = sorted(out_dir.glob(f"{world}-{policy}-episode*.mp4"))[:n_videos]
            if found:
                videos[f"{world}/{policy}"] = [_rel(p, root) for p in found]
    return {"results": results, "videos": videos}


# --------------------------------------------------------------------------- reproducibility


def versions() -> dict[str, str]:
    from importlib.metadata import PackageNotFoundError, version

    out = {"python": platform.python_version()}
    for name in VERSION_PACKAGES:
        try:
            out[name] = version(name)
        except PackageNotFoundError:
            out[name] = "not installed"
    return out


def machine() -> dict[str, str]:
    cpu = platform.processor() or platform.machine()
    try:
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.startswith("model name"):
                cpu = line.split(":", 1)[1].strip()
                break
    except OSError:
        pass
    return {
        "cpu": cpu,
        "cores (os.cpu_count)": str(os.cpu_count()),
        "platform": platform.platform(),
        "MUJOCO_GL": os.environ.get("MUJOCO_GL", "unset"),
    }


def git_commit(repo: Path | None = None) -> str | None:
    """The checked-out commit, read-only; None outside a git checkout."""
    repo = repo or Path(__file__).resolve().parents[1]
    try:
        out = subprocess.run(
            ["git", "rev-parse", "HEAD"], cwd=repo, capture_output=True, text=True, timeout=10
        )
    except (OSError, subprocess.SubprocessError):
        return None
    return out.stdout.strip() or None if out.returncode == 0 else None


# --------------------------------------------------------------------------- the run


@dataclass
class _Timer:
    progress: bool = True
    timings: dict[str, float] = field(default_factory=dict)

    def run(self, name: str, fn: Callable[[], dict]) -> dict:
        """Run one stage, timed; any exception becomes a StageError naming the stage."""
        start = time.perf_counter()
        if self.progress:
            print(f"== stage {name}", flush=True)
        try:
            result = fn()
        except Exception as err:
            seconds = time.perf_counter() - start
            raise StageError(
                f"stage {name!r} failed after {seconds:.1f} s: {type(err).__name__}: {err}"
            ) from err
        self.timings[name] = time.perf_counter() - start
        if self.progress:
            print(f"== stage {name}: {self.timings[name]:.1f} s", flush=True)
        return result


def _json_default(obj):
    """What ``json`` cannot write itself: numpy scalars and arrays, paths."""
    if isinstance(obj, np.ndarray | np.generic):
        return obj.tolist()
    if isinstance(obj, Path):
        return obj.as_posix()
    raise TypeError(f"{type(obj).__name__} is not JSON serialisable")


def run_pipeline(
    out: str | os.PathLike,
    settings: RunSettings | None = None,
    *,
    progress: bool = True,
    command: str = "topomap run",
) -> Path:
    """Collect the default dataset into ``<out>/dataset`` (reused when present), run the four
    stages into ``<out>/report/<stage>/`` and write ``<out>/report/index.html``; returns it.

    Raises :class:`StageError` (naming the stage) if any stage fails.
    """
    from sim.collect import CollectionSettings, collect_dataset
    from sim.dataset import load_dataset

    settings = settings or RunSettings()
    shown = Path(out)
    # Absolute from here on: the page links its files relative to the report folder, whatever
    # the working directory.
    out = shown.resolve()
    root = out / REPORT_DIR
    data_dir = out / "dataset"
    dirs = {name: root / name for name in ("worlds", "manifold", "grouping", "servo")}
    try:
        for d in dirs.values():
            d.mkdir(parents=True, exist_ok=True)
        probe = tempfile.NamedTemporaryFile(dir=root, prefix=".write-test-")
        probe.close()
    except OSError as err:
        raise OutputError(
            f"out must be a folder this user can write ({shown}): {type(err).__name__}: {err}"
        ) from err
    timer = _Timer(progress)
    start = time.perf_counter()
    load_at_start = os.getloadavg()
    collection = CollectionSettings(seed=settings.seed)

    def collect():
        collect_dataset(data_dir, collection, jobs=settings.jobs, progress=progress)
        return {"dataset": load_dataset(data_dir)}

    dataset = timer.run("dataset", collect)["dataset"]
    worlds = list(dict.fromkeys(s.world for s in dataset.sequences.values()))
    results = {
        "worlds": timer.run("worlds", lambda: stage_worlds(dataset, dirs["worlds"], root)),
        "manifold": timer.run(
            "manifold", lambda: stage_manifold(data_dir, dirs["manifold"], root, progress)
        ),
        "grouping": timer.run(
            "grouping", lambda: stage_grouping(dataset, dirs["grouping"], settings, progress)
        ),
        "servo": timer.run(
            "servo",
            lambda: stage_servo(
                data_dir, worlds, dirs["servo"], root, settings, out / "servo-maps", progress
            ),
        ),
    }
    info = {
        "command": command,
        "settings": {
            **asdict(settings),
            "dataset": f"{shown / 'dataset'} ({len(dataset.sequences)} sequences, "
            f"{sum(len(s) for s in dataset.sequences.values())} frames)",
            "collection": json.dumps(collection.to_json(), sort_keys=True),
        },
        "versions": versions(),
        "machine": {
            **machine(),
            "load average (1, 5, 15 min) at start": ", ".join(f"{x:.1f}" for x in load_at_start),
            "load average (1, 5, 15 min) at end": ", ".join(f"{x:.1f}" for x in os.getloadavg()),
        },
        "commit": git_commit(),
        "timings": timer.timings,
        "total": time.perf_counter() - start,
    }
    page = build_html(
        "topomap-testbed: run report",
        [
            section_worlds(results["worlds"]),
            section_manifold(results["manifold"]),
            section_grouping(results["grouping"], prefix=f"{dirs['grouping'].name}/"),
            section_servo(results["servo"]["results"], results["servo"]["videos"]),
            section_reproduce(info),
        ],
        summary=f"<p>Seed {settings.seed}; written in {info['total']:.0f} s on "
        f"{esc(info['machine']['cores (os.cpu_count)'])} cores.</p>",
    )
    report = {k: v for k, v in results.items() if k != "grouping"}
    report["grouping"] = f"{dirs['grouping'].name}/grouping.json"
    report["info"] = info
    atomic_write_bytes(
        root / "report.json", (json.dumps(report, indent=1, default=_json_default) + "\n").encode()
    )
    return write_report(root, page)
