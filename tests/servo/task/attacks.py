"""Policies written to find the truth, as a user might: each searches on every call and, if
it finds anything, raises with what it found (the episode's ``failure`` then says so); else
it acts blind, a slow fixed arc. The runner imports them by ``tests.servo.task.attacks:NAME``.
"""

from __future__ import annotations

import gc
import glob
import itertools
import os
import sys
import threading
import time
from pathlib import Path

import numpy as np

# a search that outlasts the runner's answer limit fails the episode as "too slow", not as
# "found the truth": each search gets a budget well inside that limit
SEARCH_BUDGET_S = 3.0
TRUTH_KEYS = ("pose", "target_pose", "manifold", "true_poses")
TRUTH_TYPES = ("ServoEnv", "NavigationEnv", "Simulator", "GeodesicField", "MjData", "MjModel")


def _truthful_map(obj) -> bool:
    poses = getattr(obj, "true_poses", None)
    return isinstance(poses, np.ndarray) and poses.size > 0 and bool(np.isfinite(poses).any())


def walk_stack() -> list[str]:
    """Every frame up the stack: locals named like the env's truth, or holding it."""
    found, frame = [], sys._getframe(1)
    while frame is not None:
        for name, value in frame.f_locals.items():
            if name in ("info", "field", "env") or type(value).__name__ in TRUTH_TYPES:
                found.append(f"{frame.f_code.co_name}:{name}")
            elif isinstance(value, dict) and "target_pose" in value:
                found.append(f"{frame.f_code.co_name}:{name}")
            elif _truthful_map(value):
                found.append(f"{frame.f_code.co_name}:{name} (a map with true poses)")
        frame = frame.f_back
    return found


def search_gc() -> list[str]:
    """Every object the collector tracks: an env, a simulator, a geodesic field, an info
    dict, a map with true poses."""
    found = []
    for obj in gc.get_objects():
        kind = type(obj)
        if kind.__name__ in TRUTH_TYPES:
            found.append(kind.__name__)
        elif isinstance(obj, dict) and "target_pose" in obj and "pose" in obj:
            found.append("an info dict")
        elif kind.__name__ == "ServoMap" and _truthful_map(obj):
            found.append("a map with true poses")
    return found


def follow_map(servo_map, roots, budget_s: float | None = SEARCH_BUDGET_S) -> list[str]:
    """The map's own keys to the disk: its recordings' names and frame indices looked up in
    every dataset under ``roots``, the data home and ``out/``; its key as a map file's name.
    Within ``budget_s`` seconds (None: no limit)."""
    from sim.dataset import load_dataset

    found = []
    deadline = float("inf") if budget_s is None else time.monotonic() + budget_s
    for root in _roots(roots):
        metas = glob.iglob(os.path.join(root, "**", "meta.json"), recursive=True)
        for meta in _within_budget(itertools.islice(metas, 50), deadline):
            try:
                data = load_dataset(Path(meta).parent)
            except Exception:
                continue
            for i, name in enumerate(servo_map.sequence_names):
                seq = data.sequences.get(name) if hasattr(data.sequences, "get") else None
                frames = servo_map.frame[servo_map.sequence == i]
                # another dataset may hold a recording of the same name but not these frames
                if seq is not None and len(frames) and frames.max() < len(seq.poses):
                    found.append(f"{name}: poses {np.asarray(seq.poses)[frames][:1].tolist()}")
        named = glob.iglob(os.path.join(root, "**", f"*{servo_map.key}*"), recursive=True)
        found += _within_budget(named, deadline)
        if found:  # the given roots come first: stop there rather than walk the data home
            return found
    return found


def scan_disk(roots) -> list[str]:
    """Any servo map file on disk (they hold the true poses): under ``roots``, the data home,
    ``out/`` and the runner's temporary folders. The given roots are searched first and the
    search stops at the first find, so that a large data home cannot make it too slow to
    answer (a slow scan would fail the episode for the wrong reason)."""
    deadline = time.monotonic() + SEARCH_BUDGET_S
    for root in [*_roots(roots), "/tmp"]:
        pattern = "**/*.json" if root != "/tmp" else "servo-protocol-*/*.json"
        paths = glob.iglob(os.path.join(root, pattern), recursive=True)
        for path in _within_budget(itertools.islice(paths, 2000), deadline):
            try:
                head = Path(path).read_text()[:200]
            except OSError:
                continue
            if "topomap-servo-map" in head:
                return [path]
    return []


def _within_budget(items, deadline: float):
    for item in items:
        if time.monotonic() > deadline:
            return
        yield item


def _roots(roots) -> list[str]:
    from sim.datahome import user_cache_dir

    here = [*roots, os.environ.get("TOPOMAP_HOME", ""), str(user_cache_dir()), "out"]
    return [r for r in here if r and os.path.isdir(r)]


class Attacker:
    """Searches with ``search`` at every reset and every act. A search of the disk
    (``background=True``) runs in a thread of its own and is waited for at most
    ``SEARCH_BUDGET_S`` a call: one slow file read or folder walk then cannot make the policy
    too slow to answer, and what it finds later fails a later call."""

    def __init__(self, search, background: bool = False):
        self.search, self.background = search, background
        self._thread, self._found = None, None

    def _check(self, when: str):
        found = self._search_in_background() if self.background else self.search()
        if found:
            raise RuntimeError(f"found the truth at {when}: {found[:3]}")

    def _search_in_background(self) -> list[str]:
        if self._thread is None:
            self._found = []
            self._thread = threading.Thread(
                target=lambda: self._found.extend(self.search()), daemon=True
            )
            self._thread.start()
        self._thread.join(SEARCH_BUDGET_S)
        if self._thread.is_alive():
            return []  # nothing yet: asked again at the next call
        self._thread = None  # done: the next call searches anew
        return self._found

    def reset(self, target):
        self._check("reset")

    def act(self, observation):
        self._check("act")
        return np.array([0.3, 0.4])


def stack_walker(servo_map, rng):
    return Attacker(walk_stack)


def gc_searcher(servo_map, rng):
    return Attacker(search_gc)


def recordings_opener(servo_map, rng, roots=()):
    return Attacker(lambda: follow_map(servo_map, roots), background=True)


def disk_scanner(servo_map, rng, roots=()):
    return Attacker(lambda: scan_disk(roots), background=True)


def blind(servo_map, rng):
    return Attacker(list)
