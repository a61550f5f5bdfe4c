"""The lean MuJoCo peer: a scene run as a MuJoCo user would write it, for the bench to beat.

:func:`run_lean` takes a compiled :class:`stackdsl.compile.program.Program` (its bricks, their
placing times and poses, its MuJoCo settings) and runs it without stackdsl's step loop: one
MJCF model with every brick declared up front as a free body with a box geom, the bricks
not yet placed parked on the ground far away (where MuJoCo's own sleeping puts them to
sleep), ``mujoco.mj_step`` called in a plain loop, and a brick placed by writing its free
joint's position and velocity and calling ``mujoco.mj_forward`` (which wakes it). The
collapse is watched as every lean peer watches it (:class:`stackdsl.bench.lean.CollapseWatch`),
from MuJoCo's own body frames (``xpos``, ``xmat``); the run stops when the collapse is decided,
or at the program's end.

Settings are the program's (``engine: {backend: mujoco, mode: tuned, sleep_tolerance: 1e-3}``
is the peer at its best, :data:`stackdsl.bench.bench.LEAN_SLEEP_TOLERANCE`): timestep, solver
iterations, cone, impratio, integrator, contact softness and sleeping. A brick is let go at rest the scene's
drop gap (each placement's ``drop``, 0.5 mm by default) above its pose, as the scenario asks
and as the extension places it, and is watched against its pose. Placed exactly at its pose
instead, in contact, as this peer used to be, it falls at the same levels; on the upright
30-level 4 stack at sleep tolerance 1e-4 it took 10.5 to 18.5 s against 3.5 to 5.3 s with the
drop gap (three rounds in one process, load 3.3 to 4.6 on 2 cores; about 93 contacts a step
against 50), time the scenario does not ask of it. At 1e-3 the two placements cost about the
same there (1.9 to 2.5 s in contact, 2.0 to 6.0 s with the gap, the same rounds).

With ``from_top`` a brick is let go the drop gap above the actual top of what it will rest on
(the highest corner, now, of the placed bricks under it: MuJoCo's soft contacts sink a 4 stack
about 2 mm by level 60) rather than above its nominal pose; the default, :data:`FROM_TOP`, is
the faster measured (docs/results/actions.md, "The lean peer's settings"). The solver tolerance (MuJoCo's ``tolerance``, 1e-8 by default) is ``tolerance`` when given
(:data:`stackdsl.bench.bench.LEAN_TOLERANCE` is the bench's measured best).

The hand's actions are driven as a MuJoCo user drives them, on the compiled schedule: a pulled
brick (``remove``) is a free body whose velocity is set every step to its path's plus half the
way back to the path in a step (its height free: it rests on what is under it), then taken out
of the scene; a pusher is a free body of its box, compensated for gravity and 100 kg heavy,
driven the same way along its path, then withdrawn; a shaken ground (``shake``) is a 100 kg
table on two slide joints whose position and velocity are set every step
(:meth:`stackdsl.compile.program.Shake.at`) and held at rest outside the shake (left free after
it, the table drifted on with the last velocity set, 10 mm in 2 s under the 10-level 4 stack
below its threshold, which then read as fallen), the bricks waiting on a plane below it. Driven
bodies never sleep. With ``settle`` (the actions family) the run goes on after the collapse is
decided as stackdsl's runtime does: nothing more is placed, an action under way and those after
it run, and the run ends ``settle`` seconds after the last of them.

A program that launches a projectile or has fixed bodies raises ValueError. Units: SI.
Source: stackdsl's own, on MuJoCo 4.0's Python bindings (``MjModel.from_xml_string``,
``mj_step``, ``mj_forward``, ``tree_sleep_policy``).

>>> from stackdsl import compile_scenario, parse_scenario
>>> text = "stackdsl: 1\\nstructure: {tower: {levels: 3}}\\nengine: {backend: mujoco, mode: tuned}\\n"
>>> lean = run_lean(compile_scenario(parse_scenario(text, "t.yaml")))
>>> lean.level is None, lean.steps > 0, 0.0 < lean.engine <= lean.wall
(True, True, True)
"""

from __future__ import annotations

import itertools
import math
import time
from dataclasses import dataclass
from typing import Any

import numpy as np
from scipy.spatial.transform import Rotation

from stability import Pose

from ..compile.program import Launch, Place, Program, Push, Remove, Shake
from ..engines.mujoco.settings import MuJoCoSettings
from .lean import WATCH_RATE, CollapseWatch, LeanOutcome, tipped

