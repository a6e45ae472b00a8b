"""Per-episode appearance randomisation on a compiled model: light colours and intensities and
material colours, drawn from :data:`scenes.RANDOMIZATION`, without recompiling the model.

(Textures and clutter placement are randomised when a world is *built*, with
``scenes.build_world(name, rng)``; changing them per episode would mean recompiling and a new
renderer, ~1 s.)
"""

from __future__ import annotations

import mujoco
import numpy as np

from scenes import RANDOMIZATION


class AppearanceRandomizer:
    """Remembers the model's base appearance and re-draws it on :meth:`apply`."""

    def __init__(self, model: mujoco.MjModel):
        self.model = model
        self._light_diffuse = model.light_diffuse.copy()
        self._mat_rgba = model.mat_rgba.copy()

    def apply(self, rng: np.random.Generator | None) -> dict:
        """Draw new lights and colours (``rng=None`` restores the base appearance)."""
        m = self.model
        if rng is None:
            m.light_diffuse[:] = self._light_diffuse
            m.mat_rgba[:] = self._mat_rgba
            return {}
        gain = rng.uniform(*RANDOMIZATION["light_intensity"][1:])
        tint = rng.uniform(*RANDOMIZATION["light_tint"][1:], 3)
        m.light_diffuse[:] = np.clip(self._light_diffuse * gain + tint, 0.0, 1.0)
        jitter = rng.uniform(*RANDOMIZATION["colour_jitter"][1:], (len(self._mat_rgba), 3))
        m.mat_rgba[:, :3] = np.clip(self._mat_rgba[:, :3] + jitter, 0.0, 1.0)
        return {"light_intensity": float(gain), "light_tint": tint.tolist()}
