"""stability: the stack stability extension for pybullet (report chapter 3).

Reasons about a stack of bricks as a graph (who rests on whom, centre of mass above,
mass above), freezes the bricks it proves stable and wakes them when it proves them
unstable. It attaches to any pybullet client through :class:`PyBulletEngine` and knows
nothing of YAML or scenarios.

Source: "Simulating Object Stacking Using Stack Stability", chapter 3.
"""

from ._engine import ContactPoint, Engine, FakeEngine, PyBulletEngine
from ._equilibrium import ContactPolygon, Equilibrium, RigidBlock, solve_equilibrium
from ._extension import StabilityConfig, StabilityEvent, StabilityExtension
from ._geometry import Box, ContactArea, Plane, Pose, combined_hull, contains, face_overlap, padded_hull
from ._graph import BrickGraph, BrickState, GraphEdge, GraphNode
from ._impact import breaks_loose, kinetic_energy, potential_energy
from ._leaning import lean_polygon, leaning_stands, pair_friction
from ._load import Load, LoadNode, propagate, split_load, torque_split

__all__ = [
    "Box",
    "BrickGraph",
    "BrickState",
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
    "face_overlap",
    "kinetic_energy",
    "lean_polygon",
    "leaning_stands",
    "padded_hull",
    "pair_friction",
    "potential_energy",
    "propagate",
    "solve_equilibrium",
    "split_load",
    "torque_split",
]
