"""stability: the stack stability extension for pybullet (report chapter 3).

Reasons about a stack of bricks as a graph (who rests on whom, centre of mass above,
mass above), freezes the bricks it proves stable and wakes them when it proves them
unstable. It attaches to any pybullet client through :class:`PyBulletEngine` and knows
nothing of YAML or scenarios.

Source: "Simulating Object Stacking Using Stack Stability", chapter 3.
"""

from ._engine import ContactPoint, Engine, FakeEngine, PyBulletEngine
from ._extension import StabilityConfig, StabilityEvent, StabilityExtension
from ._geometry import Box, ContactArea, Plane, Pose, combined_hull, contains, face_overlap, padded_hull
from ._graph import BrickGraph, BrickState, GraphEdge, GraphNode
from ._load import Load, LoadNode, propagate, split_load, torque_split

__all__ = [
    "Box",
    "BrickGraph",
    "BrickState",
    "ContactArea",
    "ContactPoint",
    "Engine",
    "FakeEngine",
    "GraphEdge",
    "GraphNode",
    "Load",
    "LoadNode",
    "Plane",
    "Pose",
    "PyBulletEngine",
    "StabilityConfig",
    "StabilityEvent",
    "StabilityExtension",
    "combined_hull",
    "contains",
    "face_overlap",
    "padded_hull",
    "propagate",
    "split_load",
    "torque_split",
]
