"""A run's bricks at one moment as an MJCF or a URDF model, to open in MuJoCo's (or another
engine's) own tools.

:func:`snapshot` takes every body in the world at a time of a :class:`stackdsl.Trajectory`
(its pose and state, as :meth:`stackdsl.Trajectory.at`) and the fixed bodies; :func:`mjcf`
writes them as MuJoCo XML (each brick a body with a free joint and a box geom, the fixed
bodies static boxes, the ground a plane), :func:`sdf` as an SDFormat world of one model a
brick, which pybullet's ``loadSDF`` loads as one body a brick, and :func:`urdf` as one URDF
robot whose root link is the ground and whose bricks hang on ``floating`` joints placed at
their poses (MuJoCo compiles a floating joint into a free joint; pybullet, whose URDF is one
multibody, loads it as a fixed one: the bricks welded into one body). Geoms are
coloured by state (:data:`stackdsl.draw.render.COLOURS`). Masses and friction come from the
run's brick specs when the scenario is at hand, else from the built-in pine (460 kg/m^3,
friction 0.5).

The MJCF carries MuJoCo's options and contacts as stackdsl's own MuJoCo world sets them
(:func:`mujoco_settings` says which settings, and the file says so in a comment): timestep,
gravity, solver iterations, friction cone, impratio, integrator, each geom's ``solref`` and
``solimp``, each geom its material's friction and collision bit, and two materials in contact an
explicit ``<pair>`` with the geometric mean of their coefficients
(:class:`stackdsl.engines.mujoco.materials.Materials`). Without them MuJoCo's defaults (pyramidal
cones, solref 20 ms) let a single-file staircase standing 1.5 mm inside its tipping margin fall
81 mm in 2 s; with them it moves 0.35 mm.

>>> import stackdsl
>>> from stackdsl.runtime.recorder import record_program
>>> program = stackdsl.compile_scenario(stackdsl.parse_scenario("stackdsl: 1\\nstructure: {tower: {levels: 1}}"))
>>> outcome, trajectory = record_program(program)
>>> scene = snapshot(trajectory, "end")
>>> scene.ids, scene.states
(['L01.1', 'L01.2'], ['frozen', 'frozen'])
>>> import mujoco
>>> model = mujoco.MjModel.from_xml_string(mjcf(scene))
>>> model.nbody, model.njnt  # the world and two bricks, each with its free joint
(3, 2)

Source: stackdsl's own; the box's inertia is a textbook closed form (see :func:`box_inertia`).
"""

from __future__ import annotations

import os
import xml.etree.ElementTree as ET
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ..engines.mujoco.materials import Contact, Materials
from ..engines.mujoco.settings import MuJoCoSettings
from ..engines.protocol import BrickSpec, EngineSettings
from ..engines.settings import defaults, settings
from ..runtime.trajectory import ABSENT, STATES, Trajectory
from ..util.files import written
from .render import COLOURS, resolve_time

#: The built-in pine's density (kg/m^3) and friction coefficient, for bricks whose spec is unknown.
PINE_DENSITY, PINE_FRICTION = 460.0, 0.5


@dataclass(frozen=True)
class Snapshot:
    """The bodies of a run at one moment.

    Attributes:
        time: seconds; name: the scenario's name.
        ids, levels, states: per body in the world (0 for a projectile's level).
        half_extents, positions: (bodies, 3), metres; orientations: (bodies, 4), (x, y, z, w).
        fixture_ids, fixture_half_extents, fixture_positions, fixture_orientations: the fixed bodies.
        specs: brick (or fixed body) id -> :class:`stackdsl.engines.protocol.BrickSpec` (mass,
            friction, restitution), when known.
        ground_friction, ground_restitution: of the ground's material.
    """

    time: float
    name: str
    ids: list[str]
    levels: list[int]
    states: list[str]
    half_extents: np.ndarray
    positions: np.ndarray
    orientations: np.ndarray
    fixture_ids: list[str]
    fixture_half_extents: np.ndarray
    fixture_positions: np.ndarray
    fixture_orientations: np.ndarray
    specs: dict[str, BrickSpec] = field(default_factory=dict)
    ground_friction: float = PINE_FRICTION
    ground_restitution: float = 0.0

    def mass(self, i: int) -> float:
        """kg, of body ``i``: its spec's, else pine's density times its volume."""
        spec = self.specs.get(self.ids[i])
        return spec.mass if spec is not None else float(PINE_DENSITY * 8.0 * np.prod(self.half_extents[i]))

    def friction(self, i: int) -> float:
        """The friction coefficient of body ``i``: its spec's, else pine's."""
        spec = self.specs.get(self.ids[i])
        return spec.friction if spec is not None else PINE_FRICTION

    def material(self, body: str) -> tuple[float, float]:
        """(friction, restitution) of the brick or fixed body ``body``: its spec's, else pine's."""
        spec = self.specs.get(body)
        return (spec.friction, spec.restitution) if spec is not None else (PINE_FRICTION, 0.0)


