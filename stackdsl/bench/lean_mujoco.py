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
    ground = f'friction="{program.ground_friction} 0.005 0.0001" {contact}'
    bodies = []
    if table:  # the table collides with the bricks only (contype 1), the plane below it with the bricks only (2)
        hx, hy, hz = _TABLE_HALF
        bodies.append(
            f'<body name="table" pos="0 0 {-hz}"><joint name="table_x" type="slide" axis="1 0 0"/>'
            f'<joint name="table_y" type="slide" axis="0 1 0"/><geom type="box" size="{hx} {hy} {hz}" mass="{_TABLE_MASS}" '
            f'contype="1" conaffinity="1" {ground}/></body>'
        )
        bodies.append(f'<geom type="plane" size="0 0 1" pos="0 0 {_BELOW}" contype="2" conaffinity="2" {ground}/>')
    else:
        bodies.append(f'<geom type="plane" size="0 0 1" {ground}/>')
    kinds = ' contype="3" conaffinity="3"' if table else ""
    for k, p in enumerate(program.placements):
        hx, hy, hz = p.brick.half_extents
        x, y = _PARK + [_SLOT * k, 0.0]
        bodies.append(
            f'<body name="{p.id}" pos="{x} {y} {wait + hz}"><freejoint/>'
            f'<geom type="box" size="{hx} {hy} {hz}" mass="{p.brick.mass}" friction="{p.brick.friction} 0.005 0.0001" '
            f"{contact}{kinds}/></body>"
        )
    for k, a in enumerate(a for a in program.actions if isinstance(a, Push)):
        hx, hy, hz = a.brick.half_extents
        x, y = _PARK + [_SLOT * k, -_SLOT]
        bodies.append(
            f'<body name="hand {a.id}" pos="{x} {y} 1" gravcomp="1"><freejoint/>'
            f'<geom type="box" size="{hx} {hy} {hz}" mass="{_HAND_MASS}" friction="{a.brick.friction} 0.005 0.0001" '
            f"{contact}{kinds}/></body>"
        )
    return (
        f'<mujoco><option timestep="{e.timestep}" iterations="{e.solver_iterations}" cone="{cone}" '
        f'impratio="{e.impratio}" integrator="{e.integrator}" gravity="0 0 {-e.gravity}"{sleep}{solver}>{flags}</option>'
        f"<worldbody>{''.join(bodies)}</worldbody></mujoco>"
    )


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
    import mujoco

    started = time.perf_counter()
    model = mujoco.MjModel.from_xml_string(mjcf(program, tolerance))
    data = mujoco.MjData(model)
    mujoco.mj_forward(model, data)
    never = mujoco.mjtSleepPolicy.mjSLEEP_NEVER
    places = program.placements
    index = {p.id: k for k, p in enumerate(places)}
    body = np.array([model.body(p.id).id for p in places], dtype=int)
    adr = np.array([model.jnt_qposadr[model.body_jntadr[b]] for b in body], dtype=int)
    dof = np.array([model.jnt_dofadr[model.body_jntadr[b]] for b in body], dtype=int)
    half = np.array([p.brick.half_extents for p in places]).reshape(-1, 3)
    nominal = np.array([p.position for p in places]).reshape(-1, 3) - [0.0, 0.0, program.engine.SEAT]
    quats = np.array([_quat(p) for p in places]).reshape(-1, 4)
    turned = Rotation.from_quat(quats[:, [1, 2, 3, 0]]).as_matrix() if places else np.zeros((0, 3, 3))
    corners = nominal[:, None, :] + np.einsum("nij,nkj->nki", turned, _SIGNS[None] * half[:, None, :])
    low, high = corners.min(axis=1), corners.max(axis=1)  # (n, 3): each brick's nominal bounding box
    watch = CollapseWatch(half, program.collapse_threshold)
    table_q = table_v = -1
    if program.shakes:
        table = model.body("table").id
        table_q, table_v = int(model.jnt_qposadr[model.body_jntadr[table]]), int(model.jnt_dofadr[model.body_jntadr[table]])
        model.tree_sleep_policy[model.body_treeid[table]] = never
    dt = model.opt.timestep
    every = max(1, round(1.0 / (WATCH_RATE * dt)))
    kinematic = [a for a in program.actions if isinstance(a, (Remove, Push, Shake))]
    pushers = [model.body(f"hand {a.id}").id for a in program.actions if isinstance(a, Push)]
    driven: list[_Driven] = []
    shakes: list[Shake] = []
    removed: list[str] = []
    placed, steps, engine, pushed = 0, 0, 0.0, 0
    stop: float | None = None  # when the run ends, once a collapse is decided
    cut = False  # a placement the collapse cancelled: nothing after it runs
    end = program.duration
    offset = np.zeros(3)
    while data.time < (end if stop is None else min(stop, end)) - 1e-9 and time.perf_counter() - started < timeout:
        now = float(data.time)
        while placed < len(places) and places[placed].time <= now + 1e-9:
            if stop is not None:  # nothing is placed after a collapse
                cut = True
                placed = len(places)
                break
            p, k = places[placed], placed
            corners_now = data.xpos[body[:k], None, :] + np.einsum(
                "nij,nkj->nki", data.xmat[body[:k]].reshape(-1, 3, 3), _SIGNS[None] * half[:k, None, :]
            )
            sink = (
                _sink(k, low, high, corners_now[:, :, 2].max(axis=1, initial=-np.inf), {index[r] for r in removed})
                if from_top
                else 0.0
            )
            rest = nominal[k] - [0.0, 0.0, sink]
            data.qpos[adr[k] : adr[k] + 3] = rest + [0.0, 0.0, p.drop]  # let go the drop gap above
            data.qpos[adr[k] + 3 : adr[k] + 7] = quats[k]
            data.qvel[dof[k] : dof[k] + 6] = 0.0
            mujoco.mj_forward(model, data)  # moving a body by hand and forwarding wakes it
            watch.place(k, p.level, rest, turned[k])
            placed += 1
        while kinematic and kinematic[0].time <= now + 1e-9:
            a = kinematic.pop(0)
            if cut:
                continue
            if stop is not None:
                stop = max(stop, a.end_time + (settle or 0.0))
            if isinstance(a, Shake):
                shakes.append(a)
                continue
            if isinstance(a, Remove):
                k = index[a.id]
                b, q, v, height = int(body[k]), int(adr[k]), int(dof[k]), False
                removed.append(a.id)
                watch.forget(k)
                start = data.qpos[q : q + 3].copy()
            else:
                b, height, k = pushers[pushed], True, -1
                pushed += 1
                q, v = int(model.jnt_qposadr[model.body_jntadr[b]]), int(model.jnt_dofadr[model.body_jntadr[b]])
                start = np.asarray(a.position, dtype=float)
                x, y, z, w = Pose.from_euler(a.position, a.yaw, a.pitch, 0.0).orientation
                data.qpos[q : q + 3] = start
                data.qpos[q + 3 : q + 7] = [w, x, y, z]
                data.qvel[v : v + 6] = 0.0
            model.tree_sleep_policy[model.body_treeid[b]] = never
            data.qpos[q : q + 3] = data.qpos[q : q + 3].copy()  # written: a sleeping body wakes
            mujoco.mj_forward(model, data)
            driven.append(
                _Driven(
                    q, v, start, now, np.asarray(a.velocity, dtype=float), data.qpos[q + 3 : q + 7].copy(), a.end_time, height, k
                )
            )
        hands = bool(driven or shakes)
        tick = time.perf_counter()
        for _ in range(every):
            if hands:
                offset = _drive(data, driven, shakes, table_q, table_v, dt)
            mujoco.mj_step(model, data)
        engine += time.perf_counter() - tick
        steps += every
        t = float(data.time)
        for d in [d for d in driven if d.end <= t + 1e-9]:  # over: a pulled brick is taken out, a pusher withdrawn
            driven.remove(d)
            data.qpos[d.qpos : d.qpos + 3] = [*(_PARK + [_SLOT * (d.brick if d.brick >= 0 else -1), -2 * _SLOT]), 1.0]
            data.qvel[d.dof : d.dof + 6] = 0.0
            mujoco.mj_forward(model, data)
        shakes = [s for s in shakes if s.end_time > t + 1e-9]
        if not shakes and table_q >= 0:  # the table held where it rests (the bricks' pushes on it move it a little)
            offset = np.zeros(3)
            data.qpos[table_q : table_q + 2] = data.qvel[table_v : table_v + 2] = 0.0
        if stop is None and watch.look(t, data.xpos[body[:placed]] - offset, data.xmat[body[:placed]].reshape(-1, 3, 3)):
            if settle == 0.0:
                break
            after = program.settle if settle is None else settle
            stop = max([t, *(d.end for d in driven), *(s.end_time for s in shakes)]) + after
    rotations = data.xmat[body[:placed]].reshape(-1, 3, 3)
    moved = watch.displacements(data.xpos[body[:placed]] - offset, rotations)
    tilted = tipped(half[:placed], turned[:placed], rotations)
    kept = [k for k in range(placed) if places[k].id not in removed]
    return LeanOutcome(
        watch.level,
        time.perf_counter() - started,
        engine,
        float(data.time),
        steps,
        moved={places[k].id: float(moved[k]) for k in kept},
        toppled=tuple(places[k].id for k in kept if tilted[k]),
        removed=tuple(removed),
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
