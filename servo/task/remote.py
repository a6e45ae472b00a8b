"""A policy in its own process, seen from the evaluator.

The evaluator's side is [`RemotePolicy`][servo.task.remote.RemotePolicy].

The policy runs in ``python -m servo.task.policy_host`` (decision record 073), started with a
socket, the environment without the data home's variable, and, where the platform allows
([`sandbox_tool`][servo.task.remote.sandbox_tool]: ``bwrap``, else ``unshare``), its own mount and
process namespaces in which the folders given to hide (the datasets, the maps, the data home,
``out/``) are empty. The evaluator sends plain arrays and reads back plain arrays
(``servo.task.wire``), never unpickles what comes back, and checks every answer: a process that
dies, hangs, or answers garbage ends its episode with that reason (``servo.task.guard``), and the
next episode starts a fresh process.
"""

from __future__ import annotations

import functools
import os
import shutil
import socket
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np

from servo.maps import ServoMap
from servo.task import wire
from servo.task.guard import (
    ACT_LIMIT_S,
    DIED,
    GARBAGE,
    INVALID_ACTION,
    RAISED,
    TOO_SLOW,
    PolicyFailure,
)
from servo.task.interface import PolicyLoadError, sensed_map
from servo.task.policy_host import EPISODE_CONSTANT, map_message

START_LIMIT_S = 120.0  # s to start the process, rebuild the map and run the factory
MAX_FROM_POLICY = 1 << 16  # bytes of one answer: an action, a waypoint, a failure's text
_ROOT = Path(__file__).resolve().parents[2]
_UNSHARE_SCRIPT = (
    'n=$1; shift; while [ "$n" -gt 0 ]; do mount -t tmpfs tmpfs "$1" || exit 97; '
    'shift; n=$((n-1)); done; exec "$@"'
)


def default_hidden() -> list[str]:
    """Return the folders a policy's sandbox hides whatever the run.

    They are the data home (``sim.datahome``), ``TOPOMAP_HOME``, the repository's ``out/`` and
    the temporary folder (where every run keeps its copy of the map, the truth included; the
    policy gets an empty one), those that exist; not a folder that holds the repository or the
    current directory.

    Returns
    -------
    list of str
        The folders, resolved and sorted.
    """
    from sim.datahome import ENV_VAR, user_cache_dir

    found = [
        os.environ.get(ENV_VAR) or "",
        str(user_cache_dir()),
        str(_ROOT / "out"),
        tempfile.gettempdir(),
    ]
    return sorted({str(Path(p).resolve()) for p in found if p and Path(p).is_dir()})


def outermost(folders) -> list[str]:
    """Return the folders that lie in no other of ``folders``, resolved.

    A folder that holds the repository or the current directory (hiding it would hide the
    code; a clone in the temporary folder) is replaced by its subfolders off the path to them,
    so everything else in it is still hidden.

    Parameters
    ----------
    folders : iterable of str or path
        The folders to hide.

    Returns
    -------
    list of str
        The outermost folders, sorted.
    """
    needed = (_ROOT, Path.cwd().resolve())
    keep: list[Path] = []
    for f in folders:
        keep += _off_the_path(Path(f).resolve(), needed)
    return sorted({str(f) for f in keep if not any(o in f.parents for o in keep)})


def _off_the_path(folder: Path, needed) -> list[Path]:
    if not folder.is_dir() or any(n == folder for n in needed):
        return []
    if not any(folder in n.parents for n in needed):
        return [folder]
    try:
        children = sorted(c for c in folder.iterdir() if c.is_dir() and not c.is_symlink())
    except OSError:  # a folder we may not list: nothing in it can be hidden either
        return []
    return [kept for c in children for kept in _off_the_path(c, needed)]


def _prefix(tool: str, hide: list[str]) -> list[str]:
    if tool == "bwrap":
        mounts = [a for d in hide for a in ("--tmpfs", d)]
        return [
            "bwrap",
            "--dev-bind",
            "/",
            "/",
            "--unshare-pid",
            "--proc",
            "/proc",
            "--die-with-parent",
            *mounts,
        ]
    return [
        "unshare",
        "--user",
        "--map-root-user",
        "--mount",
        "--pid",
        "--fork",
        "--mount-proc",
        "--kill-child",
        "sh",
        "-c",
        _UNSHARE_SCRIPT,
        "sh",
        str(len(hide)),
        *hide,
    ]


