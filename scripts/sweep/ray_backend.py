"""The ``ray`` sweep backend: one Ray actor per worker, on a local Ray instance or a cluster.

Each actor is an `EpisodeRunner` running whole episodes (env and policy together), on a local
Ray instance (started here, with ``num_cpus`` = the workers, no dashboard, shut down
afterwards) or on an existing cluster given its address.

Ray is optional (``pip install -e '.[ray]'``): it is imported only here, and only when the
backend is asked for. Maps travel through Ray's object store (``ray.put`` once, shared by all
actors), so a remote cluster needs no files of ours; the code travels as the runtime env's
``working_dir`` (this repository's packages) on a remote cluster, and on the local instance the
workers import it from the same checkout (``PYTHONPATH``). The headless GL backend
(``MUJOCO_GL``, chosen by ``sim`` on import) is passed to every worker in the runtime env.
"""

from __future__ import annotations

import os
import pickle
import socket
from collections.abc import Iterator
from pathlib import Path

from scripts.sweep.episode import ONE_THREAD, EpisodeRunner

PROBE_TIMEOUT_S = 5.0  # how long an address may take to accept a TCP connection
GCS_PORT, CLIENT_PORT = 6379, 10001  # Ray's defaults: `ray start --head`, the Ray Client server
REPO = Path(__file__).resolve().parents[1]
# HTTP/2 client preface, then an empty SETTINGS frame (length 0, type 4, no flags, stream 0)
_H2_PREFACE = b"PRI * HTTP/2.0\r\n\r\nSM\r\n\r\n" + b"\x00\x00\x00\x04\x00\x00\x00\x00\x00"
_CODE = ["common", "scenes", "sim", "mapping", "servo", "scripts"]  # the packages a worker imports
_PASS_ENV = ("MUJOCO_GL", "PYOPENGL_PLATFORM", "MUJOCO_EGL_DEVICE_ID", "TOPOMAP_HOME")


def require_ray():
    """Import the ``ray`` module, or raise an ImportError saying how to install it.

    Returns
    -------
    module
        ``ray``.
    """
    try:
        import ray
    except ImportError as err:
        raise ImportError(
            "the ray backend needs Ray: pip install 'ray>=2.9' (or pip install -e '.[ray]'); "
            "--backend local runs without it"
        ) from err
    return ray


def parse_address(address: str) -> tuple[str, int] | None:
    """Parse a Ray address into ``(host, port)``.

    Parameters
    ----------
    address : str
        ``host:port``; ``ray://host[:port]``, the Ray Client (the port defaults to Ray's); or
        ``auto``.

    Returns
    -------
    tuple of (str, int) or None
        The host and port, or None for ``auto`` (the cluster running on this machine).

    Raises
    ------
    ValueError
        When the address has another form.
    """
    if address == "auto":
        return None
    rest, client = (address[6:], True) if address.startswith("ray://") else (address, False)
    host, sep, port = rest.rpartition(":")
    if not sep:
        host, port = rest, str(CLIENT_PORT if client else GCS_PORT)
    if not host or not port.isdigit() or not 0 < int(port) < 65536:
        raise ValueError(f"address must look like host:port or ray://host:port, got {address!r}")
    return host, int(port)


def probe_address(address: str, timeout: float = PROBE_TIMEOUT_S) -> None:
    """Check that a Ray cluster answers at ``address``, failing within ``timeout`` seconds.

    Raises a ConnectionError saying what to do where nothing accepts a connection at
    ``address`` (see `parse_address`; ``auto`` is not probed: Ray itself fails at once where
    no local cluster runs); the same where what answers is not a gRPC server. ``ray.init``
    alone retries an unreachable GCS for minutes (measured: over 3 minutes with Ray 2.60).

    Parameters
    ----------
    address : str
        A Ray address.
    timeout : float, default PROBE_TIMEOUT_S
        Seconds to wait for the connection and for the answer.
    """
    if (parsed := parse_address(address)) is None:
        return
    host, port = parsed
    try:
        with socket.create_connection((host, int(port)), timeout=timeout) as s:
            # Ray's GCS and client servers speak gRPC: HTTP/2, whose server answers a client's
            # preface with a SETTINGS frame (RFC 9113, 3.4). Anything else is not Ray.
            s.settimeout(timeout)
            s.sendall(_H2_PREFACE)
            head = b""
            while len(head) < 9 and (chunk := s.recv(9 - len(head))):
                head += chunk
    except OSError as err:
        raise ConnectionError(
            f"no Ray cluster answers at address {address!r} ({host}:{port}: {err or 'timed out'}"
            f"; waited up to {timeout:g} s); start one there (ray start --head --port {port}) or"
            " leave --address out to run on a local Ray instance"
        ) from None
    if len(head) < 9 or head[3] != 4:
        raise ConnectionError(
            f"address {address!r} ({host}:{port}) answers, but not as a Ray cluster's GCS or "
            f"Ray Client port (no gRPC handshake); give the address `ray start --head` printed"
        )


