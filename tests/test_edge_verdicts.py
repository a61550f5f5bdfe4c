"""Verdicts at the edges: nothing decided while a hand or the ground moves, a run that ends in
motion undecided, near ties decided by statics on the placed geometry."""

import re

import pytest

from stackdsl import check, compile_scenario, evaluate, parse_scenario, run_program
from stackdsl.compile.perturb import Perturbation, perturb
from stackdsl.compile.program import Push
from stackdsl.verdicts.expect import explain

PUSH_OFF = """\
stackdsl: 1
structure:
  bricks:
    - {id: base, at: [0, 0, 4 mm]}
    - {id: top, at: [0, 0, 12 mm]}
timing: {settle: 0.5 s}
actions:
  - push: {target: {brick: top}, direction: [1, 0, 0], speed: 0.1 m/s, distance: 100 mm, at: after level 2}
expect:
  collapse: 2
"""
# a brick stood on an edge, 15 deg from upright: it falls over, and 0.1 s is not long enough to see it land
FALLS_OVER = """\
stackdsl: 1
structure:
  bricks:
    - {id: domino, at: [0, 0, 59 mm], pitch: 75}
timing: {settle: 0.1 s}
expect: {stands: true}
"""
# a brick 0.5 mm inside the edge of the one below: statics says it stands; pybullet's 1 mm
# collision margin tipped it at a timestep 1% shorter
TIE = """\
stackdsl: 1
structure:
  bricks:
    - {id: base, at: [0, 0, 4 mm]}
    - {id: top, at: [59.5 mm, 0, 12 mm]}
timing: {settle: 1 s}
expect: {stands: true}
"""


def test_no_collapse_is_decided_while_a_hand_still_pushes():
    program = compile_scenario(parse_scenario(PUSH_OFF))
    outcome = run_program(program)
    push = next(a for a in program.actions if isinstance(a, Push))
    assert outcome.collapse is not None and outcome.collapse.level == 2
    assert outcome.collapse.time < push.end_time <= outcome.collapse.decided  # dated when it went, decided after


def test_a_run_that_ends_in_motion_is_undecided_and_says_settle_longer(tmp_path):
    scenario = parse_scenario(FALLS_OVER)
    program = compile_scenario(scenario)
    outcome = run_program(program)
    assert outcome.collapse is None
    assert outcome.certificate is not None and (outcome.certificate.verdict, outcome.certificate.kind) == (
        "undecided",
        "still moving",
    )
    assert "settle longer (timing.settle, 0.1 s now)" in outcome.certificate.detail
    (verdict,) = evaluate(scenario.expect, outcome, program.collapse_threshold)
    assert (verdict.passed, verdict.inconclusive) == (False, True) and verdict.measured.startswith("undecided: domino")
    assert explain(scenario.expect, outcome, program.collapse_threshold)[0].startswith("undecided: the run ended at t=0.10 s")
    (tmp_path / "falls.yaml").write_text(FALLS_OVER)
    (result,) = check(tmp_path, jobs=1)
    assert result.verdict == "INCONCLUSIVE" and result.measured == "undecided: still moving at the end"
    (tmp_path / "falls.yaml").write_text(FALLS_OVER.replace("settle: 0.1 s", "settle: 2 s"))
    (result,) = check(tmp_path, jobs=1)
    assert result.verdict == "FAIL" and result.collapse_level == 1  # long enough: it fell, and that is decided


@pytest.mark.parametrize("change", [Perturbation("timestep", -1), Perturbation("iterations", -1)])
def test_a_near_tie_is_decided_by_statics_on_the_placed_geometry_whatever_the_engine_does(change):
    program = perturb(compile_scenario(parse_scenario(TIE)), change)
    outcome = run_program(program)
    assert outcome.collapse is None
    freeze = next(e for e in outcome.events if e.kind == "freeze" and e.brick == "top")
    assert "by exact statics on its placed geometry" in freeze.detail and "0.50 mm inside its support's edge" in freeze.detail
    assert outcome.certificate is not None
    assert "statics on the placed geometry decided top's landing" in outcome.certificate.detail


