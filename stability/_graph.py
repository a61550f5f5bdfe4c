"""The brick graph: who rests on whom, with what area and load.

Plain frozen dataclasses in SI units; the harness rounds and renames them for
snapshots. Source: report Figure 3 and 3.3.5-3.3.6; the graph form is stackdsl's own.
"""

from __future__ import annotations

from dataclasses import dataclass
from enum import Enum

import numpy as np

from ._geometry import Pose


class BrickState(str, Enum):
    """Where a body is simulated (report 3.3.1)."""

    ACTIVE = "active"  # moved by the physics engine
    FROZEN = "frozen"  # part of the stack: immovable in the engine, still colliding
    GROUND = "ground"  # environment: the ground plane and fixed bodies


@dataclass(frozen=True)
class GraphNode:
    """One body of the brick graph.

    Attributes:
        label: the name the body was registered with.
        state: :class:`BrickState`.
        pose: current pose (for frozen bricks, the pose they were frozen in; for one riding a
            pull or a shaken ground, merged, where it has been carried).
        com_above: shape (3,), metres (the brick's own centre of mass for the ground).
        mass_above: kilograms (0 for the ground).
    """

    label: str
    state: BrickState
    pose: Pose
    com_above: np.ndarray
    mass_above: float


@dataclass(frozen=True)
class GraphEdge:
    """``upper`` rests on ``support`` through a contact area.

    Attributes:
        upper, support: labels.
        area: square metres, horizontal projection of the contact area.
        load_share: fraction (0..1) of ``upper``'s mass above passed to ``support``.
        exact: True when the area is the exact face overlap, False for a point hull.
        polygon: the area's outline, counter-clockwise (x, y) vertices in metres, not
            repeating the first (the horizontal projection whose area is ``area``).
    """

    upper: str
    support: str
    area: float
    load_share: float
    exact: bool
    polygon: tuple[tuple[float, float], ...] = ()


@dataclass(frozen=True)
class BrickGraph:
    """Nodes in registration order, edges sorted by (upper, support) registration order."""

    nodes: tuple[GraphNode, ...]
    edges: tuple[GraphEdge, ...]

    def node(self, label: str) -> GraphNode:
        """The node named ``label``. Raises KeyError when there is none."""
        for n in self.nodes:
            if n.label == label:
                return n
        raise KeyError(label)
