"""The Outcome of a run: timeline, collapse record, brick graphs, timings.

Brick graphs here are the snapshot form of :class:`stability.BrickGraph`: bricks named
by their scenario ids, positions rounded to 0.1 mm and orientations to canonical quaternions
of 3 decimals, centre of mass above in mm,
mass above in grams, contact areas in mm^2 and load shares to 0.001 (docs/design.md, "brick
graph"). Source: stackdsl's own.
"""

from __future__ import annotations

import math
import warnings
from collections.abc import Sequence
from typing import Any, Literal

import numpy as np
from pydantic import BaseModel, ConfigDict
from scipy.spatial.transform import Rotation

from stability import BrickGraph

from ..compile.program import Seconds

Vec3 = tuple[float, float, float]
Vec4 = tuple[float, float, float, float]


class _Frozen(BaseModel):
    model_config = ConfigDict(extra="forbid", frozen=True)


class Event(_Frozen):
    """One entry of the timeline; ``time`` in seconds (to JSON without float noise)."""

    time: Seconds
    kind: Literal[
        "place", "launch", "freeze", "wake", "impact", "collapse", "substeps", "remove", "push", "shake", "release", "ride"
    ]
    brick: str
    level: int | None = None
    detail: str = ""


class Collapse(_Frozen):
    """The first collapse (docs/design.md, words): a structure brick left its placed pose by more than
    the collapse threshold and stayed moved (:mod:`stackdsl.runtime.collapse`).

    Attributes:
        level: the highest level placed when the brick first moved past the threshold (the
            collapse level).
        time: seconds, when it first moved past the threshold.
        brick, brick_level: the brick that moved first, and its own level.
        displacement: metres, how far it had moved when the collapse was decided.
        decided: seconds, when it was known to stay moved (its certificate says how: at rest
            displaced, off its support, in a proved mechanism, displaced at the end, or no
            equilibrium at the end); the run ends the scenario's settle time after it.
    """

    level: int
    time: Seconds
    brick: str
    brick_level: int
    displacement: float
    decided: Seconds


ProofKind = Literal[
    "equilibrium", "at rest displaced", "off its support", "mechanism", "displaced at the end", "no equilibrium", "still moving"
]
"""How a verdict was proved (:class:`Certificate`)."""


class Certificate(_Frozen):
    """The proof of a verdict (docs/design.md, "collapse" and "certificate").

    Attributes:
        verdict: ``"stands"``, ``"collapse"``, or ``"undecided"``: the run ended with bricks
            still moving (kind ``"still moving"``) and no collapse proved before, so that no
            static argument on a pose in flight decides it (settle longer: ``timing.settle``).
        kind: how it was proved. For ``stands``: ``"equilibrium"``, rigid-block equilibrium of
            every brick where it is at the end (:meth:`stability.StabilityExtension.certificate`).
            For ``collapse``: ``"at rest displaced"`` (a brick came to rest out of its place),
            ``"off its support"`` (its centre of mass, with the bricks it carries and those
            beside it that share them, left the support polygon it was placed on; on the
            ground alone, passed the edge of the face it stood on), ``"mechanism"`` (it moves
            in a collapse mechanism statics proved),
            ``"displaced at the end"``, or ``"no equilibrium"`` (the final state has none).
        detail: the proof in words.
        bricks: for ``collapse``, the bricks it involves: those displaced when it was decided,
            with those its proof names (the part that tipped, the proved mechanism; with no
            equilibrium, the mechanism's); for ``stands``, none, in every mode (the stand is of
            every brick, and ``detail`` says how many were balanced).
        margin_mm: for ``stands``, how far every centre of mass could move together (one
            common horizontal shift, in any direction) before rigid-block equilibrium would not
            hold it, with every brick within 0.5 deg of level taken level about its centre,
            rounded down to 0.1 mm: never more than that distance and at most 0.2 mm less, and
            less what a settled brick's tilt moved its corners (up to 0.04 mm for a flat KAPLA
            brick; at most 20 mm; see :attr:`stability.Certificate.margin`); else None.
        friction_share: for ``stands``, the least share of every contact's friction coefficient
            with which it still balances (0: vertical forces on level faces hold it; see
            :attr:`stability.Certificate.friction`), to 0.01 above; else None.
    """

    verdict: Literal["stands", "collapse", "undecided"]
    kind: ProofKind
    detail: str
    bricks: tuple[str, ...] = ()
    margin_mm: float | None = None
    friction_share: float | None = None