def snapshot(
    trajectory: Trajectory,
    at: str | float,
    specs: dict[str, BrickSpec] | None = None,
    ground_friction: float = PINE_FRICTION,
    ground_restitution: float = 0.0,
) -> Snapshot:
    """The bodies in the world at ``at``: ``"collapse"`` (as a picture's, :func:`stackdsl.draw.render.resolve_time`),
    ``"end"`` or seconds.

    Raises:
        ValueError: ``"collapse"`` and nothing collapsed; a time outside the run.
    """
    frame = trajectory.at(resolve_time(trajectory, at))
    present = ~np.isnan(frame.positions[:, 0]) & (frame.states != ABSENT)  # not yet placed, or taken out
    return Snapshot(
        time=frame.time,  # the frame's own: the last at or before the time asked for
        name=str(trajectory.meta.get("scenario") or "stackdsl"),
        ids=[str(i) for i in trajectory.ids[present].tolist()],
        levels=[int(v) for v in trajectory.levels[present].tolist()],
        states=[STATES[s] for s in frame.states[present]],
        half_extents=trajectory.half_extents[present],
        positions=frame.positions[present],
        orientations=frame.orientations[present],
        fixture_ids=[str(i) for i in trajectory.fixture_ids.tolist()],
        fixture_half_extents=trajectory.fixture_half_extents,
        fixture_positions=trajectory.fixture_positions_at(frame.index),  # carried by a shake's ground
        fixture_orientations=trajectory.fixture_orientations,
        specs=dict(specs or {}),
        ground_friction=ground_friction,
        ground_restitution=ground_restitution,
    )


def recorded_engine(meta: dict[str, object]) -> EngineSettings | None:
    """The engine settings a trajectory file's ``meta`` records (backend, mode, timestep), the
    rest at that mode's defaults; None when it does not say."""
    backend, mode, timestep = meta.get("backend"), meta.get("mode"), meta.get("timestep")
    try:
        values = defaults(str(backend), str(mode))
        if isinstance(timestep, float):
            values["timestep"] = timestep
        return settings(str(backend), mode=mode, **values)
    except (KeyError, ValueError):  # an older file (no backend), or one this version does not know
        return None


def mujoco_settings(run: EngineSettings | None) -> tuple[MuJoCoSettings, str]:
    """The MuJoCo settings an exported MJCF carries, and why those: the run's own when it ran on
    MuJoCo alone (``raw`` or ``tuned``, with the file's values); otherwise MuJoCo's ``tuned`` mode
    at the run's gravity. A run on pybullet has no MuJoCo settings, and MuJoCo's extension mode
    steps at 4 ms with contacts twice as soft because the extension freezes what rests: in plain
    MuJoCo, without it, a single-file staircase 1.5 mm inside its tipping margin moves 49 mm in
    2 s at those settings, 0.35 mm at the tuned ones.

    >>> settings, why = mujoco_settings(None)
    >>> settings.mode, settings.timestep, settings.elliptic_cones, why
    ('tuned', 0.002, True, "stackdsl's tuned MuJoCo mode")
    """
    if isinstance(run, MuJoCoSettings) and run.mode != "extension":
        return run, f"the run's own MuJoCo settings ({run.mode} mode)"
    tuned = MuJoCoSettings.model_validate(
        {**MuJoCoSettings.DEFAULTS["tuned"], "mode": "tuned", "gravity": run.gravity if run is not None else 9.81}
    )
    if run is None:
        return tuned, "stackdsl's tuned MuJoCo mode"
    if isinstance(run, MuJoCoSettings):
        return tuned, (
            "stackdsl's tuned MuJoCo mode, not the run's extension mode, whose 4 ms step and softer contacts "
            "rely on the extension freezing what rests"
        )
    return tuned, f"stackdsl's tuned MuJoCo mode (the run was on {run.NAME})"


