"""Random assemblies of KAPLA bricks, and what rigid-block equilibrium says of them.

:func:`assembly` draws one small structure from a ``numpy.random.Generator``: 2 to 4 levels
and 3 to 12 bricks, level 1 on the ground, each higher brick resting on one brick
of the level below or bridging two, parallel to its support or crossed over it, with its
centre of mass a signed *margin* from the edge of its support (log-uniform from 0.1 to
20 mm; inside for most bricks, outside for some, which tip). In :data:`LEANING` of the
assemblies the last brick (and level) leans on a fixed wall beside the others, its top edge
against the wall, at 20 to 70 degrees from the ground (friction holds it above an angle near 37
degrees, a ladder's). Its foot is on the ground, or in :data:`STEP` of them on a *step*: a flat
brick lying across its foot on the ground, placed just before it, which its push can slide (the
oracle takes a tilted brick's corners on flat faces). A draw that the language refuses (bricks
that overlap, or rest on nothing) is drawn again.

:func:`judge` gives the oracle's verdict on it (:func:`stackdsl.verdicts.oracle.equilibrium_collapse`,
the bricks placed one by one in order) and its margin: how far the centre of mass of every
brick can move, together, in any of eight horizontal directions, before the verdict of some
placement step flips (found to :data:`RESOLUTION` by bisection up to :data:`MAX_MARGIN`), and,
when a brick falls, no more than its clearance to a body that could catch it
(:func:`catch_clearance`).

Source: stackdsl's own.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from shapely.affinity import rotate, translate
from shapely.geometry import MultiPoint, Polygon, box

from stability import Box, Pose, RigidBlock, friction_share, is_level, solve_equilibrium

from ..compile.program import Fixture, Place, Program
from .oracle import equilibrium_collapse, structure

LENGTH, WIDTH, HEIGHT = 0.120, 0.024, 0.008
#: Metres: margins are found to this resolution, up to this distance.
RESOLUTION = 0.0001
MAX_MARGIN = 0.020
_DIRECTIONS = [np.array([math.cos(a), math.sin(a), 0.0]) for a in np.arange(8) * math.pi / 4]
_SCALE = [RESOLUTION * 2**k for k in range(8)] + [MAX_MARGIN]  # 0.1 mm doubling to 12.8 mm, then 20 mm
#: The share of assemblies with a brick leaning on a wall (half of them, so that agreement can
#: be reported for each kind with about as many assemblies), and the share of those whose
#: leaning brick stands on a step brick rather than on the ground.
LEANING = 0.5
STEP = 0.5
WALL = (0.020, 0.200, 0.200)  # m: the fixed wall's thickness, width and height
_WALL_GAP = 0.00005  # m between the leaning brick's top edge and the wall (the oracle's contacts take 0.1 mm)


@dataclass(frozen=True)
class Brick:
    """A brick of an assembly: centre (x, y) in metres, level (1: on the ground), yaw in degrees."""

    x: float
    y: float
    level: int
    yaw: float

    @property
    def footprint(self) -> Polygon:
        return translate(rotate(box(-LENGTH / 2, -WIDTH / 2, LENGTH / 2, WIDTH / 2), self.yaw), self.x, self.y)

    def axis(self) -> np.ndarray:
        """Unit vector along its length."""
        a = math.radians(self.yaw)
        return np.array([math.cos(a), math.sin(a)])


@dataclass(frozen=True)
class Leaner:
    """A brick leaning on a fixed wall. (x, y): metres, the foot of the wall's face; yaw:
    degrees, the direction from the brick to the wall; angle: degrees from the ground; step:
    metres along the brick (positive: toward the wall) and across it from its foot's middle to
    the centre of the step brick under its foot, or None: the foot is on the ground."""

    x: float
    y: float
    yaw: float
    angle: float
    step: tuple[float, float] | None = None

    def _place(self, local: tuple[float, float, float]) -> tuple[float, float, float]:
        a = math.radians(self.yaw)
        u, v, z = local
        return (self.x + u * math.cos(a) - v * math.sin(a), self.y + u * math.sin(a) + v * math.cos(a), z)

    def centre(self) -> tuple[float, float, float]:
        """The brick's centre, metres: its near bottom edge on the ground, its far one at the wall."""
        t = math.radians(self.angle)
        reach = LENGTH / 2 * math.cos(t) + HEIGHT / 2 * math.sin(t)
        lift = 0.0 if self.step is None else HEIGHT
        return self._place((-reach - _WALL_GAP, 0.0, lift + LENGTH / 2 * math.sin(t) + HEIGHT / 2 * math.cos(t)))

    def step_brick(self) -> Brick | None:
        """The flat brick under the foot (level 1, lying across the leaning brick), or None."""
        if self.step is None:
            return None
        foot = LENGTH * math.cos(math.radians(self.angle)) + _WALL_GAP  # m from the wall to the bottom near edge
        along, across = self.step
        x, y, _ = self._place((-foot + along, across, 0.0))
        return Brick(x, y, 1, (self.yaw + 90.0) % 180.0)

    def wall(self) -> tuple[float, float, float]:
        """The wall's centre, metres."""
        return self._place((WALL[0] / 2, 0.0, WALL[2] / 2))


