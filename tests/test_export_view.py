"""``stackdsl export`` (MJCF, URDF at one moment of a run) and ``stackdsl view`` (MuJoCo's viewer).

The exported files are loaded in MuJoCo (the mujoco extra; skipped without it) and their
bodies compared with the run's poses at that time. The viewer needs a display: without one
the command says so in one line; with a stand-in viewer, the live view puts the engine's
poses and the state colours into the viewer's model as the run goes.
"""

from __future__ import annotations

import contextlib
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

import stackdsl
from stackdsl.cli.main import main
from stackdsl.draw.render import COLOURS, resolve_time
from stackdsl.runtime.recorder import record_program

try:
    import mujoco
except ImportError:  # the mujoco extra
    mujoco = None
needs_mujoco = pytest.mark.skipif(mujoco is None, reason="MuJoCo is not installed: pip install -e '.[mujoco]'")

ROOT = Path(__file__).resolve().parents[1]
SLANT = ROOT / "scenarios" / "slant_tower.yaml"
TOWER = "stackdsl: 1\nname: small tower\nstructure: {tower: {levels: 3}}\nexpect: {stands: true}\n"


@pytest.fixture(scope="module")
def slant_run(tmp_path_factory):
    """The slant tower (it collapses at level 9), recorded to a trajectory file."""
    folder = tmp_path_factory.mktemp("export")
    record = folder / "slant.npz"
    assert main(["run", str(SLANT), "--record", str(record)]) == 0  # it expects its collapse
    return stackdsl.load_trajectory(record), record


def _angle(q1: np.ndarray, q2: np.ndarray) -> float:
    """Degrees between two (x, y, z, w) orientations."""
    return float(np.degrees((Rotation.from_quat(q1).inv() * Rotation.from_quat(q2)).magnitude()))


def _bodies(model) -> dict[str, tuple[np.ndarray, np.ndarray]]:
    """Each named body's pose in a freshly made model: position (m), quaternion (x, y, z, w)."""
    data = mujoco.MjData(model)
    mujoco.mj_kinematics(model, data)
    out = {}
    for b in range(1, model.nbody):
        name = model.body(b).name
        out[name] = (data.xpos[b].copy(), data.xquat[b][[1, 2, 3, 0]].copy())
    return out


@needs_mujoco
@pytest.mark.parametrize("at", ["collapse", "end", "16.2"])
def test_the_mjcf_opens_in_mujoco_with_the_runs_poses_at_that_time(slant_run, tmp_path, capsys, at):
    trajectory, record = slant_run
    out = tmp_path / "scene.xml"
    assert main(["export", str(record), "--at", at, "--mjcf", str(out)]) == 0
    assert f"wrote {out}" in capsys.readouterr().out
    model = mujoco.MjModel.from_xml_path(str(out))
    frame = trajectory.at(resolve_time(trajectory, at))
    present = [i for i in range(len(trajectory.ids)) if not np.isnan(frame.positions[i, 0])]
    bodies = _bodies(model)
    assert set(bodies) == {str(trajectory.ids[i]) for i in present}
    assert model.njnt == len(present) and all(t == mujoco.mjtJoint.mjJNT_FREE for t in model.jnt_type)
    for i in present:
        position, quaternion = bodies[str(trajectory.ids[i])]
        assert np.allclose(position, frame.positions[i], atol=1e-7), trajectory.ids[i]
        assert _angle(quaternion, frame.orientations[i]) < 1e-4, trajectory.ids[i]
        geom = model.geom(str(trajectory.ids[i]))
        assert np.allclose(geom.size, trajectory.half_extents[i])
        assert geom.rgba[:3] == pytest.approx(COLOURS[frame.state_names[i]], abs=1e-4)


@needs_mujoco
def test_the_urdf_opens_in_mujoco_as_free_bricks_at_the_same_poses(slant_run, tmp_path):
    trajectory, record = slant_run
    out = tmp_path / "scene.urdf"
    assert main(["export", str(record), "--at", "end", "--urdf", str(out)]) == 0
    model = mujoco.MjModel.from_xml_path(str(out))
    frame = trajectory.at(trajectory.end)
    bodies = _bodies(model)
    for i, brick in enumerate(trajectory.ids.tolist()):
        position, quaternion = bodies[brick]
        assert np.allclose(position, frame.positions[i], atol=1e-7), brick
        assert _angle(quaternion, frame.orientations[i]) < 1e-4, brick
    assert model.njnt == len(trajectory.ids) and all(t == mujoco.mjtJoint.mjJNT_FREE for t in model.jnt_type)
    assert model.body_mass[bodies_index(model, "L01.1")] == pytest.approx(460 * 0.12 * 0.024 * 0.008, rel=1e-6)


def bodies_index(model, name: str) -> int:
    return int(model.body(name).id)


