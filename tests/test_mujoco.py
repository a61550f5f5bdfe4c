"""The MuJoCo backend: materials, freezing, and the scenario library's verdicts on it.

The extension drives MuJoCo through the same ``stability.Engine`` protocol as pybullet;
these tests check the world adapter against closed forms and the library's expectations.
"""

import ast
import copy
import math
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from stability import Pose
from stackdsl import ScenarioError, Subscriber, compile_scenario, evaluate, load_scenario, parse_scenario, run_program
from stackdsl.engines.mujoco.materials import damping_ratio
from stackdsl.engines.mujoco.settings import MuJoCoSettings
from stackdsl.engines.mujoco.world import MuJoCoWorld
from stackdsl.engines.protocol import BrickSpec

ROOT = Path(__file__).resolve().parents[1]
KAPLA = (0.06, 0.012, 0.004)
G = 9.81


def _world(mode: str = "tuned", ground_friction: float = 0.5, **extra) -> MuJoCoWorld:
    settings = MuJoCoSettings.model_validate({"mode": mode, **MuJoCoSettings.DEFAULTS[mode], **extra})
    return MuJoCoWorld(settings, ground_friction, 0.0)


def _brick(friction: float = 0.5, restitution: float = 0.0) -> BrickSpec:
    mass = 8 * math.prod(KAPLA) * 460.0
    return BrickSpec(type="kapla", half_extents=KAPLA, mass=mass, friction=friction, restitution=restitution)


def _slide(ground: float, brick: float, speed: float = 0.4) -> float:
    """Metres a brick thrown along the ground at ``speed`` slides before it stops."""
    world = _world(ground_friction=ground)
    body = world.create(_brick(brick), Pose.from_euler([0.0, 0.0, 0.004]))
    for _ in range(50):  # settle onto the ground first
        world.step()
    start = world.pose(body).position.copy()
    world.throw(body, (speed, 0.0, 0.0), None)
    for _ in range(500):
        world.step()
    return float(world.pose(body).position[0] - start[0])


@pytest.mark.parametrize(("ground", "brick"), [(0.5, 0.5), (0.2, 0.8)])
def test_a_pair_has_the_geometric_mean_of_its_materials_friction(ground, brick):
    """Sliding distance under Coulomb friction: v^2 / (2 mu g), mu the pair's coefficient,
    sqrt(ground * brick) as on pybullet (MuJoCo's own rule would take the larger)."""
    mu = math.sqrt(ground * brick)
    expected = 0.4**2 / (2 * mu * G)
    assert _slide(ground, brick) == pytest.approx(expected, rel=0.05)


def test_restitution_becomes_a_damping_ratio_whose_bounce_is_that_restitution():
    """A linear spring-damper with damping ratio zeta rebounds with exp(-zeta pi / sqrt(1 - zeta^2))."""
    for e in (0.1, 0.5, 0.9):
        zeta = damping_ratio(e, 1.0)
        assert math.exp(-zeta * math.pi / math.sqrt(1 - zeta**2)) == pytest.approx(e)


@pytest.mark.parametrize("mode", ["tuned", "extension"])
def test_with_no_hand_a_step_is_mujocos_own(mode):
    """The hand's blows and the limit on what friction is asked apply to the hand and what it
    struck: a brick thrown along the ground (it skips, as MuJoCo's own contact does) steps
    bit for bit as mj_step steps a copy."""
    import mujoco

    world = _world(mode)
    body = world.create(_brick(), Pose.from_euler([0.0, 0.0, 0.004]))
    for _ in range(50):
        world.step()
    world.throw(body, (1.0, 0.0, 0.0), None)
    m, d = world._ready()
    copy_data = copy.copy(d)
    for _ in range(200):
        world.step()
        mujoco.mj_step(m, copy_data)
    np.testing.assert_array_equal(d.qpos, copy_data.qpos)
    np.testing.assert_array_equal(d.qvel, copy_data.qvel)


class _Path(Subscriber):
    """The last centre of brick ``brick`` and its highest once the push has begun."""

    def __init__(self, brick: str) -> None:
        self.brick, self.top, self.last = brick, -math.inf, (math.nan, math.nan, math.nan)

    def after_step(self, loop) -> None:
        record = loop.structure.records.get(self.brick)
        if record is not None:
            self.last = loop.world.pose_floats(record.body)[0]
            if "pusher1" in loop.structure.records:
                self.top = max(self.top, self.last[2])


@pytest.mark.parametrize("mode", ["tuned", "extension"])
@pytest.mark.parametrize(("speed", "pusher", "height"), [(0.5, "finger", 0), (1.0, None, 0), (1.5, "finger", 2)])
def test_a_pushed_brick_slides_as_far_as_coulomb_says_and_stays_on_the_ground(mode, speed, pusher, height):
    """A KAPLA brick lying on the ground, pushed end on: the pusher meets it after its 5 mm gap,
    carries it the other 25 mm of its stroke, is withdrawn, and the brick slides v^2 / (2 mu g)
    more. MuJoCo started the brick's slip within the step the pusher met it, and so threw it
    up at mu times its speed and forward faster than the pusher: at 1 m/s 28 mm high and 300 mm
    on instead of 127 (a domino beyond its reach fell). The pusher's default is a KAPLA brick
    itself; the finger is 20 x 10 x 6 mm, pushing at the brick's centre or 2 mm above."""
    text = (
        "stackdsl: 1\nbrick_types: {finger: {size: [20 mm, 10 mm, 6 mm]}}\n"
        "structure: {bricks: [{id: b, at: [0, 0, 4 mm]}]}\n"
        f"actions:\n  - push: {{target: {{brick: b, offset: [-60 mm, 0, {height} mm]}}, direction: [1, 0, 0], "
        f"speed: {speed} m/s, distance: 30 mm, at: after level 1{f', pusher: {pusher}' if pusher else ''}}}\n"
        f"engine: {{backend: mujoco, mode: {mode}}}\ntiming: {{settle: 2 s}}\n"
    )
    path = _Path("b")
    run_program(compile_scenario(parse_scenario(text, "push.yaml")), subscribers=(path,))
    slid = 0.030 - 0.005 + speed**2 / (2 * 0.5 * G)
    assert path.last[0] == pytest.approx(slid, abs=0.003 + 0.04 * slid)
    assert path.top - 0.004 < 0.0008


