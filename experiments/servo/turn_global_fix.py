"""Offline dev loop for ``SignalServo``'s global fix: the observing turn's
images of ``dev`` episodes, recorded once, and the fix each image descriptor would take.

Runs the controller exactly as ``topomap servo-eval`` starts an episode (same specs, starts,
env) until its observing turn ends, keeps every image it localised (``observe_every``), then
scores `contrast_fix` on the shift-aligned distances of
several descriptors of those images against the stored views (no metric check, ``fix_check``): how
far the fix's view lies from the nearest stored view (truth, for the analysis only). One turn
costs ~2 s to record; a descriptor is scored on 60 turns in seconds, where an episode run takes
minutes::

    python -m experiments.servo.turn_global_fix lawn anywhere 60:120 [--turns DIR]

``committed`` is the controller's own fix (with its metric check); ``full`` the descriptor it
uses (the whole feature image); ``far`` its top half (sky, trees, far walls); ``blur S`` the
whole image blurred by a Gaussian of S feature pixels. ``--keypoints`` adds a wide-baseline
matcher instead of the contrast fix: SIFT keypoints of the camera images (not the feature
images), Lowe's ratio test, and the fix is the stored view with the most inliers of a RANSAC
fundamental matrix against any turn image (~20 s an episode). Dev splits only.
"""

from __future__ import annotations

import argparse
from pathlib import Path

import cv2
import numpy as np

import sim  # noqa: F401  (the GL backend before mujoco)
from servo.camera_only.controller import SignalServo
from servo.camera_only.turn_global_fix import contrast_fix
from servo.localise import ImageLocaliser
from servo.maps.build import load_or_build
from servo.task.env import ServoEnv
from servo.task.protocol import Protocol, episode_specs, reset_options

DESCRIPTORS = {
    "full": (0.0, None),
    "far": (0.0, "far"),
    "blur 1": (1.0, None),
    "blur 2": (2.0, None),
    "blur 3": (3.0, None),
}


def record_turns(world: str, tier: str, lo: int, hi: int, m, out: Path) -> None:
    """The observing turn of each dev episode ``lo:hi``: its images and odometry, the start
    pose (truth) and the controller's own fix, one ``.npz`` per episode in ``out``."""
    env = ServoEnv(world, m, max_steps=600, odometry_noise=True)
    pol = SignalServo(m, world=world)
    for spec in episode_specs(Protocol(world, tier, "dev"), m.true_labels, hi)[lo:hi]:
        path = out / f"turn-{world}-{tier}-{spec.index}.npz"
        if path.is_file():
            continue
        obs, info = env.reset(seed=spec.seed, options=reset_options(env, spec, tier))
        pol.reset(info["target_view"], info)
        start = np.asarray(info["pose"], np.float64)
        images, odometry = [], []
        while pol.phase_ == "observe":
            if pol._steps % pol.config.observe_every == 0:
                images.append(obs["image"].copy())
                odometry.append(np.asarray(obs["odometry"], np.float64))
            obs, *_, info = env.step(pol.act(obs, info))
        tmp = path.with_suffix(".tmp.npz")
        np.savez_compressed(
            tmp,
            images=np.stack(images),
            odometry=np.stack(odometry),
            start=start,
            fix=pol._fix_view,
        )
        tmp.replace(path)
        print(f"recorded episode {spec.index} ({len(images)} images)", flush=True)


class Descriptors:
    """Shift-aligned distances of turn images to every stored view under each descriptor."""

    def __init__(self, m):
        self.loc = ImageLocaliser(m)
        views = self.loc._images(m.features)
        self.refs = {
            name: self.loc._crops(self._prepare(views, *how), 0)
            for name, how in DESCRIPTORS.items()
        }

    def _prepare(self, images: np.ndarray, blur: float, band: str | None) -> np.ndarray:
        if band is not None:
            images = images[:, self.loc._band_rows()[band]]
        if blur > 0:
            images = np.stack([cv2.GaussianBlur(im, (0, 0), blur) for im in images])
        return images if images.ndim == 4 else images[..., None]

    def align(self, x: np.ndarray, name: str, step: int = 2) -> tuple[np.ndarray, np.ndarray]:
        image = self._prepare(self.loc._images(np.asarray(x)[None]), *DESCRIPTORS[name])[0]
        crops = self.loc._shifted_crops(image)[::step]
        d = 2.0 - 2.0 * self.refs[name] @ crops.T
        k = np.argmin(d, axis=1)
        shifts = np.arange(-self.loc.max_shift, self.loc.max_shift + 1, step)
        return d[np.arange(len(d)), k], -shifts[k] * self.loc.radians_per_pixel