_PARK = np.array([5000.0, 5000.0])  # m: where the bricks not yet placed wait, on the ground
_SLOT = 0.5  # m between two of them
_BELOW = -5.0  # m: the height of the plane the bricks wait on when the ground is a shake table
_TABLE_MASS = 100.0  # kg of the shake table (as stackdsl's MuJoCo world makes it)
_TABLE_HALF = (5.0, 5.0, 0.5)  # m: its half extents, its top the plane z = 0
_HAND_MASS = 100.0  # kg of a pusher (as stackdsl's MuJoCo world holds one)
GAIN = 0.5
FROM_TOP = False
"""Whether a brick is let go the drop gap above the actual top of what it will rest on (True) or
above its nominal pose (False), by default: the faster measured (docs/results/actions.md, "The
lean peer's settings")."""
"""The share of a driven body's distance from its path that its velocity makes up in one step
(as stackdsl's MuJoCo world drives a guided body)."""


def mjcf(program: Program, tolerance: float | None = None) -> str:
    """The MJCF of ``program``'s scene: the ground (a plane, or a shake table on two slide
    joints above a plane the waiting bricks rest on), every brick a free body with a box geom of
    its size, mass and friction, parked far away, and each pusher a free body of its box,
    compensated for gravity, parked too; MuJoCo's solver ``tolerance`` when given.

    Raises:
        ValueError: the program's engine is not MuJoCo, or it has fixtures or launches.
    """
    e = program.engine
    if not isinstance(e, MuJoCoSettings):
        raise ValueError("the lean MuJoCo peer runs programs compiled for MuJoCo (engine: {backend: mujoco})")
    if program.fixtures or any(isinstance(a, Launch) for a in program.actions):
        raise ValueError("the lean MuJoCo peer runs placements, pulls, pushes and shakes only: no fixed bodies, no projectiles")
    cone = "elliptic" if e.elliptic_cones else "pyramidal"
    flags = '<flag sleep="enable"/>' if e.sleep_tolerance is not None else ""
    sleep = f' sleep_tolerance="{e.sleep_tolerance}"' if e.sleep_tolerance is not None else ""
    solver = f' tolerance="{tolerance}"' if tolerance is not None else ""
    contact = f'solref="{e.solref[0]} {e.solref[1]}" solimp="{e.solimp[0]} {e.solimp[1]} {e.solimp[2]} 0.5 2"'
    table = program.shakes
    wait = _BELOW if table else 0.0
    mu = _ground_friction(program)
    first = ' priority="1"' if mu != program.ground_friction else ""  # its friction, not the larger of two
    ground = f'friction="{mu} 0.005 0.0001"{first} {contact}'
    bodies = []
    if table:  # the table collides with the bricks only (contype 1), the plane below it with the bricks only (2)
        hx, hy, hz = _TABLE_HALF
        bodies.append(
            f'<body name="table" pos="0 0 {-hz}"><joint name="table_x" type="slide" axis="1 0 0"/>'
            f'<joint name="table_y" type="slide" axis="0 1 0"/><geom name="table" type="box" size="{hx} {hy} {hz}" mass="{_TABLE_MASS}" '
            f'contype="1" conaffinity="1" {ground}/></body>'
        )
        bodies.append(f'<geom name="below" type="plane" size="0 0 1" pos="0 0 {_BELOW}" contype="2" conaffinity="2" {ground}/>')
    else:
        bodies.append(f'<geom name="ground" type="plane" size="0 0 1" {ground}/>')
    kinds = ' contype="3" conaffinity="3"' if table else ""
    for k, p in enumerate(program.placements):
        hx, hy, hz = p.brick.half_extents
        x, y = _PARK + [_SLOT * k, 0.0]
        bodies.append(
            f'<body name="{p.id}" pos="{x} {y} {wait + hz}"><freejoint/>'
            f'<geom name="g {p.id}" type="box" size="{hx} {hy} {hz}" mass="{p.brick.mass}" friction="{p.brick.friction} 0.005 0.0001" '
            f"{contact}{kinds}/></body>"
        )
    for k, a in enumerate(a for a in program.actions if isinstance(a, Push)):
        hx, hy, hz = a.brick.half_extents
        x, y = _PARK + [_SLOT * k, -_SLOT]
        bodies.append(
            f'<body name="hand {a.id}" pos="{x} {y} 1" gravcomp="1"><freejoint/>'
            f'<geom name="g hand {a.id}" type="box" size="{hx} {hy} {hz}" mass="{_HAND_MASS}" friction="{a.brick.friction} 0.005 0.0001" '
            f"{contact}{kinds}/></body>"
        )
    return (
        f'<mujoco><option timestep="{e.timestep}" iterations="{e.solver_iterations}" cone="{cone}" '
        f'impratio="{e.impratio}" integrator="{e.integrator}" gravity="0 0 {-e.gravity}"{sleep}{solver}>{flags}</option>'
        f"<worldbody>{''.join(bodies)}</worldbody>{_pairs(program, contact, mu)}</mujoco>"
    )


