"""The results table, as data, and the pages that show each task's full tables.

One `Row` per task, method and setting names the committed file it reads and how
(``scripts.results.sources``).

A new result is a new row here (and its file with its ``meta.json`` entry under
``docs/results/data/``); nothing else changes.
"""

from __future__ import annotations

from dataclasses import dataclass, field

__all__ = ["PAGES", "ROWS", "SECTIONS", "Row", "Section"]

# task -> (title, the page under docs/results/ with its full tables)
PAGES = {
    "manifold": ("Visual-manifold clustering", "manifold-clustering.md"),
    "grouping": ("Laser observation grouping", "observation-grouping.md"),
    "servo": ("Closed-loop servoing", "servo.md"),
    "worlds": ("Held-out worlds", "held-out-worlds.md"),
}


@dataclass(frozen=True)
class Row:
    """One row of README's results table.

    ``reader``, ``source`` and ``keys`` say where the number is (``sources.read_estimate``).

    Parameters
    ----------
    task : str
        A key of `PAGES`.
    data : str
        What was run on.
    method : str
        What was run.
    measure : str
        The number's name (``"test error"``, ``"success"``...).
    split : str
        Which data it was measured on.
    reader : str
        The reader of ``sources.READERS``.
    source : str
        The file or folder under ``docs/results/data/``.
    keys : dict, optional
        Which number in it the row shows.
    """

    task: str
    data: str
    method: str
    measure: str
    split: str
    reader: str
    source: str
    keys: dict = field(default_factory=dict)


_PROTOCOL = "manifold/protocol"
_FRESH = "test frames, fresh seeds 1-10"


def _manifold(data: str, condition: str, features: str) -> list[Row]:
    """Ours beside scikit-learn's k-NN spectral clustering on one protocol condition."""
    return [
        Row(
            "manifold",
            data,
            label,
            "test error",
            _FRESH,
            "protocol-error",
            _PROTOCOL,
            {"condition": condition, "features": features, "method": method},
        )
        for label, method in (
            ("ManifoldClustering (ours)", "ours"),
            ("scikit-learn k-NN spectral (k=10)", "scikit-learn kNN (k=10)"),
        )
    ]


_GROUPING_SEEDS = "grouping/simulated-seed-*.json"


def _grouping(world: str) -> Row:
    return Row(
        "grouping",
        f"simulated {world}, 3 drives, odometry + ICP",
        "ObservationGraphPartitioner",
        "purity",
        "every frame, one dataset per seed",
        "grouping-score",
        _GROUPING_SEEDS,
        {"world": world, "variant": "odometry+icp", "score": "purity"},
    )


def _carmen(log: str, name: str) -> Row:
    return Row(
        "grouping",
        f"Radish {name} log, corrected poses",
        "ObservationGraphPartitioner",
        "groups (no ground truth)",
        "whole log",
        "carmen-groups",
        "grouping/radish-logs.json",
        {"log": log, "variant": "given"},
    )


_CONTROLLERS = {"servo": "ManifoldServo (laser + image)", "signal": "SignalServo (camera only)"}
_TIERS = {
    "view": ("starts near a stored view", "view-test"),
    "anywhere": ("starts anywhere", "anywhere-test"),
    "anywhere-randomize": ("starts anywhere, random lights and colours", "anywhere-randomize-test"),
}


def _servo_file(policy: str, world: str, tier: str) -> str:
    if policy == "servo" and tier == "view":  # one run of both worlds
        return "servo/servo-all-view-test-100ep.json"
    return f"servo/{policy}-{world}-{_TIERS[tier][1]}-100ep.json"


ROWS: tuple[Row, ...] = (
    *_manifold("images (HSV histograms), 8 manifolds", "interleaved", "hsv"),
    *_manifold("images (HSV), every branch in the main's materials", "hard", "hsv"),
    *_manifold("laser scans (range per beam), 8 manifolds", "interleaved", "scan-range"),
    _grouping("hallway"),
    _grouping("lawn"),
    _carmen("aces-corrected", "ACES"),
    _carmen("csail-corrected", "CSAIL"),
    *(
        Row(
            "servo",
            f"{world}, {_TIERS[tier][0]}",
            _CONTROLLERS[policy],
            "success",
            "test split",
            "servo-success",
            _servo_file(policy, world, tier),
            {"world": world},
        )
        for policy in _CONTROLLERS
        for world in ("hallway", "lawn")
        for tier in _TIERS
    ),
)


@dataclass(frozen=True)
class Section:
    """One table of a task's page.

    Parameters
    ----------
    task : str
        A key of `PAGES`.
    heading : str
        The table's heading.
    renderer : str
        The renderer (a key of ``scripts.results.render.RENDERERS``).
    sources : tuple of str
        The files it reads (under ``docs/results/data/``).
    """

    task: str
    heading: str
    renderer: str
    sources: tuple[str, ...]


# outside policies, by the same runner and episodes as ours (docs/guides/benchmark-your-policy.md)
_OUTSIDE_SERVO = (
    "servo/nearest_view_homing-all-view-test-20ep.json",
    "servo/image_descent-all-view-test-20ep.json",
)


def _servo_sources(policy: str) -> tuple[str, ...]:
    files = [_servo_file(policy, w, t) for t in _TIERS for w in ("hallway", "lawn")]
    return tuple(dict.fromkeys(files))  # the two-world file once


SECTIONS: tuple[Section, ...] = (
    Section(
        "manifold",
        "The frozen protocol: every condition, features and method",
        "protocol-summary",
        (_PROTOCOL,),
    ),
    Section(
        "manifold",
        "Methods from outside, through the protocol (topomap manifold-eval)",
        "leaderboard",
        ("manifold/leaderboard",),
    ),
    Section(
        "grouping",
        "Simulated worlds over dataset seeds: the three drives of each world",
        "grouping-seeds",
        (_GROUPING_SEEDS,),
    ),
    Section(
        "grouping",
        "Simulated worlds, dataset seed 0: every case and both sensors",
        "grouping-tables",
        ("grouping/simulated-seed-0.json",),
    ),
    Section(
        "grouping",
        "Real robot logs (Radish, Carmen format)",
        "carmen-table",
        ("grouping/radish-logs.json",),
    ),
    Section(
        "grouping",
        "Methods from outside (topomap group-eval --method)",
        "leaderboard",
        ("grouping/leaderboard",),
    ),
    *(
        Section(
            "servo",
            f"{name}, test split, 100 episodes per cell",
            "servo-summary",
            _servo_sources(policy),
        )
        for policy, name in _CONTROLLERS.items()
    ),
    Section(
        "servo",
        "The cells above rerun at the current code, first episodes",
        "servo-reruns",
        ("servo/reruns",),
    ),
    Section(
        "servo",
        "Outside policies (examples/, run as package.module:factory), test split, "
        "starts near a stored view, 20 episodes per world",
        "servo-summary",
        _OUTSIDE_SERVO,
    ),
    Section(
        "servo",
        "Leaderboard: success per episode, starts near a stored view, test split "
        "(topomap leaderboard, paired against ManifoldServo on the episodes both ran)",
        "leaderboard",
        (
            "servo/servo-all-view-test-100ep.json",
            "servo/signal-hallway-view-test-100ep.json",
            "servo/signal-lawn-view-test-100ep.json",
            *_OUTSIDE_SERVO,
        ),
    ),
    Section(
        "worlds",
        "Every task: the canonical world beside held-out test worlds",
        "heldout-summary",
        ("worlds/heldout.json",),
    ),
    Section("worlds", "Per world", "heldout-worlds", ("worlds/heldout.json",)),
)