class KeypointFix:
    """The stored view with the most epipolar inliers (SIFT, ratio 0.8, RANSAC fundamental
    matrix at 2 px) against any image of the turn."""

    def __init__(self, m, n_features: int = 500):
        self.sift = cv2.SIFT_create(nfeatures=n_features)
        self.matcher = cv2.BFMatcher(cv2.NORM_L2)
        self.views = [self._keypoints(image) for image in m.images]

    def _keypoints(self, image: np.ndarray):
        kp, desc = self.sift.detectAndCompute(cv2.cvtColor(image, cv2.COLOR_RGB2GRAY), None)
        return np.float32([k.pt for k in kp]), desc

    def _inliers(self, a, b) -> int:
        (pa, da), (pb, db) = a, b
        if da is None or db is None or len(pa) < 8 or len(pb) < 8:
            return 0
        pairs = self.matcher.knnMatch(da, db, k=2)
        good = [p[0] for p in pairs if len(p) == 2 and p[0].distance < 0.8 * p[1].distance]
        if len(good) < 8:
            return len(good) // 2
        p1 = pa[[g.queryIdx for g in good]]
        p2 = pb[[g.trainIdx for g in good]]
        _, mask = cv2.findFundamentalMat(p1, p2, cv2.FM_RANSAC, 2.0, 0.99)
        return int(mask.sum()) if mask is not None else 0

    def __call__(self, images: np.ndarray) -> int:
        turn = [self._keypoints(image) for image in images]
        return int(np.argmax([max(self._inliers(t, v) for t in turn) for v in self.views]))


def score(m, turns: list[Path], keypoints: bool = False) -> None:
    """Per descriptor: how many fixes lie within 1.5 m and 3 m of the nearest view's
    distance from the start, and the mean excess (m)."""
    desc = Descriptors(m)
    keypoint_fix = KeypointFix(m) if keypoints else None
    excess: dict[str, list[float]] = {}
    for path in turns:
        z = np.load(path, allow_pickle=False)
        dist = np.linalg.norm(m.true_poses[:, :2] - z["start"][:2], axis=1)
        xs = [desc.loc.features(image) for image in z["images"]]
        fixes = {"committed": int(z["fix"])}
        for name in DESCRIPTORS:
            d, yaw = (np.array(a) for a in zip(*(desc.align(x, name) for x in xs), strict=True))
            fixes[name] = contrast_fix(d, yaw, z["odometry"][:, 2])[0]
        if keypoint_fix is not None:
            fixes["keypoints"] = keypoint_fix(z["images"])
        for name, view in fixes.items():
            excess.setdefault(name, []).append(float(dist[view] - dist.min()))
    print("| fix | within 1.5 m of the nearest view | within 3 m | mean excess |")
    print("|---|---|---|---|")
    for name, e in excess.items():
        e = np.array(e)
        print(
            f"| {name} | {np.sum(e <= 1.5)}/{len(e)} | {np.sum(e <= 3.0)}/{len(e)} "
            f"| {e.mean():.2f} m |"
        )


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("world")
    p.add_argument("tier", nargs="?", default="anywhere")
    p.add_argument("episodes", nargs="?", default="60:120", help="LO:HI of the dev split")
    p.add_argument("--turns", type=Path, default=Path("out/turns"), help="recorded turns")
    p.add_argument("--data", default="out/dataset")
    p.add_argument("--maps", default="out/servo-maps")
    p.add_argument("--keypoints", action="store_true", help="add the SIFT keypoint fix")
    a = p.parse_args()
    lo, hi = (int(v) for v in a.episodes.split(":"))
    m = load_or_build(a.world, dataset=a.data, cache=a.maps)
    a.turns.mkdir(parents=True, exist_ok=True)
    record_turns(a.world, a.tier, lo, hi, m, a.turns)
    names = [a.turns / f"turn-{a.world}-{a.tier}-{i}.npz" for i in range(lo, hi)]
    score(m, [n for n in names if n.is_file()], a.keypoints)


if __name__ == "__main__":
    main()
