"""Choose MuJoCo's headless OpenGL backend before ``mujoco`` is imported.

MuJoCo reads ``MUJOCO_GL`` once, at import. We pick EGL (Mesa's software EGL works on CPU
machines without a display), fall back to OSMesa where EGL is missing, and never touch GLFW,
which needs a display. A user's own ``MUJOCO_GL`` always wins.
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
    return backend


BACKEND = choose_backend()