@needs_mujoco
def test_an_exported_standing_tower_stands_in_mujoco(tmp_path):
    """Masses, sizes, friction and poses in SI: MuJoCo's own step keeps the tower where it was."""
    scenario = tmp_path / "tower.yaml"
    scenario.write_text(TOWER)
    out = tmp_path / "tower.xml"
    assert main(["export", str(scenario), "--mjcf", str(out)]) == 0
    model = mujoco.MjModel.from_xml_path(str(out))
    data = mujoco.MjData(model)
    mujoco.mj_forward(model, data)
    start = data.xpos[1:].copy()
    for _ in range(int(0.5 / model.opt.timestep)):
        mujoco.mj_step(model, data)
    assert np.abs(data.xpos[1:] - start).max() < 1e-3  # less than 1 mm in half a second
    assert model.body_mass[1] == pytest.approx(460 * 0.12 * 0.024 * 0.008, rel=1e-6)  # the scenario's pine


STAIRCASE = (
    "stackdsl: 1\nname: staircase\nstructure: {tower: {levels: 9, bricks_per_layer: 1, turn: 0, shift: 13 mm}}\n"
    "expect: {stands: true}\n"
)
FOUR_STACK = "stackdsl: 1\nname: four stack\nstructure: {tower: {levels: 6}}\nexpect: {stands: true}\n"


def _stepped(path: Path, seconds: float) -> float:
    """Metres the farthest body of the MJCF at ``path`` moves in ``seconds`` of plain ``mj_step``."""
    model = mujoco.MjModel.from_xml_path(str(path))
    data = mujoco.MjData(model)
    mujoco.mj_forward(model, data)
    start = data.xpos[1:].copy()
    for _ in range(round(seconds / model.opt.timestep)):
        mujoco.mj_step(model, data)
    return float(np.linalg.norm(data.xpos[1:] - start, axis=1).max())


@needs_mujoco
@pytest.mark.parametrize("text", [STAIRCASE, FOUR_STACK], ids=["staircase-1.5mm-margin", "four-stack"])
def test_a_standing_scene_exported_at_its_end_stands_in_plain_mujoco(tmp_path, text):
    """The single-file staircase shifted 13 mm a level stands 1.5 mm inside its tipping margin
    (levels 2 to 9 have their centre of mass at 58.5 mm, level 1's edge at 60). At MuJoCo's
    defaults (pyramidal cones, solref 20 ms) the exported file fell 81 mm in 2 s; with the MuJoCo
    options and contacts stackdsl's tuned MuJoCo mode uses, it moves a fraction of a millimetre."""
    scenario, out = tmp_path / "scene.yaml", tmp_path / "scene.xml"
    scenario.write_text(text)
    assert main(["export", str(scenario), "--at", "end", "--mjcf", str(out)]) == 0
    assert _stepped(out, 2.0) < 1e-3  # every body: less than 1 mm in 2 s


@needs_mujoco
@pytest.mark.slow
@pytest.mark.parametrize(
    ("engine", "timestep", "cone", "solref"),
    [
        ("", 0.002, "ELLIPTIC", 0.004),  # a run on pybullet: MuJoCo's tuned mode
        ("engine: {backend: mujoco, mode: tuned, timestep: 1 ms}\n", 0.001, "ELLIPTIC", 0.004),  # the run's own
        ("engine: {backend: mujoco, mode: raw}\n", 0.002, "PYRAMIDAL", 0.02),
        ("engine: {backend: mujoco}\n", 0.002, "ELLIPTIC", 0.004),  # extension mode: MuJoCo's tuned mode
    ],
    ids=["pybullet", "mujoco-tuned-1ms", "mujoco-raw", "mujoco-extension"],
)
def test_the_mjcf_carries_the_mujoco_settings_its_docs_name_and_says_which(tmp_path, engine, timestep, cone, solref):
    scenario, out = tmp_path / "scene.yaml", tmp_path / "scene.xml"
    scenario.write_text(TOWER + engine)
    assert main(["export", str(scenario), "--mjcf", str(out)]) == 0
    model = mujoco.MjModel.from_xml_path(str(out))
    assert model.opt.timestep == pytest.approx(timestep) and model.opt.cone == getattr(mujoco.mjtCone, f"mjCONE_{cone}")
    assert model.opt.iterations == 100 and model.opt.gravity[2] == pytest.approx(-9.81)
    tuned = cone == "ELLIPTIC"
    assert model.opt.impratio == pytest.approx(10.0 if tuned else 1.0)
    assert model.opt.integrator == (mujoco.mjtIntegrator.mjINT_IMPLICITFAST if tuned else mujoco.mjtIntegrator.mjINT_EULER)
    assert np.allclose(model.geom_solref[:, 0], solref)  # every geom, the ground too
    assert np.allclose(model.geom_solimp[:, :3], (0.99, 0.999, 1e-4) if tuned else (0.9, 0.95, 0.001))
    head = out.read_text().splitlines()[1]
    assert head.startswith("  <!--") and f"timestep {timestep:g} s" in head
    assert ("the run's own MuJoCo settings" in head) == (engine != "" and "extension" not in engine and "mode" in engine)