def test_outside_the_edge_a_near_tie_falls_as_statics_says():
    outcome = run_program(
        compile_scenario(parse_scenario(TIE.replace("59.5 mm", "60.5 mm").replace("stands: true", "collapse: 2")))
    )
    assert outcome.collapse is not None and outcome.collapse.level == 2


PUSH_INTO_POST = """\
stackdsl: 1
brick_types:
  post: {{size: [20 mm, 40 mm, 40 mm]}}
structure:
  bricks:
    - {{id: post, brick: post, at: [85 mm, 0, 20 mm], fixed: true}}
    - {{id: b, at: [0, 0, 4 mm]}}
actions:
  - push: {{target: {{brick: b}}, direction: [1, 0, 0], speed: 0.1 m/s, distance: {distance}, at: after level 1}}
"""


def test_a_push_that_drives_its_brick_into_a_fixed_body_is_refused_before_it_runs():
    """b's end is 15 mm short of the post; the pusher starts 5 mm short of b. A push of 30 mm
    carries b 25 mm: 10 mm into the post, which no two engines agree on. 20 mm fits exactly."""
    from stackdsl import ScenarioError

    with pytest.raises(ScenarioError) as refused:
        compile_scenario(parse_scenario(PUSH_INTO_POST.format(distance="30 mm"), "push.yaml"))
    said = str(refused.value)
    assert said.startswith("push.yaml:9:80: actions[0].push.distance: the push drives b 10 mm into the fixed body post")
    assert "it has 15 mm of room ahead and the pusher carries it 25 mm" in said and "at most 20 mm" in said
    compile_scenario(parse_scenario(PUSH_INTO_POST.format(distance="20 mm")))  # room enough: it runs


# random assembly 143 of `stackdsl bench verdicts --seed 9090`: b04 (level 2) tips when b07 lands on
# it, and b06, frozen on b05, was carried by b04 too once b04 froze under it
CARRIED_ABOVE = """\
stackdsl: 1
brick_types:
  wall: {size: [20 mm, 200 mm, 200 mm], material: pine}
structure:
  bricks:
    - {id: b01, at: [90.009 mm, 84.569 mm, 4.0 mm], yaw: 90.000, level: 1}
    - {id: b02, at: [14.809 mm, -25.621 mm, 4.0 mm], yaw: 0.000, level: 1}
    - {id: b03, at: [15.560 mm, 87.775 mm, 4.0 mm], yaw: 90.000, level: 1}
    - {id: b04, at: [3.872 mm, 58.516 mm, 12.0 mm], yaw: 0.000, level: 2}
    - {id: b05, at: [26.383 mm, 116.080 mm, 12.0 mm], yaw: 0.000, level: 2}
    - {id: b06, at: [30.581 mm, 126.817 mm, 20.0 mm], yaw: 68.642, level: 3}
    - {id: b07, at: [-36.221 mm, 70.628 mm, 20.0 mm], yaw: 90.000, level: 3}
    - {id: b08, at: [83.400 mm, 119.928 mm, 20.0 mm], yaw: 90.000, level: 3}
    - {id: b09, at: [-246.239 mm, 125.271 mm, 4.0 mm], yaw: 43.995, level: 1}
    - {id: wall, brick: wall, at: [-302.449 mm, 194.752 mm, 100.000 mm], yaw: 133.995, fixed: true}
    - {id: b10, at: [-265.8177 mm, 156.8128 mm, 55.6448 mm], yaw: 133.995, pitch: -48.589, level: 4}
timing: {interval: 0.5 s, settle: 1 s}
"""


