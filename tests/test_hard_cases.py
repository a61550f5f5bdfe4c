"""Hard cases: scenes that break simulators, each held to what stackdsl promises (extension mode).

What raw pybullet does on the same scenes is recorded in docs/results/hard-cases.md
(``stackdsl bench hard``), not asserted here.
"""

import json
import math
import multiprocessing
from pathlib import Path

import numpy as np
import pytest

from stability import Box, BrickState, FakeEngine, Plane, Pose, StabilityConfig, StabilityExtension
from stackdsl import ScenarioError, compile_scenario, evaluate, load_scenario, parse_scenario, run_program
from stackdsl.bench.hard import V_LIMIT, WALL_LIMIT, format_limits, lean_on_wall, leaning_limits, vee, wall_throw

ROOT = Path(__file__).resolve().parents[1]
HARD = sorted((ROOT / "scenarios" / "hard").glob("*.yaml"))
KAPLA = Box(np.array([0.06, 0.012, 0.004]), 0.0106)


def run(name: str, **overrides):
    scenario = load_scenario(ROOT / "scenarios" / "hard" / f"{name}.yaml")
    program = compile_scenario(scenario, **overrides)
    return scenario, program, run_program(program)


@pytest.mark.slow
@pytest.mark.parametrize("path", HARD, ids=[p.stem for p in HARD])
def test_every_hard_case_holds_its_promise(path):
    scenario = load_scenario(path)
    program = compile_scenario(scenario)
    outcome = run_program(program)
    assert [v for v in evaluate(scenario.expect, outcome, program.collapse_threshold) if not v.passed] == []
    numbers = json.dumps(outcome.golden())
    assert "NaN" not in numbers and "Infinity" not in numbers


# near-critical geometry ---------------------------------------------------------------------
@pytest.mark.parametrize(
    "points, com, admitted",
    [
        ([[0.03, 0.0, 0.0]], [0.0, 0.0], False),  # one point, far from the centre of mass
        ([[0.0, -0.01, 0.0], [0.0, 0.01, 0.0]], [0.0, 0.0], True),  # a line under it (padded 1 mm, 3.3.3)
        ([[0.0, -0.01, 0.0], [0.0, 0.0, 0.0], [0.0, 0.01, 0.0]], [0.005, 0.0], False),  # collinear, 5 mm off
        ([[0.01, 0.0, 0.0]] * 4, [0.0, 0.0], False),  # four times the same point
    ],
)
@pytest.mark.parametrize("model", ["report", "equilibrium"])
def test_degenerate_contacts_give_a_verdict_without_errors(points, com, admitted, model):
    engine = FakeEngine()
    ext = StabilityExtension(engine, StabilityConfig(rest_duration=0.0, face_gap=-1.0, model=model))
    engine.frozen.add(0)
    ext.add_ground(0, Plane(0.0))
    engine.poses[1] = Pose(np.array([*com, 0.004]))
    ext.add_brick(1, KAPLA, "b1")
    engine.touch(1, 0, points, normal=[0, 0, 1])
    events = ext.update(0.0)
    if model == "report":
        assert bool(events) is admitted
    else:  # equilibrium: a single point or a line cannot hold a brick against rotation
        assert events == [] or admitted
    graph = ext.graph()
    assert all(np.isfinite(n.com_above).all() and math.isfinite(n.mass_above) for n in graph.nodes)


# long and tall ---------------------------------------------------------------------------------
def test_a_60_level_tower_left_alone_for_120_s_does_not_move():
    _, _, outcome = run("long_60")
    assert outcome.collapse is None and outcome.simulated_time >= 180.0
    assert max(outcome.displacement.values()) < 0.0005
    assert outcome.kinetic_energy == 0.0  # every brick frozen: no energy creeps in


@pytest.mark.slow
def test_a_100_level_tower_costs_no_more_steps_per_brick_than_a_10_level_one():
    # Wall time belongs to the benchmark; physics steps per placed brick are the cost
    # that must not grow (a growing stack that jitters would need ever more steps).
    def steps_per_brick(levels):
        outcome = run_program(compile_scenario(parse_scenario(f"stackdsl: 1\nstructure: {{tower: {{levels: {levels}}}}}\n")))
        assert outcome.collapse is None
        return outcome.steps / outcome.bricks_placed

    assert steps_per_brick(100) <= 1.2 * steps_per_brick(10)


