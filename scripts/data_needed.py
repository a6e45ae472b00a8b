"""The data a command reads, made when it is the default and named when it is missing.

``topomap servo-eval`` and ``topomap group-eval`` read a dataset folder (``--data``). The
default one, ``out/dataset`` (where ``topomap run`` collects), is collected on first use with a
line saying so, as ``topomap run`` does; any other folder that holds no dataset is an error
that names the one ``topomap collect`` command that would collect it and the option that points
elsewhere. ``topomap manifold-eval`` reads the protocol's datasets ``ROOT/m-data-S``: a missing
one is named with its ``topomap collect`` command, and, where only the held-out condition needs
it (seed S's held-out frames come from seed S+1), with ``--conditions interleaved``.
"""

from __future__ import annotations

import sys
from pathlib import Path

DEFAULT_DATA = "out/dataset"  # topomap run's dataset: the default --data of the commands


def is_collected(path: str | Path) -> bool:
    """Check whether ``path`` holds a dataset whose ``meta.json`` says it is complete.

    Parameters
    ----------
    path : str or Path
        The dataset folder.

    Returns
    -------
    bool
        True for a complete dataset.
    """
    from sim.dataset import DatasetError, read_meta

    try:
        return bool(read_meta(path).get("complete", False))
    except DatasetError:
        return False


def _holds_a_dataset(path: str | Path) -> bool:
    """Check whether ``path`` holds a ``meta.json`` at all.

    A damaged or unfinished one is then the reader's to report, with what is wrong, rather than
    a dataset to collect.
    """
    return (Path(path) / "meta.json").exists()


def collect_command(out: str | Path, seed: int | None = None, condition: str = "interleaved"):
    """Return the ``topomap collect`` command line that collects the dataset ``out``.

    The default settings, with ``seed`` and the flags of the manifold protocol's ``condition``.

    Parameters
    ----------
    out : str or Path
        The dataset folder.
    seed : int or None, default None
        The ``--seed``; None leaves it out.
    condition : str, default "interleaved"
        The manifold protocol's condition ("randomized" and "hard" add their flags).

    Returns
    -------
    str
        The command line.
    """
    flags = {"randomized": " --randomize", "hard": " --appearance hard"}.get(condition, "")
    seed_flag = "" if seed is None else f" --seed {seed}"
    return f"topomap collect --world all{seed_flag}{flags} --out {out}"


def missing_dataset_message(path: str | Path, option: str = "--data") -> str:
    """Say what to do about a folder ``path`` that holds no (complete) dataset.

    Parameters
    ----------
    path : str or Path
        The folder.
    option : str, default "--data"
        The option that points elsewhere.

    Returns
    -------
    str
        The message.
    """
    return (
        f"no collected dataset at {path}: `{collect_command(path)}` collects the default one "
        f"(about 30 s on 2 cores), or point {option} at a collected dataset"
    )


def ensure_dataset(path: str | Path, command: str, progress: bool = True) -> str:
    """Return ``path`` as a dataset for ``command``, collecting the default one when missing.

    The default ``out/dataset`` is collected there when missing (or resumed when unfinished),
    with a line on stderr saying so; one with a ``meta.json`` goes to the reader, which says
    what is wrong with it.

    Parameters
    ----------
    path : str or Path
        The dataset folder.
    command : str
        The subcommand that reads it, such as ``"servo-eval"``.
    progress : bool, default True
        Whether a collection shows a progress bar.

    Returns
    -------
    str
        ``path``.

    Raises
    ------
    ValueError
        For any other folder without a ``meta.json``, with `missing_dataset_message`.
    """
    default = Path(path) == Path(DEFAULT_DATA)
    if is_collected(path) or (_holds_a_dataset(path) and not default):
        return str(path)
    if not default:
        raise ValueError(missing_dataset_message(path))
    from sim.collect import CollectionSettings, collect_dataset

    print(
        f"topomap {command}: no dataset at {path}: collecting the default one there "
        f"(as `{collect_command(path)}`; --data DIR reads another)",
        file=sys.stderr,
    )
    collect_dataset(path, CollectionSettings(), progress=progress)
    return str(path)


def manifold_dataset_message(path: Path, seed: int, condition: str, held_out_of: int | None):
    """Say what to do about the protocol dataset ``path`` of ``seed`` and ``condition``.

    The message is for a dataset not collected.

    Parameters
    ----------
    path : Path
        The dataset folder.
    seed : int
        Its seed.
    condition : str
        Its condition.
    held_out_of : int or None
        The seed whose held-out condition needs it (seed - 1), when only that condition does.

    Returns
    -------
    str
        The message.
    """
    command = collect_command(path, seed, condition)
    message = f"dataset {path} not collected: `{command}` collects it"
    if held_out_of is not None:
        message += (
            f" (the held-out condition of seed {held_out_of} tests on seed {seed}'s frames; "
            "--conditions interleaved leaves that condition out)"
        )
    return message + " (python -m scripts.manifold.protocol --help lists the protocol's datasets)"