def box_inertia(mass: float, half_extents: np.ndarray) -> tuple[float, float, float]:
    """The principal moments of inertia (kg m^2) of a solid box of ``mass`` kg and ``half_extents``
    (m) about its centre: I_x = m (b^2 + c^2) / 12 with b, c the full sides across x, and so on.

    Source: the rectangular prism of J. L. Meriam and L. G. Kraige, Engineering Mechanics:
    Dynamics, Appendix B, Table D/4.
    """
    a, b, c = (2.0 * float(h) for h in half_extents)
    return mass * (b * b + c * c) / 12.0, mass * (a * a + c * c) / 12.0, mass * (a * a + b * b) / 12.0


def _numbers(values: np.ndarray | list[float] | tuple[float, ...], digits: int = 9) -> str:
    return " ".join(f"{float(v):.{digits}g}" for v in values)


def _wxyz(q: np.ndarray) -> np.ndarray:
    """(x, y, z, w) -> MuJoCo's (w, x, y, z)."""
    return np.array([q[3], q[0], q[1], q[2]])


def _rgba(key: str, alpha: float = 1.0) -> str:
    return _numbers([*COLOURS[key], alpha], 4)


def colour_key(level: int, state: str) -> str:
    """The :data:`stackdsl.draw.render.COLOURS` key of a body: ``projectile`` (level 0) or its state."""
    return "projectile" if level == 0 else state if state in COLOURS else "active"


#: The body MuJoCo names itself: a brick of this id is named :func:`body_name` in MJCF.
MUJOCO_WORLD = "world"


def body_name(brick: str) -> str:
    """The MJCF body (and URDF link) name of the brick ``brick``: its id, but for a brick named ``world``, which
    MuJoCo's own world body is named (a second body of that name is refused): ``world#``, a name
    no body id can have ('#' is no character of an id).

    >>> body_name("L01.1"), body_name("world")
    ('L01.1', 'world#')
    """
    return f"{brick}#" if brick == MUJOCO_WORLD else brick


#: stackdsl's integrator names -> MJCF's keywords.
_INTEGRATORS = {"euler": "Euler", "implicitfast": "implicitfast"}


def _contact(element: ET.Element, contact: Contact) -> None:
    """``contact``'s values as attributes of a geom or a pair."""
    if contact.bit:
        element.set("contype", str(contact.bit))
        element.set("conaffinity", str(contact.bit))
    element.set("friction", _numbers(contact.friction, 6))
    element.set("solref", _numbers(contact.solref, 6))
    element.set("solimp", _numbers(contact.solimp, 6))


def _comment(scene: Snapshot, engine: MuJoCoSettings, why: str) -> str:
    """What the file is and which MuJoCo settings it carries, said in the file."""
    sleep = "" if engine.sleep_tolerance is None else f", MuJoCo's sleeping at tolerance {engine.sleep_tolerance:g}"
    text = (
        f" Written by stackdsl export: the bodies at t = {scene.time:.3f} s of the run, at their poses, at rest"
        f" (velocities are not written). MuJoCo options: {why}: timestep {engine.timestep:g} s, gravity"
        f" {engine.gravity:g} m/s^2, {engine.solver_iterations} iterations,"
        f" {'elliptic' if engine.elliptic_cones else 'pyramidal'} cones, impratio {engine.impratio:g},"
        f" {engine.integrator}{sleep}; every geom solref ({engine.solref[0]:g} s, damping ratio {engine.solref[1]:g},"
        " a material's restitution lowering it) and solimp"
        f" ({', '.join(f'{v:g}' for v in engine.solimp)} m). Friction: each geom its material's; two geoms of"
        " different materials collide only through an explicit contact pair with the geometric mean of their"
        " coefficients, as stackdsl's MuJoCo world sets them. "
    )
    return text.replace("--", "- -")  # a comment may not hold two hyphens in a row