def _pairs(program: Program, contact: str, ground: float) -> str:
    """The MJCF ``contact`` element for a scene of bricks (and pushers) of more than one
    material: each two bodies of different coefficients collide as an explicit pair with
    stackdsl's pair rule, the geometric mean of the two (``stackdsl.engines.mujoco.materials``),
    their own contact excluded (MuJoCo would take the larger); with the ground or the table too
    when a brick's coefficient differs from the one the ground's priority gives. Empty for one
    material. An ice brick on a pine stack, shaken, stood on the peer at the pine's 0.5 where the
    extension and both tuned engines slid it off."""
    own = _bodies(program)
    if len({mu for _, _, mu in own}) < 2:
        return ""
    pairs, excluded = [], []
    for (g1, b1, m1), (g2, b2, m2) in itertools.combinations(own, 2):
        if m1 != m2:
            pairs.append((g1, g2, math.sqrt(m1 * m2)))
            excluded.append((b1, b2))
    floors = [("table", "table"), ("below", "world")] if program.shakes else [("ground", "world")]
    for geom, body, mu in own:
        if mu != ground:
            for floor, holder in floors:
                pairs.append((floor, geom, math.sqrt(mu * program.ground_friction)))
                excluded.append((holder, body))
    said = [f'<pair geom1="{g1}" geom2="{g2}" friction="{m} {m} 0.005 0.0001 0.0001" {contact}/>' for g1, g2, m in pairs]
    said += [f'<exclude body1="{b1}" body2="{b2}"/>' for b1, b2 in excluded]
    return f"<contact>{''.join(said)}</contact>"


def _bodies(program: Program) -> list[tuple[str, str, float]]:
    """Each brick's and pusher's geom name, body name and friction coefficient in the MJCF."""
    own = [(f"g {p.id}", p.id, p.brick.friction) for p in program.placements]
    return own + [(f"g hand {a.id}", f"hand {a.id}", a.brick.friction) for a in program.actions if isinstance(a, Push)]


def _ground_friction(program: Program) -> float:
    """The ground geom's friction coefficient, which its ``priority`` makes MuJoCo use for every
    contact with it (its own rule takes the larger of two geoms'): stackdsl's pair rule, the
    geometric mean of the two materials' (``stackdsl.engines.mujoco.materials``), when every
    brick and pusher is of one material; the ground's own otherwise. Pine bricks on an ice
    ground, shaken at 1.5 times their pair's slide threshold, stood on the peer at the pine's
    0.5 (the extension and both tuned engines slid them 4 to 6 mm)."""
    frictions = {mu for _, _, mu in _bodies(program)}
    if len(frictions) != 1 or frictions == {program.ground_friction}:
        return program.ground_friction
    (brick,) = frictions
    return math.sqrt(brick * program.ground_friction)


@dataclass
class _Driven:
    """A body driven along a path: free joint addresses, where the path starts (m) and when
    (s), its velocity (m/s), its orientation (MuJoCo's w, x, y, z), when the drive ends (s),
    whether its height is driven too, and what it is (a brick's index, or -1: a pusher)."""

    qpos: int
    dof: int
    start: np.ndarray
    time: float
    velocity: np.ndarray
    quat: np.ndarray
    end: float
    height: bool
    brick: int


def run_lean(
    program: Program,
    timeout: float = 600.0,
    tolerance: float | None = None,
    settle: float | None = 0.0,
    from_top: bool = FROM_TOP,
) -> LeanOutcome:
    """Run ``program`` in the lean loop (see the module's description) for at most
    ``timeout`` wall seconds (then the level so far is returned), at MuJoCo's solver
    ``tolerance`` (None: its default, 1e-8), each brick let go the drop gap above the actual top
    of what it will rest on (``from_top``) or above its pose, going on ``settle`` seconds after a collapse is
    decided (0: the run ends there; None: the program's settle time, with what stackdsl's
    runtime does meanwhile).

    Raises:
        ValueError: as :func:`mjcf`.
    """
    started = time.perf_counter()
    run = _LeanRun(program, tolerance, settle, from_top)
    while run.going() and time.perf_counter() - started < timeout:
        now = float(run.data.time)
        run.place_due(now)
        run.start_actions(now)
        if run.step():
            break
    return run.outcome(time.perf_counter() - started)


