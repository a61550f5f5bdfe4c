"""Golden snapshots compared as a physicist would: verdicts exactly, measurements within
tolerances, what chaos decides loosely (stackdsl.verdicts.golden_compare, .tolerances)."""

import copy
import json
import re
from pathlib import Path

import pytest

from stackdsl import compile_scenario, parse_scenario
from stackdsl.lang.errors import ScenarioError
from stackdsl.verdicts.golden_compare import compare_golden
from stackdsl.verdicts.tolerances import Tolerances, default_tolerances, project_tolerance, tolerances_for

ROOT = Path(__file__).resolve().parents[1]


def brick(level, x, y=0.0, *, supports=None, displaced=0.0, state="frozen", quaternion=(0.0, 0.0, 0.0, 1.0)):
    return {
        "level": level,
        "state": state,
        "position_mm": [x, y, 8.0 * level - 4.0],
        "quaternion_xyzw": list(quaternion),
        "com_above_mm": [x, y, 8.0 * level],
        "mass_above_g": 10.6 * (4 - level),
        "rests_on": supports if supports is not None else {"ground": {"area_mm2": 2880.0, "load_share": 1.0}},
        "displaced_mm": displaced,
    }


def tower(x=0.0):
    """A three-level single file at ``x`` mm: plain snapshot data as Outcome.golden gives it."""
    return {
        "scenario": "three",
        "mode": "extension",
        "levels_placed": 3,
        "collapse_threshold_mm": 4.0,
        "toppled": 0,
        "collapse": None,
        "certificate": {"verdict": "stands", "kind": "equilibrium", "bricks": [], "margin_mm": 12.0, "friction_share": 0.0},
        "collapse_graph": None,
        "final_graph": {
            "L01.1": brick(1, x),
            "L02.1": brick(2, x, supports={"L01.1": {"area_mm2": 2880.0, "load_share": 1.0}}),
            "L03.1": brick(3, x, supports={"L02.1": {"area_mm2": 2880.0, "load_share": 1.0}}),
        },
    }


def test_the_same_snapshot_matches_with_nothing_to_say():
    c = compare_golden(tower(), tower())
    assert c.matches and c.within == 0 and c.chaos == [] and c.not_failures() == []


def test_noise_within_the_tolerances_matches_and_is_counted():
    new = tower()
    for b in new["final_graph"].values():
        b["position_mm"][0] += 0.3  # a third of the position tolerance
        b["quaternion_xyzw"] = [0.0, 0.0, 0.003, 1.0]  # 0.34 deg
        b["mass_above_g"] += 0.4
    new["certificate"]["margin_mm"] = 11.4
    c = compare_golden(tower(), new)
    assert c.matches, c.lines()
    assert c.within >= 9 and c.not_failures() == [f"not failures: {c.within} fields differ within their tolerance"]


def test_a_tower_moved_beyond_the_tolerance_is_one_line_by_level():
    c = compare_golden(tower(), tower(6.0))
    assert not c.matches
    assert c.lines() == [
        "final_graph: levels 1-3 (3 bricks) moved by 6.0 mm in x (tolerance 1 mm), their centres of mass above with them"
    ]


def test_worst_first_verdicts_before_measurements():
    new = tower(2.0)
    new["final_graph"]["L03.1"]["position_mm"][0] += 10.0
    new["certificate"]["kind"] = "load paths"
    lines = compare_golden(tower(), new).lines()
    assert lines[0] == "certificate.kind: equilibrium -> load paths"
    assert lines[1].startswith("final_graph L03.1: moved by 12.0 mm in x")  # 12 tolerances off, then 2
    assert lines[2].startswith("final_graph: levels 1-2 (2 bricks) moved by 2.0 mm in x")


