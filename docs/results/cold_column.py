"""What pybullet does with frozen bricks woken at once (docs/results/shake-table.md, "A ride that
comes to rest"): ``python docs/results/cold_column.py``.

Two KAPLA bricks that only touch get no contact point from pybullet, even from
``performCollisionDetection``; overlapping by 1 um they do. A column of 15 KAPLA bricks, each frozen
only touching the one under it (as the extension freezes them, raised out of the engine's
overlaps), then all given their mass back in one step, sinks as its joints close: at pybullet's 50
solver iterations, started cold, it does not stop sinking. Prints the contact counts, and the top
brick's height change and the column's largest sideways drift after 2, 12 and 48 steps of
1/240 s. Source: stackdsl's own, measured with pybullet 3.2.7.
"""

from __future__ import annotations

import pybullet

HALF = (0.06, 0.012, 0.004)
MASS = 0.0106
LEVELS = 15


def _world() -> int:
    client = pybullet.connect(pybullet.DIRECT)
    pybullet.setGravity(0.0, 0.0, -9.81, physicsClientId=client)
    pybullet.setTimeStep(1 / 240, physicsClientId=client)
    plane = pybullet.createCollisionShape(pybullet.GEOM_PLANE, physicsClientId=client)
    pybullet.createMultiBody(0.0, plane, physicsClientId=client)
    return client


def _column(client: int, levels: int, overlap: float) -> list[int]:
    """``levels`` bricks on end to end, each ``overlap`` m into the one under it, frozen (mass 0)
    for a step, then all given their mass back."""
    box = pybullet.createCollisionShape(pybullet.GEOM_BOX, halfExtents=list(HALF), physicsClientId=client)
    bodies = [
        pybullet.createMultiBody(
            MASS, box, basePosition=[0.0, 0.0, HALF[2] * (2 * k + 1) - overlap * (k + 1)], physicsClientId=client
        )
        for k in range(levels)
    ]
    for body in bodies:
        pybullet.changeDynamics(body, -1, mass=0.0, physicsClientId=client)
    pybullet.stepSimulation(physicsClientId=client)
    for body in bodies:
        pybullet.changeDynamics(body, -1, mass=MASS, physicsClientId=client)
    return bodies


def contacts(overlap: float) -> int:
    """Contact points pybullet finds between the two lower bricks of a woken column, before a step."""
    client = _world()
    bodies = _column(client, 3, overlap)
    pybullet.performCollisionDetection(physicsClientId=client)
    found = len(pybullet.getContactPoints(bodies[0], bodies[1], physicsClientId=client))
    pybullet.disconnect(client)
    return found


def sag(iterations: int, overlap: float) -> list[tuple[int, float, float]]:
    """(steps, the top brick's height change in mm, the largest sideways drift in mm) of a woken column."""
    client = _world()
    pybullet.setPhysicsEngineParameter(numSolverIterations=iterations, physicsClientId=client)
    bodies = _column(client, LEVELS, overlap)
    top = pybullet.getBasePositionAndOrientation(bodies[-1], physicsClientId=client)[0][2]
    rows = []
    for step in range(1, 49):
        pybullet.stepSimulation(physicsClientId=client)
        if step in (2, 12, 48):
            z = pybullet.getBasePositionAndOrientation(bodies[-1], physicsClientId=client)[0][2]
            drift = max(abs(pybullet.getBasePositionAndOrientation(b, physicsClientId=client)[0][1]) for b in bodies)
            rows.append((step, (z - top) * 1000, drift * 1000))
    pybullet.disconnect(client)
    return rows


def main() -> None:
    print("contact points between two woken bricks that only touch:", contacts(0.0), "; overlapping by 1 um:", contacts(1e-6))
    print("| solver iterations | joints | steps | top brick (mm) | sideways (mm) |")
    print("|---:|---|---:|---:|---:|")
    for iterations, overlap, joints in ((50, 0.0, "touching"), (50, 1e-5, "0.01 mm into"), (150, 1e-5, "0.01 mm into")):
        for steps, dz, drift in sag(iterations, overlap):
            print(f"| {iterations} | {joints} | {steps} | {dz:+.2f} | {drift:.2f} |")


if __name__ == "__main__":
    main()
