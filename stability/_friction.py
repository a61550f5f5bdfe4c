"""How much of its friction a standing structure needs: the least share of every contact's
friction coefficient with which rigid-block equilibrium still holds it.

A stand that needs most of its friction rests on forces a shock or a rounded edge may not give
(a brick leaning on a slender column held by 73% of the wall's friction, which tuned engines
knock over): the share says how near the stand is to sliding, as the margin says how near it
is to tipping (:func:`stability.equilibrium_margin`).

Scaling every coefficient by s is not a linear program in s (s multiplies the unknown normal
forces), so the least s is found by bisection on a grid of :data:`FRICTION_STEP`, first with the
eight-sided pyramid and then with the fine one of :data:`stability._equilibrium.FINE_SIDES`
sides, two bounds apart (stackdsl's own; the programs are :func:`stability.solve_equilibrium`'s):

- the eight edges are every fourth of the fine pyramid's (both start downhill), so the fine
  pyramid contains the coarse one: where eight sides stand, the fine pyramid stands;
- the coarse pyramid contains the cone of cos(pi/8) of its coefficient, which contains the fine
  pyramid: where eight sides fail at s, the fine pyramid fails at s cos(pi/8).

So six cheap programs of eight sides bracket the answer within 8%, and the fine pyramid is
solved only there, a step at a time down from the coarse answer (where the downhill edge
decides, as on a slope, a ladder or a V, the two agree and one fine program ends it). The
programs of one pyramid differ only in their friction coefficients, so each starts from the
basis the last one ended on (:class:`stability.WarmStart`; whether one stands does not depend on
where the simplex starts): the shipped card house's share (15 bricks on 24 contacts) took
1072 simplex iterations where it took 1491, to the same share.
Each program is first tried as vertical forces on the contacts level with that share of their
friction alone (:func:`stability._equilibrium.is_level`): where those hold the blocks, so does
the whole program, a tenth of its size. A settled Jenga tower, whose blocks touch side by side,
needed seven programs of 34 bricks, 0.5 s, and read "2%" for its faces' tilt of an engine's
noise, which the rest of the model counts as level.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import replace

from ._equilibrium import FINE_SIDES, GRAVITY, BodyKey, ContactPolygon, RigidBlock, _solve, _solve_vertical, is_level, upward
from ._lp import WarmStart

#: The precision of :func:`friction_share`: 1/64 of the coefficients.
FRICTION_STEP = 1 / 64
#: Sides of the pyramid the share is bracketed with (:mod:`stability._friction`).
COARSE_SIDES = 8


def friction_share(
    blocks: Mapping[BodyKey, RigidBlock], contacts: Sequence[ContactPolygon[BodyKey]], gravity: float = GRAVITY
) -> float:
    """The least share s of every contact's friction coefficient with which rigid-block
    equilibrium still holds ``blocks`` on ``contacts`` (each coefficient mu taken as s mu), a
    multiple of :data:`FRICTION_STEP`, rounded up: 0 when they balance without friction, 1 when
    they balance only with all of it (or not at all: the caller asks this of a stand). Friction
    is what holds: a larger pyramid admits every force a smaller one does, so equilibrium with
    s mu implies it with any larger share. Decided with the fine pyramid of
    :data:`stability._equilibrium.FINE_SIDES` sides (module docstring).

    Args:
        blocks: free blocks by key (:class:`stability.RigidBlock`).
        contacts: the contact polygons (:class:`stability.ContactPolygon`).
        gravity: m/s^2, acting along -z.

    Raises:
        ValueError: as :func:`stability.solve_equilibrium`.

    Source: stackdsl's own, on the program of :func:`stability.solve_equilibrium`.

    >>> from scipy.spatial.transform import Rotation
    >>> turn = Rotation.from_euler("x", 0.2)  # a slope of 11.5 deg, tan 0.203, friction 0.5
    >>> face = turn.apply([[-0.06, -0.012, 0], [0.06, -0.012, 0], [0.06, 0.012, 0], [-0.06, 0.012, 0]])
    >>> on_slope = ContactPolygon("brick", "ramp", face, turn.apply([0, 0, 1.0]), 0.5)
    >>> friction_share({"brick": RigidBlock(0.0106, turn.apply([0, 0, 0.004]))}, [on_slope])  # tan / mu 0.405, rounded up
    0.40625
    """
    coarse_warm, fine_warm = WarmStart(), WarmStart()  # each program starts from the last one's basis
    if _stands(blocks, contacts, gravity, COARSE_SIDES, 0, coarse_warm):
        return 0.0
    fails, coarse = 0, round(1 / FRICTION_STEP)  # in steps: the coarse pyramid fails at 0, stands at 1 (taken)
    while coarse - fails > 1:
        mid = (fails + coarse) // 2
        if _stands(blocks, contacts, gravity, COARSE_SIDES, mid, coarse_warm):
            coarse = mid
        else:
            fails = mid
    fails = math.floor(fails * math.cos(math.pi / COARSE_SIDES))  # where the fine pyramid fails too
    share = coarse  # the fine answer is near the coarse one: a step down at a time
    while share - 1 > fails and _stands(blocks, contacts, gravity, FINE_SIDES, share - 1, fine_warm):
        share -= 1
    return share * FRICTION_STEP


def _stands(
    blocks: Mapping[BodyKey, RigidBlock],
    contacts: Sequence[ContactPolygon[BodyKey]],
    gravity: float,
    sides: int,
    steps: int,
    warm: WarmStart,
) -> bool:
    """Does the program with ``steps`` of :data:`FRICTION_STEP` of every coefficient hold the
    blocks? First by vertical forces on the contacts that are level with that friction alone
    (a tenth of the program: fewer contacts hold less, so where they hold the blocks, all do),
    then by the program with a pyramid of ``sides``, from ``warm``'s basis (the bisection's
    programs differ only in their friction coefficients, so the last one's basis is near)."""
    scaled = _scaled(contacts, steps * FRICTION_STEP)
    level = [c for c in map(upward, scaled) if is_level(c, sides)]
    if level and _solve_vertical(blocks, level, gravity) is not None:
        return True
    return _solve(blocks, scaled, sides, gravity, warm=warm).stands


def _scaled(contacts: Sequence[ContactPolygon[BodyKey]], share: float) -> list[ContactPolygon[BodyKey]]:
    return [replace(c, friction=c.friction * share) for c in contacts]