def mjcf(scene: Snapshot, *, mocap: bool = False, engine: EngineSettings | None = None) -> str:
    """``scene`` as MuJoCo XML (MJCF): a ground plane, each fixed body a static box, each brick a
    body at its pose with a free joint (``mocap``: a mocap body instead, moved by setting
    ``data.mocap_pos``/``mocap_quat``, as :mod:`stackdsl.draw.live` does; the ground plane and
    the fixed boxes then in one mocap body named ``ground`` at the origin, which a shake moves)
    and a box geom of its mass, friction and state colour. Names are the bricks' ids (a body's
    name is :func:`body_name`'s: MuJoCo keeps ``world`` for its own world body).

    MuJoCo's options and every geom's contact values are those of :func:`mujoco_settings` for
    ``engine`` (the run's settings; None: a run of unknown settings), with the materials' contact
    pairs as stackdsl's MuJoCo world declares them (none in a ``mocap`` model, which is not
    stepped); a comment at the top of the file says which."""
    settings, why = mujoco_settings(engine)
    materials = Materials(settings, (scene.ground_friction, scene.ground_restitution))
    root = ET.Element("mujoco", model=scene.name)
    root.append(ET.Comment(_comment(scene, settings, why)))
    ET.SubElement(root, "compiler", angle="radian")
    option = ET.SubElement(
        root,
        "option",
        timestep=f"{settings.timestep:.6g}",
        gravity=f"0 0 {-settings.gravity:.6g}",
        iterations=str(settings.solver_iterations),
        cone="elliptic" if settings.elliptic_cones else "pyramidal",
        impratio=f"{settings.impratio:.6g}",
        integrator=_INTEGRATORS[settings.integrator],
    )
    if settings.sleep_tolerance is not None:
        option.set("sleep_tolerance", f"{settings.sleep_tolerance:.6g}")
        ET.SubElement(option, "flag", sleep="enable")
    if len(scene.positions):  # the viewers' free camera frames the bricks, not the ground plane
        reach = float(np.max(scene.half_extents))
        low, high = scene.positions.min(axis=0) - reach, scene.positions.max(axis=0) + reach
        low[2] = min(low[2], 0.0)
        ET.SubElement(root, "statistic", center=_numbers((low + high) / 2), extent=f"{0.6 * float(np.max(high - low)):.6g}")
    visual = ET.SubElement(root, "visual")
    ET.SubElement(visual, "headlight", ambient="0.4 0.4 0.4", diffuse="0.6 0.6 0.6")
    asset = ET.SubElement(root, "asset")  # the ground in 0.1 m squares
    ground_rgb = np.array(COLOURS["ground"])
    ET.SubElement(
        asset,
        "texture",
        name="ground",
        type="2d",
        builtin="checker",
        rgb1=_numbers(ground_rgb * 0.9, 3),
        rgb2=_numbers(ground_rgb * 0.8, 3),
        mark="edge",
        markrgb=_numbers(ground_rgb * 0.6, 3),
        width="200",
        height="200",
    )
    ET.SubElement(asset, "material", name="ground", texture="ground", texrepeat="10 10", texuniform="true")
    world = ET.SubElement(root, "worldbody")
    span = float(np.abs(scene.positions).max()) if len(scene.positions) else 1.0
    ET.SubElement(world, "light", pos=f"0 0 {max(2.0, 3 * span):.3g}", dir="0 0 -1", directional="true")
    table = world
    if mocap:  # the ground and the fixtures bolted to it, moved together as a shake moves them
        table = ET.SubElement(world, "body", name="ground", pos="0 0 0", mocap="true")
    ground = (scene.ground_friction, scene.ground_restitution)
    _contact(
        ET.SubElement(
            table,
            "geom",
            name="ground",
            type="plane",
            size=f"{max(1.0, 2 * span):.3g} {max(1.0, 2 * span):.3g} 0.05",
            material="ground",
        ),
        materials.contact(*ground),
    )
    static = [("ground", ground)]  # geom name -> material: what cannot move
    for fid, half, position, quaternion in zip(
        scene.fixture_ids, scene.fixture_half_extents, scene.fixture_positions, scene.fixture_orientations
    ):
        geom = ET.SubElement(
            table,
            "geom",
            name=fid,
            type="box",
            size=_numbers(half),
            pos=_numbers(position),
            quat=_numbers(_wxyz(quaternion)),
            rgba=_rgba("fixture"),
        )
        _contact(geom, materials.contact(*scene.material(fid)))
        static.append((fid, scene.material(fid)))
    moving: list[tuple[str, tuple[float, float]]] = []
    for i, brick in enumerate(scene.ids):
        body = ET.SubElement(
            world, "body", name=body_name(brick), pos=_numbers(scene.positions[i]), quat=_numbers(_wxyz(scene.orientations[i]))
        )
        if mocap:
            body.set("mocap", "true")
        else:
            ET.SubElement(body, "freejoint", name=brick)
        geom = ET.SubElement(
            body,
            "geom",
            name=brick,
            type="box",
            size=_numbers(scene.half_extents[i]),
            mass=f"{scene.mass(i):.6g}",
            rgba=_rgba(colour_key(scene.levels[i], scene.states[i])),
        )
        _contact(geom, materials.contact(*scene.material(brick)))
        moving.append((brick, scene.material(brick)))
    pairs = [] if mocap else _pairs(moving, static)
    if pairs:
        contact = ET.SubElement(root, "contact")
        for one, other in pairs:
            _contact(ET.SubElement(contact, "pair", geom1=one[0], geom2=other[0]), materials.pair(one[1], other[1]))
    ET.indent(root)
    return ET.tostring(root, encoding="unicode") + "\n"