@pytest.mark.slow
def test_a_250_level_tower_keeps_its_heights_and_stands():
    # An engine's contacts are soft: a brick at rest overlaps its supports by a few
    # hundredths of a millimetre. Frozen with those overlaps, a 250-level tower had sunk
    # 2 to 4 mm by its top, unevenly, and each new brick rocked onto the lower of its two
    # supports. Frozen out of them, no brick finds its supports sunk by a tenth of that.
    # Raised by pybullet's contact distances, which overstate the overlap by several per
    # cent, the tower rose instead, 0.37 mm by level 250; raised by the faces' depth, no
    # brick ends a tenth of a millimetre from where it was placed (0.05 mm at most).
    outcome = run_program(compile_scenario(parse_scenario("stackdsl: 1\nstructure: {tower: {levels: 250}}\n")))
    assert outcome.collapse is None and outcome.levels_placed == 250
    places = [e for e in outcome.events if e.kind == "place"]
    assert len(places) == 500
    sinks = [float(e.detail.split()[-2]) for e in places if "sunk" in e.detail]  # reported above 0.05 mm
    assert max(sinks, default=0.0) < 0.2
    assert max(outcome.displacement.values()) < 1e-4


# timestep independence -------------------------------------------------------------------------
@pytest.mark.slow
@pytest.mark.parametrize("timestep", ["1/120 s", "1/500 s", "1/2000 s"])
def test_the_slant_tower_collapses_at_9_whatever_the_timestep(timestep):
    text = (ROOT / "scenarios" / "slant_tower.yaml").read_text().replace("engine:\n", f"engine:\n  timestep: {timestep}\n")
    outcome = run_program(compile_scenario(parse_scenario(text)))
    assert outcome.collapse.level == 9


@pytest.mark.parametrize("timestep", ["1/60 s", "1/30 s", "20 ms"])
def test_timesteps_that_change_the_answers_are_refused(timestep):
    with pytest.raises(ScenarioError, match="at most 10 ms"):
        parse_scenario(f"stackdsl: 1\nstructure: {{tower: {{levels: 2}}}}\nengine: {{timestep: {timestep}}}\n")


# fast impacts ----------------------------------------------------------------------------------
@pytest.mark.slow
@pytest.mark.parametrize("speed", [1, 5, 20, 50])
def test_a_thrown_brick_strikes_the_brick_it_is_aimed_at(speed):
    # The promise is that it does not slip past: the hit brick leaves its place, and what the
    # hammer cannot reach stays (at 5 m/s it strikes level 11 on its way down the face).
    _, program, outcome = run(f"fast_impact_{speed}")
    assert outcome.displacement["L13.2"] > program.collapse_threshold
    assert all(d < program.collapse_threshold for b, d in outcome.displacement.items() if int(b[1:3]) <= 10)


@pytest.mark.parametrize("speed", [5, 20, 50])
def test_a_brick_thrown_at_a_fixed_wall_stays_on_its_side(speed):
    outcome = run_program(compile_scenario(parse_scenario(wall_throw(speed, "extension"))))
    hammer = next(n for n in outcome.final_graph.nodes if n.id == "hammer")
    assert hammer.position_mm[0] < 0  # it did not pass through the wall


# determinism -----------------------------------------------------------------------------------
def _golden(path: str) -> str:
    return json.dumps(run_program(compile_scenario(load_scenario(path))).golden(), sort_keys=True)


@pytest.mark.slow
def test_runs_are_identical_in_this_process_and_in_others():
    path = str(ROOT / "scenarios" / "slant_tower.yaml")
    here = [_golden(path), _golden(path)]
    with multiprocessing.get_context("spawn").Pool(2) as pool:
        there = pool.map(_golden, [path, path])
    assert here[0] == here[1] == there[0] == there[1]