@pytest.mark.parametrize(
    ("edit", "said"),
    [
        (lambda g: g.update(levels_placed=2), "levels_placed: 3 -> 2"),
        (lambda g: g.update(collapse={"level": 3, "brick": "L03.1", "brick_level": 3}), "collapse: stands -> collapse 3"),
        (lambda g: g["certificate"].update(verdict="collapse"), "certificate.verdict: stands -> collapse"),
        (lambda g: g["final_graph"]["L02.1"].update(state="active"), "final_graph L02.1: state frozen -> active"),
        (
            lambda g: g["final_graph"]["L03.1"]["rests_on"].update(ground={"area_mm2": 1.0, "load_share": 0.0}),
            "now rests on ground",
        ),
        (lambda g: g["final_graph"].pop("L03.1"), "final_graph: removed L03.1"),
        (lambda g: g["final_graph"]["L02.1"].update(level=4), "final_graph L02.1: level 2 -> 4"),
    ],
)
def test_a_verdict_field_is_compared_exactly(edit, said):
    new = tower()
    edit(new)
    c = compare_golden(tower(), new)
    assert not c.matches and any(said in line for line in c.lines()), c.lines()


def test_a_measured_field_beyond_its_tolerance_names_it_and_the_tolerance():
    new = tower()
    new["final_graph"]["L01.1"]["mass_above_g"] = 30.0  # 31.8 stored: 1.6 g tolerance
    new["final_graph"]["L02.1"]["rests_on"]["L01.1"]["load_share"] = 0.9
    new["certificate"]["friction_share"] = 0.2
    lines = compare_golden(tower(), new).lines()
    assert "final_graph L01.1 mass above: 31.8 -> 30 g (tolerance 1.59 g)" in lines
    assert "final_graph L02.1 rests on L01.1: load share: 1 -> 0.9 (tolerance 0.05)" in lines
    assert "certificate.friction_share: 0 -> 0.2 (tolerance 0.05)" in lines


def test_debris_is_not_compared_and_a_brick_at_the_edge_of_a_fall_is_chaos():
    fell = tower()
    fell["collapse"] = {"level": 3, "brick": "L03.1", "brick_level": 3}
    fell["final_graph"]["L03.1"] = brick(3, 150.0, 40.0, displaced=160.0, state="active")
    fell["final_graph"]["L02.1"]["displaced_mm"] = 0.2
    elsewhere = copy.deepcopy(fell)
    elsewhere["final_graph"]["L03.1"] = brick(3, -90.0, 12.0, displaced=100.0, state="frozen")  # another landing
    elsewhere["final_graph"]["L02.1"] = brick(2, 70.0, 0.0, displaced=75.0, state="active")  # the level below went too
    c = compare_golden(fell, elsewhere)
    assert c.matches, c.lines()
    assert any("L02.1: moved beyond the collapse threshold; it stood in the golden" in said for said in c.chaos)


def test_a_brick_far_below_the_fall_that_moves_is_a_difference():
    fell = tower()
    fell["final_graph"]["L03.1"] = brick(3, 150.0, 40.0, displaced=160.0)
    new = copy.deepcopy(fell)
    new["final_graph"]["L01.1"] = brick(1, 20.0, displaced=20.0)  # level 1: two levels below the fall
    lines = compare_golden(fell, new).lines()
    assert "final_graph L01.1: moved beyond the collapse threshold; it stood in the golden" in lines


def test_which_of_the_fallen_bricks_moved_first_is_chaos_but_a_standing_one_is_not():
    fell = tower()
    fell["collapse"] = {"level": 3, "brick": "L03.1", "brick_level": 3}
    for b, x in (("L02.1", 90.0), ("L03.1", 150.0)):
        fell["final_graph"][b] = brick(int(b[2]), x, displaced=x)
    twin = copy.deepcopy(fell)
    twin["collapse"] = {"level": 3, "brick": "L02.1", "brick_level": 2}
    assert compare_golden(fell, twin).matches
    elsewhere = copy.deepcopy(fell)
    elsewhere["collapse"] = {"level": 3, "brick": "L01.1", "brick_level": 1}
    lines = compare_golden(fell, elsewhere).lines()
    assert lines == ["collapse.brick: L03.1 -> L01.1 (did not move in the golden)"]


