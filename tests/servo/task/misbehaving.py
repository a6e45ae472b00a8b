"""A policy that misbehaves in its own process as the target view says (view ``k``: the
``k``-th of `MODES`), for the boundary's bad-input tests; ``how`` fixes one mode."""

from __future__ import annotations

import os
import pickle
import time

import numpy as np

MODES = ("die", "hang", "print", "garbage", "pickle", "raise", "fine")


class Misbehaving:
    def __init__(self, how):
        self.how, self.mode = how, None

    def reset(self, target):
        self.mode = self.how or MODES[target.view % len(MODES)]

    def act(self, observation):
        mode = self.mode
        if mode == "die":
            os._exit(3)
        if mode == "hang":
            time.sleep(600)
        if mode == "print":
            print("hello from the policy " * 1000, flush=True)
        if mode == "garbage":
            return {"v": "fast"}
        if mode == "pickle":  # its answers become a pickled object of its own

            class Payload:
                def __reduce__(self):
                    return (os.system, ("echo pwned > /tmp/topomap-pwned",))

            from servo.task import wire

            wire.encode = lambda *a, **k: pickle.dumps(Payload())
        if mode == "raise":
            raise RuntimeError("lost")
        return np.array([0.2, 0.1])


def make(servo_map, rng, how=None):
    return Misbehaving(how)