class _LeanRun:
    """One lean run's MuJoCo model and data and the state of its loop: what is placed, the
    bodies driven along their paths, the shakes under way, and when the run stops (stackdsl's
    own)."""

    def __init__(self, program: Program, tolerance: float | None, settle: float | None, from_top: bool) -> None:
        import mujoco

        self.mujoco = mujoco
        self.program, self.settle, self.from_top = program, settle, from_top
        model = self.model = mujoco.MjModel.from_xml_string(mjcf(program, tolerance))
        self.data = mujoco.MjData(model)
        mujoco.mj_forward(model, self.data)
        self.never = mujoco.mjtSleepPolicy.mjSLEEP_NEVER
        places = self.places = program.placements
        self.index = {p.id: k for k, p in enumerate(places)}
        self.body = np.array([model.body(p.id).id for p in places], dtype=int)
        self.adr = np.array([model.jnt_qposadr[model.body_jntadr[b]] for b in self.body], dtype=int)
        self.dof = np.array([model.jnt_dofadr[model.body_jntadr[b]] for b in self.body], dtype=int)
        self.half = np.array([p.brick.half_extents for p in places]).reshape(-1, 3)
        self.nominal = np.array([p.position for p in places]).reshape(-1, 3) - [0.0, 0.0, program.engine.SEAT]
        self.quats = np.array([_quat(p) for p in places]).reshape(-1, 4)
        self.turned = Rotation.from_quat(self.quats[:, [1, 2, 3, 0]]).as_matrix() if places else np.zeros((0, 3, 3))
        corners = self.nominal[:, None, :] + np.einsum("nij,nkj->nki", self.turned, _SIGNS[None] * self.half[:, None, :])
        self.low, self.high = corners.min(axis=1), corners.max(axis=1)  # (n, 3): nominal bounding boxes
        self.watch = CollapseWatch(self.half, program.collapse_threshold)
        self.table_q = self.table_v = -1
        if program.shakes:
            table = model.body("table").id
            self.table_q = int(model.jnt_qposadr[model.body_jntadr[table]])
            self.table_v = int(model.jnt_dofadr[model.body_jntadr[table]])
            model.tree_sleep_policy[model.body_treeid[table]] = self.never
        self.dt = model.opt.timestep
        self.every = max(1, round(1.0 / (WATCH_RATE * self.dt)))
        self.kinematic = [a for a in program.actions if isinstance(a, (Remove, Push, Shake))]
        self.pushers = [model.body(f"hand {a.id}").id for a in program.actions if isinstance(a, Push)]
        self.driven: list[_Driven] = []
        self.shakes: list[Shake] = []
        self.removed: list[str] = []
        self.placed = self.steps = self.pushed = 0
        self.engine = 0.0
        self.stop: float | None = None  # when the run ends, once a collapse is decided
        self.decided = 0.0  # the wall clock (perf_counter) when it was decided
        self.cut = False  # a placement the collapse cancelled: nothing after it runs
        self.end = program.duration
        self.offset = np.zeros(3)

    def going(self) -> bool:
        """Whether simulated time is left before the program's end or the stop a collapse set."""
        end = self.end if self.stop is None else min(self.stop, self.end)
        return bool(self.data.time < end - 1e-9)

    def place_due(self, now: float) -> None:
        """Let go every brick due by ``now`` (s), the drop gap above where it will rest; after a
        collapse nothing more is placed."""
        data, k = self.data, self.placed
        while not self.cut and k < len(self.places) and self.places[k].time <= now + 1e-9:
            if self.stop is not None:  # nothing is placed after a collapse (the rest stay parked)
                self.cut = True
                return
            p = self.places[k]
            rest = self.nominal[k] - [0.0, 0.0, self._sink(k) if self.from_top else 0.0]
            data.qpos[self.adr[k] : self.adr[k] + 3] = rest + [0.0, 0.0, p.drop]  # let go the drop gap above
            data.qpos[self.adr[k] + 3 : self.adr[k] + 7] = self.quats[k]
            data.qvel[self.dof[k] : self.dof[k] + 6] = 0.0
            self.mujoco.mj_forward(self.model, data)  # moving a body by hand and forwarding wakes it
            self.watch.place(k, p.level, rest, self.turned[k])
            k = self.placed = k + 1

    def _sink(self, k: int) -> float:
        """How far the actual top under brick ``k`` lies below its nominal bottom (m): :func:`_sink`
        on the bodies' corners now."""
        data = self.data
        corners_now = data.xpos[self.body[:k], None, :] + np.einsum(
            "nij,nkj->nki", data.xmat[self.body[:k]].reshape(-1, 3, 3), _SIGNS[None] * self.half[:k, None, :]
        )
        tops = corners_now[:, :, 2].max(axis=1, initial=-np.inf)
        return _sink(k, self.low, self.high, tops, {self.index[r] for r in self.removed})

    def start_actions(self, now: float) -> None:
        """Start every pull, push and shake due by ``now`` (s): a shake is kept for :func:`_drive`; a
        pulled brick or a pusher becomes a driven body that never sleeps."""
        while self.kinematic and self.kinematic[0].time <= now + 1e-9:
            a = self.kinematic.pop(0)
            if self.cut:
                continue
            if self.stop is not None:
                self.stop = max(self.stop, a.end_time + (self.settle or 0.0))
            if isinstance(a, Shake):
                self.shakes.append(a)
            else:
                self._drive_body(a, now)

    def _drive_body(self, a: Remove | Push, now: float) -> None:
        """Hand a pulled brick (``Remove``) or a pusher (``Push``) its path from ``now`` (s)."""
        model, data = self.model, self.data
        if isinstance(a, Remove):
            k = self.index[a.id]
            b, q, v, height = int(self.body[k]), int(self.adr[k]), int(self.dof[k]), False
            self.removed.append(a.id)
            self.watch.forget(k)
            start = data.qpos[q : q + 3].copy()
        else:
            b, height, k = self.pushers[self.pushed], True, -1
            self.pushed += 1
            q, v = int(model.jnt_qposadr[model.body_jntadr[b]]), int(model.jnt_dofadr[model.body_jntadr[b]])
            start = np.asarray(a.position, dtype=float)
            x, y, z, w = Pose.from_euler(a.position, a.yaw, a.pitch, 0.0).orientation
            data.qpos[q : q + 3] = start
            data.qpos[q + 3 : q + 7] = [w, x, y, z]
            data.qvel[v : v + 6] = 0.0
        model.tree_sleep_policy[model.body_treeid[b]] = self.never
        data.qpos[q : q + 3] = data.qpos[q : q + 3].copy()  # written: a sleeping body wakes
        self.mujoco.mj_forward(model, data)
        velocity = np.asarray(a.velocity, dtype=float)
        self.driven.append(_Driven(q, v, start, now, velocity, data.qpos[q + 3 : q + 7].copy(), a.end_time, height, k))

    def step(self) -> bool:
        """Step the engine one watch interval, end what is over and watch for a collapse; True when
        the run ends at once (a collapse with ``settle`` 0)."""
        mujoco, model, data = self.mujoco, self.model, self.data
        hands = bool(self.driven or self.shakes)
        tick = time.perf_counter()
        for _ in range(self.every):
            if hands:
                self.offset = _drive(data, self.driven, self.shakes, self.table_q, self.table_v, self.dt)
            mujoco.mj_step(model, data)
        self.engine += time.perf_counter() - tick
        self.steps += self.every
        t = float(data.time)
        self._end_over(t)
        return self._look(t)

    def _end_over(self, t: float) -> None:
        """Take out a pulled brick, withdraw a pusher, and hold the table still once a shake is over."""
        data = self.data
        for d in [d for d in self.driven if d.end <= t + 1e-9]:
            self.driven.remove(d)
            data.qpos[d.qpos : d.qpos + 3] = [*(_PARK + [_SLOT * (d.brick if d.brick >= 0 else -1), -2 * _SLOT]), 1.0]
            data.qvel[d.dof : d.dof + 6] = 0.0
            self.mujoco.mj_forward(self.model, data)
        self.shakes = [s for s in self.shakes if s.end_time > t + 1e-9]
        if not self.shakes and self.table_q >= 0:  # the table held where it rests (the bricks' pushes move it)
            self.offset = np.zeros(3)
            data.qpos[self.table_q : self.table_q + 2] = data.qvel[self.table_v : self.table_v + 2] = 0.0

    def _look(self, t: float) -> bool:
        """Watch the placed bricks for a collapse at ``t`` (s); set when the run stops after one."""
        data, body = self.data, self.body[: self.placed]
        if self.stop is not None:
            return False
        if not self.watch.look(t, data.xpos[body] - self.offset, data.xmat[body].reshape(-1, 3, 3)):
            return False
        if self.settle == 0.0:
            return True
        after = self.program.settle if self.settle is None else self.settle
        self.decided = time.perf_counter()
        self.stop = max([t, *(d.end for d in self.driven), *(s.end_time for s in self.shakes)]) + after
        return False

    def outcome(self, wall: float) -> LeanOutcome:
        """The run's level, times, steps, and each kept brick's displacement and tipping."""
        data, placed, places = self.data, self.placed, self.places
        rotations = data.xmat[self.body[:placed]].reshape(-1, 3, 3)
        moved = self.watch.displacements(data.xpos[self.body[:placed]] - self.offset, rotations)
        tilted = tipped(self.half[:placed], self.turned[:placed], rotations)
        kept = [k for k in range(placed) if places[k].id not in self.removed]
        return LeanOutcome(
            self.watch.level,
            wall,
            self.engine,
            float(data.time),
            self.steps,
            after_collapse=time.perf_counter() - self.decided if self.stop is not None else 0.0,
            moved={places[k].id: float(moved[k]) for k in kept},
            toppled=tuple(places[k].id for k in kept if tilted[k]),
            removed=tuple(self.removed),
        )


