"""``SignalServoConfig``: every setting of the camera-only controller.

The settings of [`SignalServo`][servo.camera_only.controller.SignalServo], in one frozen
dataclass validated on construction.
"""

from __future__ import annotations

from dataclasses import dataclass, fields

import numpy as np

from common.validation import check_int
from sim.simulator import OMEGA_LIMIT, V_LIMITS

# settings that may be 0 (off)
_MAY_BE_ZERO = (
    "max_relocalise",
    "lateral_rounds",
    "relocalise_bumps",
    "bump_shift",
    "cross_gain",
    "pose_every",
    "pose_agree",
    "fix_check",
    "look_back",
    "unpeaked",
)

# settings that were off by default and lost their comparison; naming one is refused
REMOVED = (
    "arrive_lanes",
    "consistent_fix",
    "exclude_fix",
    "junction_fix",
    "junction_position",
    "junction_radius",
    "junction_parallax",
    "bumps_arriving",
    "refine_shift",
    "bump_turn",
    "arrive_descent",
    "descent_step",
    "descent_rounds",
    "descent_rise",
)


class _RefusesRemoved:
    """Refuse a setting in ``REMOVED`` by name before the dataclass's ``__init__`` runs.

    A base class, so that the signature shown stays ``__init__``'s.
    """

    def __new__(cls, *args, **kwargs):
        """Make the object, refusing a removed setting among ``kwargs``.

        Parameters
        ----------
        *args, **kwargs
            The arguments of the construction (checked here, used by ``__init__``).

        Returns
        -------
        SignalServoConfig
            The object, not yet initialised.
        """
        gone = [name for name in kwargs if name in REMOVED]
        if gone:
            raise TypeError(
                f"{cls.__name__}: {gone[0]} was removed (an option, off by default, that lost "
                "its comparison: docs/decisions/076-camera-only-switches-that-lost.md)"
            )
        return super().__new__(cls)


