"""Fragility: perturbed programs, and `stackdsl check --perturb N` (stackdsl.compile.perturb,
stackdsl.batch.perturb)."""

import json
from dataclasses import replace

import pytest

from stackdsl import compile_scenario, parse_scenario
from stackdsl.batch.check import prepare
from stackdsl.batch.judge import failed
from stackdsl.batch.perturb import fragility_lines, perturbed_runs
from stackdsl.cli.main import main
from stackdsl.compile.perturb import JITTER, Perturbation, perturb, perturbations
from stackdsl.compile.program import Place, Shake

TOWER = "stackdsl: 1\nstructure: {tower: {levels: 2}}\ntiming: {settle: 0.5 s}\nexpect: {stands: true}\n"
SHAKE = (
    "stackdsl: 1\nstructure: {tower: {levels: 2}}\ntiming: {settle: 0.5 s}\n"
    "actions: [{shake: {at: after level 2, amplitude: 1 mm, frequency: 2 Hz, duration: 1 s, direction: [1, 0]}}]\n"
)
# a brick 0.2 mm inside the edge of the one below, the engine alone deciding it (raw mode): a near tie
# that pybullet's 1 mm collision margin tips or keeps by chance (with the extension statics decides it)
TIE = (
    "stackdsl: 1\nstructure:\n  bricks:\n    - {id: base, at: [0, 0, 4 mm]}\n    - {id: top, at: [59.8 mm, 0, 12 mm]}\n"
    "engine: {mode: raw}\ntiming: {settle: 1 s}\nexpect: {stands: true}\n"
)


def test_every_kind_comes_in_any_four_and_the_rest_are_jitter_draws():
    kinds = [p.kind for p in perturbations(10, "mujoco")]
    assert set(kinds[:4]) == {"jitter", "timestep", "iterations", "backend"}
    assert kinds[7:] == ["jitter"] * 3 and len(kinds) == 10
    assert "backend" not in [p.kind for p in perturbations(10, None)]
    with pytest.raises(ValueError):
        perturbations(-1)


def test_a_jitter_nudges_each_placement_by_at_most_ten_micrometres_and_nothing_else():
    program = compile_scenario(parse_scenario(TOWER))
    moved = perturb(program, Perturbation("jitter", 1))
    pairs = list(zip(program.placements, moved.placements, strict=True))
    nudges = [abs(a - b) for p, q in pairs for a, b in zip(p.position[:2], q.position[:2])]
    assert 0 < max(nudges) <= JITTER and all(p.position[2] == q.position[2] for p, q in pairs)
    assert perturb(program, Perturbation("jitter", 2)).placements != moved.placements  # each draw its own
    assert moved.engine == program.engine


@pytest.mark.parametrize("sign", [1, -1])
def test_a_timestep_change_keeps_every_action_at_its_time(sign):
    program = compile_scenario(parse_scenario(SHAKE))
    changed = perturb(program, Perturbation("timestep", sign))
    dt = changed.engine.timestep
    assert dt == pytest.approx(program.engine.timestep * (1 + sign * 0.01))
    for a, b in zip(program.actions, changed.actions, strict=True):
        assert b.time == pytest.approx(b.step * dt) and abs(b.time - a.time) <= dt / 2 + 1e-12
    shake = next(a for a in changed.actions if isinstance(a, Shake))
    assert shake.frequency * (shake.end_time - shake.time) == pytest.approx(shake.periods)  # whole periods still
    assert all(isinstance(a, Place) for a in changed.placements)


def test_solver_iterations_change_by_a_tenth():
    program = compile_scenario(parse_scenario(TOWER))
    assert perturb(program, Perturbation("iterations", 1)).engine.solver_iterations == 55
    assert perturb(program, Perturbation("iterations", -1)).engine.solver_iterations == 45
    with pytest.raises(ValueError):
        perturb(program, Perturbation("backend", 0, "mujoco"))


def test_check_perturb_says_robust_with_the_margin(tmp_path, capsys):
    (tmp_path / "tower.yaml").write_text(TOWER)
    assert main(["check", str(tmp_path), "--perturb", "3", "-j", "1"]) == 0
    out = capsys.readouterr().out
    row = next(line for line in out.splitlines() if line.startswith("ROBUST"))
    assert "stands 3/3" in row and "mm" in row
    assert "1 scenarios perturbed: 1 robust, 0 fragile" in out


