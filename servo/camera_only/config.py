"""``SignalServoConfig``: every setting of :class:`~servo.camera_only.controller.SignalServo`, in
one frozen dataclass validated on construction."""

from __future__ import annotations

from dataclasses import dataclass, fields

import numpy as np

from common.validation import check_int
from sim.simulator import OMEGA_LIMIT, V_LIMITS

# settings that may be 0 (off)
_MAY_BE_ZERO = ("max_relocalise", "lateral_rounds", "relocalise_bumps", "bump_shift",
                "cross_gain", "pose_every", "pose_agree", "fix_check", "look_back", "unpeaked")


@dataclass(frozen=True)
class SignalServoConfig:
    """Everything that tunes :class:`~servo.camera_only.controller.SignalServo` (tuned on the
    ``dev`` split only).

    speed : m/s along the route (pure pursuit).
    lookahead : m ahead along the route of the pursued point.
    spacing : m between waypoint views.
    turn_rate : rad/s of the observing turn.
    observe_every : steps between localisations during the observing turn.
    fix_clusters : clusters (by eq. 13) whose views the global fix compares.
    image_trust : largest aligned image distance (0..4) that counts as an image fix.
    heading_gain / along_gain : share of an image fix's heading / along-sight error corrected.
    behind / ahead : m of route about the progress whose views an image fix compares.
    facing : rad: only route views within this of the robot's heading are compared: the
        alignment's range (``MAX_SHIFT`` pixels, 0.25 rad) plus 0.1 for the belief's own
        error; a view turned farther gives a false minimum inside the range (0.6 until
        round 16, whose dev trace had such fixes turn the belief 0.4 rad wrong).
    window : m of progress the belief may move in one step (:class:`RouteBelief`).
    arrive_distance : m of route left at which the arrival law takes over.
    arrive_drop : F toward the target below this share of its peak means past the peak.
    arrive_min : F toward a view (0..1) that counts as a signal (peak, overtaking).
    arrive_confirm : F toward the target (0..1) whose peak counts as having passed the view.
    arrive_past : m the robot must have gone past an F peak before it counts.
    overshoot : m beyond the target view the robot drives while looking for the F peak.
    sweeps : legs of the sweep along the target view's sight before the best F is taken.
    lateral / lateral_rounds : m to either side where F is probed once settled, and how many
        times a better side moves the sweep there
        (:class:`~servo.camera_only.peak_arrival.PeakArrival`).
    arrive_lanes : search the F peak on the view's line of sight and on lines ``lateral`` m to
        either side, then check F where the peak was
        (:class:`~servo.camera_only.peak_arrival.PeakArrival`); else probe F at points to the sides.
    relocalise_after / max_relocalise : steps facing route views without an image fix after
        which the robot observes and localises again, at most ``max_relocalise`` times.
    consistent_fix : take the observing turn's fix best supported by the turn's other images
        (:func:`~servo.camera_only.turn_global_fix.consistent_fix`) rather than its best single
        match.
    contrast_fix / fix_far : take the view whose best match over the turn stands out most
        against its matches from headings ``fix_far`` rad or more away
        (:func:`~servo.camera_only.turn_global_fix.contrast_fix`; overrides ``consistent_fix``).
    exclude_fix : a relocalisation (``contrast_fix``) skips the views within 3 m of the last
        fix's, once the robot has driven more than 3 m from where it fixed.
    unpeaked : observe and localise again (within ``max_relocalise``) when a whole sweep of the
        target's line of sight in the arrival (:class:`~servo.camera_only.peak_arrival.PeakArrival`)
        ended with F below ``arrive_min`` all along and below ``unpeaked`` (so any value above
        ``arrive_min``, e.g. 1, takes every such sweep): the robot is not where it believes
        the target is. 0: off, sweeping on. Round 17, dev: +1 / -0 of 200 episodes, not adopted.
    arrive_descent / descent_step / descent_rounds / descent_rise : where a sweep of the
        target's sight sees no F, search across by the image's shift-minimised distance to
        the view (:class:`~servo.camera_only.image_descent_arrival.DescentArrival`):
        ``descent_step`` m first, at most ``descent_rounds`` searches, from the line's least
        distance once the distance has risen by ``descent_rise`` of it (or a sweep there and back is
        done). Round 18, dev: lawn +1 / -0 of 140 episodes, hallway +0 / -1 of 60; not adopted.
    look_back / look_steps : m; on a map where the robot turns round rather than reverse
        (``reverse_parallax``), every ``look_back`` m driven along a recording backwards turn
        to face the way its views look, take ``look_steps`` steps of image and pose fixes,
        and turn back (:class:`~servo.camera_only.rear_view_heading.LookBack`); 0: never (session
        19).
    reverse : drive the route segments that run a recording backwards in reverse (camera
        facing the way the stored views look) rather than turned round.
    reverse_parallax : rad/m: reverse only on a map whose parallax (image shift per m across
        a view's sight, :meth:`~servo.localise.ImageLocaliser.parallax`) is at least this.
        The reversing fix's cross gain grows as 1 / parallax (lawn, 0.055: ~27 per m), so
        there it turns the shift's noise into metres across (a dev trace: 2.3 m within 20
        steps) and the robot does better turned round at full speed on odometry alone.
    reverse_speed : m/s reversing (the action space allows down to -0.5).
    reverse_heading_gain : per metre reversed, the share of the reversing fix's innovation
        taken off the heading; the cross gain is chosen for critical damping with it and the
        map's parallax (:meth:`~servo.camera_only.route_belief.RouteBelief.reverse_gains`).
    junction_fix : where the route turns from reversing to driving forward, turn on the spot
        to the forward heading before driving on
        (:class:`~servo.camera_only.junction_pose.JunctionTurn`).
    junction_position / junction_radius / junction_parallax : and there fix the position by
        the shifts against the stored views within ``junction_radius`` m, assuming
        ``junction_parallax`` times the map's parallax (off: on dev traces it moved the belief
        the wrong way as often as the right; the parallax near a junction is 2-4x the map's).
    relocalise_arrive : also observe and localise again when lost in the arrival phase (a
        wrong global fix often only shows there: dev hallway episode 8).
    relocalise_bumps : bumps since the last fix after which the robot observes and localises
        again (counts toward ``max_relocalise``; 0: never): pushing a wall over and over at one
        place means the belief is off across the route (dev hallway episode 10).
    bumps_arriving : count bumps toward ``relocalise_bumps`` in the arrival phase too (off
        since round 7: the arrival's back-and-forth by the target looks like a wall to the
        stuck detector, and the relocalisation it started cost the approach's last minute).
    bump_shift : m the belief moves across the route at a bump while reversing, toward the
        side the robot was backing to (:meth:`~servo.camera_only.route_belief.RouteBelief.bumped`);
        0: off. Round 7, dev: hallway `anywhere` 0-59 40 -> 45 of 60 (shifting at forward bumps
        too: 45, but the lawn 26 -> 25 and hallway `view` 19 -> 18 of 24); on the test split
        round 7 as a whole gained nothing (docs/servo.md).
    cross_gain : share of the offset across the matched route view's line of sight that the
        two-band measurement (:meth:`~servo.localise.ImageLocaliser.cross_offset`) corrects
        per step (0: off); round 8.
    cross_gate : m; a two-band offset farther than this from the belief is ignored.
    cross_min_parallax : pixels per m; the two-band measurement is used only on a map whose
        :meth:`~servo.localise.ImageLocaliser.cross_parallax` reaches this (below, one pixel
        is more than 0.2 m and the regression on the map's few side-by-side views is weak).
    fix_contrast : on a map whose parallax is below ``reverse_parallax`` (a far scene), an
        image fix needs its best aligned distance at most this share of the median over the
        shifts (1: any; round 8): a flat alignment (grass and sky) gives no heading
        (:meth:`~servo.localise.ImageLocaliser.align_contrast`). Dev: lawn `anywhere` 0-59
        26 -> 30 of 60; in the hallway (where it is not used) 45 -> 42.
    stuck_steps / backup_steps : commanded motion for ``stuck_steps`` steps that odometry
        does not see means a wall: drive the other way for ``backup_steps`` steps.
    refine_shift : image alignments place the best shift between the tried ones (2 pixels,
        0.025 rad apart) by a parabola (:func:`~servo.localise.refined_shift`); round 9.
    bump_turn : where the robot reverses, a bump's shift across also turns the belief's
        heading by -parallax times the shift, so the image's theta + c y is unchanged and the
        reversing fix keeps the shift (:meth:`~servo.camera_only.route_belief.RouteBelief.bumped`);
        round 9.
    pose_every : steps between metric pose fixes against the best-matching route view
        (:meth:`~servo.camera_only.view_pose.ViewPose.pose`: keypoints at the view's map-time
        depths, PnP), forward and reversing, following and arriving; 0: off. Round 10.
    pose_gain / pose_gate : share of a pose fix's error corrected (position and heading);
        a pose more than ``pose_gate`` m from the belief is ignored.
    pose_start : with ``pose_every``, the belief starts where the observing turn's images
        that matched the global fix's view best pose the robot against it (two agreeing),
        not at the view.
    pose_agree : m; a pose is used only where the one before it, carried by odometry,
        agrees within this (:class:`~servo.camera_only.view_pose.PoseAgreement`); 0: every pose.
    fix_check : with ``contrast_fix``, ``pose_every`` and ``pose_start``: where the two turn
        images that match the fix's view best do not both pose against it and agree
        (:meth:`~servo.camera_only.metric_pose_fixes.PoseFixes.supports`), the first of the next
        ``fix_check`` views by contrast score that they do support is the fix; 0: off. Round 11.
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
    arrive_lanes: bool = False
    relocalise_after: int = 40
    max_relocalise: int = 2
    consistent_fix: bool = False
    contrast_fix: bool = True
    fix_far: float = 0.6
    exclude_fix: bool = False
    unpeaked: float = 0.0
    reverse: bool = True
    reverse_parallax: float = 0.1
    reverse_speed: float = 0.5
    reverse_heading_gain: float = 1.0
    relocalise_arrive: bool = True
    junction_fix: bool = False
    junction_position: bool = False
    junction_radius: float = 3.5
    junction_parallax: float = 1.0
    relocalise_bumps: int = 3
    bumps_arriving: bool = False
    stuck_steps: int = 10
    bump_shift: float = 0.5
    cross_gain: float = 0.1
    fix_contrast: float = 0.5
    cross_gate: float = 1.0
    cross_min_parallax: float = 5.0
    backup_steps: int = 8
    refine_shift: bool = False
    bump_turn: bool = False
    pose_every: int = 3
    pose_gain: float = 0.5
    pose_gate: float = 6.0
    pose_agree: float = 0.3
    pose_start: bool = True
    fix_check: int = 8
    look_back: float = 10.0
    look_steps: int = 6
    arrive_descent: bool = False
    descent_step: float = 1.0
    descent_rounds: int = 4
    descent_rise: float = 0.3

    def __post_init__(self):
        for f in fields(self):
            v = getattr(self, f.name)
            if f.type == "bool":
                if not isinstance(v, bool):
                    raise ValueError(f"{f.name} must be a bool, got {v!r}")
            elif f.type == "int":
                check_int(v, f.name, minimum=0 if f.name in _MAY_BE_ZERO else 1)
            elif not (isinstance(v, int | float) and np.isfinite(v)
                      and (v > 0 or (v == 0 and f.name in _MAY_BE_ZERO))):  # fmt: skip
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
        gains = ("heading_gain", "along_gain", "cross_gain", "arrive_drop", "arrive_min",
                 "arrive_confirm", "fix_contrast", "pose_gain")
        for name in gains:
            if not getattr(self, name) <= 1:
                raise ValueError(f"{name} must be in (0, 1], got {getattr(self, name)}")
        if not self.image_trust < 4:
            raise ValueError(f"image_trust must be in (0, 4), got {self.image_trust}")
        if not self.facing < np.pi:
            raise ValueError(f"facing must be in (0, pi) rad, got {self.facing}")