def assembly(rng: np.random.Generator, name: str = "assembly") -> str:
    """One random assembly as a scenario file's text (see the module's description), one that
    the language accepts."""
    from ..compile.compiler import compile_scenario
    from ..lang.errors import ScenarioError
    from ..lang.loader import parse_scenario

    while True:
        leaner = _leaner(rng) if rng.random() < LEANING else None
        bricks = _draw(rng, extra=0 if leaner is None else 1 + (leaner.step is not None))
        if bricks is None:
            continue
        text = _yaml(bricks, name, leaner)
        try:
            compile_scenario(parse_scenario(text, f"{name}.yaml"))
        except ScenarioError:
            continue
        return text


def _draw(rng: np.random.Generator, extra: int = 0) -> list[Brick] | None:
    """The flat bricks: 2 to 4 levels and 3 to 12 bricks in all, one level fewer when a leaning
    brick comes last (it is the last level) and ``extra`` bricks fewer: the leaning brick and its
    step brick, if any."""
    levels = int(rng.integers(2, 5)) - (extra > 0)
    total = int(rng.integers(max(3, levels + extra), 13)) - extra
    counts = [1] * levels
    for _ in range(total - levels):
        counts[int(rng.integers(levels))] += 1
    bricks: list[Brick] = []
    for level, count in enumerate(counts, start=1):
        below = [b for b in bricks if b.level == level - 1]
        for _ in range(count):
            for _attempt in range(20):
                brick = _ground_brick(rng) if level == 1 else _upper_brick(rng, level, below)
                same = [b for b in bricks if b.level == level]
                if brick is not None and all(brick.footprint.intersection(b.footprint).area < 1e-9 for b in same):
                    bricks.append(brick)
                    break
            else:
                return None
    return bricks


def _leaner(rng: np.random.Generator) -> Leaner:
    """A leaning brick and its wall 0.35 m from the origin, clear of the flat bricks."""
    around = rng.uniform(0, 2 * math.pi)
    x, y, yaw, angle = 0.35 * math.cos(around), 0.35 * math.sin(around), float(rng.uniform(0, 360)), float(rng.uniform(20, 70))
    # the foot's edge 4 mm or more inside the step's 24 mm width, its corners (12 mm out) well inside its length
    step = (float(rng.uniform(-0.008, 0.008)), float(rng.uniform(-0.03, 0.03))) if rng.random() < STEP else None
    return Leaner(x, y, yaw, angle, step)


def _ground_brick(rng: np.random.Generator) -> Brick:
    return Brick(float(rng.uniform(-0.1, 0.1)), float(rng.uniform(-0.1, 0.1)), 1, float(rng.choice([0.0, 90.0])))


def _margin(rng: np.random.Generator) -> float:
    """Signed metres: inside the support's edge (positive) for 4 bricks in 5, outside for 1."""
    size = math.exp(rng.uniform(math.log(0.0001), math.log(MAX_MARGIN)))
    return size if rng.random() < 0.8 else -size


def _upper_brick(rng: np.random.Generator, level: int, below: list[Brick]) -> Brick | None:
    if len(below) >= 2 and rng.random() < 0.4:
        a, b = rng.choice(len(below), size=2, replace=False)
        return _bridge(rng, level, below[int(a)], below[int(b)])
    support = below[int(rng.integers(len(below)))]
    crossed = bool(rng.random() < 0.5)
    yaw = support.yaw + (90.0 if crossed else 0.0)
    # the centre of mass a margin inside (or outside) one edge of the support, along one of its axes
    along = support.axis()
    across = np.array([-along[1], along[0]])
    if rng.random() < 0.5:
        direction, half = along, LENGTH / 2
        other, spread = across, WIDTH / 2
    else:
        direction, half = across, WIDTH / 2
        other, spread = along, LENGTH / 2
    sign = 1.0 if rng.random() < 0.5 else -1.0
    offset = sign * (half - _margin(rng)) * direction + rng.uniform(-0.8, 0.8) * spread * other
    return Brick(support.x + float(offset[0]), support.y + float(offset[1]), level, float(yaw % 180.0))