@needs_mujoco
def test_two_materials_touch_at_the_geometric_mean_of_their_friction_as_in_the_mujoco_world(tmp_path):
    """Oak bricks (friction 0.8, restitution 0.1) on a pine ground (0.5, 0) with one pine brick on
    top: each contact's friction is the geometric mean of the two materials', as stackdsl's own
    MuJoCo world declares it, and a restitution softens the contact's damping."""
    from stackdsl.engines.mujoco.materials import damping_ratio

    scenario, out = tmp_path / "oak.yaml", tmp_path / "oak.xml"
    scenario.write_text(
        "stackdsl: 1\nmaterials: {oak: {density: 700 kg/m^3, friction: 0.8, restitution: 0.1}}\n"
        "brick_types: {oak: {size: [120 mm, 24 mm, 8 mm], material: oak}}\n"
        "structure:\n  bricks:\n    - {at: [0, 0, 4 mm], brick: oak}\n    - {at: [0, 0, 12 mm], yaw: 90, brick: oak}\n"
        "    - {at: [0, 0, 20 mm]}\nexpect: {stands: true}\n"
    )
    assert main(["export", str(scenario), "--mjcf", str(out)]) == 0
    model = mujoco.MjModel.from_xml_path(str(out))
    data = mujoco.MjData(model)
    for _ in range(50):
        mujoco.mj_step(model, data)
    names = {int(model.geom(n).id): n for n in ("ground", "b001", "b002", "b003")}
    material = {"ground": (0.5, 0.0), "b001": (0.8, 0.1), "b002": (0.8, 0.1), "b003": (0.5, 0.0)}
    seen = set()
    for c in range(data.ncon):
        one, other = names[int(data.contact.geom1[c])], names[int(data.contact.geom2[c])]
        (mu1, e1), (mu2, e2) = material[one], material[other]
        assert data.contact.friction[c][0] == pytest.approx(np.sqrt(mu1 * mu2)), (one, other)
        assert data.contact.solref[c][1] == pytest.approx(damping_ratio(np.sqrt(e1 * e2), 2.0)), (one, other)
        seen.add(frozenset((one, other)))
    assert seen == {frozenset(p) for p in (("ground", "b001"), ("b001", "b002"), ("b002", "b003"))}
    assert _stepped(out, 1.0) < 1e-3


@pytest.mark.parametrize(
    ("argv", "message"),
    [
        (["--mjcf", "{tmp}/no/such/out.xml"], "no such folder"),
        (["--mjcf", "{tmp}"], "this is a folder"),
        ([], "give --mjcf OUT.xml, --sdf OUT.sdf or --urdf OUT.urdf (or several)"),
        (["--sdf", "{tmp}/a.urdf"], "the SDF file must end in .sdf or .world"),
        (["--mjcf", "{tmp}/a.xml", "--at", "99"], "outside the run"),
    ],
)
def test_export_refuses_bad_requests_with_exit_2(slant_run, tmp_path, capsys, argv, message):
    _, record = slant_run
    argv = [a.replace("{tmp}", str(tmp_path)) for a in argv]
    assert main(["export", str(record), *argv]) == 2
    assert message in capsys.readouterr().err


#: A brick turned on a brick, beside a fixed one: a fixture in the ground's model.
ON_A_TABLE = """stackdsl: 1
name: on a table
structure:
  bricks:
    - {id: low, at: [0, 0, 4 mm]}
    - {id: high, at: [0, 0, 12 mm], yaw: 30}
    - {id: wall, at: [0, 100 mm, 4 mm], fixed: true}
materials: {oak: {density: 700 kg/m^3, friction: 0.6}}
brick_types: {oaken: {size: [120 mm, 24 mm, 8 mm], material: oak}}
"""


def test_the_sdf_loads_in_pybullet_as_one_body_a_brick_at_the_runs_poses(tmp_path, capsys):
    """A URDF is one multibody: pybullet welded every brick into it. The SDF export is a model a
    brick: loadSDF gives the ground and one body each, at the run's poses, masses and friction,
    and the scene stands when stepped."""
    import pybullet

    from stackdsl.draw.export import snapshot

    scenario = tmp_path / "table.yaml"
    scenario.write_text(ON_A_TABLE.replace("{id: high,", "{id: high, brick: oaken,"))
    out, urdf = tmp_path / "table.sdf", tmp_path / "table.urdf"
    assert main(["export", str(scenario), "--sdf", str(out), "--urdf", str(urdf)]) == 0
    assert "SDF, 2 bodies and the ground (pybullet.loadSDF: one body each)" in capsys.readouterr().out
    program = stackdsl.compile_scenario(stackdsl.load_scenario(scenario))
    scene = snapshot(record_program(program)[1], "end", {a.id: a.brick for a in program.placements})
    client = pybullet.connect(pybullet.DIRECT)
    try:
        pybullet.loadURDF(str(urdf), physicsClientId=client)
        assert pybullet.getNumBodies(physicsClientId=client) == 1  # the URDF: one body, the bricks welded to it
        pybullet.resetSimulation(physicsClientId=client)
        bodies = pybullet.loadSDF(str(out), physicsClientId=client)
        names = [pybullet.getBodyInfo(b, physicsClientId=client)[1].decode() for b in bodies]
        assert names == ["ground", "low", "high"] and pybullet.getNumBodies(physicsClientId=client) == 3
        assert pybullet.getDynamicsInfo(bodies[0], -1, physicsClientId=client)[0] == 0.0  # the ground stays put
        assert len(pybullet.getCollisionShapeData(bodies[0], -1, physicsClientId=client)) == 2  # the slab and the wall
        for body, brick in zip(bodies[1:], scene.ids, strict=True):
            i = scene.ids.index(brick)
            position, quaternion = pybullet.getBasePositionAndOrientation(body, physicsClientId=client)
            assert np.allclose(position, scene.positions[i], atol=1e-7) and _angle(quaternion, scene.orientations[i]) < 1e-4
            mass, friction = pybullet.getDynamicsInfo(body, -1, physicsClientId=client)[:2]
            assert mass == pytest.approx(scene.mass(i), rel=1e-5) and mass == pytest.approx(
                (700 if brick == "high" else 460) * 2.304e-5
            )
            assert friction == pytest.approx(np.sqrt(0.6 if brick == "high" else 0.5), rel=1e-5)  # Bullet multiplies two
        pybullet.setGravity(0, 0, -9.81, physicsClientId=client)
        for _ in range(240):
            pybullet.stepSimulation(physicsClientId=client)
        moved = [
            np.linalg.norm(np.subtract(pybullet.getBasePositionAndOrientation(b, physicsClientId=client)[0], scene.positions[i]))
            for i, b in enumerate(bodies[1:])
        ]
        assert max(moved) < 1e-3, moved
    finally:
        pybullet.disconnect(client)


