"""Closed-form collapse levels of the benchmark's scene families (KAPLA, L = 120 mm).

Each is the first level at which a collapse mechanism's centre of mass passes its pivot
edge; ``tests/test_closed_form.py`` checks them against rigid-block equilibrium of the
placed poses (:mod:`stackdsl.verdicts.oracle`). An exactly critical centre of mass counts as
standing (equilibrium has a solution on the edge), so the shifts used avoid ties.

Source: stackdsl's own derivations (docs/results/speed-against-error.md).
"""

from __future__ import annotations

import math

LENGTH = 0.120  # m


def log_cabin(shift: float, spacing: float = 0.096, length: float = LENGTH, limit: int = 1000) -> int:
    """Collapse level of a slanted 4 stack (2 bricks a layer, layers turned 90 deg, each
    layer moved ``shift`` along the first layer's bricks), bricks placed one at a time in
    the tower generator's order. See :func:`log_cabin_margins`.

    >>> [log_cabin(s / 1000) for s in (3, 5, 8, 13)]
    [40, 24, 15, 2]
    """
    return log_cabin_margins(shift, spacing, length, limit)[0]


def log_cabin_margins(shift: float, spacing: float = 0.096, length: float = LENGTH, limit: int = 1000) -> tuple[int, float]:
    """Collapse level of a slanted 4 stack and how close to critical it came (metres).

    Mechanism: the outer brick of level 2 and every brick of level 3 and up tip about the
    edge of level 1 (x = L/2, level 1 centred at 0). Level k >= 3 is centred at (k - 1) s
    (its bricks at (k - 1) s +- d/2 on even levels); level 2's outer brick is at s + d/2.
    After each brick is placed, in the generator's order (the outer brick of an even
    level first when its turn is 90 deg modulo 360, the inner first at 270), the
    structure fails when that set's centre of mass lies beyond L/2. Level 2's outer brick
    alone fails when s + d/2 > L/2 (s > 12 mm for d = 96 mm). The other mechanisms
    (everything from level 2, the whole tower on the ground, levels 3 up about level 2)
    need more. Valid while level 2's outer brick reaches past level 1's edge
    (s + d/2 + 12 mm >= L/2), which holds for d = 96 mm. A centre of mass exactly on the
    edge stands (equilibrium has a solution there).

    Returns:
        (collapse level, the smallest distance by which the centre of mass stayed inside
        the edge before it; 0 means a tie happened).

    Raises:
        ValueError: no collapse up to ``limit`` levels (shift <= 0).
    """
    half, mass, moment, margin = length / 2, 0, 0.0, float("inf")
    for level in range(2, limit + 1):
        centre = (level - 1) * shift
        if level == 2:
            xs = [centre + spacing / 2]  # the outer brick only
        elif level % 2:
            xs = [centre, centre]  # along x: both at the layer's centre
        else:
            outer_first = (level - 1) * 90 % 360 == 90
            xs = [centre + spacing / 2, centre - spacing / 2] if outer_first else [centre - spacing / 2, centre + spacing / 2]
        for x in xs:
            mass, moment = mass + 1, moment + x
            beyond = moment / mass - half
            if beyond > 1e-12:
                return level, margin
            margin = min(margin, -beyond)
    raise ValueError(f"no collapse up to {limit} levels for a shift of {shift} m")


def single_file(shift: float, length: float = LENGTH) -> int:
    """Collapse level of a single-file slanted stack (one brick a level, all along the
    shift, each moved ``shift`` from the one below).

    Mechanism: bricks 2..N tip about the end of brick 1 (x = L/2); their centre of mass is
    at s N / 2, which passes L/2 when N > L/s: the collapse level is floor(L/s) + 1.

    >>> [single_file(s / 1000) for s in (7, 9, 11)]
    [18, 14, 11]

    Raises:
        ValueError: a shift <= 0.
    """
    if shift <= 0:
        raise ValueError("a single-file stack needs a positive shift")
    return math.floor(length / shift + 1e-12) + 1