def test_a_seed_fixes_the_random_state():
    text = "stackdsl: 1\nseed: {seed}\nstructure: {{tower: {{levels: 6}}}}\ntiming: {{placement_error: 2 mm}}\n"
    a, b, c = (run_program(compile_scenario(parse_scenario(text.format(seed=s)))).golden() for s in (1, 1, 2))
    assert a == b and a != c


# far from the origin ---------------------------------------------------------------------------
def test_a_tower_1_km_away_behaves_as_at_the_origin():
    _, _, far = run("far_from_origin")
    near = run_program(compile_scenario(load_scenario(ROOT / "scenarios" / "slant_tower.yaml")))
    assert far.collapse.level == near.collapse.level == 9

    def frozen_before_collapse(outcome, shift):
        return {
            n.id: tuple(round(p - s, 1) for p, s in zip(n.position_mm, shift))
            for n in outcome.collapse_graph.nodes
            if n.state == "frozen"
        }

    assert frozen_before_collapse(far, (1_000_000.0, 0.0, 0.0)) == frozen_before_collapse(near, (0.0, 0.0, 0.0))
    assert all(n.state != BrickState.ACTIVE.value or n.id != "ground" for n in far.final_graph.nodes)


# the leaning limits swept (stackdsl bench hard) ------------------------------------------------
@pytest.mark.parametrize(
    "name, scene",
    [("lean_wall_stands", lean_on_wall), ("lean_wall_slides", lean_on_wall), ("vee_stands", vee), ("vee_slides", vee)],
)
def test_the_swept_scenes_are_the_library_scenarios(name, scene):
    library = compile_scenario(load_scenario(ROOT / "scenarios" / f"{name}.yaml"))
    angle = float(library.name.split(",")[-1].split()[0])  # "brick leaning on a wall, 45 deg"
    swept = compile_scenario(parse_scenario(scene(angle, "extension")))
    ours = [(p.id, p.position, p.yaw, p.pitch, p.roll) for p in library.placements]
    theirs = [(p.id, p.position, p.yaw, p.pitch, p.roll) for p in swept.placements]
    assert len(ours) == len(theirs)
    for a, b in zip(ours, theirs):
        assert np.allclose(a[1], b[1], atol=2e-5) and np.allclose(a[2:], b[2:], atol=1e-9)


@pytest.mark.slow
def test_the_sweep_brackets_each_closed_form_within_a_degree():
    found = leaning_limits(modes=("extension",), step=0.5, span=2.0)
    for (name, _), (stood, fell) in found.items():
        limit = V_LIMIT if name == "inverted V" else WALL_LIMIT
        assert stood is not None and fell is not None and stood < fell
        assert limit - 1.0 <= stood and fell <= limit + 1.5
    assert "| inverted V | 26.6 deg | extension |" in format_limits(found)


def on_a_ramp(angle: float, bricks: int, prefix: str, tilt: str, material: str, ramp_length: int, ground: bool) -> str:
    """``bricks`` KAPLA of ``material`` (a YAML mapping's entry, named first) stacked square on a
    fixed ramp of it tilted ``angle`` deg, each posed by ``tilt`` (its angles, with ``{a}`` for
    ``-angle``), ids ``prefix`` 1, 2, ...; the ground of it too when ``ground``."""
    a = math.radians(angle)
    normal = np.array([-math.sin(a), 0.0, math.cos(a)])
    name = material.split(":")[0]
    rows = [f"    - {{id: ramp, brick: ramp, at: [0, 0, 100 mm], pitch: {-angle}, fixed: true}}"]
    for i in range(bricks):
        x, _, z = 1000 * (np.array([0.0, 0.0, 0.1]) + (0.014 + 0.008 * i) * normal)
        pose = tilt.format(a=-angle)
        rows.append(f"    - {{id: {prefix}{i + 1}, brick: k, at: [{x:.3f} mm, 0, {z:.3f} mm], {pose}, level: {i + 1}}}")
    return (
        f"stackdsl: 1\nmaterials: {{{material}}}\n"
        f"brick_types: {{k: {{size: [120 mm, 24 mm, 8 mm], material: {name}}}, ramp: {{size: [{ramp_length} mm, 100 mm, 20 mm], material: {name}}}}}\n"
        + (f"ground: {{material: {name}}}\n" if ground else "")
        + "structure:\n  bricks:\n"
        + "\n".join(rows)
        + "\n"
    )


