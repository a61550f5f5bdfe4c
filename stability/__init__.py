"""stability: the stack stability extension for pybullet (report chapter 3).

Reasons about a stack of bricks as a graph (who rests on whom, centre of mass above,
mass above), freezes the bricks it proves stable and wakes them when it proves them
unstable. It attaches to any pybullet client through :class:`PyBulletEngine` and knows
nothing of YAML or scenarios.

Register the ground and every brick, call ``update`` once per step, read the brick graph:

>>> import numpy as np, pybullet
>>> from pybullet_utils.bullet_client import BulletClient
>>> from stability import Box, Plane, PyBulletEngine, StabilityExtension
>>> client = BulletClient(connection_mode=pybullet.DIRECT)
>>> client.setGravity(0, 0, -9.81)
>>> plane = client.createMultiBody(0, client.createCollisionShape(pybullet.GEOM_PLANE))
>>> half = np.array([0.06, 0.012, 0.004])  # a KAPLA brick, metres
>>> ext = StabilityExtension(PyBulletEngine(client))
>>> ext.add_ground(plane, Plane(0.0))
>>> shape = client.createCollisionShape(pybullet.GEOM_BOX, halfExtents=half.tolist())
>>> for i, z in enumerate([0.0045, 0.0125]):  # two bricks, 0.5 mm above their rest
...     ext.add_brick(client.createMultiBody(0.0106, shape, basePosition=[0, 0, z]), Box(half, 0.0106), f"b{i + 1}")
>>> events = []
>>> for step in range(240):  # one second at 240 Hz
...     _ = client.stepSimulation()
...     events += ext.update(step / 240)
>>> [(e.kind, e.label, e.reason) for e in events]
[('freeze', 'b1', 'at rest on ground'), ('freeze', 'b2', 'at rest on b1')]
>>> [(e.upper, e.support, round(e.area * 1e6)) for e in ext.graph().edges]  # contact areas in mm^2
[('b1', 'ground', 2880), ('b2', 'b1', 2880)]
>>> client.disconnect()

Source: "Simulating Object Stacking Using Stack Stability", chapter 3.
"""

from ._certificate import Certificate
from ._engine import ContactPoint, Engine, FakeEngine, PyBulletEngine
from ._equilibrium import ContactPolygon, Equilibrium, RigidBlock, is_level, solve_equilibrium
from ._extension import StabilityConfig, StabilityEvent, StabilityExtension
from ._friction import friction_share
from ._geometry import Box, ContactArea, Plane, Pose, combined_hull, contains, face_overlap, hull_xy, padded_hull
from ._graph import BrickGraph, BrickState, GraphEdge, GraphNode
from ._impact import breaks_loose, kinetic_energy, potential_energy
from ._leaning import lean_polygon, leaning_stands, pair_friction
from ._load import Load, LoadNode, propagate, split_load, torque_split
from ._load_path import load_path, proven, support_piece
from ._margin import equilibrium_margin
from ._rest import JITTER, still

__all__ = [
    "JITTER",
    "Box",
    "BrickGraph",
    "BrickState",
    "Certificate",
    "ContactArea",
    "ContactPoint",
    "ContactPolygon",
    "Engine",
    "Equilibrium",
    "FakeEngine",
    "GraphEdge",
    "GraphNode",
    "Load",
    "LoadNode",
    "Plane",
    "Pose",
    "PyBulletEngine",
    "RigidBlock",
    "StabilityConfig",
    "StabilityEvent",
    "StabilityExtension",
    "breaks_loose",
    "combined_hull",
    "contains",
    "equilibrium_margin",
    "face_overlap",
    "friction_share",
    "hull_xy",
    "is_level",
    "kinetic_energy",
    "lean_polygon",
    "leaning_stands",
    "load_path",
    "padded_hull",
    "pair_friction",
    "potential_energy",
    "propagate",
    "proven",
    "solve_equilibrium",
    "split_load",
    "still",
    "support_piece",
    "torque_split",
]
