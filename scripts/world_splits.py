"""How many test worlds repeat a training world's structure, per family.

``python -m scripts.world_splits [--out FILE]`` draws the floor plan of every train and test
seed (`scenes.families.splits.SPLITS`; about 100 s per family on one core), counts the
test worlds whose `structure` occurs among the train worlds
(`held_out_worlds` skips them, by the list in
`REPEATED_TEST_SEEDS` that this script's output fills) and writes
the counts, and which train world each repeat copies, as JSON.
"""

from __future__ import annotations

import argparse
import json

from tqdm.auto import tqdm

from common.fileio import atomic_write_bytes
from scenes.families import FAMILIES, SPLITS, SPLITS_VERSION, family_layout, split_worlds, structure


def repeats(family: str, progress: bool = True) -> dict:
    """Count one family's distinct train structures, test worlds and repeated ones.

    Parameters
    ----------
    family : str
        The family.
    progress : bool, default True
        Whether to show progress bars.

    Returns
    -------
    dict
        The counts, and ``repeats``: the train world each repeating test world copies.
    """
    train: dict[tuple, str] = {}  # structure -> the first train world that has it
    for name in tqdm(split_worlds(family, "train"), desc=f"{family} train", disable=not progress):
        train.setdefault(structure(family_layout(name)), name)
    test = {n: structure(family_layout(n)) for n in split_worlds(family, "test")}
    repeats = {n: train[s] for n, s in test.items() if s in train}
    return {
        "train_worlds": SPLITS["train"][1],
        "distinct_train_structures": len(train),
        "test_worlds": len(test),
        "test_worlds_repeating_a_train_structure": len(repeats),
        "repeats": repeats,
    }


def main(argv=None) -> int:
    """Count the repeats of every family, print them as JSON and write them to ``--out``.

    Parameters
    ----------
    argv : list of str or None, default None
        The arguments; None reads ``sys.argv[1:]``.

    Returns
    -------
    int
        The exit status, 0.
    """
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--out", help="write the counts here as JSON")
    args = parser.parse_args(argv)
    counts = {"splits_version": SPLITS_VERSION, "splits": SPLITS}
    counts["families"] = {f: repeats(f) for f in FAMILIES}
    text = json.dumps(counts, indent=2) + "\n"
    print(text, end="")
    if args.out:
        atomic_write_bytes(args.out, text.encode())
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