def test_a_twin_that_passed_the_threshold_at_the_collapse_and_came_back_may_move_first():
    """On a shake table both bricks of the bottom level slide: the golden's L01.2 was 4.2 mm
    out at the collapse and 3.2 mm at the end (shaken back under the 4 mm threshold); a jittered
    run in which L01.2 passed the threshold first is chaos, not a difference."""
    shaken = tower()
    shaken["collapse"] = {"level": 3, "brick": "L01.1", "brick_level": 1}
    shaken["collapse_graph"] = copy.deepcopy(shaken["final_graph"])
    for graph, twin_moved in (("collapse_graph", 4.2), ("final_graph", 3.2)):
        shaken[graph]["L01.1"] = brick(1, 22.6, displaced=22.6)
        shaken[graph]["L01.2"] = brick(1, twin_moved, displaced=twin_moved)
    other = copy.deepcopy(shaken)
    other["collapse"] = {"level": 3, "brick": "L01.2", "brick_level": 1}
    c = compare_golden(shaken, other)
    assert c.matches, c.lines()
    assert any("chaos picks which passes first" in said for said in c.chaos)
    for snapshot in (shaken, other):  # had it never passed the threshold: a difference
        snapshot["collapse_graph"]["L01.2"] = brick(1, 3.0, displaced=3.0)
    assert compare_golden(shaken, other).lines() == ["collapse.brick: L01.1 -> L01.2 (did not move in the golden)"]


def test_a_knocked_brick_may_differ_by_as_much_as_the_runs_moved_it():
    knocked = tower()
    knocked["final_graph"]["L03.1"] = brick(3, 2.5, supports={"L02.1": {"area_mm2": 1400.0, "load_share": 1.0}}, displaced=2.5)
    again = copy.deepcopy(knocked)
    again["final_graph"]["L03.1"] = brick(3, -0.8, supports={"L02.1": {"area_mm2": 2880.0, "load_share": 1.0}}, displaced=0.8)
    c = compare_golden(knocked, again)
    assert c.matches, c.lines()  # 3.3 mm apart, 2.5 + 0.8 + 1 allowed; its contact area is chaos's
    again["final_graph"]["L03.1"]["position_mm"][0] = -2.0  # 4.5 mm apart, more than the runs moved it
    assert [line.split(" (")[0] for line in compare_golden(knocked, again).lines()] == [
        "final_graph L03.1: moved by -4.5 mm in x"
    ]


def test_what_a_knocked_brick_carries_is_chaos_but_its_own_pose_is_not():
    knocked = tower()
    knocked["final_graph"]["L03.1"]["displaced_mm"] = 3.0
    new = copy.deepcopy(knocked)
    new["final_graph"]["L01.1"]["com_above_mm"][0] += 3.0  # loaded by a knocked brick: the model's numbers are chaos's
    new["final_graph"]["L02.1"]["rests_on"]["L01.1"]["load_share"] = 0.7
    c = compare_golden(knocked, new)
    assert c.matches and c.loose == 2, c.lines()


def test_toppled_is_a_verdict_only_where_the_scene_expects_it():
    new = tower()
    new["toppled"] = 2
    assert compare_golden(tower(), new).matches
    assert compare_golden(tower(), new, toppled=True).lines() == ["toppled: 0 -> 2"]


def test_the_defaults_follow_from_the_collapse_threshold_and_the_contact_margin():
    kapla = default_tolerances(compile_scenario(parse_scenario("stackdsl: 1\nstructure: {tower: {levels: 2}}\n")))
    assert kapla.position_mm == pytest.approx(1.0) and kapla.angle_deg == pytest.approx(0.955, abs=1e-3)
    assert kapla.radius_mm == pytest.approx(12.65, abs=0.01) and kapla.width_mm == pytest.approx(24.0)
    big = "stackdsl: 1\nstructure: {tower: {levels: 2}}\ncollapse_threshold: 20 mm\n"
    assert default_tolerances(compile_scenario(parse_scenario(big))).position_mm == pytest.approx(5.0)