def _bridge(rng: np.random.Generator, level: int, a: Brick, b: Brick) -> Brick | None:
    """A brick along the line from ``a`` to ``b``, its centre of mass a margin inside (or
    outside) the far edge of one of them, when the two are close enough to bridge."""
    gap = np.array([b.x - a.x, b.y - a.y])
    distance = float(np.linalg.norm(gap))
    if distance < WIDTH or distance > LENGTH:
        return None
    u = gap / distance
    middle = np.array([a.x, a.y]) + gap / 2
    # its centre anywhere between the supports' centres, or past one by a margin from its far side
    reach = distance / 2 + WIDTH / 2 - _margin(rng)
    centre = middle + (rng.uniform(-1, 1) * distance / 2 if rng.random() < 0.5 else rng.choice([-1, 1]) * reach) * u
    return Brick(float(centre[0]), float(centre[1]), level, float(math.degrees(math.atan2(u[1], u[0])) % 180.0))


def _yaml(bricks: list[Brick], name: str, leaner: Leaner | None = None) -> str:
    lines = [f"stackdsl: 1\nname: {name}"]
    if leaner is not None:
        size = ", ".join(f"{v * 1000:g} mm" for v in WALL)
        lines.append(f"brick_types:\n  wall: {{size: [{size}], material: pine}}")
    lines.append("structure:\n  bricks:")
    step = leaner.step_brick() if leaner is not None else None
    bricks = bricks + ([step] if step is not None else [])  # placed just before the leaning brick
    for i, b in enumerate(bricks, start=1):
        z = (b.level - 0.5) * HEIGHT
        lines.append(
            f"    - {{id: b{i:02d}, at: [{b.x * 1000:.3f} mm, {b.y * 1000:.3f} mm, {z * 1000:.1f} mm], yaw: {b.yaw:.3f}, level: {b.level}}}"
        )
    if leaner is not None:
        (wx, wy, wz), (x, y, z) = leaner.wall(), leaner.centre()
        top = max(b.level for b in bricks) + 1
        lines.append(
            f"    - {{id: wall, brick: wall, at: [{wx * 1000:.3f} mm, {wy * 1000:.3f} mm, {wz * 1000:.3f} mm], yaw: {leaner.yaw:.3f}, fixed: true}}"
        )
        lines.append(
            f"    - {{id: b{len(bricks) + 1:02d}, at: [{x * 1000:.4f} mm, {y * 1000:.4f} mm, {z * 1000:.4f} mm], "
            f"yaw: {leaner.yaw:.3f}, pitch: {-leaner.angle:.3f}, level: {top}}}"
        )
    lines.append("timing: {interval: 0.5 s, settle: 1 s}")
    return "\n".join(lines) + "\n"


#: The share of its friction coefficients above which a standing step is a friction tie: engines
#: model friction differently from the oracle's Coulomb cone (MuJoCo's default pyramid of four
#: edges reaches 71% of the cone between its edges; a brick leaning at 35 deg on the ground and a
#: wall, needing all of its friction, slid 69 mm down the wall on MuJoCo and stood on pybullet).
FRICTION_TIE = 0.9


@dataclass(frozen=True)
class Judgement:
    """The oracle's collapse level (None: stands), margin (metres, at most :data:`MAX_MARGIN`)
    and friction: the largest share of its friction coefficients that a step which stands needs
    (:func:`stability.friction_share`; 0 with none), so that a stand held only by nearly all of
    its friction is known as a friction tie (:data:`FRICTION_TIE`), which the margin, moving
    centres of mass, does not measure."""

    collapse_level: int | None
    margin: float
    friction: float = 0.0

    @property
    def friction_tie(self) -> bool:
        """Whether a step that stands needs at least :data:`FRICTION_TIE` of its friction."""
        return self.friction >= FRICTION_TIE


def judge(program: Program) -> Judgement:
    """The oracle's verdict on ``program``'s bricks, placed one by one, and its margin.

    Raises:
        ValueError: a brick does not lie flat.
    """
    verdict = equilibrium_collapse(program)
    steps = len(program.placements) if verdict.brick is None else verdict.bricks_standing + 1
    margin = min(_step_margin(program, k) for k in range(1, steps + 1))
    if verdict.brick is not None:
        margin = min(margin, catch_clearance(program, steps))
    standing = steps if verdict.brick is None else steps - 1
    return Judgement(
        verdict.collapse_level, margin, max((_step_friction(program, k) for k in range(1, standing + 1)), default=0.0)
    )


