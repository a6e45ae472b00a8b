"""The data home: one documented place for the default dataset and the servo maps.

Library entry points that need the default data (``servo.load_or_build``, ``ServoEnv`` with no
map, ``servo.task.evaluation.evaluate``) never look in the working directory. They resolve, in
order:

1. the ``home`` argument, if given;
2. the ``TOPOMAP_HOME`` environment variable, if set and not empty;
3. a per-user cache directory: ``$XDG_CACHE_HOME/topomap`` or ``~/.cache/topomap``.

A home named by 1 or 2 must already exist (a typo should not scatter data over the disk); the
per-user cache is created on first use. The home holds ``dataset/`` (the default dataset,
collected with a progress bar when missing, never replaced) and ``servo-maps/`` (the map cache).
The command line keeps its own ``--out`` folders and does not use the home.

The real laser logs are not part of the home: the folder that holds them is named by the
``TOPOMAP_RADISH`` variable (`radish_log`), read by every command and test that has a
default for them (docs/references.md says where to get them).
"""

from __future__ import annotations

import contextlib
import os
import sys
from pathlib import Path

ENV_VAR = "TOPOMAP_HOME"
DATASET_DIR = "dataset"
MAPS_DIR = "servo-maps"
LOCK_FILE = ".lock"
RADISH_VAR = "TOPOMAP_RADISH"
RADISH_LOGS = ("aces-corrected.log.gz", "csail-corrected.log.gz")


class DataHomeError(ValueError):
    """The data home named by an argument or ``TOPOMAP_HOME`` is missing or not a folder."""


def user_cache_dir() -> Path:
    """Return ``$XDG_CACHE_HOME/topomap``, else ``~/.cache/topomap`` (the XDG rule).

    Returns
    -------
    Path
        The per-user cache directory; not created here.
    """
    base = os.environ.get("XDG_CACHE_HOME") or ""
    root = Path(base) if Path(base).is_absolute() else Path.home() / ".cache"
    return root / "topomap"


def data_home(home: str | os.PathLike | None = None) -> Path:
    """Resolve the data home as an absolute path (see the module docstring for the order).

    Parameters
    ----------
    home : path-like, optional
        The data home; it must exist. None: ``TOPOMAP_HOME``, else the per-user cache.

    Returns
    -------
    Path
        The data home.
    """
    if home is not None:
        path, source = Path(home).expanduser(), "home"
    elif os.environ.get(ENV_VAR):
        path, source = Path(os.environ[ENV_VAR]).expanduser(), f"the {ENV_VAR} variable"
    else:
        path = user_cache_dir()
        try:
            path.mkdir(parents=True, exist_ok=True)
        except OSError as err:
            raise DataHomeError(
                f"cannot create the per-user data home {path} ({err}); set {ENV_VAR} to a "
                "writable folder"
            ) from err
        return path.resolve()
    if not path.exists():
        raise DataHomeError(
            f"{source} names the data home {str(path)!r}, which does not exist: create the "
            "folder first, or leave it unset to use the per-user cache"
        )
    if not path.is_dir():
        raise DataHomeError(f"{source} names the data home {str(path)!r}, which is not a folder")
    return path.resolve()


@contextlib.contextmanager
def folder_lock(folder: Path, what: str = "the data home", lock_file: str | None = None):
    """Hold an exclusive lock on ``folder`` while collecting or building into it.

    Two processes (two notebooks, the workers of a vector env starting together) thus never
    make the same files at once: the first makes them, the others wait, then find them made.
    The lock is on the folder itself (nothing is written), or on its file ``lock_file`` where
    given. A process that has to wait says so on stderr, naming ``what``.

    Parameters
    ----------
    folder : Path
        The folder to lock.
    what : str, default "the data home"
        What is being made, for the waiting message.
    lock_file : str, optional
        A file in ``folder`` to lock instead of the folder (created if missing).

    Yields
    ------
    None
        While the lock is held.
    """
    try:
        import fcntl
    except ImportError:  # not POSIX: no cross-process lock, the atomic writes still hold
        yield
        return
    if lock_file is None:
        fd = os.open(folder, os.O_RDONLY)
    else:
        fd = os.open(Path(folder) / lock_file, os.O_RDWR | os.O_CREAT, 0o644)
    try:
        try:
            fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except BlockingIOError:
            print(
                f"topomap: process {os.getpid()} waits for another process to finish "
                f"{what} in {folder}",
                file=sys.stderr,
                flush=True,
            )
            fcntl.flock(fd, fcntl.LOCK_EX)
        try:
            yield
        finally:
            fcntl.flock(fd, fcntl.LOCK_UN)
    finally:
        os.close(fd)