_SIGNS = np.array([[sx, sy, sz] for sx in (-1, 1) for sy in (-1, 1) for sz in (-1, 1)], dtype=float)


def _sink(k: int, low: np.ndarray, high: np.ndarray, tops: np.ndarray, gone: set[int]) -> float:
    """How far below its nominal bottom the actual top of what brick ``k`` will rest on lies (m;
    negative: above it), 0 on the ground. What it rests on: the bricks placed before it, not
    pulled out (``gone``), whose nominal tops are within 1 mm of its nominal bottom and whose
    footprints overlap its own (``low``, ``high``: (n, 3), nominal bounding boxes); ``tops``:
    (k,), each placed brick's highest corner now (m)."""
    under = [
        j
        for j in range(k)
        if j not in gone
        and abs(high[j, 2] - low[k, 2]) < 1e-3
        and min(high[j, 0], high[k, 0]) - max(low[j, 0], low[k, 0]) > 1e-6
        and min(high[j, 1], high[k, 1]) - max(low[j, 1], low[k, 1]) > 1e-6
    ]
    if not under:
        return 0.0
    return float(low[k, 2] - max(tops[j] for j in under))


def _drive(d: Any, driven: list[_Driven], shakes: list[Shake], table_q: int, table_v: int, dt: float) -> np.ndarray:
    """Set the driven bodies' velocities for the next step (their path's, plus :data:`GAIN` of
    the way back to it), and the shake table's position and velocity; returns the table's offset (m)."""
    t = float(d.time)
    rate = GAIN / dt
    for h in driven:
        path = h.start + h.velocity * (t - h.time)
        q, v = h.qpos, h.dof
        error = path - d.qpos[q : q + 3]
        d.qvel[v : v + 2] = h.velocity[:2] + rate * error[:2]
        if h.height:
            d.qvel[v + 2] = h.velocity[2] + rate * error[2]
        now = d.qpos[q + 3 : q + 7]
        was = Rotation.from_quat([now[1], now[2], now[3], now[0]])
        turn = (Rotation.from_quat([h.quat[1], h.quat[2], h.quat[3], h.quat[0]]) * was.inv()).as_rotvec()
        d.qvel[v + 3 : v + 6] = was.inv().apply(turn * rate)  # MuJoCo's: in the body's frame
    offset = np.zeros(3)
    for s in shakes:
        (x, y, _), (vx, vy, _) = s.at(t)
        d.qpos[table_q : table_q + 2] = [x, y]
        d.qvel[table_v : table_v + 2] = [vx, vy]
        offset = np.array([x, y, 0.0])
    return offset


def _quat(p: Place) -> np.ndarray:
    """``p``'s orientation as MuJoCo's (w, x, y, z) quaternion."""
    x, y, z, w = Pose.from_euler(p.position, p.yaw, p.pitch, p.roll).orientation
    return np.array([w, x, y, z])
