"""Off-screen RGB (and optional depth) camera through ``mujoco.Renderer``.

The renderer is created lazily on the first frame (so forked vector-env workers never inherit
a GL context) and closed idempotently. Shadows and multisampling are off by default: on a CPU
rasteriser they cost 5-10x the frame rate while adding nothing the mapping methods use.
"""

from __future__ import annotations

from dataclasses import dataclass

import mujoco
import numpy as np

from scenes import names
from sim._gl import INSTALL_HINT, check_fork_safe, note_context_created

MAX_SIZE = 4096


@dataclass(frozen=True)
class CameraConfig:
    """Image size (pixels), vertical field of view (degrees), depth and shadow switches.

    320x240 is the paper's image size.

    Parameters
    ----------
    width, height : int, default 320, 240
        Image size, pixels, in ``[1, MAX_SIZE]``.
    fovy : float, default 45.0
        Vertical field of view, degrees, in (0, 180).
    depth : bool, default False
        Also record metric depth.
    shadows : bool, default False
        Render shadows.
    """

    width: int = 320
    height: int = 240
    fovy: float = 45.0
    depth: bool = False
    shadows: bool = False

    def __post_init__(self):
        """Check the size and field of view; ``ValueError`` names the first that is invalid."""
        for k in ("width", "height"):
            v = getattr(self, k)
            if int(v) != v or not (1 <= v <= MAX_SIZE):
                raise ValueError(f"camera {k} must be an integer in [1, {MAX_SIZE}], got {v}")
        if not (0 < self.fovy < 180):
            raise ValueError(f"camera fovy must be in (0, 180) degrees, got {self.fovy}")


class Camera:
    """Renders one named camera of a model.

    Parameters
    ----------
    model : mujoco.MjModel
        The model.
    config : CameraConfig
        The camera's settings.
    camera : str, default names.ROBOT_CAMERA
        The camera's name in the model.
    """

    def __init__(
        self, model: mujoco.MjModel, config: CameraConfig, camera: str = names.ROBOT_CAMERA
    ):
        self.model = model
        self.config = config
        self.camera_id = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_CAMERA, camera)
        if self.camera_id < 0:
            raise ValueError(f"camera {camera!r} not in the model")
        self._renderer: mujoco.Renderer | None = None
        self._depth_renderer: mujoco.Renderer | None = None

    def _make_renderer(self) -> mujoco.Renderer:
        g = self.model.vis.global_
        # A frame larger than the off-screen buffer grows the buffer instead of failing.
        g.offwidth = max(g.offwidth, self.config.width)
        g.offheight = max(g.offheight, self.config.height)
        check_fork_safe()
        try:
            renderer = mujoco.Renderer(self.model, self.config.height, self.config.width)
        except Exception as err:  # the GL backends raise several unrelated types
            raise RuntimeError(
                f"could not create an off-screen renderer ({err}). {INSTALL_HINT}"
            ) from err
        note_context_created()
        renderer.scene.flags[mujoco.mjtRndFlag.mjRND_SHADOW] = self.config.shadows
        return renderer

    def render(self, data: mujoco.MjData) -> np.ndarray:
        """Render the RGB image; positions must be fresh (``mj_forward``).

        Parameters
        ----------
        data : mujoco.MjData
            The model's state.

        Returns
        -------
        ndarray of shape (H, W, 3), uint8
            The image.
        """
        if self._renderer is None:
            self.model.cam_fovy[self.camera_id] = self.config.fovy
            self._renderer = self._make_renderer()
        self._renderer.update_scene(data, self.camera_id)
        return self._renderer.render()

    def render_depth(self, data: mujoco.MjData) -> np.ndarray:
        """Render the metric depth along the camera axis.

        Parameters
        ----------
        data : mujoco.MjData
            The model's state.

        Returns
        -------
        ndarray of shape (H, W), float32
            Depth, m.
        """
        if self._depth_renderer is None:
            self._depth_renderer = self._make_renderer()
            self._depth_renderer.enable_depth_rendering()
        self._depth_renderer.update_scene(data, self.camera_id)
        return self._depth_renderer.render().astype(np.float32)

    def close(self) -> None:
        """Free the GL resources; safe to call twice."""
        for attr in ("_renderer", "_depth_renderer"):
            r = getattr(self, attr)
            if r is not None:
                setattr(self, attr, None)
                r.close()

    def __del__(self):
        """Free the GL resources, ignoring errors."""
        try:
            self.close()
        except Exception:
            pass