def runtime_env(address: str | None) -> dict:
    """Build the actors' runtime env: the GL backend and data home, and our code.

    The GL backend and data home come from this process; our code on a local instance is the
    same checkout (``PYTHONPATH``), on a cluster our packages, uploaded (``py_modules``: Ray
    takes local folders only in the job's runtime env, so `RayBackend` passes this to
    ``ray.init`` and the ``env_vars`` to each actor).

    Parameters
    ----------
    address : str or None
        The cluster's address, or None for a local instance.

    Returns
    -------
    dict
        ``env_vars`` and, on a cluster, ``py_modules``.
    """
    env = {k: os.environ[k] for k in _PASS_ENV if k in os.environ} | ONE_THREAD
    if address is None:
        env["PYTHONPATH"] = os.pathsep.join(filter(None, [str(REPO), os.environ.get("PYTHONPATH")]))
        return {"env_vars": env}
    return {"env_vars": env, "py_modules": [str(REPO / p) for p in _CODE]}


def _nbytes(obj) -> int:
    """Pickled size of ``obj``, arrays counted without copying them (protocol 5 buffers)."""
    buffers: list = []
    head = pickle.dumps(obj, protocol=5, buffer_callback=buffers.append)
    return len(head) + sum(b.raw().nbytes for b in buffers)


class RayBackend:
    """``workers`` Ray actors (1 CPU each).

    Parameters
    ----------
    workers : int
        The number of actors.
    address : str, optional
        None starts a local Ray instance (or uses the one this process already has);
        otherwise the cluster there (``ray.init(address)`` after `probe_address`).
    """

    name = "ray"

    def __init__(self, workers: int, address: str | None = None):
        self.workers, self.address = int(workers), address
        self._ray = require_ray()
        if address is not None:
            probe_address(address)
        self._started = False  # whether we started (and so shut down) Ray
        self._actors: list = []

    def _init(self, object_store_bytes: int) -> None:
        ray = self._ray
        if ray.is_initialized():  # the caller's own Ray session: use it as it is
            return
        kwargs = {
            "include_dashboard": False,
            "logging_level": "warning",
            "runtime_env": runtime_env(self.address),
        }
        if self.address is None:
            # "local": always a new instance (None would join a cluster `ray start` left on
            # this machine); the smallest object store that holds the maps (Ray's minimum is
            # 75 MiB)
            kwargs.update(
                address="local",
                num_cpus=self.workers,
                object_store_memory=max(100 << 20, 2 * object_store_bytes),
            )
        else:
            kwargs.update(address=self.address)
        ray.init(**kwargs)
        self._started = True

    def start(self, maps: dict, policy: str, max_steps: int) -> None:
        """Start the actors, each an `EpisodeRunner` of ``maps``, ``policy`` and ``max_steps``.

        Parameters
        ----------
        maps : dict
            ``{world: ServoMap}``, sent once through the object store (a cluster's nodes need
            not share our disk).
        policy : str
            A name of ``servo.task.policies.POLICIES``.
        max_steps : int
            The episodes' step limit.
        """
        self.start_runner(EpisodeRunner, maps, policy, max_steps, _put=maps)

    def start_runner(self, factory, *args, _put=None) -> None:
        """Start one actor per worker, each ``factory(*args)``.

        Parameters
        ----------
        factory : callable
            Makes a worker's runner (with ``run(task)`` and ``close()``).
        *args
            The factory's arguments.
        _put : object, optional
            The first argument, sent once through the object store instead.

        Raises
        ------
        ValueError
            When the cluster has fewer CPUs than workers.
        """
        ray = self._ray
        self._init(_nbytes(args if _put is None else _put))
        cpus = ray.cluster_resources().get("CPU", 0)
        if cpus < self.workers:
            raise ValueError(
                f"num_envs (the workers) must be at most the Ray cluster's {cpus:g} CPUs, "
                f"got {self.workers}"
            )
        if _put is not None:
            args = (ray.put(_put), *args[1:])
        env = {"env_vars": runtime_env(self.address)["env_vars"]}
        actor = ray.remote(num_cpus=1, runtime_env=env)(factory)
        self._actors = [actor.remote(*args) for _ in range(self.workers)]
        ray.get([a.__ray_ready__.remote() for a in self._actors])

    def run(self, tasks: list) -> Iterator[tuple[int, dict]]:
        """Run ``tasks`` on the actors, yielding each record as it completes.

        Each actor runs one episode at a time; the next goes to whichever finishes first.

        Parameters
        ----------
        tasks : list
            The tasks, each for the runners' ``run``.

        Yields
        ------
        index : int
            The task's index in ``tasks``.
        record : dict
            Its record.
        """
        ray = self._ray
        todo = list(enumerate(tasks))[::-1]
        running: dict = {}
        free = list(self._actors)
        while todo or running:
            while free and todo:
                i, task = todo.pop()
                a = free.pop()
                running[a.run.remote(task)] = (i, a)
            (ref,), _ = ray.wait(list(running), num_returns=1)
            i, a = running.pop(ref)
            free.append(a)
            yield i, ray.get(ref)

    def close(self) -> None:
        """Stop the actors and shut down the Ray session this backend opened."""
        ray = self._ray
        for a in self._actors:
            # a graceful exit once its queue is empty: ray.kill's forced exit of a worker on a
            # cluster once crashed in Ray's metrics thread (a SIGSEGV in the worker's log)
            a.__ray_terminate__.remote()
        self._actors = []
        if self._started:
            ray.shutdown()
            self._started = False
