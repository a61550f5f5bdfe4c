"""The stability extension's thresholds and rules (SI units).

Source: report chapter 3; each field says where it departs from the report.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ._equilibrium import GRAVITY

_RANGES = (
    ("rest_speed", 0.0, True, math.inf, "a finite speed >= 0 in m/s"),
    ("rest_angular_speed", 0.0, True, math.inf, "a finite angular speed >= 0 in rad/s"),
    ("rest_duration", 0.0, True, math.inf, "a finite duration >= 0 in seconds"),
    ("contact_pad", 0.0, False, math.inf, "a finite length > 0 in metres"),
    ("support_angle", 0.0, True, 90.0, "an angle from 0 to 90 degrees"),
    ("face_gap", -math.inf, False, math.inf, "a finite length in metres"),
    ("com_margin", 0.0, True, math.inf, "a finite length >= 0 in metres"),
    ("lean_height", 0.0, True, math.inf, "a finite length >= 0 in metres"),
    ("leaning_margin", 1.0, True, 100.0, "a factor from 1 to 100"),
    ("gravity", 0.0, False, math.inf, "a finite acceleration > 0 in m/s^2"),
)
"""The numbers of :class:`StabilityConfig`: the field, its lower bound, whether it may be the
lower bound, its upper bound, and what it must be."""


#: The default of :attr:`StabilityConfig.leaning_margin`: a part that holds a contact which is
#: not level (a brick leaning on another) is asked to stand under this many times the shake's
#: acceleration before it is kept frozen or rides as one body (:func:`stability._shake._leaning`,
#: :func:`stability._shake.sliding_parts`). Rigid-block equilibrium is exact on its own terms, but
#: a leaning part needs most of its friction at rest, and there the engines part from it and from
#: each other: a V of KAPLA legs at 22 deg, frozen where an engine settled it, holds on its bare
#: contacts up to 0.100 m/s^2, where the tuned engines fell it from 0.071 and from 0.142 over 3 s;
#: a two-level card house at 20 deg so frozen holds to 0.11 m/s^2, and both tuned engines fell it
#: at 0.10 over 10 s. Within the margin the engine decides, as for any shake statics cannot keep
#: (docs/results/shake-table.md, "A margin for what leans"). Source: stackdsl's own.
LEANING_MARGIN = 1.5


@dataclass(frozen=True)
class StabilityConfig:
    """Thresholds and rules of the stability extension (SI units).

    Attributes:
        rest_speed: m/s; a brick faster than this is not at rest, and a body faster
            than this that is about to touch a frozen brick is an impact (report 3.3.2, 3.6).
        rest_angular_speed: rad/s; likewise for rotation (report 3.3.2).
        rest_duration: s; speeds must stay under both thresholds this long before a
            brick is admitted. The report tests one frame; a brick just woken is at rest
            for that frame and would be refrozen at once, so stackdsl asks for a duration
            (its own).
        contact_pad: m; half-width of the padding of one- and two-point contact areas
            (report 3.3.3, 3.4.2).
        support_angle: degrees; a contact whose normal is within this angle of vertical
            is one the brick rests on (stackdsl's own).
        face_gap: m; two faces within this distance (and this flat, and parallel to
            :data:`stability._geometry.FACE_TILT`) touch face to face, and their overlap is
            the exact contact area (stackdsl's own).
        com_margin: m; the centre of mass must lie this far inside the area (0: strictly
            inside; on the edge counts as unstable).
        lean_height: m; a brick whose support areas differ in height by more than this
            is not admitted by the basic test (report 3.5).
        leaning_margin: times a shake's acceleration under which a frozen part with a contact
            that is not level must stand before it is kept frozen or rides the shaken ground as
            one body (:data:`LEANING_MARGIN` by default; 1: none; an engine adapter gives its own): rigid-block
            equilibrium on the geometry an engine froze can hold a leaning part past what the
            engines hold.
        leaning: run the leaning rule (report 3.4).
        max_leaning_bodies: a leaning brick may touch at most this many bodies (the
            report's model handles two).
        impacts: run the impact rule (report 3.6).
        impact_energy: what a blow must exceed to break the hit part loose: ``"least"``, the
            lesser of the energy to lift it from its base and the energy to tip it over the edge
            of its support polygon the blow turns it over (a rocking block's barrier, stackdsl's own:
            :func:`stability._impact.tipping_energy`) for a part nothing outside it holds, so
            that a blow that topples an upright brick (a domino, a post) wakes it; ``"lift"``,
            the lifting energy alone (report
            3.6.2), which holds a lone KAPLA domino against a KAPLA thrown at it at 1 m/s (5.3
            mJ against 6.2 mJ to lift it, 0.014 mJ to tip it).
        debris: admit a resting brick the other rules refuse together with every resting
            brick it touches, and they with theirs, when rigid-block equilibrium holds them
            all against what is frozen (stackdsl's own): fallen bricks leaning on each other
            are frozen again, so that what lies still costs nothing. A brick once woken is
            then at rest by the windowed test of :mod:`stability._rest`.
        per_event: run the stack-wide test only when the stack changes (a freeze or a
            wake); False runs it on every step with an active brick (for measuring).
        model: ``"report"``: the report's rules (basic test, leaning test, centre of mass
            above against the main contact area); ``"equilibrium"``: admission and the
            stack-wide test by rigid-block equilibrium (:mod:`stability._equilibrium`).
        gravity: m/s^2.

    Raises:
        ValueError: an unknown model or impact energy; a number out of its range: a speed,
            a duration, a padding, a margin or a height that is negative or not finite, a
            ``contact_pad`` or ``gravity`` that is not positive, a ``support_angle`` outside
            0 to 90 degrees, a ``face_gap`` that is not finite (a negative one turns exact
            face areas off), or ``max_leaning_bodies`` below 1.
        TypeError: one of those numbers is not a number (``True`` neither), or
            ``max_leaning_bodies`` is not a whole number.
    """

    rest_speed: float = 0.005
    rest_angular_speed: float = 0.05
    rest_duration: float = 0.05
    contact_pad: float = 0.001
    support_angle: float = 30.0
    face_gap: float = 0.001
    com_margin: float = 0.0
    lean_height: float = 0.002
    leaning_margin: float = LEANING_MARGIN
    leaning: bool = True
    max_leaning_bodies: int = 2
    impacts: bool = True
    impact_energy: str = "least"
    debris: bool = True
    per_event: bool = True
    model: str = "report"
    gravity: float = GRAVITY

    def __post_init__(self) -> None:
        for name, low, closed, high, what in _RANGES:
            value = getattr(self, name)
            if isinstance(value, bool) or not isinstance(value, (int, float, np.integer, np.floating)):
                raise TypeError(f"StabilityConfig.{name} must be a number ({what}), not {value!r}")
            number = float(value)
            if not (low <= number if closed else low < number) or not number <= high or not math.isfinite(number):
                raise ValueError(f"StabilityConfig.{name} must be {what}, not {value!r}")
        if isinstance(self.max_leaning_bodies, bool) or not isinstance(self.max_leaning_bodies, (int, np.integer)):
            raise TypeError(f"StabilityConfig.max_leaning_bodies must be a whole number, not {self.max_leaning_bodies!r}")
        if self.max_leaning_bodies < 1:
            raise ValueError(f"StabilityConfig.max_leaning_bodies must be at least 1, not {self.max_leaning_bodies!r}")
        if self.impact_energy not in ("least", "lift"):
            raise ValueError(f"unknown impact energy {self.impact_energy!r}: 'least' or 'lift'")
        if self.model not in ("report", "equilibrium"):
            raise ValueError(f"unknown stability model {self.model!r}: 'report' or 'equilibrium'")
