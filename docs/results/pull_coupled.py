"""How hard a Jenga level can be dragged and stay put: the largest drag safety factor a proof could use.

A block ``P`` of a Jenga level is pulled out along its length; each of the three blocks of the
level above (``A``) rests on ``P`` and on the two other blocks of ``P``'s level, and is dragged
by ``P``'s kinetic friction, ``s mu N_P``, at its contact with ``P`` (``N_P`` its load share on
``P``, ``s`` a safety factor). This finds, by bisection on ``s``, the largest ``s`` for which
friction forces exist, each inside its Coulomb pyramid (8 sides, at the corners of each 25 x 25 mm
contact square, under that contact's share of the load), that hold every block still, force and
twist about the vertical:

* ``alone``: each block of the level above on its own two other supports (what
  ``stability._drag.held_together`` asks of one brick);
* ``coupled``: the three blocks held together by the layer resting on them (each brick of that
  layer in balance on its three contacts), the friction between the layers carrying the twist
  from block to block.

The load shares are given as the share of each block of ``P``'s level (the pulled one's among
them): the report's equal thirds (section 3.3.6), pybullet's most skewed share seen on a side pull
(46% on the pulled block, docs/results/actions-freeze.md), and an elastic beam's 3/16, 5/8,
3/16 on three rigid supports. Every block of the levels above weighs the same: the level above
carries ``riders`` levels over it.

    python docs/results/pull_coupled.py [RIDERS]     # default 4: the side pull of L07.3 in jenga_stands

Output: docs/results/actions-freeze.md ("No proof for the side pull"). Source: stackdsl's own
linear program (scipy's HiGHS) on Coulomb friction.
"""

from __future__ import annotations

import math
import sys

import numpy as np
from scipy.optimize import linprog

SIDES = 8
SPACING = 0.0255  # m between the blocks of a level (scenarios/jenga_stands.yaml)
HALF = 0.0125  # m: half the side of a contact square (25 mm blocks crossing)
MU = 0.4
EDGES = np.array([[math.cos(2 * math.pi * k / SIDES), math.sin(2 * math.pi * k / SIDES)] for k in range(SIDES)])


def held(safety: float, pulled: int, shares: tuple[float, float, float], coupled: bool, riders: int) -> bool:
    """Can the level above hold a pull of block ``pulled`` (0, 1, 2 across the level) at ``safety``?"""
    lines = [-SPACING, 0.0, SPACING]  # where the blocks of P's level lie (y), and those above them (x)
    load_a = (1 + riders) * 1.0  # each block above P, in block weights: itself and its share of the riders
    load_r = riders * 1.0  # each brick of the layer above it: itself and what is over it
    patches = []  # (kind, block above, rider, centre, normal)
    for i, x in enumerate(lines):
        for j, y in enumerate(lines):
            if j != pulled:
                patches.append(("support", i, -1, (x, y), load_a * shares[j]))
            if coupled:
                patches.append(("layer", i, j, (x, y), load_r / 3))
    corners = [
        (p, np.array([cx + dx, cy + dy]))
        for p, (*_, (cx, cy), _) in enumerate(patches)
        for dx in (-HALF, HALF)
        for dy in (-HALF, HALF)
    ]
    per = 1 + SIDES  # the corner's normal force, then its weight on each edge of the pyramid
    n = len(corners) * per
    balance = np.zeros((3 * (3 + (3 if coupled else 0)), n))  # fx, fy, twist of each block above, then each rider
    for c, (p, at) in enumerate(corners):
        kind, i, j, _, _ = patches[p]
        for k in range(SIDES):
            fx, fy = MU * EDGES[k]
            row = np.array([fx, fy, at[0] * fy - at[1] * fx])
            balance[3 * i : 3 * i + 3, c * per + 1 + k] += row
            if kind == "layer":
                balance[9 + 3 * j : 9 + 3 * j + 3, c * per + 1 + k] -= row
    drag = safety * MU * load_a * shares[pulled]
    rhs = np.zeros(balance.shape[0])
    for i, x in enumerate(lines):
        at = (x, lines[pulled])
        rhs[3 * i : 3 * i + 3] = [-drag, 0.0, at[1] * drag]  # the drag along +x at (x, y_P): its twist -y drag
    rows, values = [balance], [rhs]
    for p, (_, _, _, centre, normal) in enumerate(patches):  # each contact's normals: its share, at its centre
        members = [c for c, (q, _) in enumerate(corners) if q == p]
        for axis in (None, 0, 1):
            row = np.zeros(n)
            for c in members:
                row[c * per] = 1.0 if axis is None else corners[c][1][axis]
            rows.append(row[None])
            values.append(np.array([normal if axis is None else normal * centre[axis]]))
    cone = np.zeros((len(corners), n))
    for c in range(len(corners)):
        cone[c, c * per] = -1.0
        cone[c, c * per + 1 : c * per + per] = 1.0
    result = linprog(
        np.zeros(n),
        A_ub=cone,
        b_ub=np.zeros(len(corners)),
        A_eq=np.vstack(rows),
        b_eq=np.concatenate(values),
        bounds=(0, None),
        method="highs",
    )
    return bool(result.status == 0)


def largest(pulled: int, shares: tuple[float, float, float], coupled: bool, riders: int) -> float:
    """The largest safety factor held, to 0.001."""
    low, high = 0.0, 8.0
    while high - low > 1e-3:
        mid = (low + high) / 2
        low, high = (mid, high) if held(mid, pulled, shares, coupled, riders) else (low, mid)
    return low


def main(riders: int) -> None:
    cases = [
        ("equal thirds", (1 / 3, 1 / 3, 1 / 3)),
        ("pulled side block 46%", (0.27, 0.27, 0.46)),
        ("elastic beam 3/16, 5/8, 3/16", (3 / 16, 5 / 8, 3 / 16)),
    ]
    print(f"largest drag safety factor held, {riders} levels over the dragged one, mu {MU}")
    print("| shares (side, middle, side) | side pull, alone | side pull, coupled | middle pull, alone | middle pull, coupled |")
    print("|---|---:|---:|---:|---:|")
    for name, shares in cases:
        cells = [largest(pulled, shares, coupled, riders) for pulled in (2, 1) for coupled in (False, True)]
        print(f"| {name} | " + " | ".join(f"{c:.2f}" for c in cells) + " |")


if __name__ == "__main__":
    main(int(sys.argv[1]) if len(sys.argv) > 1 else 4)
