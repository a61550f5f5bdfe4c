"""Rigid-block equilibrium as a linear program (Livesley 1978; Whiting, Ochsendorf & Durand 2009).

A set of rigid blocks stands when contact forces exist that balance every block's
weight: at each vertex of each contact polygon a compressive normal force (>= 0) and a
friction force inside the Coulomb cone, and for every free block the six equations of
static equilibrium (force, and torque about its centre of mass). Bodies that are not
free blocks (the ground, fixed bodies, bricks held fixed) are supports: they take any
force.

The Coulomb cone |f_t| <= mu f_n is replaced by an *inscribed* pyramid: the force at a
vertex is a non-negative combination of the pyramid's ``sides`` edges, n + mu t_k for
unit tangents t_k (the same set as a normal force f_n with friction weights on the t_k
summing to at most mu f_n, without that inequality's row: the program is the equilibrium
rows alone, and HiGHS solves the programs of the benchmark's fallen heaps of 33 to 49
bricks 2 to 2.5 times as fast, with the same tensions and collapse mechanisms).
Inscribed means every force the pyramid allows the true cone allows too, so the
linearisation can only call a block unstable that is (barely) stable, never the
reverse; a program the eight-sided pyramid fails by a small tension is solved again with
32 sides, which lose at most 0.5% of mu, from the eight-sided program's optimum (its edges are
every fourth of the 32: column generation adds only the edges that lower the tension). The
first tangent points downhill along the contact (or along x when the contact is horizontal),
so for planar problems in the x-z plane, the slope, the ladder and the V, the pyramid is
exact in the direction that matters.

When every contact is (nearly) level, a ten-times smaller program of vertical forces
alone is tried first: if it balances the blocks, they stand (friction takes the rest);
otherwise the full program decides. Each vertex may also carry a tension (a negative
normal force), which the program minimises: the minimum total tension is 0 exactly when the blocks stand, and otherwise
measures how far from standing they are (Whiting et al.'s infeasibility measure).
Solved with HiGHS (:mod:`stability._lp`). Sources: Livesley, "Limit
analysis of structures formed from rigid blocks" (1978); Whiting, Ochsendorf, Durand,
"Procedural modeling of structurally-sound masonry buildings" (2009).
"""

from __future__ import annotations

import math
from collections.abc import Callable, Collection, Hashable, Mapping, Sequence
from dataclasses import dataclass, field, replace
from typing import Generic, TypeVar

import numpy as np
from scipy import sparse
from scipy.sparse.csgraph import connected_components

from ._lp import OPTIMAL, WarmStart, solve, solve_by_columns

GRAVITY = 9.81

VERTICAL_PIVOTS = 3.0
"""Simplex iterations a row the vertical-force program may take before the full program
decides instead (a balanced stack of the benchmark's slant log cabins took at most 1.35 a row)."""

BodyKey = TypeVar("BodyKey", bound=Hashable)  # how the caller names bodies (pybullet ids, labels)


@dataclass(frozen=True)
class RigidBlock:
    """A free rigid block: mass in kg, centre of mass shape (3,) in metres.

    Raises:
        ValueError: a mass that is not a finite positive number of kilograms (a negative
            one would be held up by gravity), or a centre of mass that is not 3 finite
            coordinates.
    """

    mass: float
    com: np.ndarray

    def __post_init__(self) -> None:
        if not 0.0 < self.mass < math.inf:
            raise ValueError(f"RigidBlock.mass must be a finite positive number of kg, not {self.mass!r}")
        com = self.com  # checked in plain floats: numpy's checks cost ten times as much
        x, y, z = np.asarray(com, dtype=float).tolist() if np.shape(com) == (3,) else (math.nan,) * 3
        if not math.isfinite(x + y + z):
            raise ValueError(f"RigidBlock.com must be 3 finite coordinates in metres, not {self.com!r}")


@dataclass(frozen=True)
class ContactPolygon(Generic[BodyKey]):
    """A contact polygon between ``body`` and ``other``.

    Attributes:
        body: the body the normal points into; it receives the forces reported.
        other: the other body (a free block or a support).
        points: shape (k, 3), metres, the polygon's vertices (1 <= k).
        normal: shape (3,), unit, from ``other`` into ``body``.
        friction: Coulomb coefficient of the pair, finite and >= 0 (0: frictionless).
        core: shape (j, 3), metres, the contact points themselves when ``points`` pads them
            across the normal for want of area (report 3.4.2), else None.

    Raises:
        ValueError: a negative or not finite ``friction`` (a negative one would turn the
            friction pyramid inside out and hold a block on a slope that no friction holds).
    """

    body: BodyKey
    other: BodyKey
    points: np.ndarray
    normal: np.ndarray
    friction: float
    core: np.ndarray | None = None

    def __post_init__(self) -> None:
        if not 0.0 <= self.friction < math.inf:
            raise ValueError(f"ContactPolygon.friction must be a finite friction coefficient >= 0, not {self.friction!r}")


