"""The structure's largest motion during a run: how far any structure brick tilted from the
orientation it was placed with, and how far the centre of its base slipped on the ground (in
the ground's frame: a shaken table's offset taken off), the largest over every step. What the
expectation ``still:`` judges (:attr:`stackdsl.lang.expectations.Expect.still`): the onset of
rocking or sliding on a shake table, which no collapse verdict marks.

Units: radians and metres. Source: stackdsl's own (the motions of
:mod:`stackdsl.bench.shake_family`, whose onsets docs/results/shake-table.md measures).
"""

from __future__ import annotations

import math

import numpy as np
from scipy.spatial.transform import Rotation

from ..compile.program import Shake
from .loop import StepLoop, Subscriber


class PeakMotion(Subscriber):
    """After each step, the tilt (rad, the angle of its rotation from its placed orientation)
    and the slip (m, the horizontal distance its base's centre moved, in the ground's frame) of
    each structure brick placed; :attr:`tilt` and :attr:`slip` are the largest seen."""

    def __init__(self) -> None:
        self.tilt = 0.0
        self.slip = 0.0

    def after_step(self, loop: StepLoop) -> None:
        records = loop.structure.placed
        if not records:
            return
        offset = np.zeros(3)
        for action in loop.program.actions:
            if isinstance(action, Shake):
                offset = offset + np.asarray(action.at(loop.now)[0])
        positions, quaternions = loop.world.poses_of([r.body for r in records])
        for r, position, q in zip(records, positions, quaternions):
            placed = Rotation.from_quat(r.placed_xyzw)
            turned = Rotation.from_quat(q) * placed.inv()
            down = np.array([0.0, 0.0, float(r.corners[:, 2].min()) - r.placed_xyz[2]])  # centre to base's centre
            base = np.asarray(position) + turned.apply(down) - offset
            start = np.asarray(r.placed_xyz) + down
            self.slip = max(self.slip, math.hypot(float(base[0] - start[0]), float(base[1] - start[1])))
            self.tilt = max(self.tilt, float(turned.magnitude()))