def describe_certificate(c: Certificate) -> str:
    """One line for a person: ``"stands: rigid-block equilibrium of ... (margin 12.0 mm)"``."""
    margin = f" (margin {c.margin_mm:.1f} mm)" if c.margin_mm is not None else ""
    return f"{c.verdict}, {c.kind}: {c.detail}{margin}"


class Node(_Frozen):
    """A brick of the graph (ground: level None, state "ground").

    ``quaternion_xyzw`` is its orientation as scipy writes a quaternion, (x, y, z, w), to 3
    decimals (about 0.1 deg, as the angles were), in canonical sign (w > 0; when w rounds to 0, the first nonzero part > 0): unlike
    yaw, pitch and roll it has no gimbal lock (a standing brick's yaw and roll are one angle
    there, and scipy warns), and a small turn changes it a little. ``displaced_mm``: how far its
    farthest corner is from where it was placed, to 0.1 mm (None: not a structure brick, a
    thrown body or a pusher): beyond the collapse threshold it is debris, and where a brick
    comes to rest is chaos's in proportion to how far it was knocked
    (:mod:`stackdsl.verdicts.golden_compare`)."""

    id: str
    level: int | None
    state: str
    position_mm: Vec3
    quaternion_xyzw: Vec4
    com_above_mm: Vec3
    mass_above_g: float
    displaced_mm: float | None = None

    @property
    def yaw_pitch_roll_deg(self) -> Vec3:
        """Yaw, pitch and roll (degrees, intrinsic z-y-x as in the scenario language), rounded to
        0.1 deg; at pitch ±90 deg the roll is 0 and the yaw carries the turn (no warning)."""
        return _degrees(euler_degrees(self.quaternion_xyzw))


class Edge(_Frozen):
    """``upper`` rests on ``support`` through ``area_mm2``, passing it ``load_share`` of its load;
    ``polygon_mm`` is the contact area's horizontal outline, (x, y) in mm counter-clockwise
    (drawn by the brick-graph plot; not part of a golden snapshot)."""

    upper: str
    support: str
    area_mm2: float
    load_share: float
    polygon_mm: tuple[tuple[float, float], ...] = ()


class Graph(_Frozen):
    """A brick graph in snapshot form."""

    nodes: tuple[Node, ...]
    edges: tuple[Edge, ...]

    @classmethod
    def from_stability(cls, graph: BrickGraph, levels: dict[str, int], displaced: dict[str, float] | None = None) -> Graph:
        """Round and rename a :class:`stability.BrickGraph`; ``levels`` maps ids to levels;
        ``displaced``: structure brick id -> metres its farthest corner is from where it was placed."""
        displaced = displaced or {}
        turns = canonical_quaternions([n.pose.orientation for n in graph.nodes])
        nodes = tuple(
            Node(
                id=n.label,
                level=levels.get(n.label),
                state=n.state.value,
                position_mm=_mm(n.pose.position),
                quaternion_xyzw=turn,
                com_above_mm=_mm(n.com_above),
                mass_above_g=_round(n.mass_above * 1000, 1),
                displaced_mm=_round(displaced[n.label] * 1000, 1) if n.label in displaced else None,
            )
            for n, turn in zip(graph.nodes, turns, strict=True)
        )
        edges = tuple(
            Edge(
                upper=e.upper,
                support=e.support,
                area_mm2=_round(e.area * 1e6, 1),
                load_share=_round(e.load_share, 3),
                polygon_mm=tuple((_round(x * 1000, 2), _round(y * 1000, 2)) for x, y in e.polygon),
            )
            for e in graph.edges
        )
        return cls(nodes=nodes, edges=edges)

    def bricks(self) -> dict[str, dict[str, Any]]:
        """The graph as plain data, one entry per brick (the ground left out): brick id ->
        level, state, position (mm), orientation (quaternion), centre of mass above (mm), mass
        above (g), ``rests_on``: support id -> contact area (mm^2) and load share, and
        ``displaced_mm``: how far from where it was placed (None: not a structure brick)."""
        supports: dict[str, dict[str, dict[str, float]]] = {}
        for e in self.edges:
            supports.setdefault(e.upper, {})[e.support] = {"area_mm2": e.area_mm2, "load_share": e.load_share}
        return {
            n.id: {
                "level": n.level,
                "state": n.state,
                "position_mm": list(n.position_mm),
                "quaternion_xyzw": list(n.quaternion_xyzw),
                "com_above_mm": list(n.com_above_mm),
                "mass_above_g": n.mass_above_g,
                "rests_on": supports.get(n.id, {}),
                "displaced_mm": n.displaced_mm,
            }
            for n in self.nodes
            if n.state != "ground"
        }