def test_export_at_collapse_of_a_run_that_stood_is_bad_input(tmp_path, capsys):
    scenario = tmp_path / "tower.yaml"
    scenario.write_text(TOWER)
    assert main(["export", str(scenario), "--at", "collapse", "--mjcf", str(tmp_path / "a.xml")]) == 2
    assert "did not collapse" in capsys.readouterr().err and not (tmp_path / "a.xml").exists()


# -- view ---------------------------------------------------------------------------------------
def test_view_without_a_display_says_so_in_one_line_and_points_to_replay(monkeypatch, capsys, tmp_path):
    monkeypatch.delenv("DISPLAY", raising=False)
    monkeypatch.delenv("WAYLAND_DISPLAY", raising=False)
    monkeypatch.setattr("sys.platform", "linux")
    scenario = tmp_path / "tower.yaml"
    scenario.write_text(TOWER)
    assert main(["view", str(scenario)]) == 2
    captured = capsys.readouterr()
    assert captured.out == ""
    lines = captured.err.splitlines()
    assert len(lines) == 1 and "no display" in lines[0] and f"stackdsl replay {scenario} -o DIR" in lines[0]


@pytest.mark.slow
@needs_mujoco
@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="X11 and Wayland displays")
@pytest.mark.parametrize("variable", ["DISPLAY", "WAYLAND_DISPLAY"])
def test_view_on_a_display_that_cannot_be_opened_says_so_in_one_line(variable, tmp_path):
    scenario = tmp_path / "tower.yaml"
    scenario.write_text(TOWER)
    env = {k: v for k, v in os.environ.items() if k not in ("DISPLAY", "WAYLAND_DISPLAY")}
    env[variable] = ":987" if variable == "DISPLAY" else "stackdsl-no-such-display-9"
    done = subprocess.run(
        [sys.executable, "-m", "stackdsl", "view", str(scenario)], capture_output=True, text=True, env=env, timeout=120
    )
    assert done.returncode == 2 and done.stdout == "", done.stderr
    (line,) = done.stderr.splitlines()
    assert "the display cannot be opened" in line and f"stackdsl replay {scenario} -o DIR" in line
    assert "GLFWError" not in line and "warn" not in line


class Clock:
    """A wall clock that moves only when slept on."""

    def __init__(self) -> None:
        self.now = 0.0

    def __call__(self) -> float:
        return self.now

    def sleep(self, seconds: float) -> None:
        assert seconds >= 0
        self.now += seconds


class StandIn:
    """A viewer without a window: counts its syncs; closed after ``open_for`` of them."""

    def __init__(self, open_for: int = 10**9) -> None:
        self.syncs, self.open_for = 0, open_for

    def sync(self) -> None:
        self.syncs += 1

    def is_running(self) -> bool:
        return self.syncs < self.open_for

    def lock(self):
        return contextlib.nullcontext()


@needs_mujoco
def test_the_live_view_shows_the_engines_poses_and_the_state_colours():
    from stackdsl.draw import live

    program = stackdsl.compile_scenario(stackdsl.load_scenario(SLANT))
    scene = live.program_scene(program)
    assert (scene.model.geom_rgba[scene.geom, 3] == 0).all()  # nothing in the world yet
    camera = mujoco.MjvCamera()
    scene.aim(camera)  # at the bricks as placed, not at the 2 m ground plane
    assert 0.1 < camera.distance < 1.0 and 0.0 < camera.lookat[2] < 0.1
    viewer, wall = StandIn(), Clock()
    view = live.LiveView(program, scene, viewer, speed=1.0, sleep=wall.sleep, clock=wall)
    outcome = stackdsl.run_program(program, subscribers=(view,))
    assert outcome.collapse is not None and viewer.syncs == view.pictures > 50  # 65: each brick frozen as it lands
    # at the end the viewer shows the run's last poses (the recording's, to its tolerances), in its colours
    trajectory = view.trajectory(outcome)
    frame = trajectory.at(trajectory.end)
    for i, brick in enumerate(trajectory.ids.tolist()):
        position, quaternion = scene.pose_of(brick)
        assert np.allclose(position, frame.positions[i], atol=2e-5), brick
        assert _angle(quaternion, frame.orientations[i]) < 0.02, brick
        assert scene.colour_of(brick) == pytest.approx(COLOURS[frame.state_names[i]], abs=1e-6), brick
    assert "fallen" in frame.state_names and "frozen" in frame.state_names
    # the bricks placed are seen; those never placed (building stops at the collapse) are not
    placed = np.isin(scene.ids, trajectory.ids)
    assert not placed.all() and (scene.model.geom_rgba[scene.geom, 3] == placed).all()
    # paced to real time, the quiet waits between placements (which the loop jumps) shortened
    quiet = sum(1.0 - live.QUIET_HOLD for p in program.placements[1:])  # a placement a second
    assert outcome.simulated_time - quiet - 1.0 < wall.now < outcome.simulated_time