@pytest.mark.parametrize("mode", ["tuned", "extension"])
def test_a_brick_pushed_from_under_another_leaves_it_on_top(mode):
    """The lower of two KAPLA bricks pushed end on at 1 m/s slides out from under the upper one,
    which friction drags along at mu g: neither leaves its level. MuJoCo threw the upper one
    72 mm high and the lower one 300 mm on."""
    text = (
        "stackdsl: 1\nbrick_types: {finger: {size: [20 mm, 10 mm, 6 mm]}}\n"
        "structure: {bricks: [{id: b, at: [0, 0, 4 mm], level: 1}, {id: t, at: [10 mm, 3 mm, 12 mm], level: 2}]}\n"
        "actions:\n  - push: {target: {brick: b, offset: [-60 mm, 0, 0]}, direction: [1, 0, 0], "
        "speed: 1.0 m/s, distance: 30 mm, at: after level 2, pusher: finger}\n"
        f"engine: {{backend: mujoco, mode: {mode}}}\ntiming: {{settle: 2 s}}\n"
    )
    low, high = _Path("b"), _Path("t")
    run_program(compile_scenario(parse_scenario(text, "push.yaml")), subscribers=(low, high))
    assert low.top - 0.004 < 0.0008 and high.top - 0.012 < 0.001
    # braked at 3 mu g at most (its load and the upper one's drag), and by the upper one too
    assert 0.025 + 1.0 / (6 * 0.5 * G) < low.last[0] < 0.025 + 1.0 / (2 * 0.5 * G)
    assert high.last[2] > 0.010  # still on it


@pytest.mark.parametrize("mode", ["raw", "tuned", "extension"])
@pytest.mark.parametrize("e", [0.3, 0.5, 0.8])
def test_a_dropped_brick_bounces_with_its_restitution(mode, e):
    """A brick of restitution e dropped flat 50 mm onto a ground of the same rises e^2 of it.
    At the setting's own time constant a small damping ratio made the contact ring faster than
    the timestep could follow: tuned MuJoCo bounced a brick of e = 0.5 back 2.5 times as fast as it fell."""
    settings = MuJoCoSettings.model_validate({"mode": mode, **MuJoCoSettings.DEFAULTS[mode]})
    world, drop = MuJoCoWorld(settings, 0.5, e), 0.05
    body = world.create(_brick(restitution=e), Pose.from_euler([0.0, 0.0, 0.004 + drop]))
    heights = []
    for _ in range(round(0.6 / settings.timestep)):
        world.step()
        heights.append(float(world.pose(body).position[2]) - 0.004)
    landed = int(np.argmin(heights[: round(0.2 / settings.timestep)]))
    assert math.sqrt(max(heights[landed:]) / drop) == pytest.approx(e, abs=0.05)


@pytest.mark.parametrize("mode", ["tuned", "extension"])
def test_a_stack_of_bouncy_bricks_stands(mode):
    """Three bricks of restitution 0.5 in a single file: they flew metres apart on tuned MuJoCo."""
    text = (
        "stackdsl: 1\nmaterials: {bouncy: {density: 600, friction: 0.5, restitution: 0.5}}\n"
        "brick_types: {kapla: {size: [120 mm, 24 mm, 8 mm], material: bouncy}}\n"
        "structure: {tower: {levels: 3, bricks_per_layer: 1, turn: 0}}\n"
        f"engine: {{backend: mujoco, mode: {mode}}}\nexpect: {{stands: true}}\n"
    )
    outcome = run_program(compile_scenario(parse_scenario(text)))
    assert outcome.collapse is None and max(outcome.displacement.values()) < 0.001