_Geom = tuple[str, tuple[float, float]]


def _pairs(moving: list[_Geom], static: list[_Geom]) -> list[tuple[_Geom, _Geom]]:
    """Every two geoms of different materials (each (friction, restitution)) that can touch: a
    moving one and a static one, or two moving ones (two static geoms never move into each other).
    Each material has its own collision bit, so these collide only through such a pair."""
    out = [(m, s) for m in moving for s in static if m[1] != s[1]]
    out += [(a, b) for k, a in enumerate(moving) for b in moving[k + 1 :] if a[1] != b[1]]
    return out


def urdf(scene: Snapshot) -> str:
    """``scene`` as one URDF robot: the root link ``ground`` (a static 0.1 m thick slab whose
    top is z = 0, and the fixed bodies), each brick a link on a ``floating`` joint from the
    ground at its pose (``rpy``: roll, pitch, yaw about fixed x, y, z), with its mass, box
    inertia (:func:`box_inertia`) and state colour; links are named as :func:`body_name` names
    MJCF bodies (MuJoCo reads a link named ``world`` as its world body). A URDF is one
    multibody: MuJoCo frees its floating joints, pybullet fixes them (every brick welded to the
    ground); for pybullet, :func:`sdf`."""
    from scipy.spatial.transform import Rotation

    robot = ET.Element("robot", name=scene.name)
    for key in dict.fromkeys(["ground", "fixture", *(colour_key(v, s) for v, s in zip(scene.levels, scene.states))]):
        ET.SubElement(ET.SubElement(robot, "material", name=key), "color", rgba=_rgba(key))
    ground = ET.SubElement(robot, "link", name="ground")
    inertial = ET.SubElement(ground, "inertial")
    ET.SubElement(inertial, "mass", value="0")
    ET.SubElement(inertial, "inertia", ixx="0", iyy="0", izz="0", ixy="0", ixz="0", iyz="0")
    span = max(1.0, 2 * float(np.abs(scene.positions).max())) if len(scene.positions) else 1.0
    boxes = [(np.array([span, span, 0.05]), np.array([0.0, 0.0, -0.05]), np.array([0.0, 0.0, 0.0, 1.0]), "ground")]
    boxes += [
        (h, p, q, "fixture") for h, p, q in zip(scene.fixture_half_extents, scene.fixture_positions, scene.fixture_orientations)
    ]
    for half, position, quaternion, material in boxes:
        rpy = Rotation.from_quat(quaternion).as_euler("xyz")
        for kind in ("visual", "collision"):
            element = ET.SubElement(ground, kind)
            ET.SubElement(element, "origin", xyz=_numbers(position), rpy=_numbers(rpy))
            ET.SubElement(ET.SubElement(element, "geometry"), "box", size=_numbers(2 * np.asarray(half)))
            if kind == "visual":
                ET.SubElement(element, "material", name=material)
    for i, brick in enumerate(scene.ids):
        link = ET.SubElement(robot, "link", name=body_name(brick))
        inertial = ET.SubElement(link, "inertial")
        mass = scene.mass(i)
        ET.SubElement(inertial, "mass", value=f"{mass:.6g}")
        ixx, iyy, izz = box_inertia(mass, scene.half_extents[i])
        ET.SubElement(inertial, "inertia", ixx=f"{ixx:.6g}", iyy=f"{iyy:.6g}", izz=f"{izz:.6g}", ixy="0", ixz="0", iyz="0")
        for kind in ("visual", "collision"):
            element = ET.SubElement(link, kind)
            ET.SubElement(ET.SubElement(element, "geometry"), "box", size=_numbers(2 * scene.half_extents[i]))
            if kind == "visual":
                ET.SubElement(element, "material", name=colour_key(scene.levels[i], scene.states[i]))
        joint = ET.SubElement(robot, "joint", name=brick, type="floating")
        ET.SubElement(joint, "parent", link="ground")
        ET.SubElement(joint, "child", link=body_name(brick))
        rpy = Rotation.from_quat(scene.orientations[i]).as_euler("xyz")
        ET.SubElement(joint, "origin", xyz=_numbers(scene.positions[i]), rpy=_numbers(rpy))
    ET.indent(robot)
    return '<?xml version="1.0"?>\n' + ET.tostring(robot, encoding="unicode") + "\n"


