"""Frozen bricks out of MuJoCo's collision detection while nothing that moves can reach them: :class:`Culling`.

MuJoCo makes no contact between two bodies without degrees of freedom, so two frozen bricks
(held bodies) never touch, but its broad phase still pairs every two overlapping bounding
boxes before it finds that out. In a tower the neighbours of each frozen brick overlap it, so
that stage costs in proportion to the frozen stack on every step, however few bricks move:
measured on MuJoCo 4.0.0, a 250-level tower of two bricks a layer, all 500 frozen: 366 us of
``mj_collision`` a step (576 us ``mj_step``) with every held brick colliding, 6 us (76 us) with
the top 10 alone. A run that adds a brick to such a stack is then quadratic in its height.

A held brick takes part in collisions only while the bounding sphere of some body that
moves (a free brick in the scene) could reach its own within the next step: the sphere's
radius is the body's bounding radius, plus twice the distance the fastest moving body
covers in a step (a struck body can move as fast as what struck it), plus a skin wider than
any contact margin. A full search (every frozen brick against every moving body) grants
each moving body more than that (:data:`SLACK`) and is made again only when one has used
its slack up; between two, a brick that wakes brings back in what it can reach, and one
that freezes leaves if nothing that moves reaches it. Contacts are then the ones MuJoCo
makes with every held brick colliding: only pairs that no step could bring within reach
are left out (the shipped scenarios and the bench scenes run bit for bit alike, culled
from the first frozen brick or not at all). A 200-level tower, two bricks a layer: broad
phase 59 -> 8 us a step, ``mj_step`` 157 -> 107 us (MuJoCo's own timers).

Below :data:`FROM` frozen bricks nothing is culled: there the broad phase is cheap and the
test costs as much as it saves (a few microseconds a step, some tens a brick that wakes or
freezes, in Python). A world whose ground moves (a shake table, a body with
degrees of freedom under every brick) culls nothing either.

Source: stackdsl's own, on MuJoCo 4.0's Python bindings.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

FROM = 200
"""Frozen bricks (parked ones too) from which held ones out of reach leave the collision
detection. Measured in one process, interleaved, fastest of 5, towers of two bricks a layer
culled from the first frozen brick against never: 1.02, 1.04-1.10, 0.99, 0.81-0.85 of the time
at 30, 60, 100 and 200 levels."""
SLACK = 0.01
"""m a moving body's reach is granted beyond its need at each update."""
SKIN = 0.01
"""m beyond the bounding spheres: wider than a contact's margin (MuJoCo's default, 0)."""
FEW = 8
"""Up to this many moving bodies, the step's test reads them one by one (numpy's fixed costs
are larger for a few)."""
PAIRS = 250_000
"""Moving bodies times frozen ones above which every held brick collides: the distance
table would cost more than it saves (a heap of falling debris)."""