def ramp_stack(angle: float, bricks: int) -> str:
    """``bricks`` KAPLA laid parallel on a fixed ramp tilted ``angle`` deg, every surface friction 0.3."""
    return on_a_ramp(angle, bricks, "b", "pitch: {a}", "slick: {density: 460 kg/m^3, friction: 0.3}", 400, ground=True)


@pytest.mark.parametrize("model", ["report", "equilibrium"])
@pytest.mark.parametrize("angle", [15.0, 17.5])
def test_a_stack_on_a_ramp_slides_at_level_1_beyond_the_friction_angle(model, angle):
    """atan(0.3) = 16.70 deg: beyond it the first brick slides as soon as it is let go
    (a = g (sin a - 0.3 cos a) = 0.14 m/s^2 at 17.5 deg, 71 mm in a second), and is never frozen
    on the ramp; within it the stack stands. Both models, the report's included: its unlimited
    friction between stack bricks is not friction a tilted support lacks."""
    program = compile_scenario(parse_scenario(ramp_stack(angle, 4)), model=model)
    outcome = run_program(program)
    slides = math.tan(math.radians(angle)) > 0.3
    if not slides:
        assert outcome.collapse is None
        return
    assert outcome.collapse is not None and outcome.collapse.level == 1 and outcome.collapse.brick == "b1"
    assert outcome.collapse.time < 1.0  # when it slid, not the run's end
    assert not any(e.kind == "freeze" and e.brick == "b1" and e.time < outcome.collapse.time for e in outcome.events)


def ramp_column(angle: float, bricks: int) -> str:
    """A column of ``bricks`` KAPLA stacked square on a fixed ramp tilted ``angle`` deg, each
    across the slope (24 mm along it, 8 mm thick), every surface friction 1.5: none slides
    below 56 deg."""
    return on_a_ramp(angle, bricks, "c", "yaw: 90, roll: {a}", "grip: {friction: 1.5}", 300, ground=False)


@pytest.mark.parametrize("model", ["report", "equilibrium"])
@pytest.mark.parametrize("angle", [28.0, 32.0, 35.0, 47.0])
def test_a_column_on_a_ramp_tips_at_its_closed_form_level_either_side_of_the_support_angle(model, angle):
    """k bricks 24 mm wide and 8 mm thick tip about their downhill edge once their centre of mass,
    4k mm above the ramp, passes it: tan a > 12 / 4k, so at the first k > 3 / tan a (6 at 28 deg,
    5 at 32 and 35, 3 at 47). Beyond the 30 deg support angle the bricks are frozen on the ramp by
    the debris rule, and the brick that tips the column is refused admission: its weight on the
    frozen column, found from the tilted faces it lies on (past 45 deg, whose bottom face is then
    a side, from its contacts), must wake it (the report model built on to level 8 when those
    faces were missed)."""
    level = math.floor(3.0 / math.tan(math.radians(angle))) + 1
    outcome = run_program(compile_scenario(parse_scenario(ramp_column(angle, level + 1)), model=model))
    assert outcome.collapse is not None and outcome.collapse.level == level, outcome.collapse
    assert outcome.collapse.time < level  # when the brick of that level was placed (one a second), not the run's end