def home_lock(home: Path):
    """Lock the data home ``home`` with `folder_lock`, on its file ``.lock``.

    Parameters
    ----------
    home : Path
        The data home.

    Returns
    -------
    context manager
        The lock.
    """
    return folder_lock(home, "the default dataset", LOCK_FILE)


def default_dataset(home: str | os.PathLike | None = None, progress: bool = True) -> Path:
    """Return the default dataset in the data home, collected if it is missing.

    It is collected with a progress bar. An existing dataset there is never replaced: one
    collected with other settings, or a damaged one, is reported by ``sim.collect`` /
    ``sim.dataset`` with what to do.

    Parameters
    ----------
    home : path-like, optional
        The data home (see `data_home`).
    progress : bool, default True
        Show a progress bar while collecting.

    Returns
    -------
    Path
        The dataset's folder.
    """
    from common.cores import spawn_problem
    from sim.collect import CollectionSettings, collect_dataset
    from sim.dataset import META_FILE, read_meta

    root = data_home(home)
    directory = root / DATASET_DIR
    if directory.exists() and not directory.is_dir():
        raise DataHomeError(f"{directory} should be the default dataset folder but is a file")
    meta_path = directory / META_FILE
    if meta_path.is_file() and read_meta(directory).get("complete", False):
        return directory
    with home_lock(root):
        if not (meta_path.is_file() and read_meta(directory).get("complete", False)):
            problem = spawn_problem()
            where = f", in this process: {problem}" if problem else ""
            print(
                f"topomap: collecting the default dataset into {directory} (once; the maps and "
                f"envs that need it read it from there){where}",
                file=sys.stderr,
                flush=True,
            )
            collect_dataset(directory, CollectionSettings(), progress=progress)
    return directory


def maps_dir(home: str | os.PathLike | None = None) -> Path:
    """Return the servo-map cache of the data home (created on first use).

    Parameters
    ----------
    home : path-like, optional
        The data home (see `data_home`).

    Returns
    -------
    Path
        The cache folder.
    """
    directory = data_home(home) / MAPS_DIR
    if directory.exists() and not directory.is_dir():
        raise DataHomeError(f"{directory} should be the servo-map cache folder but is a file")
    directory.mkdir(exist_ok=True)
    return directory


def radish_log(name: str) -> Path:
    """Find a Radish Carmen log in the folder the ``TOPOMAP_RADISH`` variable names.

    Parameters
    ----------
    name : str
        The log's file name in that folder, e.g. ``"aces-corrected.log.gz"`` (the two logs the
        project uses are `RADISH_LOGS`).

    Returns
    -------
    Path
        The log's absolute path; it exists.

    Raises
    ------
    DataHomeError
        When the variable is unset or empty, or its folder does not hold ``name``; the message
        names the variable, so a skipped test or a failed command says what to set.
    """
    folder = os.environ.get(RADISH_VAR, "")
    if not folder:
        raise DataHomeError(
            f"{RADISH_VAR} is not set: set it to the folder holding the Radish logs "
            f"({', '.join(RADISH_LOGS)}; docs/references.md says where to get them)"
        )
    path = Path(folder).expanduser() / name
    if not path.is_file():
        raise DataHomeError(f"{RADISH_VAR}={folder!r} holds no {name}")
    return path.resolve()