class Culling:
    """Which held bricks' geoms are out of collisions, kept up to date before each step.

    Args:
        model: the compiled ``MjModel``; its ``geom_contype``, ``geom_conaffinity`` and the
            bodies' ones are written for the held geoms culled and brought back.
        held_geom: (bricks,) geom id of each brick's held body.
        free_qpos, free_dof: (bricks,) first qpos and dof address of each brick's free joint.
        mocap: (bricks,) mocap index of each brick's held body.
        timestep: s, the world's whole step (all its substeps).

    The world calls :meth:`changed` for a brick whose collision bits it has just written (as
    it freezes, wakes or moves it). ``out[i]`` is whether brick ``i + 1``'s held geom is out.

    Source: stackdsl's own.
    """

    def __init__(
        self, model: Any, held_geom: np.ndarray, free_qpos: np.ndarray, free_dof: np.ndarray, mocap: np.ndarray, timestep: float
    ) -> None:
        self._m = model
        self._held_geom, self._held_body = held_geom, model.geom_bodyid[held_geom]
        self._qpos3 = free_qpos[:, None] + np.arange(3)
        self._dof6 = free_dof[:, None] + np.arange(6)
        self._mocap = mocap
        self._radius = np.asarray(model.geom_rbound[held_geom], dtype=float)  # the free geom's is the same box
        self._timestep = timestep
        self._skin = SKIN + 2.0 * float(np.max(model.geom_margin, initial=0.0))
        self.out = np.zeros(len(held_geom), dtype=bool)
        self._bits = np.zeros(len(held_geom), dtype=np.int32)  # a culled geom's contype (= conaffinity)
        self._at = np.zeros((len(held_geom), 3))  # each frozen brick's centre, as last looked at
        self._on = False  # culling: enough bricks frozen, few enough moving
        # the moving bricks (index), where each was and how far it may go from there
        self._moving = np.zeros(0, dtype=int)
        self._centres = np.zeros((0, 3))
        self._granted = np.zeros(0)
        self._few: list[tuple[int, int, float]] = []  # their qpos and dof addresses and radius, while few
        self._woken: list[int] = []  # bricks woken since the last update
        self._frozen: list[int] = []  # bricks frozen (or held ones moved) since the last update
        self._stale = True

    @property
    def culls(self) -> bool:
        """Whether held bricks out of every moving body's reach are out of the collisions now."""
        return self._on

    def changed(self, i: int, frozen: bool) -> None:
        """Brick ``i + 1``'s collision bits are the world's again: it froze or its held body moved
        (at the next update its held geom leaves the collisions if nothing moving reaches it), or
        it woke (it moves from the next update on, and what it can reach is brought in)."""
        self.out[i] = False
        if not self._on:
            self._stale = True
            return
        for pending in (self._woken, self._frozen):
            if i in pending:
                pending.remove(i)
        keep = self._moving != i
        if not keep.all():
            self._moving, self._centres, self._granted = self._moving[keep], self._centres[keep], self._granted[keep]
            self._few = self._one_by_one(self._moving)
        (self._frozen if frozen else self._woken).append(i)

    def update(self, data: Any, frozen: np.ndarray) -> None:
        """Bring in the held bricks something moving could reach within the next step and take
        out the others; ``frozen``: (bricks,) bool. The step's test reads only the bodies that
        move (one by one while there are few)."""
        if self._stale:
            self._find(data, frozen)
            return
        if not self._on:
            return
        if self._woken:
            self._wake(data)
        if self._frozen:
            held, self._frozen = np.array(self._frozen, dtype=int), []
            self._at[held] = data.mocap_pos[self._mocap[held]]
            if not len(self._moving):  # nothing moves: every frozen brick out
                held = np.flatnonzero(frozen & ~self.out)
            self._put(held[~self._within(held, self._centres, self._granted)], out=True)
        moving = self._moving
        if len(moving) > FEW:
            where = data.qpos[self._qpos3[moving]]
            velocity = data.qvel[self._dof6[moving]]
            radius = self._radius[moving]
            fastest = float(np.max(np.linalg.norm(velocity[:, :3], axis=1) + np.linalg.norm(velocity[:, 3:], axis=1) * radius))
            step = 2.0 * fastest * self._timestep + self._skin
            if not np.all(np.linalg.norm(where - self._centres, axis=1) + radius + step <= self._granted):
                self._find(data, frozen)
            return
        qpos, qvel, fastest, at = data.qpos, data.qvel, 0.0, []
        for q, v, r in self._few:
            x, y, z = qpos[q : q + 3].tolist()
            a, b, c, e, f, g = qvel[v : v + 6].tolist()
            fastest = max(fastest, math.sqrt(a * a + b * b + c * c) + math.sqrt(e * e + f * f + g * g) * r)
            at.append((x, y, z, r))
        step = 2.0 * fastest * self._timestep + self._skin
        for (x, y, z, r), (cx, cy, cz), granted in zip(at, self._centres.tolist(), self._granted.tolist(), strict=True):
            if math.sqrt((x - cx) ** 2 + (y - cy) ** 2 + (z - cz) ** 2) + r + step > granted:
                self._find(data, frozen)
                return

    def _reach(self, data: Any, moving: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Where ``moving`` bricks are, (n, 3), and how far each may go from there, (n,)."""
        if len(moving) <= FEW:  # in floats: numpy's fixed costs are larger for a few
            rows, fastest = [], 0.0
            for q, v, r in self._one_by_one(moving):
                a, b, c, e, f, g = data.qvel[v : v + 6].tolist()
                fastest = max(fastest, math.sqrt(a * a + b * b + c * c) + math.sqrt(e * e + f * f + g * g) * r)
                rows.append(data.qpos[q : q + 3].tolist())
            where = np.array(rows, dtype=float).reshape(len(moving), 3)
        else:
            where = data.qpos[self._qpos3[moving]]
            velocity = data.qvel[self._dof6[moving]]  # (n, 6): linear, then angular in the body frame
            speeds = np.linalg.norm(velocity[:, :3], axis=1) + np.linalg.norm(velocity[:, 3:], axis=1) * self._radius[moving]
            fastest = float(np.max(speeds))
        return where, self._radius[moving] + (2.0 * fastest * self._timestep + self._skin + SLACK)

    def _within(self, held: np.ndarray, where: np.ndarray, granted: np.ndarray) -> np.ndarray:
        """Which of the ``held`` bricks (their centres looked at) some sphere (``where``,
        ``granted``) reaches, (held,) bool."""
        distance = np.linalg.norm(self._at[held][:, None, :] - where[None, :, :], axis=2)  # (held, moving)
        return np.asarray((distance <= granted[None, :] + self._radius[held][:, None]).any(axis=1))

    def _one_by_one(self, moving: np.ndarray) -> list[tuple[int, int, float]]:
        if len(moving) > FEW:
            return []
        return list(
            zip(self._qpos3[moving, 0].tolist(), self._dof6[moving, 0].tolist(), self._radius[moving].tolist(), strict=True)
        )

    def _wake(self, data: Any) -> None:
        """The bricks woken since the last update move from now on: what they reach back in."""
        woken, self._woken = np.array(self._woken, dtype=int), []
        where, granted = self._reach(data, woken)
        culled = np.flatnonzero(self.out)
        if culled.size:
            back = culled[self._within(culled, where, granted)]
            if back.size:
                self._put(back, out=False)
        self._moving = np.concatenate([self._moving, woken])
        self._centres, self._granted = np.concatenate([self._centres, where]), np.concatenate([self._granted, granted])
        self._few = self._one_by_one(self._moving)

    def _find(self, data: Any, frozen: np.ndarray) -> None:
        """The whole set anew: every frozen brick against every moving one."""
        self._stale, self._woken, self._frozen = False, [], []
        held = np.flatnonzero(frozen)
        moving = np.flatnonzero(~frozen)
        self._on = len(held) >= FROM and len(moving) * len(held) <= PAIRS
        if not self._on:  # nothing out
            if self.out.any():
                self._put(np.flatnonzero(self.out), out=False)
            return
        where, granted = self._reach(data, moving)
        self._moving, self._centres, self._granted = moving, where, granted
        self._few = self._one_by_one(moving)
        want = np.zeros(len(self.out), dtype=bool)
        self._at[held] = data.mocap_pos[self._mocap[held]]
        want[held[~self._within(held, where, granted)]] = True
        if (change := np.flatnonzero(want != self.out)).size:
            self._put(change[want[change]], out=True)
            self._put(change[~want[change]], out=False)

    def _put(self, bricks: np.ndarray, *, out: bool) -> None:
        if not bricks.size:
            return
        m = self._m
        geoms, bodies = self._held_geom[bricks], self._held_body[bricks]
        if out:
            self._bits[bricks] = m.geom_contype[geoms]
            m.geom_contype[geoms] = m.geom_conaffinity[geoms] = 0
            m.body_contype[bodies] = m.body_conaffinity[bodies] = 0
        else:
            m.geom_contype[geoms] = m.geom_conaffinity[geoms] = self._bits[bricks]
            m.body_contype[bodies] = m.body_conaffinity[bodies] = self._bits[bricks]
        self.out[bricks] = out
