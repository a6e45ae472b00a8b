"""Dev study: the manifold clustering's minimum cluster size Q on generated worlds.

On held-out worlds the protocol's fixed Q = 35 (chosen on the canonical worlds) exceeds the
training frames of many leaf manifolds (a drive's 150 frames are shared by every stretch it
crosses, so a short leaf gets 25-37 even frames): those manifolds cannot form a cluster. This
study scores fixed Q values and a rule scaled to the data, Q = clip(n // (c K), 8, 35), on the
DEV worlds only (seeds 10,000-10,005 of each family), and picks the rule by the mean error
over both families; the test worlds are then scored once with the pick.

    .venv/bin/python -m experiments.heldout.q_rule [--worlds 20] [--out experiments/heldout]
"""

from __future__ import annotations

import argparse
import json
import time
from pathlib import Path

import numpy as np

import sim  # noqa: F401
from common.blas import on_one_blas_thread
from scenes.families import split_worlds

FIXED = (35, 20, 12)
DIVISORS = (2, 3)


def q_rule(n: int, k: int, c: int) -> int:
    return int(np.clip(n // (c * k), 8, 35))


def score_world(world: str, data_root: Path) -> dict:
    from mapping import ColorHistogramFeatures, ManifoldClustering, clustering_error
    from scenes import build_world
    from sim.collect import CollectionSettings, collect_dataset
    from sim.dataset import load_dataset

    directory = data_root / world.replace(":", "-")
    collect_dataset(
        directory, CollectionSettings(worlds=(world,), frames=150, seed=0), progress=False, jobs=1
    )
    data = load_dataset(directory)
    train, test = data.paper_split()
    images = data.concat("images")
    f = ColorHistogramFeatures().fit(images[train])
    Xtr, Xte = f.transform(images[train]), f.transform(images[test])
    labels = data.concat("labels")
    k = len(build_world(world).manifold_names)
    n = int(train.sum())
    qs = {f"Q={q}": q for q in FIXED} | {f"n//({c}K)": q_rule(n, k, c) for c in DIVISORS}
    out = {"world": world, "k": k, "n": n, "errors": {}, "q": qs}
    for name, q in qs.items():
        try:
            model = ManifoldClustering(k, q).fit(Xtr)
            out["errors"][name] = clustering_error(labels[test], model.predict(Xte))
        except ValueError as err:  # too few points for k clusters of q
            out["errors"][name] = None
            out.setdefault("refused", {})[name] = str(err)
    return out


def main(argv=None) -> None:
    p = argparse.ArgumentParser()
    p.add_argument("--worlds", type=int, default=6)
    p.add_argument("--out", type=Path, default=Path("experiments/heldout"))
    p.add_argument("--data", type=Path, default=Path("out/heldout-dev/data"))
    a = p.parse_args(argv)
    rows = []
    for family in ("hallway", "lawn"):
        for world in split_worlds(family, "dev", a.worlds):
            t = time.perf_counter()
            rows.append(on_one_blas_thread(score_world, world, a.data))
            errors = {k: v and round(v, 3) for k, v in rows[-1]["errors"].items()}
            print(world, rows[-1]["k"], errors, f"{time.perf_counter() - t:.0f}s", flush=True)
    names = list(rows[0]["errors"])
    summary = {}
    for name in names:
        e = [r["errors"][name] for r in rows]
        ok = [x for x in e if x is not None]
        summary[name] = {
            "mean": float(np.mean(ok)) if ok else None,
            "refused": len(e) - len(ok),
            "past_15pct": int(sum(x > 0.15 for x in ok)),
        }
    (a.out / "q_rule.json").write_text(json.dumps({"summary": summary, "rows": rows}, indent=1))
    for name, s in summary.items():
        print(f"{name:10s} mean {s['mean']}  past 15%: {s['past_15pct']}  refused {s['refused']}")


if __name__ == "__main__":
    main()