class Outcome(_Frozen):
    """What a run produced.

    Attributes:
        scenario, mode, backend: what ran (backend: the engine, pybullet or mujoco; not part of
            a golden snapshot, which is the scenario's own engine's).
        collapse: the first collapse, or None when the structure stood.
        events: the timeline.
        final_graph: the brick graph at the end; collapse_graph: at the first collapse.
        displacement: structure brick id -> metres from its placed pose at the end.
        drift: metres, the largest displacement of a standing structure brick (one not
            beyond the collapse threshold) seen before each placement until the first
            collapse, and at the end if there was none.
        kinetic_energy: joules, of the structure's bricks at the end (their linear and
            angular motion).
        levels_placed, bricks_placed: how much was built (building stops at a collapse).
        simulated_time, wall_time: seconds (the wall time from the start of the run to the
            outcome built, its final brick graph included); steps: physics steps taken; steps_skipped:
            steps jumped over while every brick was frozen.
        engine_time: seconds of the wall time spent in the engine's own steps (the rest is
            stackdsl's: the extension, the monitor, placing).
        after_collapse: seconds of the wall time after the collapse was decided (0 without
            one): the settle time's cost.
        certificate: the proof of the verdict (None when the run stopped early).
        certificate_time: seconds of the wall time spent proving that the structure stands.
        toppled: the structure bricks tilted past their tipping angle at the end (a domino
            fallen over), in the order they were placed (:meth:`stackdsl.runtime.bricks.Structure.toppled`).
        removed: the bricks a hand pulled out of the structure (``actions: remove``).
        unplaced: the structure bricks of the scene never placed (building stops at a collapse),
            in placing order; ``toppled: all`` counts them as standing.
        not_run: the actions (impacts, pulls, pushes, shakes) a collapse ended the run before,
            each in a few words, as "remove L06.2 at 29.83 s".
        collapse_threshold_mm: the run's collapse threshold, mm (a brick farther from where it
            was placed has moved: :attr:`Node.displaced_mm`).
        margin: metres, the verdict's signed margin (not part of a golden snapshot): positive
            when it stands, the certificate's margin unrounded (how far every centre of mass
            could move together before rigid-block equilibrium would not hold it,
            :attr:`Certificate.margin_mm`); negative when it collapsed, minus how far the deciding
            proof was past its limit (:func:`stackdsl.runtime.collapse.signed_margin`): a part placed
            with its centre of mass d outside its support polygon gives -d (so the margin goes
            through 0 where statics' verdict changes, continuous across that boundary), else the
            proof's own distance when it decided (the centre of mass outside its support, or
            the brick past the collapse threshold), or -0 (no equilibrium at the end, nothing
            past the threshold). None when the run stopped early or is undecided.
        peak_tilt, peak_slip: radians and metres, the largest tilt of any structure brick from
            its placed orientation and the largest slip of its base's centre on the ground (a
            shaken table's offset taken off) over the run (:class:`stackdsl.runtime.motion.PeakMotion`),
            when the scenario expects ``still:``; else None.
        stopped: None when the run went to its end; else why and where it stopped early,
            e.g. ``"timeout after 120 s at t = 37.2 s simulated (of 201 s)"`` (the rest of
            the outcome then covers the simulated time so far, and the expectations fail:
            :func:`stackdsl.evaluate` adds a failed ``finished`` verdict).
    """

    scenario: str
    mode: str
    collapse: Collapse | None
    backend: str = "pybullet"
    events: tuple[Event, ...]
    final_graph: Graph
    collapse_graph: Graph | None
    displacement: dict[str, float]
    drift: float
    kinetic_energy: float
    levels_placed: int
    bricks_placed: int
    simulated_time: float
    wall_time: float
    steps: int
    steps_skipped: int
    engine_time: float = 0.0
    after_collapse: float = 0.0
    certificate: Certificate | None = None
    certificate_time: float = 0.0
    toppled: tuple[str, ...] = ()
    removed: tuple[str, ...] = ()
    unplaced: tuple[str, ...] = ()
    stopped: str | None = None
    not_run: tuple[str, ...] = ()
    collapse_threshold_mm: float = 4.0
    margin: float | None = None
    peak_tilt: float | None = None
    peak_slip: float | None = None

    def golden(self) -> dict[str, Any]:
        """Plain JSON data for a golden snapshot: what was built, how many bricks toppled, the
        collapse record, the certificate (without its words, which carry unrounded numbers), and the brick graphs at
        the collapse and at the end, each brick keyed by its id (see :func:`Graph.bricks`). The collapse time is left out: the level and the brick are
        what a scenario asserts, and the time would show every small change as a diff."""
        collapse = None
        if self.collapse:
            c = self.collapse
            collapse = {"level": c.level, "brick": c.brick, "brick_level": c.brick_level}
        certificate = None
        if self.certificate:
            certificate = self.certificate.model_dump(mode="json", exclude={"detail"})
        return {
            "scenario": self.scenario,
            "mode": self.mode,
            "levels_placed": self.levels_placed,
            "collapse_threshold_mm": self.collapse_threshold_mm,
            "toppled": len(self.toppled),
            "collapse": collapse,
            "certificate": certificate,
            "collapse_graph": self.collapse_graph.bricks() if self.collapse_graph else None,
            "final_graph": self.final_graph.bricks(),
        }