def _sdf_pose(position: np.ndarray, quaternion: np.ndarray) -> str:
    """SDFormat's ``<pose>``: x y z (m) and roll pitch yaw (rad) about the fixed x, y, z axes."""
    from scipy.spatial.transform import Rotation

    return _numbers([*position, *Rotation.from_quat(quaternion).as_euler("xyz")])


def _sdf_box(parent: ET.Element, kind: str, name: str, half: np.ndarray, pose: str | None = None) -> ET.Element:
    """A ``<collision>`` or ``<visual>`` box of ``half`` extents (m) under ``parent``."""
    element = ET.SubElement(parent, kind, name=name)
    if pose is not None:
        ET.SubElement(element, "pose").text = pose
    ET.SubElement(ET.SubElement(ET.SubElement(element, "geometry"), "box"), "size").text = _numbers(2 * np.asarray(half))
    return element


def _sdf_material(link: ET.Element, collisions: list[ET.Element], friction: float, restitution: float) -> None:
    """A link's friction and restitution: pybullet's own ``<contact>`` element (each body the
    square root of its material's values, as stackdsl's pybullet world sets them: Bullet
    multiplies the two bodies', :mod:`stackdsl.engines.pybullet.world`), and SDFormat's
    ``<surface>`` of each collision, the material's own coefficients, for other readers."""
    contact = ET.SubElement(link, "contact")
    ET.SubElement(contact, "lateral_friction").text = f"{np.sqrt(friction):.6g}"
    ET.SubElement(contact, "restitution").text = f"{np.sqrt(restitution):.6g}"
    for collision in collisions:
        surface = ET.SubElement(collision, "surface")
        ode = ET.SubElement(ET.SubElement(surface, "friction"), "ode")
        ET.SubElement(ode, "mu").text = f"{friction:.6g}"
        ET.SubElement(ode, "mu2").text = f"{friction:.6g}"
        ET.SubElement(ET.SubElement(surface, "bounce"), "restitution_coefficient").text = f"{restitution:.6g}"


def _sdf_inertial(link: ET.Element, mass: float, half: np.ndarray | None) -> None:
    """A link's mass (kg) and box inertia (:func:`box_inertia`; all 0 for a static link, which
    pybullet then keeps still)."""
    inertial = ET.SubElement(link, "inertial")
    ET.SubElement(inertial, "mass").text = f"{mass:.6g}"
    moments = box_inertia(mass, half) if half is not None else (0.0, 0.0, 0.0)
    inertia = ET.SubElement(inertial, "inertia")
    for key, value in zip(("ixx", "ixy", "ixz", "iyy", "iyz", "izz"), (moments[0], 0, 0, moments[1], 0, moments[2])):
        ET.SubElement(inertia, key).text = f"{value:.6g}"


