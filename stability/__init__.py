"""stability: the stack stability extension for a physics engine (report chapter 3).

Reasons about a stack of bricks as a graph (who rests on whom, centre of mass above,
mass above), freezes the bricks it proves stable and wakes them when it proves them
unstable. It drives any engine through the small :class:`Engine` protocol (poses,
velocities, contact points, freezing), knows no engine by name and nothing of YAML or
scenarios; :class:`FakeEngine` is one held in memory.

Register the ground and every brick, call ``update`` once per step, read the brick graph:

>>> import numpy as np
>>> from stability import Box, FakeEngine, Plane, Pose, StabilityExtension
>>> engine = FakeEngine()  # two KAPLA bricks at rest, one on the other (metres)
>>> half = np.array([0.06, 0.012, 0.004])
>>> engine.poses.update({1: Pose(np.array([0, 0, 0.004])), 2: Pose(np.array([0, 0, 0.012]))})
>>> face = [[x, y, 0.0] for x in (-0.06, 0.06) for y in (-0.012, 0.012)]
>>> engine.touch(1, 0, face, normal=[0, 0, 1])
>>> engine.touch(2, 1, np.add(face, [0, 0, 0.008]), normal=[0, 0, 1])
>>> ext = StabilityExtension(engine)
>>> ext.add_ground(0, Plane(0.0))
>>> for body in (1, 2):
...     ext.add_brick(body, Box(half, 0.0106), f"b{body}")
>>> events = []
>>> for step in range(240):  # one second at 240 Hz
...     events += ext.update(step / 240)
>>> [(e.kind, e.label, e.reason) for e in events]
[('freeze', 'b1', 'at rest on ground'), ('freeze', 'b2', 'at rest on b1')]
>>> [(e.upper, e.support, round(e.area * 1e6)) for e in ext.graph().edges]  # contact areas in mm^2
[('b1', 'ground', 2880), ('b2', 'b1', 2880)]

Source: "Simulating Object Stacking Using Stack Stability", chapter 3.
"""

from ._certificate import Certificate
from ._contacts import PlacedBox, contacts_of
from ._engine import ContactPoint, Engine, FakeEngine
from ._equilibrium import ContactPolygon, Equilibrium, RigidBlock, balanced_tilted, is_level, solve_equilibrium
from ._extension import StabilityConfig, StabilityEvent, StabilityExtension
from ._friction import friction_share
from ._geometry import Box, ContactArea, Plane, Pose, combined_hull, contains, face_overlap, hull_xy, padded_hull
from ._graph import BrickGraph, BrickState, GraphEdge, GraphNode
from ._impact import breaks_loose, kinetic_energy, potential_energy
from ._leaning import lean_polygon, leaning_stands, pair_friction
from ._load import Load, LoadNode, propagate, split_load, torque_split
from ._load_path import load_path, proven, support_piece
from ._lp import OutOfTime, WarmStart
from ._margin import equilibrium_margin
from ._placing import GAP as CONTACT_GAP
from ._placing import Placed, Placing, load_paths_hold
from ._rest import JITTER, still

__all__ = [
    "CONTACT_GAP",
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
    "OutOfTime",
    "Placed",
    "PlacedBox",
    "Placing",
    "Plane",
    "Pose",
    "RigidBlock",
    "StabilityConfig",
    "StabilityEvent",
    "StabilityExtension",
    "WarmStart",
    "balanced_tilted",
    "breaks_loose",
    "combined_hull",
    "contacts_of",
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
    "load_paths_hold",
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