@needs_mujoco
def test_closing_the_viewer_stops_the_pictures_not_the_run():
    from stackdsl.draw import live

    program = stackdsl.compile_scenario(stackdsl.parse_scenario(TOWER))
    scene = live.program_scene(program)
    viewer = StandIn(open_for=3)
    view = live.LiveView(program, scene, viewer, sleep=lambda s: None)
    outcome = stackdsl.run_program(program, subscribers=(view,))
    assert viewer.syncs == 3 and view.pictures == 3 and outcome.levels_placed == 3


@needs_mujoco
def test_a_recorded_trajectory_plays_in_the_viewer(slant_run):
    from stackdsl.draw import live

    trajectory, _ = slant_run
    scene = live.trajectory_scene(trajectory)
    viewer = StandIn()
    assert live.play(trajectory, scene, viewer, speed=100.0, sleep=lambda s: None) == len(trajectory.times)
    position, _ = scene.pose_of("L09.1")
    assert np.allclose(position, trajectory.at(trajectory.end).positions[list(trajectory.ids).index("L09.1")])


@needs_mujoco
def test_record_program_and_live_view_record_the_same_run():
    """The live view is a recorder: what it keeps is what ``run --record`` keeps."""
    from stackdsl.draw import live

    program = stackdsl.compile_scenario(stackdsl.parse_scenario(TOWER))
    view = live.LiveView(program, live.program_scene(program), StandIn(), sleep=lambda s: None)
    outcome = stackdsl.run_program(program, subscribers=(view,))
    _, recorded = record_program(program)
    mine = view.trajectory(outcome)
    assert np.array_equal(mine.times, recorded.times) and np.allclose(mine.row_position, recorded.row_position)


@pytest.mark.parametrize(
    ("argv", "where"),
    [
        (["export", "{npz}", "--mjcf", "/sys/x.xml"], "/sys/x.xml: --mjcf: Permission denied"),
        (["replay", "{npz}", "-o", "/proc/x"], "/proc/x: -o: No such file or directory"),
        (["replay", "{npz}", "-o", "/tmp/" + "x" * 300], "File name too long"),
    ],
    ids=["a folder kept by the system", "a folder that takes no file", "name too long"],
)
def test_a_path_the_system_refuses_is_one_line_and_exit_2(slant_run, argv, where, capsys):
    _, record = slant_run
    assert main([a.replace("{npz}", str(record)) for a in argv]) == 2
    (line,) = capsys.readouterr().err.strip().splitlines()
    assert line.startswith("stackdsl: ") and line.endswith(where)


def test_a_damaged_trajectory_is_bad_input_for_replay_export_and_view(tmp_path, capsys, monkeypatch):
    bad = tmp_path / "bad.npz"
    bad.write_text("hello\n")
    monkeypatch.setenv("DISPLAY", ":99")  # the trajectory is read before any window opens
    for argv in (
        ["replay", str(bad), "-o", str(tmp_path / "r")],
        ["export", str(bad), "--urdf", str(tmp_path / "x.urdf")],
        *([["view", str(bad)]] if mujoco is not None else []),
    ):
        assert main(argv) == 2
        (line,) = capsys.readouterr().err.strip().splitlines()
        assert line.startswith(f"{bad}: not a stackdsl trajectory"), line
    assert not (tmp_path / "x.urdf").exists() and not (tmp_path / "r" / "replay.html").exists()


@needs_mujoco
@pytest.mark.skipif(
    not os.environ.get("DISPLAY"), reason="no display: run it with xvfb-run -a python -m pytest -n0 tests/test_export_view.py"
)
def test_the_live_view_in_mujocos_own_passive_viewer():
    import mujoco.viewer

    from stackdsl.draw import live

    program = stackdsl.compile_scenario(stackdsl.load_scenario(SLANT))
    scene = live.program_scene(program)
    with mujoco.viewer.launch_passive(scene.model, scene.data) as viewer:
        with viewer.lock():
            scene.aim(viewer.cam)
        view = live.LiveView(program, scene, viewer, speed=20.0)
        outcome = stackdsl.run_program(program, subscribers=(view,))
        assert view.pictures > 100 and viewer.is_running()
        with viewer.lock():  # the viewer's copy of the model has the state colours
            assert viewer.m.geom_rgba[scene.geom[scene.index[outcome.collapse.brick]]][:3] == pytest.approx(COLOURS["fallen"])
        viewer.close()