def _round(x: float, digits: int) -> float:
    return round(float(x), digits) + 0.0  # + 0.0 turns -0.0 into 0.0


def _mm(v: Any) -> Vec3:
    x, y, z = (_round(c * 1000, 1) for c in v)
    return x, y, z


def canonical_quaternion(quaternion: Any) -> Vec4:
    """A unit quaternion (x, y, z, w) rounded to 3 decimals (about 0.1 deg), in canonical sign: w > 0, or when w
    rounds to 0 the first nonzero part > 0 (q and -q are the same turn; scipy's
    ``as_quat(canonical=True)``, applied after rounding so that rounding cannot flip it).

    >>> canonical_quaternion([0.0, 0.0, -1.0, -1e-9]), canonical_quaternion([0, 0, 0.70710678, -0.70710678])
    ((0.0, 0.0, 1.0, 0.0), (0.0, 0.0, -0.707, 0.707))
    """
    (parts,) = canonical_quaternions([quaternion])
    return parts


def canonical_quaternions(quaternions: Sequence[Any]) -> list[Vec4]:
    """:func:`canonical_quaternion` of each of ``quaternions`` (shape (n, 4), x y z w), by one
    call of scipy's ``Rotation`` for all of them (a brick graph's nodes).

    >>> canonical_quaternions([[0.0, 0.0, -1.0, -1e-9], [0, 0, 0.70710678, -0.70710678]])
    [(0.0, 0.0, 1.0, 0.0), (0.0, 0.0, -0.707, 0.707)]
    """
    if len(quaternions) == 0:
        return []
    out: list[Vec4] = []
    for q in Rotation.from_quat(np.asarray(quaternions, dtype=float).reshape(-1, 4)).as_quat(canonical=True):
        x, y, z, w = (_round(c, 3) for c in q)
        parts = (x, y, z, w)
        first = next((c for c in (w, x, y, z) if c != 0.0), 1.0)
        if first < 0:
            parts = (-x + 0.0, -y + 0.0, -z + 0.0, -w + 0.0)
        out.append(parts)
    return out


def euler_degrees(quaternion: Any) -> Vec3:
    """Yaw, pitch, roll in degrees (intrinsic z-y-x) of a quaternion (x, y, z, w), without
    scipy's gimbal-lock warning. On end (pitch within 0.2 deg of +-90, a domino: two quaternion
    decimals' worth, as a graph node keeps three) only yaw - roll
    (at +90) or yaw + roll (at -90) is defined, and an engine's reading splits it at random: it
    is given as the yaw, with roll 0 (stackdsl's own convention).

    >>> [round(a, 6) + 0.0 for a in euler_degrees([0.0, 0.70710678, 0.0, 0.70710678])]
    [0.0, 90.0, 0.0]
    """
    with warnings.catch_warnings():
        warnings.filterwarnings("ignore", message="Gimbal lock detected")
        yaw, pitch, roll = (
            float(c) for c in Rotation.from_quat(np.asarray(quaternion, dtype=float)).as_euler("ZYX", degrees=True)
        )
    if abs(pitch) > 89.8:
        yaw, roll = math.remainder(yaw - roll if pitch > 0 else yaw + roll, 360.0), 0.0
    return yaw, pitch, roll


def _degrees(angles: Any) -> Vec3:
    yaw, pitch, roll = (_deg(a) for a in angles)
    return yaw, pitch, roll


def _deg(a: float) -> float:
    a = _round(a, 1)
    return 180.0 if a == -180.0 else a
