"""The proofs at a run's end that decided no collapse: the bricks still moving, or the
certificate of the structure as it stands, in words (the module :mod:`stackdsl.runtime.collapse`'s
last proofs).

A brick still moves when it is faster than :data:`stability.JITTER` times the rest thresholds,
or moved farther or turned more over the last rest duration than a brick under them could (the
windowed rest test of fallen bricks, :mod:`stability._rest`): no static argument holds on a pose
in flight, and the verdict is "undecided". Otherwise rigid-block equilibrium of every brick where
it is (:meth:`stability.StabilityExtension.certificate`) says it stands, with its margin and what
it asks of friction, or names the bricks of its collapse mechanism.

Source: stackdsl's own.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np

from stability import JITTER, Pose, still
from stability import Certificate as Equilibrium

from .bricks import BrickRecord
from .loop import StepLoop


class MotionWindow:
    """Where the structure's moving bricks were, once every rest duration (the last two such
    moments), to tell at the end a brick that still moves from one that jitters in place.

    Args:
        rest_speed, rest_angular_speed: m/s and rad/s under which a brick is at rest.
        rest_duration: seconds between two moments kept.
    """

    def __init__(self, rest_speed: float, rest_angular_speed: float, rest_duration: float) -> None:
        self.rest = (rest_speed, rest_angular_speed, rest_duration)
        self._window: tuple[tuple[float, dict[str, Pose]], ...] = ()  # (time, id -> pose)

    def watch(self, loop: StepLoop) -> None:
        """Every rest duration, where the structure's moving bricks are (two such moments kept):
        at the end, a brick that moved farther since than its speeds at rest allow still moves."""
        if self._window and loop.now - self._window[-1][0] < self.rest[2] - 1e-9:
            return
        records = [r for r in loop.structure.placed if r.moving]
        positions, quaternions = loop.world.poses_of([r.body for r in records]) if records else (np.zeros((0, 3)),) * 2
        poses = {r.id: Pose(p, q) for r, p, q in zip(records, positions, quaternions)}
        self._window = (*self._window[-1:], (loop.now, poses))

    def _fast(self, loop: StepLoop, records: list[BrickRecord], speed: np.ndarray, spin: np.ndarray) -> list[int]:
        """The indices of the ``records`` (moving at ``speed``, m/s, and ``spin``, rad/s, now)
        that still move: faster than :data:`stability.JITTER` times a rest threshold, over one
        with no pose a rest duration ago, or moved or turned more since than the thresholds allow."""
        rest_speed, rest_spin, _ = self.rest
        then = next((w for w in self._window if loop.now - w[0] >= self.rest[2] - 1e-9), None)
        positions, quaternions = loop.world.poses_of([r.body for r in records])
        fast = []
        for i, r in enumerate(records):
            if speed[i] <= rest_speed and spin[i] <= rest_spin:
                continue
            before = then[1].get(r.id) if then is not None else None
            span = loop.now - then[0] if then is not None else 0.0
            if speed[i] > JITTER * rest_speed or spin[i] > JITTER * rest_spin or before is None:
                fast.append(i)
            elif not still(before, Pose(positions[i], quaternions[i]), rest_speed * span, rest_spin * span):
                fast.append(i)
        return fast

    def still_moving(self, loop: StepLoop) -> tuple[set[str], str]:
        """The structure bricks that still move at the end of a run that decided no collapse, and
        that in words with the hint to settle longer (none, ``""``): faster now than
        :data:`stability.JITTER` times the rest thresholds, or moved farther or turned more over
        the last rest duration or more than a brick under the thresholds could, the windowed rest
        test of fallen bricks (:mod:`stability._rest`); a brick that jitters in place (raw
        pybullet spins one at 0.4 rad/s, back and forth) does not."""
        records = [r for r in loop.structure.placed if r.moving]
        if not records:
            return set(), ""
        lin, ang = loop.world.velocities_of([r.body for r in records])
        speed, spin = np.sqrt((lin**2).sum(axis=1)), np.sqrt((ang**2).sum(axis=1))
        fast = self._fast(loop, records, speed, spin)
        if not fast:
            return set(), ""
        worst = max(fast, key=lambda i: (speed[i] / self.rest[0], spin[i] / self.rest[1]))
        names = [records[i].id for i in fast]
        who = names_and(names) if len(names) <= 3 else f"{', '.join(names[:3])} and {len(names) - 3} more"
        return {records[i].id for i in fast}, (
            f"{who} still {'moves' if len(names) == 1 else 'move'} at the end (up to {speed[worst] * 1000:.3g} mm/s, "
            f"{spin[worst]:.3g} rad/s; at rest is under {self.rest[0] * 1000:g} mm/s and {self.rest[1]:g} rad/s): "
            f"settle longer (timing.settle, {loop.program.settle:g} s now)"
        )


def stand_words(certificate: Equilibrium, near_ties: dict[str, str]) -> str:
    """How a structure that stands was proved, for its certificate: by its load paths (every
    brick frozen over its own) or by the equilibrium program, what it asks of friction
    (:func:`_friction`) and which landings statics decided (:func:`_statics`)."""
    if certificate.method == "load paths":
        frozen = (
            f"each of {certificate.bricks} bricks frozen over its load path to the ground"
            if certificate.bricks != 1
            else "the brick frozen over its load path to the ground"
        )
        said = frozen + _friction(certificate.friction)
    else:
        said = (
            f"the equilibrium program balances {_count(certificate.bricks, 'brick')} on "
            f"{_count(certificate.contacts, 'contact')}{_friction(certificate.friction)}"
        )
    return said + _statics(near_ties)


def names_and(names: Sequence[str]) -> str:
    """``"B"``, ``"B and C"``, ``"B, C and D"``."""
    return names[0] if len(names) == 1 else f"{', '.join(names[:-1])} and {names[-1]}"


def _count(n: int, noun: str) -> str:
    """``"1 brick"``, ``"3 bricks"``."""
    return f"{n} {noun}{'' if n == 1 else 's'}"


def _statics(near_ties: dict[str, str]) -> str:
    """Which bricks' landings statics decided, for a stand's words: ``"; statics on the placed
    geometry decided L05.1's landing (its centre of mass 0.56 mm inside its support's edge,
    within the engine's 1 mm contact margin), not the engine"``; nothing when none."""
    if not near_ties:
        return ""
    first, why = next(iter(near_ties.items()))
    said = why.split(": ", 1)[-1]
    more = f" and {len(near_ties) - 1} more near ties" if len(near_ties) > 1 else ""
    return f"; statics on the placed geometry decided {first}'s landing ({said}){more}, not the engine"


