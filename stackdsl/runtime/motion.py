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
    each structure brick placed; :attr:`tilt` and :attr:`slip` are the largest seen.

    Every brick placed is measured at once, one rotation of the whole set a step: the placed
    orientations and the bases' offsets in the bricks' own frames are kept while no brick is placed.
    """

    def __init__(self) -> None:
        self.tilt = 0.0
        self.slip = 0.0
        self._placed: tuple[int, ...] = ()
        self._quat = np.zeros((0, 4))  # the placed orientations, (n, 4) unit quaternions (x, y, z, w)
        self._down = np.zeros((0, 3))  # each centre to its base's centre in the brick's own frame, (n, 3) m
        self._start = np.zeros((0, 3))  # each base's centre, placed, (n, 3) m
        self._shakes: list[Shake] | None = None  # the program's shakes, whose table's offset is taken off

    def after_step(self, loop: StepLoop) -> None:
        records = loop.structure.placed
        if not records:
            return
        bodies = tuple(r.body for r in records)
        if bodies != self._placed:  # a brick placed since: its placed pose joins the set
            self._placed = bodies
            self._quat = np.array([r.placed_xyzw for r in records], dtype=float)
            down = np.array([[0.0, 0.0, float(r.corners[:, 2].min()) - r.placed_xyz[2]] for r in records])
            self._down = Rotation.from_quat(self._quat).inv().apply(down)
            self._start = np.array([r.placed_xyz for r in records]) + down
        if self._shakes is None:
            self._shakes = [a for a in loop.program.actions if isinstance(a, Shake)]
        offset = sum((np.asarray(shake.at(loop.now)[0]) for shake in self._shakes), np.zeros(3))
        positions, quaternions = loop.world.poses_of(list(bodies))
        base = np.asarray(positions) + Rotation.from_quat(quaternions).apply(self._down) - offset
        self.slip = max(self.slip, float(np.hypot(*(base[:, :2] - self._start[:, :2]).T).max()))
        # the angle of q p^-1 is 2 acos |q . p|: one dot product a brick, not a rotation composed
        cosine = float(np.abs(np.einsum("ij,ij->i", np.asarray(quaternions, dtype=float), self._quat)).min())
        self.tilt = max(self.tilt, 2.0 * math.acos(min(1.0, cosine)))
