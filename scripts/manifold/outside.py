r"""``topomap manifold-eval``: any scikit-learn-style clusterer through the frozen protocol.

    topomap manifold-eval --root ROOT --out OUT --method sklearn.cluster:SpectralClustering \
        [--param affinity=rbf ...] [--seeds 1 2 ... 10] [--features hsv] \
        [--conditions interleaved held-out] [--baselines]

The method is fitted on each cell's training frames exactly as ours is
(``scripts.manifold.protocol.cell_data``: same datasets, seeds, conditions, features). The
protocol passes ``n_clusters=K`` (8, the number of manifolds) when the class's constructor
takes ``n_clusters`` and ``--param`` does not set it, as it does for the baselines, and
``random_state=S`` (the cell's dataset seed) when it takes ``random_state``, so that a run is
repeated exactly; a class
without it (HDBSCAN, DBSCAN) finds its own number of clusters, and every cluster beyond the
K matched ones counts as error (``mapping.clustering_error``). The test frames are labelled by
the method's ``predict`` where it has one; otherwise each takes the cluster of its nearest
training frame (1-NN in the feature space), and the result file says so
(``assignment: nearest training neighbour``). A cell where the method raises is recorded with
the reason and the run goes on.

``--baselines`` adds ours and the baselines of ``scripts.manifold.METHODS`` (one result file
each); ``OUT`` then holds the files ``topomap leaderboard OUT`` ranks.
"""

from __future__ import annotations

import argparse
import time
import warnings
from pathlib import Path

import numpy as np

from mapping import clustering_error
from scripts.data_needed import manifold_dataset_message
from scripts.leaderboard import OutsideMethod, envelope, parse_params, write_result
from scripts.manifold.methods import METHODS, score_methods
from scripts.manifold.protocol import (
    ALL_FEATURES,
    CONDITIONS,
    DEV_SEED,
    PROTOCOL,
    K,
    Q,
    cell_data,
    dataset_dir,
)

__all__ = ["TASK", "add_parser", "evaluate_method", "run"]

TASK = "manifold-clustering"
METRIC = ("test_error", "error")
NEAREST = "nearest training neighbour"


def _fit_outside(method: OutsideMethod, X_train, y_train, X_test, y_test, seed: int) -> dict:
    """One cell of an outside method: its errors, or the reason it has none."""
    start = time.perf_counter()
    model = method.make(n_clusters=K, random_state=seed)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # a method's warnings are its own business here
        model.fit(X_train)
        labels = getattr(model, "labels_", None)
        if labels is None:
            raise ValueError("fit left no labels_ attribute")
        labels = np.asarray(labels)
        if labels.shape != (len(X_train),):
            raise ValueError(f"labels_ has shape {labels.shape}, expected ({len(X_train)},)")
        if callable(getattr(model, "predict", None)):
            pred, assignment = np.asarray(model.predict(X_test)), "predict"
        else:
            from sklearn.neighbors import KNeighborsClassifier

            nearest = KNeighborsClassifier(n_neighbors=1).fit(X_train, labels)
            pred, assignment = nearest.predict(X_test), NEAREST
    return {
        "value": clustering_error(y_test, pred),
        "train_error": clustering_error(y_train, labels),
        "clusters": len(np.unique(labels[labels >= 0])),
        "noise": int(np.sum(labels < 0)),
        "assignment": assignment,
        "seconds": time.perf_counter() - start,
    }