def _friction(share: float) -> str:
    """What a stand asks of friction (:attr:`stability.Certificate.friction`: the program's least
    share, or what the load paths' vertical forces need on supports out of level), for its
    certificate's words: ``", needing 73% of each friction coefficient"``; nothing when vertical
    forces on level faces hold it."""
    if share <= 0.0:
        return ""
    return f", needing {math.ceil(share * 100)}% of each friction coefficient"


def named(bricks: Sequence[BrickRecord], moved: Sequence[float] | np.ndarray) -> tuple[BrickRecord, float]:
    """The brick a collapse with no equilibrium at the end names, of the structure's ``bricks`` in
    its mechanism (each ``moved`` so far, m), and how far it moved: the one that moved most (to the
    micrometre: where the part that does not stand has started to go), of equals the lowest level,
    then the first placed. None passed the threshold (else the collapse would have been decided
    before the end), so no brick is the first moved; a brick of the mechanism carried along, or
    woken with it, has moved less than the one that gives way. Source: stackdsl's own.

    >>> from types import SimpleNamespace as B
    >>> left, right = B(id="kl", level=2, order=2), B(id="kr", level=2, order=3)
    >>> [(b.id, d) for b, d in [named([left, right], [0.0, 0.0011]), named([left, right], [0.0, 0.0])]]
    [('kr', 0.0011), ('kl', 0.0)]
    """
    best = min(range(len(bricks)), key=lambda i: (-round(float(moved[i]), 6), bricks[i].level, bricks[i].order))
    return bricks[best], float(moved[best])