def _sdf_colour(visual: ET.Element, key: str) -> None:
    material = ET.SubElement(visual, "material")
    for channel in ("ambient", "diffuse"):
        ET.SubElement(material, channel).text = _rgba(key)


def sdf(scene: Snapshot) -> str:
    """``scene`` as an SDFormat 1.6 world of one model a body, which pybullet's ``loadSDF`` loads
    as one body a brick (a URDF is one multibody, whose bricks pybullet welds): a static model
    ``ground`` (a 0.1 m thick slab whose top is z = 0, and the fixed bodies, with mass 0, which
    pybullet keeps still), then each brick a model named by its id at its pose (``<pose>``: x y z,
    roll pitch yaw about the fixed axes), its one link of the brick's mass, box inertia
    (:func:`box_inertia`), friction and restitution (:func:`_sdf_material`) and state colour.

    >>> import pybullet, tempfile
    >>> scene = Snapshot(0.0, "two", ["a", "b"], [1, 2], ["frozen", "active"], np.full((2, 3), 0.01),
    ...     np.array([[0.0, 0.0, 0.01], [0.0, 0.0, 0.03]]), np.array([[0.0, 0.0, 0.0, 1.0]] * 2),
    ...     [], np.zeros((0, 3)), np.zeros((0, 3)), np.zeros((0, 4)))
    >>> folder = tempfile.TemporaryDirectory()
    >>> path = write_text(sdf(scene), f"{folder.name}/two.sdf")
    >>> client = pybullet.connect(pybullet.DIRECT)
    >>> [pybullet.getBodyInfo(b, physicsClientId=client)[1].decode() for b in pybullet.loadSDF(str(path), physicsClientId=client)]
    ['ground', 'a', 'b']
    >>> pybullet.disconnect(client); folder.cleanup()
    """
    root = ET.Element("sdf", version="1.6")
    world = ET.SubElement(root, "world", name=scene.name)
    model = ET.SubElement(world, "model", name="ground")
    ET.SubElement(model, "static").text = "true"
    link = ET.SubElement(model, "link", name="ground")
    _sdf_inertial(link, 0.0, None)
    span = max(1.0, 2 * float(np.abs(scene.positions).max())) if len(scene.positions) else 1.0
    collisions = []
    origin = _sdf_pose(np.array([0.0, 0.0, -0.05]), np.array([0.0, 0.0, 0.0, 1.0]))
    boxes = [("ground", np.array([span, span, 0.05]), origin, "ground")]
    boxes += [
        (fid, h, _sdf_pose(p, q), "fixture")
        for fid, h, p, q in zip(
            scene.fixture_ids, scene.fixture_half_extents, scene.fixture_positions, scene.fixture_orientations
        )
    ]
    for name, half, pose, colour in boxes:
        collisions.append(_sdf_box(link, "collision", name, half, pose))
        _sdf_colour(_sdf_box(link, "visual", name, half, pose), colour)
    _sdf_material(link, collisions, scene.ground_friction, scene.ground_restitution)
    for i, brick in enumerate(scene.ids):
        model = ET.SubElement(world, "model", name=brick)
        ET.SubElement(model, "pose").text = _sdf_pose(scene.positions[i], scene.orientations[i])
        link = ET.SubElement(model, "link", name=brick)
        _sdf_inertial(link, scene.mass(i), scene.half_extents[i])
        collision = _sdf_box(link, "collision", brick, scene.half_extents[i])
        _sdf_colour(_sdf_box(link, "visual", brick, scene.half_extents[i]), colour_key(scene.levels[i], scene.states[i]))
        _sdf_material(link, [collision], *scene.material(brick))
    ET.indent(root)
    return '<?xml version="1.0"?>\n' + ET.tostring(root, encoding="unicode") + "\n"


def write_text(text: str, path: str | os.PathLike[str]) -> Path:
    """Write ``text`` at ``path`` whole or not at all (:func:`stackdsl.util.files.written`).

    Raises:
        OSError: the file cannot be written.
    """
    with written(path) as part:
        Path(part).write_text(text, encoding="utf-8")
    return Path(path)


__all__ = ["Snapshot", "box_inertia", "mjcf", "mujoco_settings", "recorded_engine", "sdf", "snapshot", "urdf", "write_text"]