def test_a_project_and_a_scenario_set_their_own_key_by_key(tmp_path):
    pyproject = tmp_path / "pyproject.toml"
    pyproject.write_text('[tool.stackdsl.golden.tolerance]\nposition = "2 mm"\nload_share = 0.1\n')
    text = "stackdsl: 1\nstructure: {tower: {levels: 2}}\ngolden: {tolerance: {position: 3 mm, level: 2}}\n"
    scenario = parse_scenario(text)
    t = tolerances_for(compile_scenario(scenario), scenario, pyproject)
    assert (t.position_mm, t.load_share, t.level, t.mass) == (pytest.approx(3.0), 0.1, 2, 0.05)
    assert tolerances_for(compile_scenario(scenario), scenario, tmp_path / "none.toml").load_share == 0.05


@pytest.mark.parametrize(
    ("table", "said"),
    [
        ('position = "2 kg"', "tool.stackdsl.golden.tolerance.position: expected a length"),
        ("speed = 1", "tool.stackdsl.golden.tolerance.speed: unknown key; known: position, angle"),
        # the keys a scenario's golden.tolerance takes: radius and width are no tolerance given
        ("radius = 1", "known: position, angle, mass, area, load_share, margin, friction_share, level\n"),
        ("load_share = 2", "tool.stackdsl.golden.tolerance.load_share:"),
    ],
)
def test_a_bad_project_tolerance_is_one_error_naming_the_file_and_key(tmp_path, table, said):
    pyproject = tmp_path / "pyproject.toml"
    pyproject.write_text(f"[tool.stackdsl.golden.tolerance]\n{table}\n")
    with pytest.raises(ScenarioError) as caught:
        project_tolerance(pyproject)
    assert str(pyproject) in str(caught.value) and said in str(caught.value) + "\n"


@pytest.mark.parametrize(
    ("text", "said"),
    [
        ("[tool.stackdsl]\ngolden = 3\n", "tool.stackdsl.golden: expected a table, got int 3"),
        ("[tool]\nstackdsl = 'strict'\n", "tool.stackdsl: expected a table, got str 'strict'"),
        (
            "[tool.stackdsl.golden.tolerances]\nposition = '1 mm'\n",
            "tool.stackdsl.golden.tolerances: unknown key; known: tolerance",
        ),
    ],
)
def test_a_project_golden_table_of_another_shape_is_not_ignored(tmp_path, text, said):
    """[tool.stackdsl] golden = 3, or a misspelt tolerance table, was read as no tolerances at all."""
    pyproject = tmp_path / "pyproject.toml"
    pyproject.write_text(text)
    with pytest.raises(ScenarioError) as caught:
        project_tolerance(pyproject)
    assert str(caught.value) == f"{pyproject}: {said}"
    pyproject.write_text("[tool]\nblack = 3\n[tool.stackdsl.other]\nx = 1\n")  # other tools' and other tables: none
    assert project_tolerance(pyproject) is None


def test_every_shipped_golden_matches_itself_and_fails_a_moved_structure():
    """Each shipped golden against itself, and against itself with every standing brick moved
    by twice the position tolerance (a scene changed): the first matches, the second not."""
    goldens = sorted((ROOT / "golden" / "scenarios").rglob("*.json"))
    assert len(goldens) >= 30
    for path in goldens:
        data = json.loads(path.read_text())
        assert compare_golden(data, data).matches, path
        moved = copy.deepcopy(data)
        graph = moved["final_graph"]
        standing = [b for b in graph.values() if b.get("displaced_mm") is not None and b["displaced_mm"] <= 1.0]
        for b in standing:
            b["position_mm"][1] += 2.0 * Tolerances().position_mm + b["displaced_mm"] * 2
        if standing:
            assert not compare_golden(data, moved).matches, path