@pytest.mark.parametrize("mode", ["raw", "tuned"])
def test_a_brick_put_down_at_rest_settles_whatever_its_restitution(mode):
    """An underdamped contact threw a resting brick off the ground every few steps (a step of
    free fall takes it g dt^2 = 39 um into the ground at 2 ms, the spring throws it back above):
    it hopped 0.04 mm without end on tuned MuJoCo from e = 0.1. A contact bounces only while
    one of its bodies is fast."""
    settings = MuJoCoSettings.model_validate({"mode": mode, **MuJoCoSettings.DEFAULTS[mode]})
    world = MuJoCoWorld(settings, 0.5, 0.5)
    body = world.create(_brick(restitution=0.5), Pose.from_euler([0.0, 0.0, 0.004]))
    heights = []
    for _ in range(round(1.0 / settings.timestep)):
        world.step()
        heights.append(float(world.pose(body).position[2]))
    late = heights[len(heights) // 2 :]
    assert max(late) - min(late) < 1e-6 and max(late) <= 0.004


@pytest.mark.slow
@pytest.mark.parametrize(("mode", "e", "levels"), [("tuned", 0.3, 4), ("raw", 0.5, 4), ("extension", 0.99, 10)])
def test_a_stack_of_bouncy_bricks_put_down_at_rest_stands(mode, e, levels):
    """A 4 stack of restitution 0.3 fell at level 3 on tuned MuJoCo, one of 0.99 at 2 with the
    extension, its lowest bricks never at rest (0.99 is refused for its bounces: run past the limits)."""
    text = (
        f"stackdsl: 1\nmaterials: {{rubber: {{restitution: {e}}}}}\nbrick_types: {{k: {{material: rubber}}}}\n"
        f"ground: {{material: rubber}}\nstructure: {{tower: {{levels: {levels}, brick: k}}}}\n"
        f"engine: {{backend: mujoco, mode: {mode}}}\nexpect: {{stands: true}}\n"
    )
    outcome = run_program(compile_scenario(parse_scenario(text), limits=False))
    assert outcome.collapse is None and max(outcome.displacement.values()) < 0.001


def test_a_frozen_brick_does_not_move_when_a_brick_lands_on_it():
    world = _world()
    low = world.create(_brick(), Pose.from_euler([0.0, 0.0, 0.004]))
    for _ in range(50):
        world.step()
    world.set_frozen(low, True, _brick().mass)
    held = world.pose(low)
    top = world.create(_brick(), Pose.from_euler([0.01, 0.0, 0.0125], yaw=90.0))  # created after: the model is rebuilt
    for _ in range(200):
        world.step()
    assert np.array_equal(world.pose(low).position, held.position)
    assert np.allclose(world.velocity(low)[0], 0.0)
    assert world.pose(top).position[2] == pytest.approx(0.012, abs=2e-4)  # it landed on the frozen brick
    assert {c.other for c in world.contact_points([top])} == {low}
    world.set_frozen(top, True, _brick().mass)
    world.step()
    assert world.contact_points() == []  # two frozen bricks: no contact between them, none with the ground


def test_a_copy_without_collisions_is_out_of_mujocos_broadphase():
    """MuJoCo's broadphase filters bodies by their own contype and conaffinity (each the OR of
    its geoms' at compile time, not updated when a geom's are written): a brick's copy that
    collides with nothing must have zeros there too, or the broadphase sorts it every step."""
    world = _world()
    body = world.create(_brick(), Pose.from_euler([0.0, 0.0, 0.004]))
    world.step()  # the model is compiled at the first step
    m = world._model
    free, held = (m.geom_bodyid[g[body - 1]] for g in (world._free_geom, world._held_geom))
    for frozen in (True, False, True):
        world.set_frozen(body, frozen, _brick().mass)
        on, off = (held, free) if frozen else (free, held)
        assert m.body_contype[on] != 0 and m.body_conaffinity[on] != 0
        assert m.body_contype[off] == 0 and m.body_conaffinity[off] == 0


@pytest.mark.parametrize("mode", ["tuned", "extension"])
def test_a_restored_brick_falls_again(mode):
    """In extension mode the free body of a frozen brick sleeps where it waits (MuJoCo then
    steps none of its degrees of freedom); put back, it wakes and falls."""
    world = _world(mode)
    body = world.create(_brick(), Pose.from_euler([0.0, 0.0, 0.05]), mass=0.0)  # created frozen, in the air
    for _ in range(100):
        world.step()
    assert world.pose(body).position[2] == pytest.approx(0.05)
    assert world._data.nv_awake == (0 if mode == "extension" else 6)
    world.set_frozen(body, False, _brick().mass)
    for _ in range(150):
        world.step()
    assert world.pose(body).position[2] == pytest.approx(0.004, abs=2e-4)


def test_velocities_are_in_the_world_frame():
    world = _world()
    body = world.create(_brick(), Pose.from_euler([0.0, 0.0, 0.5], yaw=90.0, pitch=30.0))
    world.step()
    world._data.qvel[3:6] = [0.0, 0.0, 2.0]  # about the body's own z axis
    _, angular = world.velocity(body)
    axis = Pose.from_euler([0, 0, 0], yaw=90.0, pitch=30.0).rotation @ [0.0, 0.0, 2.0]
    assert np.allclose(angular, axis)
    assert np.allclose(world.velocities_of([body])[1][0], axis)


def test_many_bodies_read_at_once_match_one_by_one():
    """poses_of reads few bodies one by one and many at once: the same numbers, frozen bodies
    included (at their held pose). Velocities, read once a step for every body (one by one for
    few moving bodies, at once for many), are MuJoCo's own (mj_objectVelocity, world frame),
    zero for a frozen body, and read again after a step."""
    import mujoco

    world = _world()
    bodies = [world.create(_brick(), Pose.from_euler([0.2 * k, 0.0, 0.5], yaw=10.0 * k, pitch=5.0 * k)) for k in range(12)]
    world.step()
    world.set_frozen(bodies[3], True, 0.0)
    rng = np.random.default_rng(0)
    for b in bodies:
        if b != bodies[3]:
            world.throw(b, rng.normal(size=3), None)
            v = world._dof[b - 1]
            world._data.qvel[v + 3 : v + 6] = rng.normal(size=3)
    for chosen in (bodies[:2], bodies):  # one by one, and at once
        positions, quaternions = world.poses_of(chosen)
        for k, b in enumerate(chosen):
            pose = world.pose(b)
            assert np.allclose(positions[k], pose.position) and np.allclose(quaternions[k], pose.orientation)

    def own(body):  # MuJoCo's (angular, linear) of the free body, world frame
        m, d = world._ready()
        out = np.zeros(6)
        mujoco.mj_objectVelocity(m, d, mujoco.mjtObj.mjOBJ_BODY, int(m.geom_bodyid[world._free_geom[body - 1]]), out, 0)
        return out[3:], out[:3]

    for moving in (bodies, bodies[:3]):  # many moving bodies, then few
        for b in bodies:
            if b not in moving:
                world.set_frozen(b, True, 0.0)
        mujoco.mj_forward(*world._ready())
        linear, angular = world.velocities_of(bodies)
        for k, b in enumerate(bodies):
            lin, ang = own(b) if b in moving and b != bodies[3] else (np.zeros(3), np.zeros(3))
            assert np.allclose(linear[k], lin) and np.allclose(angular[k], ang), (len(moving), k)
            assert np.allclose(world.velocity(b)[0], lin) and np.allclose(world.velocity(b)[1], ang)
        before = world.velocity(bodies[0])[0]
        world.step()  # gravity: 2 ms later the body falls faster
        assert world.velocity(bodies[0])[0][2] == pytest.approx(before[2] - G * 0.002, abs=1e-4)


@pytest.mark.parametrize("mode", ["raw", "tuned"])  # pyramidal and elliptic friction cones
def test_contact_points_carry_mujocos_own_normal_force(mode):
    """The normal forces read at once from the constraint forces are mj_contactForce's, and a
    brick resting on the ground carries its weight."""
    import mujoco

    world = _world(mode)
    body = world.create(_brick(), Pose.from_euler([0.0, 0.0, 0.0041]))
    for _ in range(100):
        world.step()
    points = world.contact_points([body])
    m, d = world._ready()
    force = np.zeros(6)
    own = []
    for i in range(d.ncon):
        mujoco.mj_contactForce(m, d, i, force)
        own.append(force[0])
    assert sorted(c.normal_force for c in points) == pytest.approx(sorted(own))
    assert sum(c.normal_force for c in points) == pytest.approx(_brick().mass * G, rel=0.02)


def test_a_pile_that_the_stack_test_would_wake_is_not_frozen():
    """The single-file stack shifted 7 mm a level falls at 18 (its closed form) on MuJoCo, and
    its bricks come to rest as a tower leaning on the floor. Friction holds that pile, but
    the report's load tree cannot carry it: frozen, the stack test would wake it at once,
    and each of its bricks was woken 29 times, once every rest duration. Now the pile is refused."""
    from collections import Counter

    from stackdsl.runtime.run import RunOptions

    text = "stackdsl: 1\nstructure: {tower: {levels: 20, bricks_per_layer: 1, turn: 0, shift: 7 mm}}\n"
    text += "engine: {mode: extension, backend: mujoco}\n"
    out = run_program(compile_scenario(parse_scenario(text, "slant.yaml")), RunOptions(stop_at_collapse=True))
    assert out.collapse is not None and out.collapse.level == 18
    wakes = Counter(e.brick for e in out.events if e.kind == "wake")
    assert wakes and max(wakes.values()) <= 2


def test_bricks_declared_up_front_or_as_they_come_give_the_same_answer():
    """Parked (every body in the first model) and rebuilt (the model compiled again as each
    brick enters) both build a 3-level tower that stands."""
    from stackdsl.runtime.run import RunOptions

    program = compile_scenario(parse_scenario("stackdsl: 1\nstructure: {tower: {levels: 3}}\n"), "extension", backend="mujoco")
    for lazy in (True, False):
        outcome = run_program(program, RunOptions(lazy_bodies=lazy))
        assert outcome.collapse is None and outcome.bricks_placed == 6
        assert max(outcome.displacement.values()) < 0.001


@pytest.mark.slow
def test_with_mujocos_sleeping_a_parked_brick_lands_where_it_is_put():
    """A parked body asleep far away and moved in stayed asleep 0.5 mm above its pose, in the
    air (every brick of the bench's parked peer drifted exactly the drop gap): a body out of
    the scene now never sleeps. Declared up front or as they come, the bricks land."""
    from stackdsl.runtime.run import RunOptions

    text = "stackdsl: 1\nstructure: {tower: {levels: 3}}\nengine: {mode: tuned, backend: mujoco, sleep_tolerance: 0.0001}\n"
    program = compile_scenario(parse_scenario(text))
    for lazy in (True, False):
        outcome = run_program(program, RunOptions(lazy_bodies=lazy))
        assert outcome.collapse is None and outcome.bricks_placed == 6
        assert max(outcome.displacement.values()) < 0.0002, lazy


SCENARIOS = sorted((ROOT / "scenarios").rglob("*.yaml"))
#: The two Jenga scenes take 8-12 s each on MuJoCo, the pushed KAPLA block 4-5 s: in .ci/nightly's slow
#: part (pytest -m slow); the default suite runs every one of them on pybullet (scenarios/).
LONG_ON_MUJOCO = {"jenga_falls", "jenga_stands", "kapla_push_out"}


@pytest.mark.parametrize(
    "path",
    [pytest.param(p, marks=pytest.mark.slow) if p.stem in LONG_ON_MUJOCO else p for p in SCENARIOS],
    ids=[p.stem for p in SCENARIOS],
)
def test_the_extension_on_mujoco_gives_the_librarys_verdicts(path):
    """Every shipped scenario gives its verdicts on MuJoCo too, or is refused as beyond what
    MuJoCo simulates faithfully (a projectile faster than its soft contacts stop), naming it."""
    scenario = load_scenario(path)
    try:
        program = compile_scenario(scenario, "extension", backend="mujoco")
    except ScenarioError as exc:
        assert "MuJoCo simulates" in exc.message, exc.message
        compile_scenario(scenario, "extension")  # pybullet takes it
        return
    outcome = run_program(program)
    failed = [v for v in evaluate(scenario.expect, outcome, program.collapse_threshold) if not v.passed]
    assert failed == []


def test_the_stability_package_knows_no_engine():
    """stability/ imports neither engine nor stackdsl, and names no backend: it sees an
    engine only through its Engine protocol."""
    for file in (ROOT / "stability").glob("*.py"):
        tree = ast.parse(file.read_text())
        imported = {a.name.split(".")[0] for n in ast.walk(tree) if isinstance(n, ast.Import) for a in n.names}
        imported |= {
            n.module.split(".")[0] for n in ast.walk(tree) if isinstance(n, ast.ImportFrom) and n.module and n.level == 0
        }
        assert imported <= {
            "__future__",
            "collections",
            "contextlib",
            "contextvars",
            "dataclasses",
            "enum",
            "graphlib",
            "heapq",
            "functools",
            "itertools",
            "math",
            "time",
            "typing",
            "warnings",
            "numpy",
            "scipy",
            "shapely",
            "highspy",
        }, file.name
        assert "mujoco" not in file.read_text().lower(), file.name


@pytest.mark.slow
def test_a_mujoco_setting_on_pybullet_is_bad_input(tmp_path):
    path = tmp_path / "s.yaml"
    path.write_text("stackdsl: 1\nstructure: {tower: {levels: 2}}\nengine:\n  sleep_tolerance: 0.0001\n")
    result = subprocess.run([sys.executable, "-m", "stackdsl", "check", str(path)], capture_output=True, text=True)
    assert result.returncode == 2
    assert "s.yaml:4:3:" in result.stderr and "sleep_tolerance is a mujoco setting" in result.stderr


@pytest.mark.slow
def test_an_unknown_backend_is_bad_input(tmp_path):
    result = subprocess.run(
        [sys.executable, "-m", "stackdsl", "check", str(ROOT / "scenarios" / "vee_stands.yaml"), "--backend", "bullet"],
        capture_output=True,
        text=True,
    )
    assert result.returncode == 2 and "unknown backend 'bullet'" in result.stderr


def test_the_freeze_means_chosen_holds_and_the_others_do_not():
    """Why frozen bricks are held mocap bodies (stackdsl bench freeze): a brick landing on a
    sleeping stack wakes it, and welded bricks move as free ones do; held ones stay put."""
    from stackdsl.bench.freeze import freeze_cost

    free, weld, sleep, held = (freeze_cost(6, m, seconds=0.3) for m in ("free", "weld", "sleep", "held"))
    assert held.frozen_moved_mm == 0.0
    assert weld.frozen_moved_mm > 0.5 * free.frozen_moved_mm > 0.0
    assert sleep.frozen_moved_mm > 0.5 * free.frozen_moved_mm
    with pytest.raises(ValueError, match="means is one of"):
        freeze_cost(6, "glue")


@pytest.mark.slow  # 3-5 s: in .ci/nightly's slow part
def test_mujocos_own_sleeping_still_drops_the_slant_tower_at_its_closed_form():
    """With MuJoCo's sleeping on (bricks parked up front, the runtime's default on MuJoCo) the
    slant tower falls at its closed form; when a parked brick moved in stayed asleep where it
    was put, the tower stood."""
    scenario = load_scenario(ROOT / "scenarios" / "slant_tower.yaml")
    program = compile_scenario(scenario, "tuned", backend="mujoco")
    program = program.model_copy(update={"engine": program.engine.model_copy(update={"sleep_tolerance": 1e-4})})
    outcome = run_program(program)
    assert outcome.collapse is not None and outcome.collapse.level == 9


def test_substeps_survive_a_brick_entering():
    """A recompiled model takes the spec's timestep; the split step must stay split."""
    world = _world()
    world.create(_brick(), Pose.from_euler([0.0, 0.0, 0.004]))
    world.set_substeps(4)
    world.create(_brick(), Pose.from_euler([0.3, 0.0, 0.004]))  # the model is compiled again
    assert world._model.opt.timestep == pytest.approx(world.timestep / 4)


def test_near_points_from_the_other_body_into_this_one():
    world = _world()
    low = world.create(_brick(), Pose.from_euler([0.0, 0.0, 0.004]), mass=0.0)
    high = world.create(_brick(), Pose.from_euler([0.0, 0.0, 0.013]), mass=0.0)  # 1 mm above it
    (hit,) = [c for c in world.near(high, 0.002) if c.other == low]
    assert hit.distance == pytest.approx(0.001, abs=1e-6)
    assert np.allclose(hit.normal, [0.0, 0.0, 1.0])


@pytest.mark.quick  # the quick set's run on MuJoCo
def test_a_frozen_tower_on_mujoco_keeps_its_heights():
    """MuJoCo's soft contacts let a brick at rest sink about 0.02 mm into the one below: a
    13-level tower frozen with the overlaps stood 0.2 mm low at its top. Each brick is now
    frozen out of them, at its height in the scenario (to the graph's 0.1 mm)."""
    text = "stackdsl: 1\nstructure: {tower: {levels: 13}}\nengine: {mode: extension, backend: mujoco}\n"
    outcome = run_program(compile_scenario(parse_scenario(text)))
    bricks = [n for n in outcome.final_graph.nodes if n.level is not None]
    assert outcome.collapse is None and len(bricks) == 26
    for node in bricks:
        assert node.position_mm[2] == pytest.approx((node.level - 0.5) * 8.0, abs=0.051), node.id


def test_an_unstable_simulation_stops_the_run_failed_and_prints_nothing(capfd):
    """MuJoCo resets its state when positions, velocities or accelerations blow up; a run on
    would judge bricks put back where the model declared them. A brick given a huge speed
    (past MuJoCo's 1e10) stands in for a blow-up: the step raises, in the run too (the run
    stops there, failed, with the reason), and MuJoCo's own warning is not printed."""
    from stackdsl.engines.protocol import EngineUnstable
    from stackdsl.runtime.loop import StepLoop

    world = _world("tuned")
    body = world.create(_brick(), Pose.from_euler([0.0, 0.0, 0.004]))
    for _ in range(5):
        world.step()
    world.throw(body, (1e12, 0.0, 0.0), None)
    with pytest.raises(EngineUnstable, match=r"became unstable at t = 0\.012 s"):
        world.step()
    assert "WARNING" not in capfd.readouterr().out

    class Blows(MuJoCoWorld):
        def step(self) -> None:
            raise EngineUnstable("it blew up")

    program = compile_scenario(parse_scenario("stackdsl: 1\nstructure: {tower: {levels: 2}}\nengine: {backend: mujoco}\n"))
    loop = StepLoop(Blows(program.engine, 0.5, 0.0), program, jump=False)
    loop.run()
    assert loop.stopped == "it blew up" and loop.step == 0


@pytest.mark.parametrize("mode", ["tuned", "extension"])
def test_a_held_brick_has_the_constants_mujoco_derives_for_its_mass(mode):
    """A brick in a hand's grip weighs GUIDED_MASS; the constants MuJoCo's compiler derives from
    the mass (the contact softness's ``invweight0``, ``dof_M0``, the subtree masses) must follow,
    as ``mj_setConst`` recomputes them, and come back when the hand lets go."""
    import mujoco

    world = _world(mode)
    body = world.create(_brick(), Pose.from_euler([0.0, 0.0, 0.004]))
    world.create(_brick(), Pose.from_euler([0.2, 0.0, 0.004]))
    world.step()
    m, _ = world._ready()
    names = ("body_invweight0", "dof_invweight0", "dof_M0", "body_subtreemass", "body_mass")
    own = {k: np.array(getattr(m, k)).copy() for k in names}
    world.guide(body, Pose.from_euler([0.0, 0.0, 0.004]), (0.1, 0.0, 0.0))
    held = {k: np.array(getattr(m, k)).copy() for k in names}
    derived = copy.copy(m)
    mujoco.mj_setConst(derived, mujoco.MjData(derived))
    for k in names:
        assert not np.allclose(held[k], own[k]), k
        np.testing.assert_allclose(held[k], getattr(derived, k), rtol=1e-9, err_msg=k)
    world.move(body, Pose.from_euler([0.0, 0.0, 0.004]), 0.0106)
    for k in names:
        np.testing.assert_allclose(getattr(m, k), own[k], rtol=1e-12, err_msg=k)


@pytest.mark.slow
def test_a_pusher_on_tuned_mujoco_pushes_the_shipped_domino_row_over():
    """The shipped domino row on the peer at its best: the pusher touching the first domino blew
    the simulation up when its 100 kg kept a 1 g finger's contact constants."""
    scenario = load_scenario(ROOT / "scenarios" / "dominoes_30.yaml")
    program = compile_scenario(scenario, "tuned", backend="mujoco")
    outcome = run_program(program)
    assert outcome.stopped is None
    failed = [v for v in evaluate(scenario.expect, outcome, program.collapse_threshold) if not v.passed]
    assert failed == []


@pytest.mark.slow
def test_the_extension_on_mujoco_topples_a_row_of_widely_spaced_dominoes():
    """Twenty dominoes 100 mm apart (of the 128 mm a KAPLA domino reaches): each top edge comes
    at the next domino's face down and forward. Judged by its centre of mass's heading, the
    blow was seen only after the frozen domino had stopped it (3 of 20 toppled)."""
    text = (
        "stackdsl: 1\nstructure: {dominoes: {count: 20, spacing: 100 mm}}\n"
        "engine: {backend: mujoco}\ntiming: {interval: 0.1 s, settle: 4 s}\n"
        "actions:\n  - push: {target: {brick: D01, offset: [0, 0, 45 mm]}, direction: [1, 0, 0],"
        " speed: 0.2 m/s, distance: 15 mm, at: after level 1}\n"
    )
    outcome = run_program(compile_scenario(parse_scenario(text, "row.yaml")))
    assert len(outcome.toppled) == 20


@pytest.mark.parametrize(
    "argv, said",
    [
        (["compare", "--backend", "mujoco,bullet"], "unknown backend 'bullet': give one or more of"),
        (["check", "--backend", "mujoco,pybullet"], "one backend, not 2 ('mujoco,pybullet'): give one of"),
    ],
)
def test_a_bad_backend_in_a_list_is_named_alone(argv, said, capsys):
    from stackdsl.cli.main import main

    assert main([argv[0], str(ROOT / "scenarios" / "vee_stands.yaml"), *argv[1:]]) == 2
    assert said in capsys.readouterr().err


_HIT_TOWER = """stackdsl: 1
structure: {tower: {levels: 30}}
impacts:
  - {projectile: kapla, target: {level: 30, side: +y}, speed: 3 m/s, at: after level 30}
timing: {interval: 0.2 s, settle: 1 s}
engine: {mode: extension, backend: mujoco}
"""


def _culled_run(monkeypatch, text: str, cull_from: int) -> tuple[object, int]:
    """The outcome of ``text`` with frozen bricks culled from ``cull_from`` on, and the most
    held geoms that were out of the collisions at once."""
    from stackdsl.engines.mujoco import culling

    monkeypatch.setattr(culling, "FROM", cull_from)
    most = [0]
    update = culling.Culling.update

    def counted(self, data, frozen):
        update(self, data, frozen)
        most[0] = max(most[0], int(self.out.sum()))

    monkeypatch.setattr(culling.Culling, "update", counted)
    outcome = run_program(compile_scenario(parse_scenario(text)))
    return outcome, most[0]


@pytest.mark.slow  # two 30-level MuJoCo runs, 4 s: in .ci/nightly's slow part
def test_frozen_bricks_out_of_reach_leave_mujocos_collisions_and_change_nothing(monkeypatch):
    """A frozen brick that nothing moving can reach within a step is out of MuJoCo's collision
    detection (its broad phase paired every two frozen neighbours, each step); a brick thrown
    into the tower, and everything it sets moving, still meets every brick it reaches: the run
    is the same, bit for bit, as with every frozen brick colliding."""
    culled, out = _culled_run(monkeypatch, _HIT_TOWER, 0)
    whole, none_out = _culled_run(monkeypatch, _HIT_TOWER, 10**9)
    assert none_out == 0 and out >= 50  # of 60 bricks, all but the few near what moves
    assert [e.model_dump() for e in culled.events] == [e.model_dump() for e in whole.events]
    assert culled.displacement == whole.displacement
    assert culled.final_graph == whole.final_graph and culled.collapse == whole.collapse
    assert max(culled.displacement.values()) > 0.004  # the throw moved bricks: contacts were made


def test_near_finds_frozen_bricks_out_of_the_collisions(monkeypatch):
    """The impact rule and the supports ask ``near`` for frozen neighbours, which culling may
    have taken out of MuJoCo's collisions: they are still found."""
    from stackdsl.engines.mujoco import culling

    monkeypatch.setattr(culling, "FROM", 0)
    world = _world("extension")
    bricks = [world.create(_brick(), Pose.from_euler([0.0, 0.0, 0.004 + 0.008 * k]), mass=0.0) for k in range(4)]
    world.step()
    assert world._culling is not None and world._culling.out.all()  # nothing moves: all out
    assert {c.other for c in world.near(bricks[1], 0.001)} == {bricks[0], bricks[2]}


def test_near_sees_a_body_where_it_was_just_put_and_where_it_is_after_a_step():
    """``mj_step`` leaves the geoms where their bodies were when it began, and a body put in
    place keeps its parked geom until MuJoCo computes them again: ``near`` asks for them anew."""
    world = _world("extension")
    a = world.create(_brick(), Pose.from_euler([0.0, 0.0, 0.004]))
    b = world.create(_brick(), Pose.from_euler([0.5, 0.0, 0.004]))
    world.step()
    assert world.near(a, 0.01, [b]) == []
    world.move(b, Pose.from_euler([0.125, 0.0, 0.004]), 0.0106)  # 5 mm from a's end, frozen
    (hit,) = world.near(a, 0.01, [b])
    assert hit.other == b and hit.distance == pytest.approx(0.005, abs=1e-4)
    world.move(b, Pose.from_euler([0.5, 0.0, 0.004]), 0.0106)
    world.throw(b, (-2.0, 0.0, 0.0), None)  # 8 mm a 4 ms step towards a
    world.step()
    x = world.pose(b).position[0]
    (hit,) = world.near(a, 0.5, [b])
    assert hit.distance == pytest.approx(x - 0.06 - 0.06, abs=2e-4)  # where b is now, not a step back


IMPACT_END_ON = """stackdsl: 1
structure: {{bricks: [{{id: b, at: [0, 0, 4 mm]}}]}}
impacts:
  - {{id: hit, target: {{point: [-60 mm, 0, 5 mm]}}, direction: [1, 0, 0], speed: {speed} m/s, distance: 20 mm, at: 1 s}}
timing: {{settle: 2 s}}
expect: {{moved: b}}
"""


@pytest.mark.parametrize("speed", [4.0, 8.0])
def test_a_brick_thrown_end_on_into_a_lying_one_passes_on_its_momentum_and_stays_behind(speed):
    """Equal KAPLA bricks, mu 0.5: the struck one leaves at least at v / 2 (restitution 0) and
    slides at least (v / 2)^2 / (2 mu g), and the thrower cannot end ahead of it. The extension
    on MuJoCo slid it 116 mm of 408 at 4 m/s and 1 of 1631 at 8 m/s: its 8 ms contacts let the
    thrower press into the struck brick's end and ride up over it (and at 8 m/s it met the brick
    frozen: the launch's first step was not looked at)."""
    scenario = parse_scenario(IMPACT_END_ON.format(speed=speed), "throw.yaml")
    outcome = run_program(compile_scenario(scenario, "extension", backend="mujoco"))
    pose = {n.id: n.position_mm for n in outcome.final_graph.nodes}
    least = (speed / 2) ** 2 / (2 * 0.5 * 9.81) * 1000
    assert pose["b"][0] >= least, (pose["b"][0], least)
    assert pose["hit"][0] < pose["b"][0]
    wake = next(e for e in outcome.events if e.kind == "wake" and e.brick == "b")
    assert wake.time == pytest.approx(1.0) and "impact of hit" in wake.detail


JENGA_MIDDLE = """stackdsl: 1
materials: {{maple: {{density: 700 kg/m^3, friction: {mu}}}}}
brick_types: {{jenga: {{size: [75 mm, 25 mm, 15 mm], material: maple}}}}
ground: {{material: maple}}
structure: {{tower: {{levels: 6, bricks_per_layer: 3, spacing: 25.5 mm, turn: 90, brick: jenga}}}}
timing: {{interval: 0.5 s, settle: 1 s}}
actions: [{{remove: {{brick: L03.2, at: after level 6, speed: 40 mm/s}}}}]
expect: {{stands: true}}
"""


@pytest.mark.slow  # 4 runs of 2-4 s: in .ci/nightly's slow part
@pytest.mark.parametrize("mu", [0.05, 0.4])
@pytest.mark.parametrize("mode", ["extension", "tuned"])
def test_a_middle_jenga_block_pulled_out_leaves_the_levels_above_on_the_others(mu, mode):
    """By Coulomb the two side blocks hold the level above back with twice the friction the
    pulled middle one drags it with, at any friction coefficient. MuJoCo's friction, asked to
    stop the slip on the pulled block within a step, lifted the level onto it: at mu 0.05 the
    tower above rode off to 1.8 m, at 0.4 it was dragged 7.8 mm (extension mode)."""
    scenario = parse_scenario(JENGA_MIDDLE.format(mu=mu), "jenga.yaml")
    outcome = run_program(compile_scenario(scenario, mode, backend="mujoco"))
    assert outcome.collapse is None
    assert max(d for b, d in outcome.displacement.items() if b != "L03.2") < 0.003


def test_merged_bricks_move_as_one_body_and_come_apart_where_they_are():
    """As on pybullet (tests/test_shelf.py): two frozen bricks on a third merged into one free
    body ride the third as a hand slides it out, rigid, read brick by brick (pose, v + w x r,
    contacts named by the brick touched), and come apart frozen where they rode to; one woken
    at once moves on with the velocity it rode with."""
    world = _world("extension")
    spec = _brick()
    bricks = []
    for i in range(3):
        body = world.create(spec, Pose.from_euler([0.0, 0.0, 0.004 + 0.008 * i]), mass=0.0)
        bricks.append(body)
    base, middle, top = bricks
    world.set_frozen(base, False, spec.mass)
    assert not world.merge([middle])  # one alone is not merged
    assert world.merge([middle, top])
    assert not world.merge([middle, base])  # merged already, or moving
    assert list(world.merged_groups().values()) == [(middle, top)]
    for k in range(48):  # a hand slides the base out: friction carries what rests on it
        world.guide(base, Pose.from_euler([0.05 * k / 240, 0.0, 0.004]), (0.05, 0.0, 0.0), hold=False)
        world.step()
    assert world.pose(middle).position[0] > 0.002  # carried along (MuJoCo lets it slip some of the way)
    gap = world.pose(top).position - world.pose(middle).position
    assert float(np.linalg.norm(gap)) == pytest.approx(0.008, abs=1e-9)  # rigid: one body
    assert abs(float(world.pose(top).orientation @ world.pose(middle).orientation)) == pytest.approx(1.0, abs=1e-12)
    (v_middle, spin), (v_top, spin_top) = world.velocity(middle), world.velocity(top)
    assert spin_top.tolist() == pytest.approx(spin.tolist(), abs=1e-12) and v_middle[0] > 0.0
    assert (v_top - v_middle).tolist() == pytest.approx(np.cross(spin, gap).tolist(), abs=1e-9)
    assert world.speeds(top)[0] == pytest.approx(float(np.linalg.norm(v_top)), abs=1e-12)
    seen = {(c.body, c.other) for c in world.contact_points([base])}
    assert seen == {(base, world.ground), (base, middle)}  # named by the brick touched
    assert {c.other for c in world.near(top, 0.001)} == {base}  # of the whole merged body, itself left out
    positions, _ = world.poses_of([base, middle, top, top, middle, base, top, middle, base])
    assert positions[2].tolist() == pytest.approx(world.pose(top).position.tolist(), abs=1e-12)
    there, rode = world.pose(top).position, world.velocity(top)
    world.unmerge([middle, top])
    assert world.merged_groups() == {}
    assert world.pose(top).position.tolist() == pytest.approx(there.tolist(), abs=1e-9)
    assert world.speeds(top) == (0.0, 0.0)  # frozen again
    world.set_frozen(top, False, spec.mass)  # woken in the same step: it moves on as it rode
    assert np.concatenate(world.velocity(top)).tolist() == pytest.approx(np.concatenate(rode).tolist(), abs=1e-9)
    world.step()
    world.set_frozen(middle, False, spec.mass)  # a step later: from rest
    assert world.speeds(middle) == (0.0, 0.0)
    assert world.pose(top).position[2] == pytest.approx(there[2], abs=2e-4)  # it rests where it rode to
