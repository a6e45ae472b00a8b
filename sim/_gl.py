"""Choose MuJoCo's headless OpenGL backend before ``mujoco`` is imported.

MuJoCo reads ``MUJOCO_GL`` once, at import. We pick EGL (Mesa's software EGL works on CPU
machines without a display), fall back to OSMesa where EGL is missing, and never touch GLFW,
which needs a display. A user's own ``MUJOCO_GL`` always wins.

Mesa's software rasteriser (llvmpipe) renders with a pool of threads by default. A process
forked after its parent created a GL context inherits that pool's locks but not its threads, and
hangs on its first frame: exactly what ``gym.make_vec(..., vectorization_mode="async")`` does
with the default ``fork`` context after the parent rendered anything. We therefore default
``LP_NUM_THREADS=0`` (render in the calling thread; as fast for our 320x240 frames, see
``bench/``), which makes forked workers safe. Where a user set their own thread count,
`check_fork_safe` turns the hang into an immediate error saying what to pass instead.
"""

from __future__ import annotations

import ctypes.util
import os
import sys
import warnings

INSTALL_HINT = (
    "No headless OpenGL found. On Debian/Ubuntu install Mesa's EGL: "
    "`apt-get install libegl1 libgl1-mesa-dri` (or OSMesa: `apt-get install libosmesa6`), "
    "or set MUJOCO_GL to a backend that works on this machine."
)


def choose_backend() -> str:
    """Set ``MUJOCO_GL`` (and ``PYOPENGL_PLATFORM``) if unset; return the backend in force."""
    backend = os.environ.get("MUJOCO_GL")
    if not backend:
        if ctypes.util.find_library("EGL"):
            backend = "egl"
        elif ctypes.util.find_library("OSMesa"):
            backend = "osmesa"
        else:
            backend = "egl"  # rendering will fail with INSTALL_HINT; physics and lasers still work
        os.environ["MUJOCO_GL"] = backend
        if "mujoco" in sys.modules:
            warnings.warn(
                "mujoco was imported before sim: MUJOCO_GL could not take effect; import sim "
                "first or set MUJOCO_GL=egl in the environment",
                RuntimeWarning,
                stacklevel=3,
            )
    if backend in ("egl", "osmesa"):
        os.environ.setdefault("PYOPENGL_PLATFORM", backend)
        os.environ.setdefault("LP_NUM_THREADS", "0")
    return backend


# (pid, threaded) of the first GL context this process or an ancestor created; inherited by fork.
_context_owner: tuple[int, bool] | None = None


def note_context_created() -> None:
    """Record that this process now holds a GL context (called by the camera)."""
    global _context_owner
    if _context_owner is None or _context_owner[0] != os.getpid():
        _context_owner = (os.getpid(), os.environ.get("LP_NUM_THREADS") != "0")


def check_fork_safe() -> None:
    """Raise at once where creating a GL context would hang.

    It would hang in a process forked after its parent created one with llvmpipe's render
    threads on.
    """
    if _context_owner is None:
        return
    pid, threaded = _context_owner
    if pid != os.getpid() and threaded:
        raise RuntimeError(
            "this process was forked after its parent created an OpenGL context with "
            f"LP_NUM_THREADS={os.environ.get('LP_NUM_THREADS')!r}; rendering here would hang. "
            "Start vector envs with the spawn context (gym.make_vec(..., vectorization_mode="
            "'async', vector_kwargs={'context': 'spawn'}) or AsyncVectorEnv(..., "
            "context='spawn')), or leave LP_NUM_THREADS unset (sim sets it to 0)."
        )


BACKEND = choose_backend()