@functools.cache
def sandbox_tool() -> str | None:
    """Return the sandbox tool that works here: ``"bwrap"``, ``"unshare"`` or None.

    The tool is whichever first runs a command in its own mount and process namespaces with a
    folder hidden here; None where neither does.

    Returns
    -------
    str or None
        ``"bwrap"``, ``"unshare"`` or None.

    Examples
    --------
    >>> from servo.task import sandbox_tool
    >>> sandbox_tool() in (None, "bwrap", "unshare")
    True
    """
    for tool in ("bwrap", "unshare"):
        if shutil.which(tool) is None:
            continue
        try:
            done = subprocess.run(
                [*_prefix(tool, [str(_ROOT)]), "true"], timeout=20, capture_output=True
            )
        except (OSError, subprocess.SubprocessError):
            continue
        if done.returncode == 0:
            return tool
    return None


class RemotePolicy:
    """The policy ``spec`` made in its own process on the sensed ``servo_map``.

    Has the [`Policy`][servo.task.interface.Policy] interface; every call crosses the process
    boundary as plain arrays. ``reset`` and ``act`` raise
    [`PolicyFailure`][servo.task.guard.PolicyFailure] (``policy too slow``, ``policy process died``,
    ``policy sent garbage``, ``policy raised``, ``invalid action``) after which the process is
    ended and the next ``reset`` starts a fresh one.

    Parameters
    ----------
    spec : str
        ``package.module:factory``, or one of our controllers (``policy_host.BUILTIN``).
    servo_map : ServoMap
        The world's map; only its sensed part ([`sensed_map`][servo.task.interface.sensed_map]) is
        sent.
    policy_seed : int, default 0
        The seed of the policy's generator.
    params : dict, optional
        The factory's keyword arguments (JSON values).
    sandbox : bool, default False
        Run in a sandbox ([`sandbox_tool`][servo.task.remote.sandbox_tool]); ``ValueError`` when the
        platform has none.
    hide : list of str, optional
        Folders emptied in the sandbox besides `default_hidden`.
    start_limit_s : float, default START_LIMIT_S
        Seconds the process may take to start and make the policy.

    Attributes
    ----------
    limit_s : float
        Seconds a ``reset`` or ``act`` may take (the runner sets it).
    waypoint_ : int or None
        The stored view the policy said it heads for after its last ``act``.
    sandboxed : bool
        Whether it runs in a sandbox.
    hidden : list of str
        The folders the sandbox empties (`outermost` of `default_hidden` and
        ``hide``).

    Examples
    --------
    Made by the runner for every outside policy (``run_protocol``); whether this machine
    can sandbox it:

    >>> from servo.task import RemotePolicy, sandbox_tool
    >>> sandbox_tool() in (None, "bwrap", "unshare")
    True
    >>> callable(RemotePolicy.set_episode)
    True

    See Also
    --------
    servo.task.run_protocol : Runs a policy this way (``isolate``, ``sandbox``).
    servo.task.Policy : The interface it has, as the policy in its process does.
    """

    def __init__(
        self,
        spec: str,
        servo_map: ServoMap,
        policy_seed: int = 0,
        params: dict | None = None,
        *,
        sandbox: bool = False,
        hide=(),
        start_limit_s: float = START_LIMIT_S,
    ):
        self.spec, self.params, self.policy_seed = spec, dict(params or {}), int(policy_seed)
        self.sandboxed = bool(sandbox)
        tool = sandbox_tool() if sandbox else None
        if sandbox and tool is None:
            raise ValueError(
                "no sandbox on this platform: neither bwrap nor unshare can make "
                "a mount namespace here"
            )
        self.hidden = outermost([*default_hidden(), *hide]) if tool else []
        self._prefix = _prefix(tool, self.hidden) if tool else []
        self._views = len(servo_map)
        values, self._arrays = map_message(sensed_map(servo_map))
        self._init = {
            "spec": spec,
            "params": self.params,
            "policy_seed": self.policy_seed,
            "map": values,
        }
        self.limit_s, self.start_limit_s = ACT_LIMIT_S, float(start_limit_s)
        self.waypoint_ = None
        self._proc = self._sock = None
        self._episode, self._sent = (0, self.policy_seed), {}
        self._start()

    # -- the process ----------------------------------------------------------------------
    def _start(self) -> None:
        parent, child = socket.socketpair()
        self._sent = {}  # a fresh process knows nothing of the episode
        env = {k: v for k, v in os.environ.items() if not k.startswith("TOPOMAP_")}
        env["PYTHONPATH"] = os.pathsep.join(filter(None, [str(_ROOT), env.get("PYTHONPATH")]))
        command = [
            *self._prefix,
            sys.executable,
            "-m",
            "servo.task.policy_host",
            str(child.fileno()),
        ]
        try:
            self._proc = subprocess.Popen(
                command, pass_fds=[child.fileno()], env=env, stdin=subprocess.DEVNULL, stdout=2
            )
        except OSError as err:  # no python, no sandbox tool any more, no processes left
            parent.close()
            raise PolicyLoadError(
                f"policy {self.spec!r}: its process did not start ({type(err).__name__}: {err})"
            ) from None
        finally:
            child.close()
        self._sock = parent
        try:
            wire.send(parent, wire.encode("init", self._init, self._arrays))
            kind, values, _ = self._answer(self.start_limit_s)
        except PolicyFailure as err:
            self.close()
            raise PolicyLoadError(f"policy {self.spec!r}: {err}") from None
        if kind != "ready":
            self.close()
            raise PolicyLoadError(str(values.get("detail", "the factory failed"))[:2000])

    def close(self) -> None:
        """End the process (asked first, then killed)."""
        proc, sock, self._proc, self._sock = self._proc, self._sock, None, None
        if sock is not None:
            try:
                wire.send(sock, wire.encode("close"))
            except wire.WireError:
                pass
            sock.close()
        if proc is not None:
            try:
                proc.wait(timeout=2.0)
            except subprocess.TimeoutExpired:
                proc.kill()
                proc.wait()

    def _fail(self, reason: str, detail: str):
        proc = self._proc
        self._proc = None  # killed, not asked: it misbehaved
        if proc is not None:
            proc.kill()
            code = proc.wait()
            if reason == DIED:
                detail = f"{detail} (exit status {code})"
        if self._sock is not None:
            self._sock.close()
            self._sock = None
        raise PolicyFailure(reason, detail)

    def _answer(self, limit: float) -> tuple[str, dict, dict]:
        try:
            data = wire.receive(self._sock, MAX_FROM_POLICY, limit)
            return wire.decode(data, MAX_FROM_POLICY)
        except wire.Timeout:
            self._fail(TOO_SLOW, f"no answer within {limit:g} s")
        except wire.Closed as err:
            self._fail(DIED, str(err))
        except wire.WireError as err:
            self._fail(GARBAGE, str(err))

    def _ask(self, kind: str, values: dict, arrays: dict, expected: str):
        if self._proc is None:
            try:
                self._start()
            except PolicyLoadError as err:
                raise PolicyFailure(DIED, f"could not start again: {err}") from None
        try:
            wire.send(self._sock, wire.encode(kind, values, arrays))
        except wire.Closed as err:
            self._fail(DIED, str(err))
        got, answer, out = self._answer(self.limit_s)
        if got == "error":
            raise PolicyFailure(RAISED, str(answer.get("detail", "?"))[:2000])
        if got != expected:
            self._fail(GARBAGE, f"a {str(got)[:40]!r} message where {expected!r} was due")
        return answer, out

    # -- the Policy interface ---------------------------------------------------------------
    def set_episode(self, episode_seed: int, policy_seed: int) -> None:
        """Set the seeds the next ``reset`` sets the policy's generator from (outside policies).

        Parameters
        ----------
        episode_seed : int
            The episode's seed.
        policy_seed : int
            The run's policy seed.
        """
        self._episode = (int(episode_seed), int(policy_seed))

    def reset(self, target) -> None:
        """Start an episode toward ``target`` (a ``Target``: its view and image go over).

        Parameters
        ----------
        target : Target
            The target's stored view.
        """
        seed, policy_seed = self._episode
        self._sent = {}
        values = {"view": int(target.view), "episode_seed": seed, "policy_seed": policy_seed}
        self._ask("reset", values, {"image": target.image}, "done")

    def act(self, observation: dict) -> np.ndarray:
        """Return the policy's command for ``observation``.

        Plain arrays go over, two numbers come back.

        Parameters
        ----------
        observation : dict
            The env's observation.

        Returns
        -------
        ndarray of shape (2,), float64
            The command (v m/s, omega rad/s).
        """
        self.waypoint_ = None
        send, same = {}, []
        for k, v in observation.items():  # what stays the same in an episode goes over once
            if k in EPISODE_CONSTANT and k in self._sent and np.array_equal(self._sent[k], v):
                same.append(k)
            else:
                send[k] = v
        answer, arrays = self._ask("act", {"same": same}, send, "action")
        self._sent.update({k: np.array(send[k]) for k in EPISODE_CONSTANT if k in send})
        if set(arrays) - {"action"} or set(answer) - {"waypoint", "invalid"}:
            self._fail(GARBAGE, "an action message with other fields")
        if "invalid" in answer or "action" not in arrays:
            raise PolicyFailure(INVALID_ACTION, f"not numbers: {str(answer.get('invalid'))[:200]}")
        w = answer.get("waypoint")
        if isinstance(w, int) and not isinstance(w, bool) and 0 <= w < self._views:
            self.waypoint_ = w
        return np.array(arrays["action"], dtype=np.float64)

    def __del__(self):
        """Kill the process if it still runs."""
        if getattr(self, "_proc", None) is not None:
            self._proc.kill()