@pytest.mark.parametrize("backend", ["pybullet", "mujoco"])
def test_a_brick_frozen_onto_one_that_froze_later_wakes_with_it(backend):
    # b06 was frozen on b05; b04 froze later under its edge and b06 was made to rest on it too,
    # but b04 did not know b06 lay on it: woken, b04 left b06 frozen on it, a fixed body holding
    # it down, and was frozen again "leaning on b03, b05, b06" where rigid statics has no
    # equilibrium; the end certificate then called the collapse at level 4, the oracle's is 3
    program = compile_scenario(parse_scenario(CARRIED_ABOVE), "extension", "report", backend)
    outcome = run_program(program)
    assert outcome.collapse is not None and outcome.collapse.level == 3
    woken = {e.brick for e in outcome.events if e.kind == "wake" and "rests on b04" in e.detail}
    assert "b06" in woken


# six bricks in a single file, the top one 0.28 mm past the edge of the one under it: MuJoCo's
# soft contacts held it through its settle, and the run said "stands" (near tie 4242-310). Each
# brick under it is now frozen flat where it landed, and both engines tip it as statics says.
HELD_PAST_THE_EDGE = """\
stackdsl: 1
structure:
  bricks:
    - {id: b01, at: [0.000000 mm, 0, 4 mm], level: 1}
    - {id: b02, at: [13.939341 mm, 0, 12 mm], level: 2}
    - {id: b03, at: [-24.910008 mm, 0, 20 mm], level: 3}
    - {id: b04, at: [-17.963185 mm, 0, 28 mm], level: 4}
    - {id: b05, at: [-30.741814 mm, 0, 36 mm], level: 5}
    - {id: b06, at: [-91.006876 mm, 0, 44 mm], level: 6}
timing: {settle: 1 s}
"""


@pytest.mark.parametrize("backend", ["pybullet", "mujoco"])
def test_a_brick_placed_past_the_edge_falls_as_statics_says_even_where_the_engine_holds_it(backend):
    outcome = run_program(compile_scenario(parse_scenario(HELD_PAST_THE_EDGE), "extension", "report", backend))
    assert outcome.collapse is not None and (outcome.collapse.level, outcome.collapse.brick) == (6, "b06")
    assert outcome.certificate is not None and outcome.certificate.kind == "off its support"
    assert outcome.margin is not None and -0.0003 < outcome.margin < -0.0002  # placed 0.27 mm out
    assert "outside the support polygon it was placed on (0.3 mm as it was placed)" in outcome.certificate.detail


def _load_tie(out: float) -> str:
    """Four bricks in a single file whose top two together lie ``out`` metres past the edge of
    the second (negative: inside), each brick well inside the edge of the one under it."""
    top = 80.0 + 2 * out * 1000
    return (
        "stackdsl: 1\nstructure:\n  bricks:\n"
        "    - {id: b01, at: [0, 0, 4 mm]}\n    - {id: b02, at: [0, 0, 12 mm]}\n"
        f"    - {{id: b03, at: [40 mm, 0, 20 mm]}}\n    - {{id: b04, at: [{top:.6f} mm, 0, 28 mm]}}\n"
        "timing: {settle: 1 s}\n"
    )


@pytest.mark.parametrize("backend", ["pybullet", "mujoco"])
@pytest.mark.parametrize("out", [1.5e-6, -1.5e-6])
def test_a_verdict_on_a_load_placed_on_an_exact_tie_says_so(backend, out):
    # the tie is of the load above b02, not of any brick's own centre of mass: the certificate
    # named none (a miss on MuJoCo, one level early or late, said nothing of why)
    outcome = run_program(compile_scenario(parse_scenario(_load_tie(out)), "extension", "report", backend))
    assert outcome.certificate is not None
    # the edge is where the engine has b02 when b04 is placed: a few um from its placed pose
    said = re.search(
        r"b03 with the 1 brick it carries placed (\d\.\d+) mm \w+ its support's edge when b04 was placed: an exact tie",
        outcome.certificate.detail,
    )
    assert said is not None and float(said[1]) < 0.1