def evaluate_method(
    root: Path,
    method: OutsideMethod | str,
    conditions=("interleaved", "held-out"),
    features=("hsv",),
    seeds=tuple(range(1, 11)),
    progress: bool = True,
) -> dict:
    """Evaluate ``method`` on every (condition, features, seed) cell into a result file.

    The split is ``dev`` for the dev seed alone and ``test`` for fresh seeds; the two are not
    mixed in one file (the settings were chosen on the dev seed).

    Parameters
    ----------
    root : Path
        The folder of the ``m-data-*`` datasets.
    method : OutsideMethod or str
        An [`OutsideMethod`][scripts.leaderboard.outside.OutsideMethod], or the name of one of
        ``METHODS``.
    conditions : sequence of str, default ("interleaved", "held-out")
        Conditions, of ``CONDITIONS``.
    features : sequence of str, default ("hsv",)
        Feature sets, of ``ALL_FEATURES``.
    seeds : sequence of int, default 1 to 10
        Dataset seeds; the dev seed only alone.
    progress : bool, default True
        Whether to show a progress bar.

    Returns
    -------
    dict
        The result file (``scripts.leaderboard``), one record per cell.

    Raises
    ------
    ValueError
        For bad seeds, conditions, features or built-in method, or a missing dataset.
    """
    from tqdm.auto import tqdm

    seeds = [int(s) for s in seeds]
    if not seeds or any(s < 0 for s in seeds):
        raise ValueError(f"seeds must be integers >= 0, got {seeds}")
    if DEV_SEED in seeds and len(seeds) > 1:
        raise ValueError(f"seed {DEV_SEED} is the dev seed: evaluate it apart from fresh seeds")
    for name, given, allowed in (
        ("conditions", conditions, CONDITIONS),
        ("features", features, ALL_FEATURES),
    ):
        bad = [g for g in given if g not in allowed]
        if bad or not given:
            raise ValueError(f"{name} must be among {allowed}, got {list(given)}")
    builtin = isinstance(method, str)
    if builtin and method not in METHODS:
        raise ValueError(f"a built-in method is one of {METHODS}, got {method!r}")
    records = []
    plan = [(c, f, s) for c in conditions for f in features for s in seeds]
    for condition, feat, seed in tqdm(plan, disable=not progress, desc="manifold-eval"):
        record = {"group": f"{condition}/{feat}", "unit": f"seed {seed}", "seed": seed}
        needed = [dataset_dir(root, seed, condition)]
        if condition == "held-out":
            needed.append(dataset_dir(root, seed + 1, condition))
        for k, path in enumerate(needed):
            if not (path / "meta.json").is_file():
                raise ValueError(
                    manifold_dataset_message(path, seed + k, condition, seed if k else None)
                )
        X_train, y_train, X_test, y_test = cell_data(root, condition, feat, seed)
        if builtin:
            row = score_methods(X_train, y_train, K, Q, X_test, y_test, methods=(method,))[0]
            record.update(
                value=row.pop("test_error"),
                failure=None,
                assignment="predict",
                **{k: v for k, v in row.items() if k != "method"},
            )
        else:
            try:
                record.update(_fit_outside(method, X_train, y_train, X_test, y_test, seed))
                record["failure"] = None
            except Exception as err:  # an outside method may raise anything
                record.update(value=None, failure=f"{type(err).__name__}: {err}"[:500])
        records.append(record)
    if builtin:
        described = {
            "name": method,
            "spec": f"scripts.manifold.methods:{method}",
            "params": {},
            "protocol_params": [],
        }
    else:
        described = method.describe(n_clusters=K, random_state="the dataset seed")
    assignments = sorted({r["assignment"] for r in records if r.get("failure") is None})
    if NEAREST in assignments:
        described["notes"] = f"test frames: {NEAREST} (the class has no predict)"
    return envelope(
        TASK,
        PROTOCOL,
        "dev" if seeds == [DEV_SEED] else "test",
        described,
        METRIC,
        records,
        settings={
            "K": K,
            "Q": Q,
            "conditions": list(conditions),
            "features": list(features),
            "seeds": seeds,
            "root": str(root),
        },
    )


def file_name(method: dict) -> str:
    """Name a result file ``manifold-<spec>[-<params digest>].json``.

    The name holds ``scripts.leaderboard.files.file_tag`` of the full
    ``package.module:Class``, so a class of the same name elsewhere never shares the file,
    safe on every file system; the parameters the protocol chose are left out.

    Parameters
    ----------
    method : dict
        A result file's ``method`` block.

    Returns
    -------
    str
        The file name.
    """
    from scripts.leaderboard import file_tag

    chosen = method.get("protocol_params", [])
    params = {k: v for k, v in method["params"].items() if k not in chosen}
    return f"manifold-{file_tag(method.get('spec') or method['name'], params)}.json"