# A brick beside a KAPLA bolted to the table, shaken 30 mm at 1 Hz along y (raw: the ground moves).
SHAKEN = (
    "stackdsl: 1\nstructure:\n  bricks:\n    - {id: a, at: [0, 0, 4 mm]}\n    - {id: bolted, at: [200 mm, 0, 4 mm], fixed: true}\n"
    "timing: {settle: 0.2 s}\nactions: [{shake: {amplitude: 30 mm, frequency: 1 Hz, duration: 1 s, at: 1 s, direction: [0, 1]}}]\n"
)


class Watching(StandIn):
    """A stand-in viewer that notes where the scene shows the fixture at each sync."""

    def __init__(self, scene) -> None:
        super().__init__()
        self.scene, self.shown = scene, []

    def sync(self) -> None:
        super().sync()
        self.shown.append(self.scene.fixture_positions()["bolted"])


@needs_mujoco
def test_the_viewer_and_export_carry_the_fixtures_with_a_shakes_ground(tmp_path):
    """The viewer's fixtures were static geoms and export put them at rest: a shake moved the
    bricks and the table, not them. They ride the ground's mocap body, moved by its offset."""
    from stackdsl.draw import live
    from stackdsl.draw.export import snapshot

    program = stackdsl.compile_scenario(stackdsl.parse_scenario(SHAKEN), "raw")
    scene = live.program_scene(program)
    viewer = Watching(scene)
    view = live.LiveView(program, scene, viewer, sleep=lambda s: None)
    trajectory = view.trajectory(stackdsl.run_program(program, subscribers=(view,)))
    rest = np.array([0.2, 0.0, 0.004])
    carried = np.array(viewer.shown) - rest
    assert np.abs(carried[:, 1]).max() == pytest.approx(0.06, abs=0.003) and np.allclose(carried[:, [0, 2]], 0.0)
    assert np.allclose(carried[-1], 0.0)  # fixed again where it rests once the shake is over
    # a recorded trajectory plays the same: each picture has the frame's fixture where the frame has it
    replayed = live.trajectory_scene(trajectory)
    watching = Watching(replayed)
    live.play(trajectory, replayed, watching, speed=100.0, sleep=lambda s: None)
    expected = [trajectory.fixture_positions_at(k)[0] for k in range(len(trajectory.times))]
    assert np.allclose(watching.shown, expected, atol=1e-9)
    # and export at the table's farthest puts it there
    k = int(np.argmax(np.abs(trajectory.ground_offset[:, 1])))
    assert np.allclose(snapshot(trajectory, float(trajectory.times[k])).fixture_positions, trajectory.fixture_positions_at(k))


WORLD_AND_WALL = """stackdsl: 1
brick_types:
  wall: {size: [20 mm, 200 mm, 200 mm]}
structure:
  bricks:
    - {id: wall, brick: wall, at: [200 mm, 0, 100 mm], fixed: true}
    - {id: world, at: [0, 0, 4 mm]}
    - {id: Ground_1, at: [0, 0, 12 mm], yaw: 90}
    - {id: frozen, at: [0, 0, 20 mm]}
timing: {settle: 0.3 s}
"""


def _edited(record: Path, target: Path, edit) -> Path:
    with np.load(record) as data:
        arrays = {name: data[name] for name in data.files}
    edit(arrays)
    np.savez(target, **arrays)
    return target


def _rename(arrays, i: int, name: str) -> None:
    ids = arrays["ids"].tolist()
    ids[i] = name
    arrays["ids"] = np.array(ids)


EDITS = {
    "as recorded": lambda a: None,
    "a brick of another's id": lambda a: _rename(a, 1, str(a["ids"][0])),
    "a brick of the fixture's id": lambda a: _rename(a, 0, str(a["fixture_ids"][0])),
    "a brick named ground": lambda a: _rename(a, 0, "ground"),
    "zero quaternions": lambda a: a.update(row_orientation=np.zeros_like(a["row_orientation"])),
    "a zero fixture quaternion": lambda a: a.update(fixture_orientations=np.zeros_like(a["fixture_orientations"])),
    "NaN quaternions": lambda a: a.update(row_orientation=np.full_like(a["row_orientation"], np.nan)),
    "quaternions a little off unit length": lambda a: a.update(row_orientation=a["row_orientation"] * 1.0004),
}


@needs_mujoco
@pytest.mark.parametrize("edit", EDITS, ids=list(EDITS))
def test_export_writes_only_mjcf_and_urdf_that_mujoco_loads(edit, tmp_path, capsys):
    """A run with a brick named as MuJoCo's world body and a fixture, recorded, then edited by
    hand: export either refuses the trajectory (exit 2, one line naming it) or writes files that
    MuJoCo loads, with a body for every brick."""
    scenario = tmp_path / "world.yaml"
    scenario.write_text(WORLD_AND_WALL)
    record = tmp_path / "run.npz"
    assert main(["run", str(scenario), "--record", str(record)]) == 0
    bad = _edited(record, tmp_path / "edited.npz", EDITS[edit])
    capsys.readouterr()
    code = main(["export", str(bad), "--mjcf", str(tmp_path / "x.xml"), "--urdf", str(tmp_path / "x.urdf")])
    if code == 2:
        (line,) = capsys.readouterr().err.strip().splitlines()
        assert line.startswith(f"{bad}: not a stackdsl trajectory"), line
        assert not (tmp_path / "x.xml").exists() and not (tmp_path / "x.urdf").exists()
        assert edit != "as recorded" and "a little off" not in edit
        return
    assert code == 0, capsys.readouterr().err
    mjcf = mujoco.MjModel.from_xml_string((tmp_path / "x.xml").read_text())
    urdf = mujoco.MjModel.from_xml_path(str(tmp_path / "x.urdf"))
    assert mjcf.njnt == urdf.njnt == 3 and mjcf.ngeom == 5  # three free bricks; the ground, the wall and the bricks
    assert {mjcf.geom(g).name for g in range(mjcf.ngeom)} == {"ground", "wall", "world", "Ground_1", "frozen"}
    assert mjcf.body("world#").id > 0  # MuJoCo's own world body keeps its name