FINE_SIDES = 32
"""Sides of the pyramid a program is solved again with when the eight-sided one fails it by
little (:data:`NEAR_TENSION`): inscribed in the cone, it loses at most 0.5% of mu where eight
sides lose 7.6%. A ladder whose foot needs its friction between two of the eight edges
stands on the cone and on this pyramid, and would otherwise be called fallen."""

NEAR_TENSION = 0.25
"""Fraction of the blocks' weight below which a failed program's tension may be the
pyramid's and not the blocks' (:data:`FINE_SIDES`); a real collapse mechanism needs more."""

LEVEL_TILT = 1e-3
"""Sine of the tilt below which a contact counts as horizontal when the pyramid's first edge
is chosen (:func:`_tangents`): an engine's normal is off the face's by 1e-5 or so, and its
"downhill" then points anywhere."""

MOVES = 1e-4
"""Relative virtual velocity above which a block moves in a collapse mechanism (below it:
the program's round-off)."""


@dataclass(frozen=True)
class Equilibrium(Generic[BodyKey]):
    """The answer of :func:`solve_equilibrium`.

    Attributes:
        stands: True when forces exist that balance every free block.
        tension: newtons, the least total tension the contacts would have to carry for
            the blocks to stand (0 when they stand; ``inf`` when not even glue would do).
        forces: per contact, shape (k, 3): the force on ``body`` at each vertex, newtons
            (one solution of many; empty when no solution exists).
        tension_by_body: free block -> newtons of tension at its contacts (both sides).
        contact_tension: per contact, newtons of tension it carries (empty when no
            solution exists).
        mechanism: when the blocks do not stand, free block -> magnitude (0..1, relative
            to the largest) of its virtual velocity in the collapse mechanism: the dual
            solution of the program (Livesley 1978). The blocks with a non-zero value are
            the ones that must move; the others can stay. Empty when they stand.
    """

    stands: bool
    tension: float
    forces: tuple[np.ndarray, ...]
    tension_by_body: dict[BodyKey, float]
    contact_tension: tuple[float, ...] = ()
    mechanism: dict[BodyKey, float] = field(default_factory=dict)

    def moving(self) -> set[BodyKey]:
        """The blocks that move in the collapse mechanism, however little: every block whose
        virtual velocity is above :data:`MOVES` of the largest. A tower that topples about
        its base's edge moves its lowest brick least (a quarter of the top's, say); it must
        move all the same. Empty when the blocks stand. Source: stackdsl's own."""
        return {b for b, v in self.mechanism.items() if v > MOVES}


def solve_equilibrium(
    blocks: Mapping[BodyKey, RigidBlock],
    contacts: Sequence[ContactPolygon[BodyKey]],
    *,
    sides: int = 8,
    gravity: float = GRAVITY,
    quick: bool = True,
    sideways: tuple[float, float] = (0.0, 0.0),
    decide: bool = False,
) -> Equilibrium[BodyKey]:
    """Do forces exist that hold every free block in ``blocks`` still?

    Args:
        blocks: free blocks by key; every other key named by a contact is a support.
        contacts: the contact polygons.
        sides: sides of the friction pyramid (>= 3); a program it fails by a tension under
            :data:`NEAR_TENSION` of the weight is solved again with :data:`FINE_SIDES`.
        gravity: m/s^2, acting along -z.
        quick: try the vertical-force program first when every contact is level.
        sideways: m/s^2, (x, y): a horizontal part of gravity (d'Alembert's inertial force of
            a frame accelerating by minus it: blocks on a shaken ground); (0, 0) by default.
        decide: only whether they stand, and a collapse mechanism, are wanted. A program the
            pyramid fails by little is then asked first with the pyramid around the friction
            cone (each friction coefficient over cos(pi / sides)); when even that one fails,
            so does the cone, and every pyramid inscribed in it: the program's dual (its
            mechanism) is a certificate for them too, and the :data:`FINE_SIDES` program, four
            times the unknowns, is not solved. The tension returned is then a lower bound of
            the cone's. (An 18-level Jenga tower's fallen piles failed the fine program 5
            times of 5, 150 to 300 ms each.)

    Returns:
        :class:`Equilibrium`.

    Raises:
        ValueError: a contact has no point, or ``sides`` < 3. (A negative friction
            coefficient or mass is refused where the contact or the block is made:
            :class:`ContactPolygon`, :class:`RigidBlock`.)

    >>> import numpy as np
    >>> ground = ContactPolygon("brick", "ground", np.array([[-0.06, -0.012, 0], [0.06, -0.012, 0],
    ...     [0.06, 0.012, 0], [-0.06, 0.012, 0]]), np.array([0, 0, 1.0]), 0.5)
    >>> solve_equilibrium({"brick": RigidBlock(0.0106, np.array([0, 0, 0.004]))}, [ground]).stands
    True
    """
    if sides < 3:
        raise ValueError(f"sides: the friction pyramid needs at least 3 sides, not {sides!r}")
    upright = sideways == (0.0, 0.0)
    if quick and upright and contacts and all(is_level(c, sides) for c in contacts):
        vertical = _solve_vertical(blocks, contacts, gravity)
        if vertical is not None:
            return vertical
    coarse = WarmStart()  # the basis this program ends on: where the wider and finer pyramids start
    found = _solve(blocks, contacts, sides, gravity, sideways, warm=coarse)
    total = sum(b.mass for b in blocks.values()) * gravity
    if not found.stands and sides < FINE_SIDES and found.tension < NEAR_TENSION * total:  # the pyramid's, or the blocks'?
        if decide:
            widened = 1.0 / math.cos(math.pi / sides)  # the pyramid's inner radius then is the friction coefficient
            wider = [replace(c, friction=c.friction * widened) for c in contacts]
            around = _solve(blocks, wider, sides, gravity, sideways, warm=coarse.copy(), primal=True)
            if not around.stands:
                return around
        return _solve(blocks, contacts, FINE_SIDES, gravity, sideways, start=(sides, coarse) if FINE_SIDES % sides == 0 else None)
    return found