# near tie 2711-202: b06 0.3947 mm inside the edge of b05 as placed; MuJoCo landed it 15 um
# further in, and the certificate, measured where the engine holds the bricks, said 0.4 mm
LANDED_FURTHER_IN = """\
stackdsl: 1
structure:
  bricks:
    - {id: b01, at: [0.000000 mm, 0, 4 mm], level: 1}
    - {id: b02, at: [8.186400 mm, 0, 12 mm], level: 2}
    - {id: b03, at: [-11.170714 mm, 0, 20 mm], level: 3}
    - {id: b04, at: [35.604732 mm, 0, 28 mm], level: 4}
    - {id: b05, at: [8.803832 mm, 0, 36 mm], level: 5}
    - {id: b06, at: [68.409166 mm, 0, 44 mm], level: 6}
timing: {settle: 1 s}
"""


@pytest.mark.parametrize("backend", ["pybullet", "mujoco"])
def test_a_stands_margin_is_no_larger_than_the_placed_geometrys_where_the_engine_settled_it(backend):
    from stackdsl.bench.random_stack import interface_margins

    program = compile_scenario(parse_scenario(LANDED_FURTHER_IN), "extension", "report", backend)
    true = float(interface_margins([p.position[0] for p in sorted(program.placements, key=lambda p: p.level)]).min())
    outcome = run_program(program)
    assert outcome.collapse is None and outcome.certificate is not None and outcome.certificate.margin_mm is not None
    assert 0.39 < true * 1000 < 0.4
    assert outcome.certificate.margin_mm <= true * 1000 and outcome.margin is not None and outcome.margin <= true
    assert true - outcome.margin < 0.0005  # and within 0.5 mm of it


# a KAPLA brick on end, shaken across its 24 mm side at 1.13 times its rocking threshold: it
# rocked 11 deg and came back; at the still turning point of a rock, 2.6 deg tilted on the edge
# of its face, the extension froze it (woken by the shake, it was no longer a just-placed brick,
# whose rocks were already waited out), and the run called its top's 4.5 mm a collapse
ROCKED_BACK = """\
stackdsl: 1
brick_types: {blk: {size: [120 mm, 24 mm, 8 mm]}}
structure: {bricks: [{id: b, brick: blk, at: [0, 0, 60 mm], roll: 0, pitch: 90}]}
timing: {settle: 2 s}
actions:
  - shake: {amplitude: 3.521581 mm, frequency: 4 Hz, duration: 1 s, direction: [0, 1], at: 1 s}
"""


def test_a_woken_brick_is_not_frozen_at_the_turning_point_of_a_rock():
    outcome = run_program(compile_scenario(parse_scenario(ROCKED_BACK), "extension", "report", "pybullet"))
    assert outcome.collapse is None
    assert outcome.displacement["b"] < 0.001  # its farthest corner within 1 mm of its place: it came back


# a brick 0.3 mm past the edge of the pillar it lies on, a narrow step 0.9 mm lower beside the pillar:
# within the 1 mm face gap of the step, but not on it (a new user's, with both tuned engines)
STEP_BESIDE = """\
stackdsl: 1
brick_types:
  a: {size: [30 mm, 40 mm, 50 mm]}
  b: {size: [10 mm, 40 mm, STEP mm]}
structure:
  bricks:
    - {id: A, brick: a, at: [-15 mm, 0, 25 mm], fixed: true}
    - {id: B, brick: b, at: [5.5 mm, 0, HALF mm], fixed: true}
    - {id: top, at: [0.3 mm, 0, 54 mm]}
"""