@needs_mujoco
def test_the_live_view_finds_a_brick_named_world():
    from stackdsl.draw.live import program_scene

    scene = program_scene(stackdsl.compile_scenario(stackdsl.parse_scenario(WORLD_AND_WALL)))
    world = scene.mocap[scene.index["world"]]
    assert world >= 0 and world != scene.mocap[scene.index["Ground_1"]]  # its own mocap body, not MuJoCo's world
    position, _ = scene.pose_of("world")
    assert position == pytest.approx([0.0, 0.0, 0.004])


def test_an_export_that_fails_on_the_trajectorys_numbers_names_the_file_not_at(slant_run, tmp_path, capsys, monkeypatch):
    _, record = slant_run

    def fails(*args, **kwargs):
        raise ValueError("Found zero norm quaternions in `quat`.")

    monkeypatch.setattr("stackdsl.draw.export.urdf", fails)
    assert main(["export", str(record), "--at", "end", "--urdf", str(tmp_path / "x.urdf")]) == 2
    assert (
        capsys.readouterr().err.strip() == f"{record}: this trajectory cannot be exported: Found zero norm quaternions in `quat`."
    )
    assert not (tmp_path / "x.urdf").exists()


@pytest.mark.slow
def test_export_at_a_time_writes_the_runs_state_then_not_an_earlier_frame(tmp_path, capsys):
    """``export --at T`` wrote the last frame recorded at or before T, up to 1/30 s earlier, under
    the label T: 15 mm off for a brick knocked at 1.7 m/s. The run now keeps a frame at the last
    physics step at or before T, and the label is that step's time."""
    import xml.etree.ElementTree as ET

    scene = ROOT / "scenarios" / "impact_top.yaml"  # the top level knocked off by a thrown brick
    program = stackdsl.compile_scenario(stackdsl.load_scenario(scene))
    _, every_step = record_program(program, rate=1 / program.engine.timestep)  # the run's own poses at each step
    _, plain = record_program(program)  # 30 frames a second
    # halfway between two plain frames while the fastest brick moves fastest
    moved = np.nan_to_num(np.linalg.norm(np.diff([f.positions for f in every_step.frames()], axis=0), axis=2)).max(axis=1)
    fastest = float(every_step.times[int(np.argmax(moved)) + 1])
    k = plain.frame_index(fastest)
    at = round(float(plain.times[k] + plain.times[k + 1]) / 2, 4)
    truth, stale = every_step.at(at), plain.at(at)
    ids = every_step.ids.tolist()
    assert np.nanmax(np.linalg.norm(truth.positions - stale.positions, axis=1)) > 0.003  # the case: a frame before is off
    out = tmp_path / "at.xml"
    assert main(["export", str(scene), "--at", str(at), "--mjcf", str(out)]) == 0
    said = capsys.readouterr().out
    assert f"at t = {truth.time:.3f} s" in said and (truth.time == at or f"at or before {at:.3f} s" in said), said
    assert 0 <= at - truth.time < program.engine.timestep
    bodies = {b.get("name"): b for b in ET.parse(out).getroot().iter("body")}
    compared = 0
    for i, brick in enumerate(ids):
        if brick not in bodies or np.isnan(truth.positions[i, 0]):
            continue
        position = np.array([float(v) for v in bodies[brick].get("pos").split()])
        assert np.linalg.norm(position - truth.positions[i]) < 1e-3, (brick, position, truth.positions[i])
        compared += 1
    assert compared == len(ids)


def test_render_of_a_trajectory_file_says_which_frame_it_drew(slant_run, tmp_path, capsys):
    trajectory, record = slant_run
    at = float(trajectory.times[-2] + trajectory.times[-1]) / 2  # between two recorded frames: none at that time
    assert main(["render", str(record), "--at", f"{at:.4f}", "-o", str(tmp_path / "p.png")]) == 0
    said = capsys.readouterr().out
    assert f"t = {trajectory.times[-2]:.3f} s (the last recorded frame at or before {at:.3f} s)" in said, said