def _solve(
    blocks: Mapping[BodyKey, RigidBlock],
    contacts: Sequence[ContactPolygon[BodyKey]],
    sides: int,
    gravity: float,
    sideways: tuple[float, float] = (0.0, 0.0),
    warm: WarmStart | None = None,
    primal: bool = False,
    start: tuple[int, WarmStart] | None = None,
) -> Equilibrium[BodyKey]:
    """The program of :func:`solve_equilibrium` with a pyramid of ``sides`` sides, once (never
    solved again with :data:`FINE_SIDES`), from ``warm``'s basis (:class:`stability.WarmStart`:
    whether the blocks stand, and the least tension, do not depend on it), by the primal
    simplex with ``primal``.

    With ``start`` (``coarse`` sides dividing ``sides``, and the basis the program of that
    pyramid ended on), the program is solved by columns (:func:`stability._lp.solve_by_columns`)
    from the coarse pyramid's unknowns: its edges are every ``sides // coarse``-th edge of this
    one (:func:`_tangents`), so its optimum is a feasible start, and only the edges that lower
    the tension are added. The optimum is the same; where the program has many, the forces and
    the mechanism found may be another of them."""
    keys = list(blocks)
    if not contacts:  # nothing holds them: every block falls (none at all: they stand)
        return Equilibrium(
            not keys, float("inf") if keys else 0.0, (), dict.fromkeys(keys, float("inf")), (), dict.fromkeys(keys, 1.0)
        )
    index = {k: i for i, k in enumerate(keys)}
    weight = max((b.mass for b in blocks.values()), default=1.0) * gravity or 1.0
    per_point = 1 + sides  # tension, the pyramid's edges
    points, owner = _vertices(contacts)
    along = None if sideways == (0.0, 0.0) else np.array([sideways[0], sideways[1], 0.0])
    generators = _generators(contacts, blocks, sides, points, owner, along)
    a_eq = _balance(contacts, blocks, index, generators, points, owner)
    n = len(owner)
    cost = np.zeros(n * per_point)
    cost[::per_point] = 1.0  # the tension of every point
    rhs = np.zeros(6 * len(keys))
    for key, block in blocks.items():  # the contact forces bear the block's weight, and its inertia
        rhs[6 * index[key] : 6 * index[key] + 3] = (
            -block.mass * sideways[0] / weight,
            -block.mass * sideways[1] / weight,
            block.mass * gravity / weight,
        )
    if start is None:
        result = solve(cost, a_eq, rhs, warm=warm, primal=primal)
    else:
        coarse, basis = start
        edges = np.concatenate([[0], 1 + (sides // coarse) * np.arange(coarse)])  # the tension, the coarse edges
        result = solve_by_columns(cost, a_eq, rhs, (np.arange(n)[:, None] * per_point + edges).ravel(), basis)
    if result.status != OPTIMAL:
        return Equilibrium(False, float("inf"), (), {k: float("inf") for k in keys}, (), {k: 1.0 for k in keys})
    tension = float(result.fun) * weight
    total = sum(b.mass for b in blocks.values()) * gravity
    forces, by_body, by_contact = _forces(result.x.reshape(n, per_point) * weight, contacts, generators, owner, keys)
    stands = tension <= 1e-7 * max(total, 1e-12)
    mechanism = {} if stands else _mechanism(result.eq_duals, keys)
    return Equilibrium(stands, tension, forces, by_body, by_contact, mechanism)


def bare_contacts(contacts: Sequence[ContactPolygon[BodyKey]]) -> list[ContactPolygon[BodyKey]]:
    """``contacts`` with each padded polygon replaced by its own contact points (its
    :attr:`ContactPolygon.core`): a line or a point takes no moment about itself, which the
    padding for the report's centre-of-mass test (3.4.2) would. Source: stackdsl's own."""
    return [replace(c, points=c.core) if c.core is not None else c for c in contacts]


def connected_part(
    blocks: Mapping[BodyKey, RigidBlock], contacts: Sequence[ContactPolygon[BodyKey]], around: Collection[BodyKey]
) -> tuple[dict[BodyKey, RigidBlock], list[ContactPolygon[BodyKey]]]:
    """The part of a rigid-block problem that ``around`` belongs to: the free blocks joined to
    one of ``around`` through contacts between free blocks, and every contact of theirs (with
    supports too).

    Blocks of different parts exchange no force (a support takes any force, so it joins
    nothing): the program is block-diagonal, part by part, the whole stands exactly when
    every part does, and a part's collapse mechanism moves only its own blocks. A stack test
    that asks about some bricks solves only their part: a fallen domino row of 105 bricks
    was 83 parts, the largest of 22. Keys of ``around`` that are not free blocks are ignored.
    Source: stackdsl's own (the block structure of Livesley's 1978 equilibrium matrix).

    >>> import numpy as np
    >>> up = np.array([0, 0, 1.0])
    >>> def on(a, b):
    ...     return ContactPolygon(a, b, np.zeros((1, 3)), up, 0.5)
    >>> blocks = {k: RigidBlock(0.01, np.zeros(3)) for k in "abc"}
    >>> part, touching = connected_part(blocks, [on("a", "ground"), on("b", "a"), on("c", "ground")], {"b"})
    >>> sorted(part), len(touching)
    (['a', 'b'], 2)
    """
    keys = list(blocks)
    index = {k: i for i, k in enumerate(keys)}
    joined = [(index[c.body], index[c.other]) for c in contacts if c.body in index and c.other in index]
    rows, cols = (np.array(x, dtype=int) for x in zip(*joined, strict=True)) if joined else (np.zeros(0, int),) * 2
    graph = sparse.coo_matrix((np.ones(len(rows)), (rows, cols)), shape=(len(keys), len(keys)))
    _, label = connected_components(graph, directed=False)
    wanted = {label[index[k]] for k in around if k in index}
    part = {k: b for k, b in blocks.items() if label[index[k]] in wanted}
    return part, [c for c in contacts if c.body in part or c.other in part]


def _generators(
    contacts: Sequence[ContactPolygon[BodyKey]],
    blocks: Mapping[BodyKey, RigidBlock],
    sides: int,
    points: np.ndarray,
    owner: np.ndarray,
    along: np.ndarray | None = None,
) -> np.ndarray:
    """Per contact the force directions of each of its vertices, shape (C, 1 + sides, 3):
    the opposite of the unit normal (a tension) and the friction pyramid's edges, normal +
    mu x tangent; ``points`` and ``owner`` are the contacts' vertices as :func:`_vertices`
    gives them. With ``along`` (shape (3,): a horizontal part of gravity), a level contact's
    first edge lies along it (:func:`_tangents`): an even pyramid then reaches the cone fully
    both ways along a shake, where a sliding part needs its friction. All contacts at once, the
    same numbers to the last bit as one contact at a time (each norm and dot product a row's
    own, each polygon's centre its own mean): 5 times as fast for the 124 contacts of a fallen
    log cabin."""
    if not contacts:
        return np.zeros((0, 1 + sides, 3))
    normals = np.array([np.asarray(c.normal, dtype=float).reshape(3) for c in contacts])
    normals /= _norms(normals)[:, None]
    friction = np.array([c.friction for c in contacts], dtype=float)
    edges = normals[:, None, :] + friction[:, None, None] * _tangents(
        normals, sides, _towards(contacts, blocks, points, owner, along)
    )
    return np.concatenate([-normals[:, None, :], edges], axis=1)


def _towards(
    contacts: Sequence[ContactPolygon[BodyKey]],
    blocks: Mapping[BodyKey, RigidBlock],
    points: np.ndarray,
    owner: np.ndarray,
    along: np.ndarray | None,
) -> Callable[[np.ndarray], np.ndarray]:
    """What :func:`_tangents` asks of the contacts it finds level (indices): for each, ``along``,
    or from the contact's centre toward the centre of mass of the block it holds (``body``, or
    ``other`` when only that one is free), shape (k, 3); a row of NaN for a contact between two
    supports."""

    def toward(level: np.ndarray) -> np.ndarray:
        if along is not None:
            return np.tile(np.asarray(along, dtype=float), (len(level), 1))
        starts = np.searchsorted(owner, level)
        ends = np.searchsorted(owner, level, side="right")
        out = np.full((len(level), 3), np.nan)
        for row, (i, a, b) in enumerate(zip(level.tolist(), starts.tolist(), ends.tolist(), strict=True)):
            held = next((blocks[k] for k in (contacts[i].body, contacts[i].other) if k in blocks), None)
            if held is not None:
                out[row] = np.asarray(held.com, dtype=float) - points[a:b].mean(axis=0)
        return out

    return toward


def _norms(rows: np.ndarray) -> np.ndarray:
    """Each row's Euclidean norm, shape (n,), as ``np.linalg.norm`` gives a row's (the root of
    its dot product with itself, to the last bit)."""
    norms: np.ndarray = np.sqrt(np.array([row.dot(row) for row in rows]))
    return norms


def _dots(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Each pair of rows' dot product, shape (n,), as ``@`` gives a pair's."""
    return np.array([x.dot(y) for x, y in zip(a, b, strict=True)])


def _balance(
    contacts: Sequence[ContactPolygon[BodyKey]],
    blocks: Mapping[BodyKey, RigidBlock],
    index: Mapping[BodyKey, int],
    generators: np.ndarray,
    points: np.ndarray,
    owner: np.ndarray,
) -> sparse.csr_matrix:
    """The equilibrium rows of the full program, shape (6 blocks, P (1 + sides)): for each
    free block its force and its torque about its centre of mass (lever arms in units of
    10 cm, which keep the rows comparable), from the generators of every vertex it touches
    (``points``, ``owner``: :func:`_vertices`); one column per vertex and generator."""
    scale = 0.1
    per_point = generators.shape[1]
    cols = np.arange(len(owner) * per_point).reshape(len(owner), per_point)
    rows_out, cols_out, vals_out = [], [], []
    for side, block, com in _ends(contacts, blocks, index, owner):
        free = block >= 0
        if not free.any():
            continue
        force = side * generators[owner[free]]  # (F, G, 3)
        lever = (points[free] - com[free]) / scale
        torque = np.cross(lever[:, None, :], force)  # (F, G, 3)
        base = 6 * block[free][:, None, None] + np.arange(3)
        for rows, values in ((base, force), (base + 3, torque)):
            keep = values != 0.0
            rows_out.append(np.broadcast_to(rows, values.shape)[keep])
            cols_out.append(np.broadcast_to(cols[free][:, :, None], values.shape)[keep])
            vals_out.append(values[keep])
    shape = (6 * len(index), len(owner) * per_point)
    return sparse.csr_matrix((_cat(vals_out), (_cat(rows_out), _cat(cols_out))), shape=shape)


def _cat(parts: list[np.ndarray]) -> np.ndarray:
    """The parts end to end; an empty array when there are none."""
    return np.concatenate(parts) if parts else np.zeros(0)


def is_level(contact: ContactPolygon[BodyKey], sides: int = 8) -> bool:
    """Is the contact so near horizontal that friction takes the sideways part of a vertical
    force on it: tan(tilt) <= mu cos(pi / sides), the reach of the inscribed friction
    pyramid, or the tilt under :data:`LEVEL_TILT` (an engine's noise on a level face: so even
    with no friction), and its normal pointing up into ``contact.body``? ``sides``: of the
    pyramid, >= 3. Source: stackdsl's own.

    Raises:
        ValueError: ``sides`` < 3.

    >>> import numpy as np
    >>> flat = ContactPolygon(1, 0, np.zeros((1, 3)), np.array([0, 0, 1.0]), 0.5)
    >>> steep = ContactPolygon(1, 0, np.zeros((1, 3)), np.array([0.5, 0, 0.866]), 0.5)
    >>> is_level(flat), is_level(steep)
    (True, False)
    """
    if sides < 3:
        raise ValueError(f"sides: the friction pyramid needs at least 3 sides, not {sides!r}")
    normal = np.asarray(contact.normal, dtype=float).ravel(order="K")
    # in floats (asked of every contact of every freeze): numpy's norm, the root of this dot
    up = float(normal[2])
    cos = abs(up) / math.sqrt(normal.dot(normal))
    tan = math.sqrt(max(1.0 - cos * cos, 0.0)) / max(cos, 1e-12)
    # a tilt under LEVEL_TILT is the engine's noise on a level face: level even without friction
    return up > 0 and tan <= max(contact.friction * math.cos(math.pi / sides), LEVEL_TILT)


def upward(contact: ContactPolygon[BodyKey]) -> ContactPolygon[BodyKey]:
    """``contact`` seen from the body above it: the same contact, its two bodies swapped and its
    normal turned, when the normal points down (a pile frozen together records each contact
    from either side). The program is the same (each force acts on both bodies, opposite);
    :func:`is_level` asks for a normal pointing up into ``body``. Source: stackdsl's own.

    >>> import numpy as np
    >>> down = ContactPolygon("base", "top", np.zeros((1, 3)), np.array([0, 0, -1.0]), 0.5)
    >>> flipped = upward(down)
    >>> flipped.body, flipped.other, float(flipped.normal[2]), is_level(down), is_level(flipped)
    ('top', 'base', 1.0, False, True)
    """
    normal = np.asarray(contact.normal, dtype=float)
    if normal[2] >= 0.0:
        return contact
    return ContactPolygon(contact.other, contact.body, contact.points, -normal, contact.friction, contact.core)


def balanced_vertically(
    blocks: Mapping[BodyKey, RigidBlock], contacts: Sequence[ContactPolygon[BodyKey]], gravity: float = GRAVITY
) -> bool | None:
    """Do vertical compressive forces alone hold every free block? None when there is no contact
    or one is not level (:func:`is_level`: the test does not apply). The fast sufficient test
    that :func:`solve_equilibrium` tries first, on its own: True proves that the blocks stand.
    False is no proof that they fall (friction couples across a block's height may hold what
    vertical forces do not), so a caller may act on it only where refusing is the safe side (a
    proof not given).

    Args:
        blocks, contacts, gravity: as :func:`solve_equilibrium`'s.

    Source: stackdsl's own.

    >>> import numpy as np
    >>> face = np.array([[-0.06, -0.012, 0], [0.06, -0.012, 0], [0.06, 0.012, 0], [-0.06, 0.012, 0]])
    >>> ground = ContactPolygon("brick", "ground", face, np.array([0, 0, 1.0]), 0.5)
    >>> balanced_vertically({"brick": RigidBlock(0.0106, np.array([0, 0, 0.004]))}, [ground])
    True
    >>> balanced_vertically({"brick": RigidBlock(0.0106, np.array([0.07, 0, 0.004]))}, [ground])
    False
    """
    if not contacts or not all(is_level(c) for c in contacts):
        return None
    return _solve_vertical(blocks, contacts, gravity) is not None


def balanced_tilted(
    blocks: Mapping[BodyKey, RigidBlock],
    contacts: Sequence[ContactPolygon[BodyKey]],
    run: tuple[float, float],
    gravity: float = GRAVITY,
    warm: WarmStart | None = None,
) -> bool:
    """Do compressive forces parallel to gravity tilted by ``run`` (its horizontal part per
    metre of its drop, (x, y)) hold every free block in ``blocks``? True proves that they stand
    under that gravity; False proves nothing (forces that are not parallel might hold them), so
    a caller may act on it only where refusing is the safe side.

    Only a contact whose friction cone holds such a force carries one (its normal within the
    pair's friction angle of the force: Coulomb's cone itself, not a pyramid inscribed in it);
    the others carry none. Forces all parallel to gravity balance a block when the points where
    they act, carried along that direction to a common level, balance its centre of mass
    carried so: the vertical program of :func:`balanced_vertically` on those points, a tenth of
    the full program's size (a Jenga tower's top of 36 bricks: 10 ms, where
    :func:`solve_equilibrium` with ``sideways`` takes 60 to 190 ms). Each block's sideways load
    is then carried by the sideways parts of the forces under it less those over it, in the
    proportion of the vertical ones: a uniform tilt asks each contact for ``|run|`` times its
    normal force, as the report's sliding test under a tilted gravity does
    (:mod:`stability._shake`). ``warm``: the program starts from the basis of the last one
    solved with it, when of the same shape (:class:`stability.WarmStart`: a search over
    tilts of the same blocks).

    Raises:
        ValueError: a contact without points.

    Source: rigid-block equilibrium (Livesley 1978; Whiting et al. 2009) with the forces
    restricted to gravity's direction; stackdsl's own.

    >>> import numpy as np
    >>> face = np.array([[-0.06, -0.012, 0], [0.06, -0.012, 0], [0.06, 0.012, 0], [-0.06, 0.012, 0]])
    >>> ground = ContactPolygon("post", "ground", face / [15, 1, 1], np.array([0, 0, 1.0]), 0.5)
    >>> post = {"post": RigidBlock(0.01, np.array([0.0, 0.0, 0.06]))}  # 8 x 24 mm on end, its centre 60 mm up
    >>> [balanced_tilted(post, [ground], run) for run in ((0.06, 0.0), (0.07, 0.0), (0.0, 0.19), (0.0, 0.21))]
    [True, False, True, False]
    >>> balanced_tilted({"brick": RigidBlock(0.01, np.array([0.0, 0.0, 0.004]))}, [ground], (0.51, 0.0))
    False
    """
    sx, sy = (float(v) for v in run)
    along = np.array([-sx, -sy, 1.0]) / math.sqrt(1.0 + sx * sx + sy * sy)  # the force on the block above
    usable = []
    for contact in contacts:
        normal = np.asarray(contact.normal, dtype=float)
        cos = float(along @ normal) / float(np.linalg.norm(normal))
        if cos > 0.0 and math.sqrt(max(1.0 - cos * cos, 0.0)) <= contact.friction * cos:
            points = np.asarray(contact.points, dtype=float).reshape(-1, 3)
            usable.append(replace(contact, points=points + points[:, 2:3] * np.array([sx, sy, 0.0])))
    if not usable:
        return not blocks
    carried = {
        k: RigidBlock(b.mass, np.asarray(b.com, dtype=float) + float(b.com[2]) * np.array([sx, sy, 0.0]))
        for k, b in blocks.items()
    }
    return _solve_vertical(carried, usable, gravity, warm) is not None


def _solve_vertical(
    blocks: Mapping[BodyKey, RigidBlock],
    contacts: Sequence[ContactPolygon[BodyKey]],
    gravity: float,
    warm: WarmStart | None = None,
) -> Equilibrium[BodyKey] | None:
    """Balance by vertical compressive forces alone: a fast sufficient test.

    For contacts that are all (nearly) level, a balance of vertical forces extends to a
    full one (friction takes each tilted normal's sideways part, :func:`is_level`), so when
    this program has one the blocks stand. When it has none, friction couples might still
    help: None, and the full program decides. Three equations per block (vertical force,
    torques about x and y), one force per vertex: a tenth of the full program's size.
    It gets :data:`VERTICAL_PIVOTS` simplex iterations a row, and None beyond them:
    HiGHS's dual simplex can stall on an infeasible program built from engine poses (702
    iterations and 0.55 s, ending in numerical difficulties, for the 51 bricks of a slant
    log cabin at its collapse), where the full program decides in a quarter of that.
    ``warm``: :class:`stability.WarmStart`.
    """
    keys = list(blocks)
    index = {k: i for i, k in enumerate(keys)}
    weight = max((b.mass for b in blocks.values()), default=1.0) * gravity or 1.0
    points, owner = _vertices(contacts)
    rows: list[np.ndarray] = []
    cols: list[np.ndarray] = []
    vals: list[np.ndarray] = []
    for side, block, com in _ends(contacts, blocks, index, owner):
        free = np.flatnonzero(block >= 0)
        lever = (points[free] - com[free]) / 0.1
        rows += [3 * block[free], 3 * block[free] + 1, 3 * block[free] + 2]
        cols += [free] * 3
        vals += [np.full(len(free), side), side * lever[:, 1], -side * lever[:, 0]]  # Fz, Mx = y Fz, My = -x Fz
    rhs = np.zeros(3 * len(keys))
    for key, b in blocks.items():
        rhs[3 * index[key]] = b.mass * gravity / weight
    a_eq = sparse.csr_matrix((_cat(vals), (_cat(rows), _cat(cols))), shape=(3 * len(keys), len(owner)))
    budget = max(1, round(VERTICAL_PIVOTS * a_eq.shape[0]))
    result = solve(np.zeros(len(owner)), a_eq, rhs, iteration_limit=budget, warm=warm)
    if result.status != OPTIMAL:  # no balance, or none found within the budget
        return None
    vertical = np.zeros((len(owner), 3))
    vertical[:, 2] = result.x * weight
    forces = tuple(np.split(vertical, np.cumsum(np.bincount(owner, minlength=len(contacts)))[:-1])) if contacts else ()
    return Equilibrium(True, 0.0, forces, {k: 0.0 for k in keys}, tuple(0.0 for _ in contacts), {})


def _vertices(contacts: Sequence[ContactPolygon[BodyKey]]) -> tuple[np.ndarray, np.ndarray]:
    """Every contact's vertices end to end, shape (P, 3) in metres, and the index of each
    one's contact, shape (P,). Raises ValueError for a contact without points."""
    polygons = [np.asarray(c.points, dtype=float).reshape(-1, 3) for c in contacts]
    if any(len(p) == 0 for p in polygons):
        raise ValueError("a contact needs at least one point")
    if not polygons:
        return np.zeros((0, 3)), np.zeros(0, dtype=int)
    return np.vstack(polygons), np.repeat(np.arange(len(polygons)), [len(p) for p in polygons])


def _ends(
    contacts: Sequence[ContactPolygon[BodyKey]],
    blocks: Mapping[BodyKey, RigidBlock],
    index: Mapping[BodyKey, int],
    owner: np.ndarray,
) -> list[tuple[float, np.ndarray, np.ndarray]]:
    """For each end of the contacts (``body``, sign +1; ``other``, sign -1), per vertex the
    free block it belongs to (its index, -1 for a support, shape (P,)) and that block's centre
    of mass (shape (P, 3), metres; zeros for a support)."""
    out = []
    for side, ends in ((1.0, [c.body for c in contacts]), (-1.0, [c.other for c in contacts])):
        block = np.array([index.get(k, -1) for k in ends], dtype=int)
        com = np.array([np.asarray(blocks[k].com, dtype=float) if k in index else np.zeros(3) for k in ends]).reshape(-1, 3)
        out.append((side, block[owner], com[owner]))
    return out


def _mechanism(duals: np.ndarray, keys: list[BodyKey]) -> dict[BodyKey, float]:
    """Relative virtual-velocity magnitude of every block from the equilibrium rows' duals."""
    magnitude = np.linalg.norm(np.asarray(duals).reshape(-1, 6), axis=1)
    top = magnitude.max()
    return {k: float(m / top) if top > 0 else 1.0 for k, m in zip(keys, magnitude)}


def _tangents(normals: np.ndarray, sides: int, towards: Callable[[np.ndarray], np.ndarray]) -> np.ndarray:
    """``sides`` unit tangents for each of ``normals`` (shape (C, 3), unit), shape (C, sides,
    3), the first downhill; for a horizontal contact (tilted by less than :data:`LEVEL_TILT`),
    along ``towards`` of it (:func:`_towards`: from the contact to the held block's centre of
    mass, where the foot of a leaning brick needs its friction, or a shake's direction) or,
    without one, along x. An inscribed pyramid reaches the cone fully only along its
    generators: a ladder's foot at 22.5 deg between two lost up to 8% of mu."""
    first = np.array([0.0, 0.0, -1.0]) + normals[:, 2:3] * normals  # down, less its part along the normal
    level = np.flatnonzero(_norms(first) < LEVEL_TILT)
    if len(level):
        toward = towards(level)
        known = ~np.isnan(toward[:, 0])
        rows, toward, normal = level[known], toward[known], normals[level[known]]
        first[rows] = toward - _dots(toward, normal)[:, None] * normal
    flat = np.flatnonzero(_norms(first) < 1e-6)
    if len(flat):
        normal = normals[flat]
        axis = np.where((np.abs(normal[:, 0]) < 0.9)[:, None], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0])
        first[flat] = axis - _dots(axis, normal)[:, None] * normal
    first /= _norms(first)[:, None]
    second = np.cross(normals, first)
    angles = 2 * np.pi * np.arange(sides) / sides
    tangents: np.ndarray = np.cos(angles)[None, :, None] * first[:, None, :] + np.sin(angles)[None, :, None] * second[:, None, :]
    return tangents


def _forces(
    x: np.ndarray,
    contacts: Sequence[ContactPolygon[BodyKey]],
    generators: np.ndarray,
    owner: np.ndarray,
    keys: list[BodyKey],
) -> tuple[tuple[np.ndarray, ...], dict[BodyKey, float], tuple[float, ...]]:
    """Per contact the force at each vertex (shape (k, 3), newtons) from the program's
    solution ``x`` (shape (P, 1 + sides), newtons: the tension and the weights of the
    pyramid's edges at each vertex), the tension by free block and the tension by contact."""
    vertex = np.einsum("pg,pgd->pd", x, generators[owner])
    ends = np.cumsum(np.bincount(owner, minlength=len(contacts)))[:-1]
    forces = tuple(np.split(vertex, ends)) if len(contacts) else ()
    by_contact = tuple(float(t) for t in np.bincount(owner, weights=x[:, 0], minlength=len(contacts)))
    by_body: dict[BodyKey, float] = {k: 0.0 for k in keys}
    for contact, pulled in zip(contacts, by_contact):
        for key in (contact.body, contact.other):
            if key in by_body:
                by_body[key] += pulled
    return forces, by_body, by_contact