def test_check_perturb_finds_a_near_tie_fragile_and_names_what_flipped_it(tmp_path, capsys):
    (tmp_path / "tie.yaml").write_text(TIE)
    status = main(["check", str(tmp_path / "tie.yaml"), "--perturb", "7", "-j", "1", "--json"])
    document = json.loads(capsys.readouterr().out)
    (fragility,) = document["perturbed"]
    assert status == 1 and fragility["verdict"] == "FRAGILE"
    assert fragility["near_tie"] and fragility["margin_mm"] == pytest.approx(0.2, abs=0.1)
    labels = [r["perturbation"] for r in fragility["runs"]]
    flips = [flip.split(":")[0] for flip in fragility["flipped_by"]]
    assert flips and set(flips) <= set(labels)
    held = fragility["held"]["stands"]
    assert held["of"] == 7 and held["held"] == 7 - len(flips)
    assert [r["perturbation"] for r in fragility["runs"]][:4] == [
        "jitter 10 µm (draw 1)",
        "timestep +1%",
        "solver iterations +10%",
        "on mujoco",
    ]


@pytest.mark.parametrize("bad", ["0", "-2", "x", "101"])
def test_a_bad_perturb_count_is_a_usage_error(tmp_path, bad, capsys):
    (tmp_path / "tower.yaml").write_text(TOWER)
    with pytest.raises(SystemExit) as exited:
        main(["check", str(tmp_path), "--perturb", bad])
    assert exited.value.code == 2


def test_perturb_past_the_timeout_is_refused_before_anything_runs(tmp_path, capsys):
    """--timeout bounds a scenario's perturbed check whole: `--perturb 100 --timeout 1` took a
    hundred times the timeout; now its estimate is refused up front, naming the reruns that fit."""
    (tmp_path / "tower.yaml").write_text(TOWER)
    status = main(["check", str(tmp_path / "tower.yaml"), "--perturb", "100", "--timeout", "0.5", "-j", "1"])
    out, err = capsys.readouterr()
    assert status == 2 and out == ""
    (line,) = err.strip().splitlines()
    assert line.startswith(f"{tmp_path / 'tower.yaml'}: --perturb 100: the run as written and 100 reruns take about ")
    assert "past --timeout 0.5 s" in line and "reruns fit" in line


def test_perturbed_reruns_share_what_the_timeout_leaves_after_the_run_as_written(tmp_path):
    (tmp_path / "tower.yaml").write_text(TOWER)
    (p,) = prepare([tmp_path / "tower.yaml"])
    spent = replace(failed(str(p.path), p.program, p.expect, "as written"), wall_time=5.0)  # the whole budget
    (fragility,) = perturbed_runs([p], [spent], 4, jobs=1, timeout=5.0)
    assert [r.result for r in fragility.runs] == [None] * 4
    assert all("--timeout 5 s, which bounds a scenario's perturbed check whole, was spent" in r.skipped for r in fragility.runs)
    lines = fragility_lines([fragility], 4)
    assert any("4 reruns: not run: --timeout 5 s" in line for line in lines)
    (ran,) = perturbed_runs([p], [replace(spent, wall_time=0.0)], 1, jobs=1, timeout=60.0)
    assert ran.runs[0].result is not None and not ran.runs[0].result.stopped  # time left: it ran


def test_a_sweep_listed_not_perturbed_is_not_counted_robust(tmp_path, capsys):
    # the table said NOT PERTURBED and the summary "1 scenarios perturbed: 1 robust, 0 fragile"
    (tmp_path / "tower.yaml").write_text(TOWER)
    (tmp_path / "sweep.yaml").write_text(
        "stackdsl: 1\nstructure: {tower: {levels: 2, bricks_per_layer: 1, turn: 0, shift: {uniform: [0, 5 mm]}}}\n"
        "sweep: {samples: 3}\nexpect: {p_stands: '>= 0.5'}\n"
    )
    assert main(["check", str(tmp_path), "--perturb", "3", "-j", "1"]) in (0, 1)  # 3 samples may not decide P(stands)
    out = capsys.readouterr().out
    assert any(line.startswith("NOT PERTURBED") and "sweep.yaml" in line for line in out.splitlines())
    assert "1 scenarios perturbed: 1 robust, 0 fragile; 1 not perturbed" in out


@pytest.mark.parametrize("count", [1, 3, 4, 7])
def test_the_heading_names_only_the_kinds_the_reruns_take(count):
    """`--perturb 3` said "the other engine" in its heading, which only the fourth rerun runs: the
    heading names the kinds that ``count`` reruns take, each of them a rerun's label."""
    heading = fragility_lines([], count)[1]
    labels = [p.label for p in perturbations(count, "mujoco")]
    assert heading.startswith(f"perturbed {count} times each: ")
    other = any(label == "on mujoco" for label in labels)
    assert other == heading.endswith(", the other engine"), (heading, labels)
    assert ("timestep" in heading) == any("timestep" in label for label in labels)
    assert ("solver iterations" in heading) == any("iterations" in label for label in labels)