@dataclass(frozen=True)
class SignalServoConfig(_RefusesRemoved):
    """Every setting of [`SignalServo`][servo.camera_only.controller.SignalServo].

    A frozen dataclass, checked when made: change a setting with `dataclasses.replace`. The
    defaults are the settings the servo evaluation measures (chosen on the ``dev`` split of the
    benchmark protocol only, so the ``test`` split stays unseen). Gains and shares lie in (0,
    1]; a setting marked "0: off" may be 0, every other number must be positive; a wrong value
    raises ``ValueError`` naming the field. A setting that was removed (``REMOVED``: options,
    off by default, that lost their comparison; decision record 076) raises ``TypeError`` naming
    it.

    Parameters
    ----------
    speed : float, default 1.5
        Forward speed along the route, m/s (pure pursuit); at most the action space's 1.5.
    lookahead : float, default 1.0
        Distance ahead along the route of the pursued point, m.
    spacing : float, default 0.8
        Distance between the waypoint views picked along a route, m.
    turn_rate : float, default 1.2
        Angular speed of the observing turn, rad/s; at most the action space's 1.5.
    observe_every : int, default 2
        Steps between the images localised during the observing turn.
    fix_clusters : int, default 2
        Clusters (ranked by eq. 13's ``predict``) whose views the global fix compares.
    image_trust : float, default 0.9
        Largest aligned image distance (of 0..4) that counts as an image fix.
    heading_gain : float, default 0.5
        Share of an image fix's heading error corrected per fix.
    along_gain : float, default 0.2
        Share of an image fix's error along the view's sight corrected per fix.
    behind, ahead : float, default 1.5 and 2.5
        Route behind and ahead of the believed progress whose views an image fix compares, m.
    facing : float, default 0.35
        Only route views within this of the robot's heading are compared, rad, in (0, pi): the
        alignment's range (0.25 rad) plus 0.1 for the belief's own error, since a view turned
        farther gives a false minimum inside the range.
    window : float, default 2.0
        Largest move of the believed progress in one step, m.
    arrive_distance : float, default 1.0
        Route left at which the arrival law takes over, m.
    arrive_drop : float, default 0.5
        F toward the target below this share of its peak means the robot is past the peak.
    arrive_min : float, default 0.05
        F toward a view (0..1) that counts as a signal at all (a peak, an overtaking).
    arrive_confirm : float, default 0.5
        F toward the target (0..1) whose peak counts as having passed the view.
    arrive_past : float, default 0.4
        Distance the robot must have gone past an F peak before it counts, m.
    overshoot : float, default 1.0
        Distance beyond the target view driven while looking for the F peak, m.
    sweeps : int, default 3
        Legs of the sweep along the target view's line of sight before the best F is taken.
    lateral : float, default 0.6
        Offset to either side at which F is probed once the sweep has settled, m.
    lateral_rounds : int, default 2
        Times a better side moves the sweep there (0: off;
        `PeakArrival`).
    relocalise_after : int, default 40
        Steps facing route views without an image fix after which the robot observes and
        localises again.
    max_relocalise : int, default 2
        Most relocalisations in an episode (0: never).
    contrast_fix : bool, default True
        Take the view whose best match over the turn stands out most against its matches from
        headings ``fix_far`` or more away
        (`contrast_fix`); off, the best single match over the turn.
        On by default: look-alike places match one heading well, a true fix one heading only.
    fix_far : float, default 0.6
        Heading difference from which ``contrast_fix`` counts a match as another heading's, rad.
    unpeaked : float, default 0.0
        Observe and localise again when a whole sweep of the target's line of sight ended with F
        below ``arrive_min`` all along and below this (0: off, sweeping on).
    reverse : bool, default True
        Drive the route segments that run a recording backwards in reverse, the camera facing
        the way the stored views look, rather than turned round.
    reverse_parallax : float, default 0.1
        Reverse only on a map whose parallax (image shift per m across a view's sight,
        `parallax`) is at least this, rad/m: the reversing
        fix's cross gain grows as 1 / parallax, so on a far scene (the lawn, ~0.055) it turns the
        shift's noise into metres across, and the robot does better turned round on odometry.
    reverse_speed : float, default 0.5
        Speed when reversing, m/s; at most the action space's 0.5.
    reverse_heading_gain : float, default 1.0
        Per metre reversed, the share of the reversing fix's innovation taken off the heading;
        the cross gain is then chosen for critical damping with it and the map's parallax
        (`reverse_gains`).
    relocalise_arrive : bool, default True
        Also observe and localise again when lost in the arrival phase, since a wrong global fix
        often shows only there.
    relocalise_bumps : int, default 3
        Bumps since the last fix after which the robot observes and localises again (counts
        toward ``max_relocalise``; 0: never): pushing a wall again and again at one place means
        the belief is off across the route. Only bumps while following count: the arrival's
        back-and-forth by the target looks like a wall to the stuck detector.
    stuck_steps : int, default 10
        Steps of commanded motion that odometry does not see that mean a wall.
    bump_shift : float, default 0.5
        Distance the belief moves across the route at a bump while reversing, toward the side
        the robot was backing to, m (0: off;
        `bumped`).
    cross_gain : float, default 0.1
        Share of the offset across the matched route view's line of sight, measured by the
        image's two bands (`cross_offset`), corrected per
        step (0: off).
    fix_contrast : float, default 0.5
        On a far scene (parallax below ``reverse_parallax``), an image fix needs its best
        aligned distance at most this share of the median over the shifts (1: any), since a flat
        alignment (grass and sky) gives no heading
        (`align_contrast`).
    cross_gate : float, default 1.0
        A two-band offset farther than this from the belief is ignored, m.
    cross_min_parallax : float, default 5.0
        The two-band measurement is used only on a map whose
        `cross_parallax` reaches this, pixels per m: below
        it one pixel is more than 0.2 m and the fit on the map's few side-by-side views is weak.
    backup_steps : int, default 8
        Steps driven the other way after a wall is detected.
    pose_every : int, default 3
        Steps between metric pose fixes against the best-matching route view
        (`pose`: keypoints at the view's map-time
        depths, PnP), in every phase (0: off).
    pose_gain : float, default 0.5
        Share of a pose fix's error corrected, position and heading.
    pose_gate : float, default 6.0
        A pose farther than this from the belief is ignored, m.
    pose_agree : float, default 0.3
        A pose is used only where the one before it, carried by odometry, agrees within this, m
        (0: every pose; `PoseAgreement`).
    pose_start : bool, default True
        With ``pose_every``, start the belief where the observing turn's two best images pose
        the robot against the fix's view (when they agree), not at the view itself.
    fix_check : int, default 8
        With ``contrast_fix``, ``pose_every`` and ``pose_start``: where the turn's two best
        images do not both pose against the fix's view and agree
        (`supports`), the first of the next
        ``fix_check`` views by contrast that they do support becomes the fix (0: off).
    look_back : float, default 10.0
        On a map where the robot turns round rather than reverses, every this many metres driven
        along a recording backwards, turn to face the way its views look, take ``look_steps``
        steps of image and pose fixes, and turn back, m (0: never;
        `LookBack`).
    look_steps : int, default 6
        Steps of fixes taken while looking back.

    Attributes
    ----------
    speed, lookahead, spacing, ...
        Each parameter, stored under its own name (the object is frozen).

    Examples
    --------
    >>> from dataclasses import replace
    >>> from servo.camera_only import SignalServoConfig
    >>> config = SignalServoConfig()
    >>> config.speed, config.contrast_fix, config.pose_every
    (1.5, True, 3)
    >>> replace(config, pose_every=0).pose_every  # metric pose fixes off
    0
    >>> SignalServoConfig(speed=2.0)
    Traceback (most recent call last):
        ...
    ValueError: speed must be in (0, 1.5] m/s, got 2.0

    See Also
    --------
    servo.camera_only.SignalServo : The controller these settings tune.
    servo.laser_image.ManifoldServoConfig : The settings of the laser + image controller.
    """

    speed: float = 1.5
    lookahead: float = 1.0
    spacing: float = 0.8
    turn_rate: float = 1.2
    observe_every: int = 2
    fix_clusters: int = 2
    image_trust: float = 0.9
    heading_gain: float = 0.5
    along_gain: float = 0.2
    behind: float = 1.5
    ahead: float = 2.5
    facing: float = 0.35
    window: float = 2.0
    arrive_distance: float = 1.0
    arrive_drop: float = 0.5
    arrive_min: float = 0.05
    arrive_confirm: float = 0.5
    arrive_past: float = 0.4
    overshoot: float = 1.0
    sweeps: int = 3
    lateral: float = 0.6
    lateral_rounds: int = 2
    relocalise_after: int = 40
    max_relocalise: int = 2
    contrast_fix: bool = True
    fix_far: float = 0.6
    unpeaked: float = 0.0
    reverse: bool = True
    reverse_parallax: float = 0.1
    reverse_speed: float = 0.5
    reverse_heading_gain: float = 1.0
    relocalise_arrive: bool = True
    relocalise_bumps: int = 3
    stuck_steps: int = 10
    bump_shift: float = 0.5
    cross_gain: float = 0.1
    fix_contrast: float = 0.5
    cross_gate: float = 1.0
    cross_min_parallax: float = 5.0
    backup_steps: int = 8
    pose_every: int = 3
    pose_gain: float = 0.5
    pose_gate: float = 6.0
    pose_agree: float = 0.3
    pose_start: bool = True
    fix_check: int = 8
    look_back: float = 10.0
    look_steps: int = 6

    def __post_init__(self):
        """Check every setting (see the class doc); a wrong one raises ``ValueError``."""
        for f in fields(self):
            v = getattr(self, f.name)
            if f.type == "bool":
                if not isinstance(v, bool):
                    raise ValueError(f"{f.name} must be a bool, got {v!r}")
            elif f.type == "int":
                check_int(v, f.name, minimum=0 if f.name in _MAY_BE_ZERO else 1)
            elif not (
                isinstance(v, int | float)
                and np.isfinite(v)
                and (v > 0 or (v == 0 and f.name in _MAY_BE_ZERO))
            ):
                bound = ">= 0" if f.name in _MAY_BE_ZERO else "> 0"
                raise ValueError(f"{f.name} must be a finite number {bound}, got {v!r}")
        if not self.speed <= V_LIMITS[1]:
            raise ValueError(f"speed must be in (0, {V_LIMITS[1]}] m/s, got {self.speed}")
        if not self.reverse_speed <= -V_LIMITS[0]:
            raise ValueError(
                f"reverse_speed must be in (0, {-V_LIMITS[0]}] m/s, got {self.reverse_speed}"
            )
        if not self.turn_rate <= OMEGA_LIMIT:
            raise ValueError(f"turn_rate must be in (0, {OMEGA_LIMIT}] rad/s, got {self.turn_rate}")
        gains = (
            "heading_gain",
            "along_gain",
            "cross_gain",
            "arrive_drop",
            "arrive_min",
            "arrive_confirm",
            "fix_contrast",
            "pose_gain",
        )
        for name in gains:
            if not getattr(self, name) <= 1:
                raise ValueError(f"{name} must be in (0, 1], got {getattr(self, name)}")
        if not self.image_trust < 4:
            raise ValueError(f"image_trust must be in (0, 4), got {self.image_trust}")
        if not self.facing < np.pi:
            raise ValueError(f"facing must be in (0, pi) rad, got {self.facing}")
