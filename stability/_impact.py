"""Impacts (report 3.6): the impactor's kinetic energy against the hit part's potential energy.

A body moving faster than the rest threshold that is about to touch a frozen brick
either breaks it loose or not: if its kinetic energy exceeds the potential energy of
the hit brick and the stack above it, measured from the centre of the brick's main
contact area to its centre of mass above, that brick and everything above it wake and
the engine simulates the blow; otherwise the stack holds and the engine handles the
impactor alone (against immovable bricks). Threshold-based, as the report's.
"""

from __future__ import annotations

from ._equilibrium import GRAVITY


def kinetic_energy(mass: float, speed: float) -> float:
    """Joules of a body of ``mass`` kg at ``speed`` m/s (report 3.6.2).

    >>> kinetic_energy(0.0106, 1.0)
    0.0053
    """
    return 0.5 * mass * speed * speed


def potential_energy(mass_above: float, com_above_z: float, base_z: float, gravity: float = GRAVITY) -> float:
    """Joules to lift the hit brick and the stack above it from its base (report 3.6.2).

    Args:
        mass_above: kg, the hit brick's mass above.
        com_above_z: m, height of its centre of mass above.
        base_z: m, height of the centre of its main contact area.
        gravity: m/s^2.
    """
    return mass_above * gravity * max(com_above_z - base_z, 0.0)


def breaks_loose(kinetic: float, potential: float) -> bool:
    """True when the impact wakes the hit part: kinetic energy above potential (report 3.6.2)."""
    return kinetic > potential