def _step_friction(program: Program, k: int) -> float:
    """The share of its friction coefficients step ``k`` (which stands) needs."""
    blocks, contacts = structure(list(program.placements[:k]), program.fixtures, program.ground_friction)
    return friction_share(blocks, contacts)


def catch_clearance(program: Program, k: int) -> float:
    r"""Metres between the brick placed at step ``k`` (1-based) and the nearest body placed
    before it (or fixed) that it does not touch; :data:`MAX_MARGIN` when there is none nearer.

    The oracle judges placed poses: a brick it finds falling may be caught by a neighbour
    after a fraction of a degree (a brick 1.3 mm past the edge of the one brick under it,
    its end 0.08 mm from the next brick's, tips onto that brick and is held there), so a
    falling brick's verdict is no surer than its clearance. Each body is its footprint (the
    hull of its corners, shapely) over its height range: the distance is exact between
    bricks lying flat and a lower bound otherwise.

    >>> from stackdsl import compile_scenario, parse_scenario
    >>> text = "stackdsl: 1\nstructure:\n  bricks:\n" + "".join(
    ...     f"    - {{id: {n}, at: [{x} mm, 0, {z} mm]}}\n" for n, x, z in [("a", 0, 4), ("b", 170.08, 4), ("c", 50, 12)])
    >>> round(catch_clearance(compile_scenario(parse_scenario(text, "x.yaml")), 3) * 1000, 3)  # c's end to b, mm
    0.08
    """
    places = program.placements[:k]
    falling = places[-1]
    _, contacts = structure(list(places), program.fixtures, program.ground_friction)
    touching = {c.other for c in contacts if c.body == falling.id} | {c.body for c in contacts if c.other == falling.id}
    footprint, low, high = _extent(falling)
    best = MAX_MARGIN
    others: list[Place | Fixture] = [*places[:-1], *program.fixtures]
    for other in others:
        if other.id in touching:
            continue
        shape, bottom, top = _extent(other)
        rise = max(0.0, bottom - high, low - top)
        best = min(best, math.hypot(footprint.distance(shape), rise))
    return best


def _extent(p: Place | Fixture) -> tuple[Polygon, float, float]:
    """A body's footprint (the hull of its corners' (x, y)) and its lowest and highest z, metres."""
    corners = Box(np.array(p.brick.half_extents), p.brick.mass).corners(Pose.from_euler(p.position, p.yaw, p.pitch, p.roll))
    return MultiPoint([tuple(c[:2]) for c in corners]).convex_hull, float(corners[:, 2].min()), float(corners[:, 2].max())


def _step_margin(program: Program, k: int) -> float:
    """How far every centre of mass can move together before step ``k``'s verdict flips, and
    no more than the width of a level contact whose loss flips it."""
    blocks, contacts = structure(list(program.placements[:k]), program.fixtures, program.ground_friction)

    def stands(shift: np.ndarray) -> bool:
        moved = {name: RigidBlock(b.mass, b.com + shift) for name, b in blocks.items()}
        return solve_equilibrium(moved, contacts).stands

    verdict = stands(np.zeros(3))
    best = MAX_MARGIN
    for u in _DIRECTIONS:
        # the verdict need not flip once and stay flipped: a ladder that stands 0.1 mm nearer
        # its wall falls again 20 mm on, with the bricks beside it off their footprints; so the
        # first flip is looked for on a doubling scale of shifts, then bisected
        low, high = 0.0, None
        for shift in [x for x in _SCALE if x < best] + [best]:
            if stands(u * shift) != verdict:
                high = shift
                break
            low = shift
        if high is None:
            continue
        while high - low > RESOLUTION:
            mid = (low + high) / 2
            low, high = (mid, high) if stands(u * mid) == verdict else (low, mid)
        best = high
    # a support no wider than the margin: a brick that lies 0.4 mm onto the edge of a second
    # support stands by statics, but a move of 0.4 mm takes that support away
    for k, c in enumerate(contacts):
        width = _width(c.points) if is_level(c) else MAX_MARGIN
        if width < best and solve_equilibrium(blocks, contacts[:k] + contacts[k + 1 :]).stands != verdict:
            best = width
    return best


def _width(points: np.ndarray) -> float:
    """Metres: the narrower side of the smallest rectangle around a level contact's points;
    :data:`MAX_MARGIN` for a line or a point (a tilted brick's edge or corner: no overlap to lose)."""
    hull = MultiPoint([tuple(p[:2]) for p in points]).convex_hull
    if not isinstance(hull, Polygon):
        return MAX_MARGIN
    x, y = np.asarray(hull.minimum_rotated_rectangle.exterior.coords).T
    sides = np.hypot(np.diff(x), np.diff(y))
    return float(sides[:2].min())
