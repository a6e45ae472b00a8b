"""Per-episode appearance randomisation on a compiled model, without recompiling it.

Light colours and intensities (the scene's lights and the headlight) and material colours are
drawn from [`scenes.RANDOMIZATION`][scenes.RANDOMIZATION].

(Textures and clutter placement are randomised when a world is *built*, with
``scenes.build_world(name, rng)``; changing them per episode would mean recompiling and a new
renderer, ~1 s.)

Why multiplicative and unclipped: every material's base ``rgba`` is white (its colour is in
its texture, which ``rgba`` multiplies), and the lights' diffuse colours are 0.85-1.0. An
additive jitter clipped to [0, 1] could then only darken materials, and a light gain above 1
was mostly clipped away, so such "randomised" images differed from the plain ones
by 0.4-7 grey levels of 255. OpenGL's fixed-function lighting accepts light colours above 1
(it clamps the lit fragment, not the light), so gains brighten as well as darken; a material's
colour factor is a hue shift, divided by its largest channel so that channel keeps its base
value (a white texture multiplier cannot exceed 1), and the overall brightness is the lights'
job.
"""

from __future__ import annotations

import mujoco
import numpy as np

from scenes import RANDOMIZATION

# Light colours above this are pointless (the lit fragment saturates) and risk all-white images.
MAX_LIGHT = 2.0


class AppearanceRandomizer:
    """Remembers the model's base appearance and re-draws it on `apply`.

    Parameters
    ----------
    model : mujoco.MjModel
        The compiled model, changed in place.
    """

    def __init__(self, model: mujoco.MjModel):
        self.model = model
        self._light_diffuse = model.light_diffuse.copy()
        self._mat_rgba = model.mat_rgba.copy()
        self._headlight = (model.vis.headlight.ambient.copy(), model.vis.headlight.diffuse.copy())

    def _restore(self) -> None:
        m = self.model
        m.light_diffuse[:] = self._light_diffuse
        m.mat_rgba[:] = self._mat_rgba
        m.vis.headlight.ambient[:], m.vis.headlight.diffuse[:] = self._headlight

    def apply(self, rng: np.random.Generator | None) -> dict:
        """Draw new lights and colours (``rng=None`` restores the base appearance).

        One intensity gain and one per-channel tint for every light (the headlight too), and
        per material a per-channel colour factor ``1 + U(colour_jitter)`` divided by its
        largest channel (a hue shift; see the module doc).

        Parameters
        ----------
        rng : numpy.random.Generator or None
            Draws the appearance; None restores the base one.

        Returns
        -------
        dict
            ``{"light_intensity", "light_tint"}`` as drawn; ``{}`` for ``rng=None``.
        """
        self._restore()
        if rng is None:
            return {}
        m = self.model
        gain = rng.uniform(*RANDOMIZATION["light_intensity"][1:])
        tint = rng.uniform(*RANDOMIZATION["light_tint"][1:], 3)
        m.light_diffuse[:] = np.clip(self._light_diffuse * gain + tint, 0.0, MAX_LIGHT)
        ambient, diffuse = self._headlight
        m.vis.headlight.ambient[:] = np.clip(ambient * gain + tint * ambient, 0.0, MAX_LIGHT)
        m.vis.headlight.diffuse[:] = np.clip(diffuse * gain + tint * diffuse, 0.0, MAX_LIGHT)
        factor = 1.0 + rng.uniform(*RANDOMIZATION["colour_jitter"][1:], (len(self._mat_rgba), 3))
        m.mat_rgba[:, :3] = self._mat_rgba[:, :3] * (factor / factor.max(axis=1, keepdims=True))
        return {"light_intensity": float(gain), "light_tint": tint.tolist()}