_DESCRIPTION = """Run any scikit-learn-style clusterer (fit, labels_, optional predict) through the
frozen manifold-clustering protocol; one result file per method in --out, then the
leaderboard of that folder.

n_clusters=8 and random_state=S (the dataset seed) are passed when the constructor takes
them and --param does not set them. Without
predict, each test frame takes the cluster of its nearest training frame (recorded as such).
A cell where the method raises is recorded with the reason and the run goes on. Loading a
method imports its module like python -m: its code runs. See
docs/guides/benchmark-your-method.md."""


def add_parser(sub, help_text: str):
    """Register ``manifold-eval`` on the subparsers action ``sub``.

    Parameters
    ----------
    sub : argparse._SubParsersAction
        The subparsers action.
    help_text : str
        The command's help line.

    Returns
    -------
    argparse.ArgumentParser
        The new parser.
    """
    p = sub.add_parser(
        "manifold-eval",
        help=help_text,
        description=_DESCRIPTION,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    p.add_argument("--root", type=Path, required=True, help="folder of the m-data-* datasets")
    p.add_argument("--out", type=Path, required=True, help="folder for the result files")
    p.add_argument(
        "--method",
        action="append",
        default=[],
        metavar="MODULE:CLASS",
        help="a clusterer (fit, labels_, optional predict); repeat for several",
    )
    p.add_argument(
        "--param",
        action="append",
        default=[],
        metavar="KEY=VALUE",
        help="constructor argument of every --method (a Python literal or text)",
    )
    p.add_argument(
        "--baselines",
        action="store_true",
        help="also ours and the baselines (scripts.manifold.METHODS)",
    )
    p.add_argument(
        "--seeds",
        type=int,
        nargs="+",
        default=list(range(1, 11)),
        help="dataset seeds (default: the test seeds 1-10; 0 is the dev seed)",
    )
    p.add_argument("--features", nargs="+", choices=ALL_FEATURES, default=["hsv"])
    p.add_argument(
        "--conditions", nargs="+", choices=CONDITIONS, default=["interleaved", "held-out"]
    )
    p.add_argument("--quiet", action="store_true", help="no progress bar")
    p.set_defaults(func=run)
    return p


def run(args) -> int:
    """Run ``topomap manifold-eval``: one result file per method in ``--out``, then a ranking.

    The ranking is the leaderboard of the folder (reference: ours where present).

    Parameters
    ----------
    args : argparse.Namespace
        The command line of ``add_parser``.

    Returns
    -------
    int
        The exit status, 0.

    Raises
    ------
    ValueError
        When neither ``--method`` nor ``--baselines`` is given.
    """
    from scripts.leaderboard import leaderboard_markdown, load_results

    if not args.method and not args.baselines:
        raise ValueError("give --method MODULE:CLASS (or --baselines)")
    params = parse_params(args.param)
    methods: list = [OutsideMethod(spec, ("fit",), params) for spec in args.method]
    if args.baselines:
        methods += list(METHODS)
    args.out.mkdir(parents=True, exist_ok=True)
    for method in methods:
        result = evaluate_method(
            args.root, method, args.conditions, args.features, args.seeds, progress=not args.quiet
        )
        path = write_result(args.out / file_name(result["method"]), result)
        failed = [
            f"{r['group']} {r['unit']}: {r['failure']}" for r in result["records"] if r["failure"]
        ]
        print(f"wrote {path}" + "".join(f"\n  failed {f}" for f in failed))
    results = load_results([args.out])
    reference = "ours" if any(r["method"]["name"] == "ours" for r in results) else None
    print()
    print(leaderboard_markdown(results, reference=reference))
    return 0