@pytest.mark.parametrize("angle", [30.0, 35.0, 36.0])
def test_a_leaning_bricks_margin_is_the_ladders_on_its_corner_contacts(angle):
    """A KAPLA brick leaning on a fixed wall, every surface friction 0.3: its centre of mass can
    move towards the wall by mu/(1+mu^2) (L cos a + L mu sin a) - (L/2 sin a - h/2 cos a) before
    no forces hold it (both corners at their friction limits; a from vertical, L = 120 mm,
    h = 8 mm): 7.0, 1.6 and 0.51 mm at 30, 35 and 36 deg.
    The engine's corner contacts are padded 1 mm across to decide; the margin is the bare
    corners', not 1 mm more."""
    a = math.radians(angle)
    x, z = -(60 * math.sin(a) + 4 * math.cos(a)), 60 * math.cos(a) + 4 * math.sin(a)
    text = (
        "stackdsl: 1\nmaterials: {slick: {density: 460 kg/m^3, friction: 0.3}}\n"
        "brick_types: {k: {size: [120 mm, 24 mm, 8 mm], material: slick}, wall: {size: [20 mm, 200 mm, 200 mm], material: slick}}\n"
        "ground: {material: slick}\nstructure:\n  bricks:\n    - {id: wall, brick: wall, at: [10 mm, 0, 100 mm], fixed: true}\n"
        f"    - {{id: leaner, brick: k, at: [{x:.3f} mm, 0, {z:.3f} mm], pitch: {angle - 90:g}}}\n"
    )
    outcome = run_program(compile_scenario(parse_scenario(text)))
    assert outcome.collapse is None and outcome.certificate is not None
    mu = 0.3  # at the placed angle: the brick settles by up to 0.3 deg, which the bound allows for
    hand = mu / (1 + mu * mu) * (120 * math.cos(a) + 120 * mu * math.sin(a)) - (60 * math.sin(a) - 4 * math.cos(a))
    assert abs(outcome.certificate.margin_mm - hand) < 0.35, (outcome.certificate.margin_mm, hand)


@pytest.mark.parametrize("model", ["report", "equilibrium"])
def test_a_tower_with_no_friction_at_all_stands_on_its_level_faces(model):
    """Friction 0 everywhere: level faces need none, so a 4 stack stands; an engine's normals a
    hair off vertical (under 1e-3) are no slope that friction 0 cannot hold."""
    text = (
        "stackdsl: 1\nmaterials: {ice: {density: 460 kg/m^3, friction: 0}}\n"
        "brick_types: {k: {size: [120 mm, 24 mm, 8 mm], material: ice}}\nground: {material: ice}\n"
        "structure: {tower: {levels: 6, brick: k}}\n"
    )
    outcome = run_program(compile_scenario(parse_scenario(text), model=model))
    assert outcome.collapse is None and outcome.certificate is not None and outcome.certificate.verdict == "stands"
    assert outcome.certificate.margin_mm is not None and outcome.certificate.margin_mm > 10.0


def test_a_thrown_brick_still_in_flight_at_the_end_is_no_part_of_the_stand():
    """A throw that misses an untouched tower, the run ending while the brick flies: the final
    state's equilibrium leaves out what touches nothing (no contact force can act on it), and
    the tower stands, as it does when the brick has landed."""
    text = (
        "stackdsl: 1\nstructure: {tower: {levels: 2}}\n"
        "impacts: [{id: p, target: {point: [0, 0, 300 mm]}, direction: [1, 0, 0], speed: 3 m/s, at: after level 2, distance: 100 mm}]\n"
        "allow: [floating]\ntiming: {settle: %s}\n"
    )
    for settle in ("0.2 s", "2 s"):  # in flight at the end, and landed
        outcome = run_program(compile_scenario(parse_scenario(text % settle)))
        assert outcome.collapse is None, (settle, outcome.collapse)
        assert outcome.certificate is not None and outcome.certificate.verdict == "stands"


def test_a_collapse_by_no_equilibrium_is_not_said_as_a_brick_that_moved():
    """ "moved past 4.0 mm ... (0 mm by ...)" contradicted itself: a final state no equilibrium
    holds names its proof and its mechanism instead."""
    from stackdsl.verdicts.expect import explain

    scenario, _, outcome = run("overhang_falls")
    assert outcome.collapse is not None and outcome.certificate is not None
    proof = outcome.certificate.model_copy(
        update={"kind": "no equilibrium", "detail": "no equilibrium at the end: 0.5 N of tension needed", "bricks": ("b2",)}
    )
    lines = explain(
        scenario.expect.model_copy(update={"collapse": None, "stands": True}),
        outcome.model_copy(update={"certificate": proof}),
        0.004,
    )
    said = next(line for line in lines if line.startswith("collapsed:"))
    assert "moved past" not in said and "0.5 N of tension needed" in said and "b2" in said