def test_the_levels_a_scene_says_may_fall_are_chaos():
    stood = tower()
    stood["final_graph"]["L03.1"]["displaced_mm"] = 40.0  # the top fell in the golden
    fell = copy.deepcopy(stood)
    fell["final_graph"]["L01.1"] = brick(1, 30.0, displaced=30.0)  # and the bottom too, in this run
    assert not compare_golden(stood, fell).matches
    assert compare_golden(stood, fell, may_fall=[1]).matches
    assert compare_golden(stood, fell, may_fall=["L01"]).matches
    assert not compare_golden(stood, fell, may_fall=["L0"]).matches  # the start of an id is a whole part of it


def test_near_tie_names_a_stand_under_the_engines_contact_margin():
    from stackdsl import run_program
    from stackdsl.verdicts.golden_compare import near_tie

    text = "stackdsl: 1\nstructure:\n  bricks:\n    - {{id: base, at: [0, 0, 4 mm]}}\n    - {{id: top, at: [{x}, 0, 12 mm]}}\n"
    tie = compile_scenario(parse_scenario(text.format(x="59.5 mm")))
    said = near_tie(run_program(tie), tie)
    assert re.match(r"stands with a margin of 0\.[45] mm, under pybullet's 1 mm contact margin", said), said  # 0.5 mm, down
    wide = compile_scenario(parse_scenario(text.format(x="50 mm")))
    assert near_tie(run_program(wide), wide) == ""


def test_near_tie_names_a_collapse_of_an_exact_tie():
    from stackdsl import run_program
    from stackdsl.verdicts.golden_compare import near_tie

    text = "stackdsl: 1\nstructure:\n  bricks:\n    - {id: base, at: [0, 0, 4 mm]}\n    - {id: top, at: [60.02 mm, 0, 12 mm]}\n"
    tie = compile_scenario(parse_scenario(text))
    outcome = run_program(tie)
    assert outcome.collapse is not None and outcome.certificate is not None and "exact tie" in outcome.certificate.detail
    assert near_tie(outcome, tie).startswith("collapses on a near tie (")


def test_near_tie_names_a_run_left_undecided_by_a_brick_tipping_off_an_exact_tie():
    from stackdsl import run_program
    from stackdsl.verdicts.golden_compare import near_tie

    # 0.0005 mm outside its support's edge, the top brick tips too slowly to fall in a second
    # (0.002 mm outside, it fell in 0.8 s on a base frozen flat where it landed)
    text = "stackdsl: 1\nstructure:\n  bricks:\n    - {id: base, at: [0, 0, 4 mm]}\n"
    text += "    - {id: top, at: [-60.0005 mm, 0, 12 mm]}\ntiming: {settle: 1 s}\n"
    tie = compile_scenario(parse_scenario(text))
    outcome = run_program(tie)
    assert outcome.certificate is not None and outcome.certificate.verdict == "undecided", outcome.certificate
    assert "placed 0.00 mm outside its support's edge: an exact tie" in outcome.certificate.detail
    assert near_tie(outcome, tie).startswith("undecided on a near tie (")


def test_which_proof_decided_a_collapse_first_is_chaos_but_an_end_proof_is_not():
    """jenga_falls under ten perturbations: five collapses decided by "off its support", five by
    "at rest displaced", at the same level. A collapse proved only at the end of the run ("no
    equilibrium") where the golden's fell while it ran is a difference."""
    fell = tower()
    fell["collapse"] = {"level": 3, "brick": "L03.1", "brick_level": 3}
    fell["certificate"] = {
        "verdict": "collapse",
        "kind": "at rest displaced",
        "bricks": ["L03.1"],
        "margin_mm": None,
        "friction_share": None,
    }
    fell["final_graph"]["L03.1"] = brick(3, 150.0, displaced=150.0, state="active")
    raced = copy.deepcopy(fell)
    raced["certificate"]["kind"] = "off its support"
    c = compare_golden(fell, raced)
    assert c.matches, c.lines()
    assert any("the first to hold decides" in said for said in c.chaos)
    late = copy.deepcopy(fell)
    late["certificate"]["kind"] = "no equilibrium"
    assert compare_golden(fell, late).lines() == ["certificate.kind: at rest displaced -> no equilibrium"]
