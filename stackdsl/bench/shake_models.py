"""Two references for a single block on a shake table whose base moves by ``A (1 - cos 2 pi f t)``
(a shake of ``stackdsl``'s language, docs/actions.md): a Coulomb block that slides and a rigid
block that rocks. Each is the motion its closed-form threshold is the onset of (docs/actions.md,
"The closed forms it is checked against": it slides from ``a > mu g``, it tips from ``a > g b / h``).

- :func:`coulomb_slip`: a block that cannot tip, held by Coulomb friction ``mu`` on the base;
  its slip relative to the base, integrated in time (docs/results/shake_drift.py uses it). The
  block rides the base while the base's acceleration is at most ``mu g``, and slides against
  kinetic friction ``mu g`` otherwise.
- :func:`rocking`: a rigid block that cannot slide, rocking on its bottom edges (Housner, "The
  behavior of inverted pendulum structures during earthquakes", Bull. Seism. Soc. Am. 53(2),
  1963; in the form of Makris & Konstantinidis, "The rocking spectrum and the limitations of
  practical design methodologies", Earthq. Eng. Struct. Dyn. 32, 2003, eq. 1-3):
  ``theta'' = -p^2 (sin(alpha sgn theta - theta) + a/g cos(alpha sgn theta - theta))`` with
  ``p^2 = 3 g / (4 R)``, ``R = sqrt(b^2 + h^2)``, ``alpha = atan(b / h)``; at rest it starts to
  rock when ``|a| > g tan alpha = g b / h``; each impact (``theta`` through 0) keeps the share
  ``r = 1 - 3/2 sin^2 alpha`` of its angular velocity. It topples when ``|theta|`` reaches
  ``pi / 2`` (it lies on its side). Integrated with :func:`scipy.integrate.solve_ivp`.

Both are the base's frame's: ``a`` is the base's acceleration along the shake, ``A (2 pi f)^2
cos(2 pi f t)`` during the shake and 0 after it. Units: metres, seconds, radians.
Source: as cited; the code is stackdsl's own.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from scipy.integrate import solve_ivp

G = 9.81
#: Radians: an impact after which the block would lift its other edge by less than this lands it
#: on its base (the impacts of a rocking block that comes to rest are infinitely many, in a
#: finite time: Housner 1963).
SETTLED = 1e-5


def coulomb_slip(amplitude: float, frequency: float, periods: int, mu: float, dt: float = 1e-5) -> tuple[float, float]:
    """(final, largest): the slip (m) of a Coulomb block relative to a base shaken by
    ``amplitude`` (m) at ``frequency`` (Hz) along +x for ``periods`` whole periods: where it
    ends once it has slid to rest after the shake (signed, along the shake), and the largest
    distance from its place during the run. Time steps of ``dt`` seconds, in the base's frame:
    the block rides the base while its acceleration is at most ``mu g``; it slides against
    kinetic friction ``mu g`` otherwise, and sticks again where its speed on the base crosses 0
    while the base's acceleration is at most ``mu g``.

    Raises:
        ValueError: a non-positive amplitude, frequency, period count, friction coefficient or step.

    >>> coulomb_slip(0.99 * 0.5 * G / (2 * math.pi * 2) ** 2, 2.0, 2, 0.5)  # below mu g: it rides
    (0.0, 0.0)
    >>> final, largest = coulomb_slip(1.5 * 0.5 * G / (2 * math.pi * 2) ** 2, 2.0, 2, 0.5)
    >>> 0.012 < final <= largest
    True
    """
    if not (amplitude > 0 and frequency > 0 and periods >= 1 and mu > 0 and dt > 0):
        raise ValueError(f"positive amplitude, frequency, periods, mu and dt, not {amplitude, frequency, periods, mu, dt}")
    w = 2 * math.pi * frequency
    end = periods / frequency
    grip = mu * G
    slip = speed = t = largest = 0.0  # the block's place and speed on the base
    while t < end or speed != 0.0:
        base = amplitude * w * w * math.cos(w * t) if t < end else 0.0
        if speed == 0.0:
            if abs(base) <= grip:  # stuck: it rides the base
                t += dt
                continue
            friction = grip * math.copysign(1.0, base)  # the base drags it along, short of its own acceleration
        else:
            friction = -grip * math.copysign(1.0, speed)
        new = speed + (friction - base) * dt
        if speed != 0.0 and new * speed <= 0.0 and abs(base) <= grip:
            new = 0.0  # its speed on the base crosses 0 where friction can hold it: it sticks
        slip += (speed + new) / 2 * dt
        speed, t = new, t + dt
        largest = max(largest, abs(slip))
    return slip, largest


@dataclass(frozen=True)
class Rocking:
    """What :func:`rocking` found: the largest tilt (rad), whether the block toppled (reached
    ``pi / 2``), the tilt at the end (rad, signed; ``pi / 2`` when it toppled), and the
    impacts it made."""

    largest: float
    toppled: bool
    final: float
    impacts: int


def rocking(
    half_width: float, half_height: float, amplitude: float, frequency: float, periods: int, after: float = 2.0
) -> Rocking:
    """The rigid rocking block (module docstring) of half-width ``half_width`` along the shake
    and centre of mass ``half_height`` above its base (m), on a base shaken by ``amplitude``
    (m) at ``frequency`` (Hz) for ``periods`` whole periods, followed for ``after`` seconds more.

    Raises:
        ValueError: a non-positive size, amplitude, frequency or period count, or a negative ``after``.

    >>> rocking(0.004, 0.012, 0.95 * G / 3 / (2 * math.pi * 2) ** 2, 2.0, 2).largest  # below g b / h
    0.0
    >>> rocking(0.004, 0.012, 1.5 * G / 3 / (2 * math.pi * 2) ** 2, 2.0, 2).toppled
    True
    """
    if not (half_width > 0 and half_height > 0 and amplitude > 0 and frequency > 0 and periods >= 1 and after >= 0):
        raise ValueError(f"positive sizes, amplitude, frequency and periods, not {half_width, half_height, amplitude, frequency}")
    w = 2 * math.pi * frequency
    shake_end = periods / frequency
    end = shake_end + after
    alpha = math.atan2(half_width, half_height)
    p2 = 3 * G / (4 * math.hypot(half_width, half_height))
    r = 1 - 1.5 * math.sin(alpha) ** 2
    onset = G * math.tan(alpha)

    def accel(t: float) -> float:
        return amplitude * w * w * math.cos(w * t) if t <= shake_end else 0.0

    t, theta, omega = 0.0, 0.0, 0.0
    largest, impacts = 0.0, 0
    resting = True
    while t < end - 1e-12:
        if resting:
            start = _next_onset(t, min(end, shake_end), amplitude * w * w, w, onset)
            if start is None:
                return Rocking(largest, False, 0.0, impacts)
            t, side = start, -math.copysign(1.0, accel(start))  # a > 0 pushes it back: it rocks on theta < 0
            theta, omega, resting = 0.0, 0.0, False
        side = math.copysign(1.0, theta) if theta != 0.0 else side
        stops = [x for x in (shake_end, end) if x > t + 1e-12]

        def rhs(time: float, y: np.ndarray, s: float = side) -> list[float]:
            a = amplitude * w * w * math.cos(w * time) if time <= shake_end else 0.0
            return [y[1], -p2 * (math.sin(s * alpha - y[0]) + a / G * math.cos(s * alpha - y[0]))]

        def through_zero(time: float, y: np.ndarray) -> float:
            return float(y[0])

        def fallen(time: float, y: np.ndarray) -> float:
            return abs(float(y[0])) - math.pi / 2

        through_zero.terminal = True  # type: ignore[attr-defined]
        through_zero.direction = -side  # type: ignore[attr-defined]
        fallen.terminal = True  # type: ignore[attr-defined]
        y0 = [theta if theta != 0.0 else side * 1e-12, omega]
        sol = solve_ivp(rhs, (t, stops[0]), y0, events=(through_zero, fallen), rtol=1e-9, atol=1e-12, max_step=1e-3)
        largest = max(largest, float(np.max(np.abs(sol.y[0]))))
        t = float(sol.t[-1])
        if sol.t_events[1].size:
            return Rocking(math.pi / 2, True, math.copysign(math.pi / 2, float(sol.y[0][-1])), impacts)
        if sol.t_events[0].size:  # an impact: the other edge takes over
            impacts += 1
            theta, omega = 0.0, r * float(sol.y_events[0][0][1])
            side = math.copysign(1.0, omega)
            pull = -p2 * (side * math.sin(alpha) + accel(t) / G * math.cos(alpha))  # theta'' on the new edge
            if side * pull < 0 and omega * omega / (2 * abs(pull)) < SETTLED:  # it would barely lift: it lands
                omega = 0.0
                if abs(accel(t)) > onset:
                    side = -math.copysign(1.0, accel(t))
                else:
                    resting = True
            continue
        theta, omega = float(sol.y[0][-1]), float(sol.y[1][-1])
    return Rocking(largest, False, theta, impacts)


def _next_onset(t: float, until: float, peak: float, w: float, onset: float) -> float | None:
    """The first time from ``t`` to ``until`` (s) at which the base's acceleration
    ``peak cos(w t)`` exceeds ``onset`` in size, or None."""
    if peak <= onset or t >= until:
        return None
    if abs(peak * math.cos(w * t)) > onset:
        return t
    # |cos(w t)| = c at w t = +-acos(c) + k pi
    c = math.acos(onset / peak)
    k = math.floor(w * t / math.pi)
    for n in range(k, k + 3):
        for phase in (n * math.pi - c, n * math.pi + c):
            when = phase / w
            if when > t and when < until:
                return when
    return None
