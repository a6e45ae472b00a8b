"""Domain randomisation of a world's look: the table of parameters and one draw from it."""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

__all__ = [
    "APPEARANCE_MODES",
    "RANDOMIZATION",
    "TEXTURE_SEED",
    "Appearance",
    "check_appearance_mode",
    "draw_appearance",
]

# Domain randomisation table, as Miniworld's params: name -> (default, low, high). Without an
# RNG every parameter takes its default, so the canonical world is one fixed scene.
RANDOMIZATION: dict[str, tuple[float, float, float]] = {
    "light_intensity": (1.0, 0.55, 1.45),  # multiplier on every light's diffuse colour
    "light_tint": (0.0, -0.12, 0.12),  # per-channel shift of light colour
    "light_shift": (0.0, -0.6, 0.6),  # m, light positions along the corridor / sun direction
    "colour_jitter": (0.0, -0.08, 0.08),  # per-channel shift of every base texture colour
    "clutter_shift": (0.0, -0.5, 0.5),  # m, furniture and posters slid along their wall
}
TEXTURE_SEED = 20_040_607  # canonical textures: fixed noise, part of the world's identity
# How the manifolds of a world differ in look. "default": each branch has its own wall, floor
# and light colour (a colour histogram tells them apart). "hard": every branch shares the main
# manifold's wall, floor (ground) and light materials, so only the layout (branch directions,
# lengths, furniture and landmarks) tells them apart: what colour alone cannot tell is then
# measured (experiments/manifold/colour_bound.py).
APPEARANCE_MODES = ("default", "hard")


@dataclass(frozen=True)
class Appearance:
    """One draw from [`RANDOMIZATION`][scenes.appearance.RANDOMIZATION], its generators and mode.

    The draw's parameters plus the generator that made the textures, and the appearance mode
    (one of `APPEARANCE_MODES`).

    Parameters
    ----------
    params : dict
        The drawn value of each parameter of ``RANDOMIZATION``.
    texture_rng : numpy.random.Generator
        The generator of the textures.
    rng : numpy.random.Generator or None, default None
        The generator of further draws (jitter, shifts); None: not randomised.
    mode : str, default "default"
        One of `APPEARANCE_MODES`.
    """

    params: dict
    texture_rng: np.random.Generator = field(compare=False, repr=False)
    rng: np.random.Generator | None = field(compare=False, repr=False, default=None)
    mode: str = "default"

    @property
    def shared_materials(self) -> bool:
        """Whether every branch wears the main manifold's wall, floor and light materials."""
        return self.mode == "hard"

    def __getitem__(self, key: str) -> float:
        """Return the drawn value of parameter ``key``."""
        return self.params[key]

    def colour(self, rgb) -> tuple[float, float, float]:
        """Return a base colour with this draw's jitter (a new jitter per call when randomised).

        Parameters
        ----------
        rgb : array_like of shape (3,)
            The base colour, 0..1 per channel.

        Returns
        -------
        tuple of float
            The jittered colour, clipped to 0..1.
        """
        rgb = np.asarray(rgb, np.float64)
        if self.rng is not None:
            lo, hi = RANDOMIZATION["colour_jitter"][1:]
            rgb = rgb + self.rng.uniform(lo, hi, 3)
        return tuple(np.clip(rgb, 0.0, 1.0))

    def light(self, rgb) -> tuple[float, float, float]:
        """Return a light's colour with this draw's intensity (and a new tint when randomised).

        Parameters
        ----------
        rgb : array_like of shape (3,)
            The light's base colour, 0..1 per channel.

        Returns
        -------
        tuple of float
            The colour times ``light_intensity``, plus the tint, clipped to 0..1.
        """
        tint = (
            np.zeros(3)
            if self.rng is None
            else self.rng.uniform(*RANDOMIZATION["light_tint"][1:], 3)
        )
        return tuple(np.clip(np.asarray(rgb) * self["light_intensity"] + tint, 0.0, 1.0))

    def shift(self, key: str) -> float:
        """Return a fresh draw of a positional parameter (its default when not randomised).

        Parameters
        ----------
        key : str
            A parameter of ``RANDOMIZATION`` (``"light_shift"``, ``"clutter_shift"``).

        Returns
        -------
        float
            The drawn shift, m.
        """
        if self.rng is None:
            return RANDOMIZATION[key][0]
        return float(self.rng.uniform(*RANDOMIZATION[key][1:]))


def check_appearance_mode(mode) -> str:
    """Return ``mode`` if it is one of `APPEARANCE_MODES`, else raise a ValueError naming them.

    Parameters
    ----------
    mode : str
        The appearance mode.

    Returns
    -------
    str
        ``mode``.
    """
    if not isinstance(mode, str) or mode not in APPEARANCE_MODES:
        raise ValueError(f"appearance must be one of {APPEARANCE_MODES}, got {mode!r}")
    return mode


def draw_appearance(rng: np.random.Generator | None, mode: str = "default") -> Appearance:
    """Draw an appearance: defaults and canonical textures without an RNG; randomised with one.

    ``mode`` only changes which materials the builders assign, never what the generators draw,
    so a hard world has the same textures, lights and clutter draws as its default twin.

    Parameters
    ----------
    rng : numpy.random.Generator or None
        The generator to draw from; None: the defaults and ``TEXTURE_SEED``'s textures.
    mode : str, default "default"
        One of `APPEARANCE_MODES`.

    Returns
    -------
    Appearance
        The draw.
    """
    mode = check_appearance_mode(mode)
    if rng is None:
        params = {k: v[0] for k, v in RANDOMIZATION.items()}
        return Appearance(params, np.random.default_rng(TEXTURE_SEED), None, mode)
    if not isinstance(rng, np.random.Generator):
        raise TypeError(f"rng must be a numpy.random.Generator or None, got {type(rng).__name__}")
    params = {k: float(rng.uniform(lo, hi)) for k, (_, lo, hi) in RANDOMIZATION.items()}
    texture_rng, layout_rng = rng.spawn(2)
    return Appearance(params, texture_rng, layout_rng, mode)