@pytest.mark.parametrize("backend", ["pybullet", "mujoco"])
@pytest.mark.parametrize(("step_mm", "tips"), [(49.1, True), (50.0, False)])
def test_a_placed_brick_is_frozen_only_on_what_it_touches_not_a_step_below(backend, step_mm, tips):
    """A placed brick is frozen where it lands only on the faces it touches. The step 0.9 mm lower
    lies within the face gap of its bottom, and was counted among its supports: its centre of mass
    lay inside the two together, and it was frozen flat (stands, a margin of 10.2 mm) where both
    tuned engines tip it onto the step, its far end 5.2 mm down. Level with the pillar, the step
    is a support, and the brick stands."""
    text = STEP_BESIDE.replace("STEP", f"{step_mm}").replace("HALF", f"{step_mm / 2}")
    outcome = run_program(compile_scenario(parse_scenario(text), "extension", "report", backend))
    assert (outcome.collapse is not None) is tips, outcome.certificate
    placed = next(e.time for e in outcome.events if e.kind == "place" and e.brick == "top")
    frozen = next(e for e in outcome.events if e.kind == "freeze" and e.brick == "top")
    assert (frozen.time - placed < 0.05) is not tips, frozen  # frozen as it landed only where it lies on both


def _counterweight(interval: float) -> str:
    """A KAPLA brick placed 1 mm past the edge of the one under it, and a counterweight on its
    back end ``interval`` s later that brings their centre of mass 14.5 mm inside that edge."""
    return (
        "stackdsl: 1\nstructure:\n  bricks:\n    - {id: L1, at: [0, 0, 4 mm]}\n"
        "    - {id: L2, at: [61 mm, 0, 12 mm]}\n    - {id: L3, at: [30 mm, 0, 20 mm]}\n"
        f"timing: {{interval: {interval} s}}\nexpect: {{stands: true}}\n"
    )


@pytest.mark.parametrize("backend", ["pybullet", "mujoco"])
def test_a_counterweight_placed_in_time_catches_a_brick_placed_past_the_edge(backend):
    # 0.1 s after it was placed the brick has turned 2.4 deg at most, its far end 2.5 mm down: the
    # counterweight catches it, as the engines show (pybullet tips it 1.5 deg, then back); statics
    # on the placed geometry alone had called it fallen at level 2
    scenario = parse_scenario(_counterweight(0.1))
    outcome = run_program(compile_scenario(scenario, "extension", "report", backend))
    assert outcome.collapse is None and all(v.passed for v in evaluate(scenario.expect, outcome, 0.004))
    # 0.3 s after, it has tipped past the threshold before the counterweight comes
    late = run_program(compile_scenario(parse_scenario(_counterweight(0.3)), "extension", "report", backend))
    assert late.collapse is not None and (late.collapse.level, late.collapse.brick) == (2, "L2")


@pytest.mark.parametrize("expects", ["stands: true", "collapse: 2", "stays: [base]"])
def test_a_run_stopped_early_decides_only_what_came_before_it_stopped(expects):
    """A timeout leaves what the rest of the run would have said undecided; the run fails on its
    own ``finished`` verdict. A collapse seen before it stopped is decided: ``stands`` failed and
    ``collapse: 2`` held; ``stays: [base]`` is decided only had the base moved."""
    scenario = parse_scenario(PUSH_OFF.replace("collapse: 2", expects))
    program = compile_scenario(scenario)
    whole = run_program(program)
    assert whole.collapse is not None and whole.collapse.level == 2
    stopped = "timeout after 1 s at t = 0.1 s simulated (of 2 s)"
    early = whole.model_copy(update={"stopped": stopped, "collapse": None, "simulated_time": 0.1})
    late = whole.model_copy(update={"stopped": stopped})
    for outcome, decided in ((early, False), (late, expects != "stays: [base]")):
        verdict, finished = evaluate(scenario.expect, outcome, program.collapse_threshold)
        assert (finished.name, finished.passed, finished.measured) == ("finished", False, stopped)
        if decided:
            assert verdict == evaluate(scenario.expect, whole, program.collapse_threshold)[0]
        else:
            assert (verdict.passed, verdict.inconclusive) == (False, True), verdict
            said = f"not decided: the run stopped at t = {outcome.simulated_time:.2f} s (so far: "
            assert verdict.measured.startswith(said), verdict
