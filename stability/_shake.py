"""A pseudo-static check of the frozen stack under an effective gravity: a shaking ground.

A rigid stack on a base that accelerates horizontally by ``a`` moves with it as long as, in the
base's frame, every part stands under the effective gravity ``g_eff = (-a_x, -a_y, -g)``: gravity
plus the inertial force of the base's acceleration (d'Alembert). A shake's worst instant is its
peak acceleration, either way, so the stack must stand under ``g_eff`` for ``+a_peak`` and for
``-a_peak``.

Two tests, each the report's (or Coulomb's) with the tilted gravity:

* **tipping**: the resultant of a brick and everything it carries acts through its centre of
  mass above (report 3.3.5) along ``g_eff``; it must meet the plane of the brick's main contact
  area inside that area (report 3.3.4, with the line of action tilted instead of vertical). For
  a centre of mass ``h`` above the contact, the point moves by ``h a / g`` against the
  acceleration.
* **sliding**: with level contacts and a uniform acceleration every contact carries a tangential
  force ``a / g`` times its normal force (each part above it is accelerated by ``a``, held by
  its weight ``m g``); it holds while ``a / g`` is at most the pair's friction coefficient
  (Coulomb).

For a single block of half-width ``b`` (along the shake) with its centre of mass ``h`` above its
base, on a base of friction coefficient ``mu``, the two give the textbook thresholds: it slides
when ``a > mu g`` and tips when ``a > g b / h``, whichever is smaller first (it tips before it
slides when ``b / h < mu``). Meriam & Kraige, *Engineering Mechanics: Statics*, chapter 6 (dry
friction: "impending tipping or slipping" of a block under a horizontal force); Shenton, "Criteria
for initiation of slide, rock, and slide-rock rigid-body modes", J. Eng. Mech. 122(7), 1996, for
the same thresholds under a base acceleration.

The stack needs no engine to answer: the records as frozen (poses, main contact areas, supports)
are enough. Source: report 3.3.4-3.3.5 with a tilted gravity; the thresholds above.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np
import shapely

from ._leaning import pair_friction
from ._load import propagate
from ._stack import Stack


def withstands(stack: Stack, effective_gravity: Sequence[float], margin: float = 0.0) -> str | None:
    """Does the frozen stack stand pseudo-statically under ``effective_gravity`` (m/s^2, shape (3,),
    pointing down: gravity plus the inertial force of the base's acceleration, ``(-a_x, -a_y, -g)``
    for a base accelerating by ``(a_x, a_y)``)? None when it does; else why not, in words, naming
    the first brick that would tip or slide (in the order they froze).

    Args:
        stack: the extension's bodies (only the frozen ones are asked).
        effective_gravity: shape (3,), m/s^2, with a downward vertical part.
        margin: metres the tilted line of action must lie inside the main contact area.

    Raises:
        ValueError: an effective gravity that does not point down.

    Source: see the module docstring (report 3.3.4-3.3.5; Meriam & Kraige, Statics, ch. 6).
    """
    gx, gy, gz = (float(v) for v in effective_gravity)
    if gz >= 0:
        raise ValueError(f"an effective gravity points down, not {gx, gy, gz}")
    g, sideways = -gz, math.hypot(gx, gy)
    frozen = stack.in_order()
    if not frozen or sideways == 0.0:
        return None
    loads = propagate(stack.nodes(frozen))
    tilt = np.array([gx, gy]) / g  # the line of action's horizontal run per metre of drop
    for rec in frozen:
        slides = next(
            (
                f"slides on {stack.bodies[s].label}: a/g = {sideways / g:.3f} > friction {mu:.3f}"
                for s in rec.rests_on
                if sideways / g > (mu := pair_friction(rec.friction, stack.bodies[s].friction))
            ),
            None,
        )
        tips = None
        main, load = rec.main_contact, loads.get(rec.body)
        if main is not None and load is not None:
            rise = float(load.com_above[2]) - main.height
            region = main.polygon.buffer(-margin) if margin > 0 else main.polygon
            x, y = np.asarray(load.com_above[:2]) + rise * tilt
            if not shapely.contains_xy(region, float(x), float(y)):
                tips = (
                    f"tips: under a = {sideways:.3g} m/s^2 its centre of mass above, {rise * 1000:.1f} mm over its "
                    "contact area, acts outside it"
                )
        if slides and tips:  # past both thresholds: the slide-rock mode (Shenton 1996)
            return f"{rec.label} {tips}, and {slides}"
        if slides or tips:
            return f"{rec.label} {slides or tips}"
    return None