@pytest.mark.parametrize("speed", ["0", "nan", "-2", "1001"])
def test_view_refuses_a_bad_speed_before_it_looks_for_a_display(monkeypatch, capsys, tmp_path, speed):
    """With no display, ``view --speed 0`` was answered "no display here", not "bad speed"."""
    monkeypatch.delenv("DISPLAY", raising=False)
    monkeypatch.delenv("WAYLAND_DISPLAY", raising=False)
    monkeypatch.setattr("sys.platform", "linux")
    scenario = tmp_path / "tower.yaml"
    scenario.write_text(TOWER)
    assert main(["view", str(scenario), "--speed", speed]) == 2
    lines = capsys.readouterr().err.splitlines()
    assert len(lines) == 1 and "--speed" in lines[0] and "speed-up above 0" in lines[0] and "display" not in lines[0]


class _OpenWindow:
    """A viewer whose window nobody closes (a virtual display)."""

    def __init__(self) -> None:
        self.closed = False

    def is_running(self) -> bool:
        return not self.closed

    def close(self) -> None:
        self.closed = True


def test_view_closes_its_window_when_its_timeout_is_reached(capsys):
    # under a virtual display 'view' waited for a window nobody closes, at 99% CPU past its --timeout
    from stackdsl.cli.scene import wait_for_close

    now = [0.0]
    window = _OpenWindow()
    assert wait_for_close(window, 5.0, sleep=lambda s: now.__setitem__(0, now[0] + s), clock=lambda: now[0])
    assert window.closed and 5.0 <= now[0] < 5.2
    assert "stackdsl view: --timeout reached: the window is closed" in capsys.readouterr().err
    closed = _OpenWindow()
    closed.closed = True
    assert not wait_for_close(closed, 5.0)  # closed by its user: nothing to do


def test_views_window_thread_is_waited_for_once_closed():
    # left running, the viewer's thread tore its window down as the interpreter exited: under a
    # virtual display 'view' then hung after its --timeout, or aborted (a mutex assertion, exit 134)
    import threading
    import time

    from stackdsl.cli.scene import _window

    done = threading.Event()

    class Viewer(_OpenWindow):
        def close(self) -> None:
            super().close()
            done.set()

    def launch(model, data):
        thread = threading.Thread(target=lambda: (done.wait(), time.sleep(0.3)), daemon=True)
        thread.start()
        launch.thread = thread
        return Viewer()

    scene = type("Scene", (), {"model": None, "data": None})()
    with _window(launch, scene) as viewer:
        assert launch.thread.is_alive() and not viewer.closed
    assert viewer.closed and not launch.thread.is_alive()


def test_a_trajectory_played_in_view_stops_at_its_deadline():
    from stackdsl.draw import live

    _, trajectory = record_program(stackdsl.compile_scenario(stackdsl.parse_scenario(TOWER)))
    now = [0.0]
    window = _OpenWindow()
    window.sync = window.lock = lambda *a: contextlib.nullcontext()
    scene = type("Scene", (), {"show": lambda *a: None})()
    sleep, clock = (lambda s: now.__setitem__(0, now[0] + s)), (lambda: now[0])
    whole = live.play(trajectory, scene, window, sleep=sleep, clock=clock)
    deadline, now[0] = now[0] / 2, 0.0  # half the whole play's time
    cut = live.play(trajectory, scene, window, sleep=sleep, clock=clock, deadline=deadline)
    assert whole == len(trajectory.times) and 0 < cut < whole and now[0] < deadline + live.QUIET_HOLD


@pytest.mark.slow
def test_view_under_a_virtual_display_ends_by_its_timeout(tmp_path):
    """``view`` of a 20-level tower (41 s at real time) under Xvfb with --timeout 6: it closes its
    window and ends, exit 0, within a few seconds of its timeout (startup: imports, the window)."""
    import resource
    import shutil
    import time

    if shutil.which("Xvfb") is None:
        pytest.skip("no Xvfb here to give 'view' a virtual display (apt-get install xvfb)")
    pytest.importorskip("mujoco", reason="'view' is MuJoCo's viewer: the mujoco extra is not installed")
    display = f":{90 + os.getpid() % 100}"
    server = subprocess.Popen(["Xvfb", display, "-screen", "0", "1024x768x24"], stderr=subprocess.DEVNULL)
    try:
        time.sleep(1.0)
        (tmp_path / "t.yaml").write_text("stackdsl: 1\nstructure: {tower: {levels: 20}}\n")
        for name in ("t.yaml", "t.npz"):
            if name == "t.npz":
                assert main(["run", str(tmp_path / "t.yaml"), "--record", str(tmp_path / "t.npz")]) == 0
            before = resource.getrusage(resource.RUSAGE_CHILDREN)
            start = time.monotonic()
            done = subprocess.run(
                [sys.executable, "-m", "stackdsl", "view", name, "--timeout", "6"],
                cwd=tmp_path,
                env={**os.environ, "DISPLAY": display},
                capture_output=True,
                text=True,
                timeout=60,
            )
            wall = time.monotonic() - start
            after = resource.getrusage(resource.RUSAGE_CHILDREN)
            cpu = (after.ru_utime + after.ru_stime) - (before.ru_utime + before.ru_stime)
            assert done.returncode == 0, done.stderr
            assert "--timeout reached" in done.stderr and "Traceback" not in done.stderr
            assert wall < 6 + 8, wall  # its timeout, and the imports and window it cannot stop
            assert cpu < 0.9 * wall, (cpu, wall)  # not a core spinning
    finally:
        server.terminate()
        server.wait(10)
