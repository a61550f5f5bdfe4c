"""The work budget: runaway scenes refused before simulating, the substep cap, the timeout."""

import math
import time
from pathlib import Path

import numpy as np
import pytest

from stackdsl import ScenarioError, compile_scenario, evaluate, load_scenario, parse_scenario, run_program
from stackdsl.bench.bench import SETTINGS, program_for, scenes
from stackdsl.compile.compiler import MAX_WORK
from stackdsl.compile.program import MAX_SUBSTEPS, SETTLING, estimate_work
from stackdsl.runtime import loop as _loop
from stackdsl.runtime import subscribers as _subscribers
from stackdsl.verdicts.expect import explain

ROOT = Path(__file__).resolve().parents[1]


def program(text: str, mode=None):
    return compile_scenario(parse_scenario(text, "w.yaml"), mode)


def refusal(text: str) -> ScenarioError:
    with pytest.raises(ScenarioError) as info:
        program(text)
    return info.value


# the estimate ------------------------------------------------------------------------------

TWO = "stackdsl: 1\nstructure: {tower: {levels: 1}}\n"  # two bricks, placed at 0 s and 1 s, then 2 s settle


def test_raw_and_tuned_step_every_brick_from_its_placement_to_the_end():
    p = program(TWO + "engine: {mode: raw}\n")  # 240 Hz: placed at steps 0 and 240, the end at 720
    work = estimate_work(p)
    assert (work.steps, work.moving, work.resting) == (720, 720 + 480, 0)
    heavy = estimate_work(program(TWO + "engine: {mode: raw, solver_iterations: 150}\n"))
    assert heavy.moving == 3 * work.moving and heavy.steps == work.steps  # iterations / 50 a body-step
    assert p.work == work.total and p.wall_estimate == pytest.approx(work.seconds)


def test_extension_steps_only_until_each_placed_brick_rests():
    p = program(TWO)
    active = math.ceil((math.sqrt(2 * 0.0005 / 9.81) + SETTLING + 0.05) * 240)  # fall, settling, rest duration
    work = estimate_work(p)
    # each brick moves `active` steps; while the second does, the first rests in the engine
    assert (work.steps, work.moving, work.resting) == (2 * active, 2 * active, active)
    longer = estimate_work(program(TWO + "stability: {rest_duration: 0.5 s}\n"))
    assert longer.steps == 2 * math.ceil((math.sqrt(2 * 0.0005 / 9.81) + SETTLING + 0.5) * 240)


def test_a_fast_projectile_costs_substeps_up_to_the_cap():
    def work(speed):  # each flies 10 ms
        return estimate_work(
            program(
                "stackdsl: 1\nstructure: {tower: {levels: 1}}\nimpacts: [{target: {level: 1, side: +y}, "
                f"speed: {speed}, at: after level 1, distance: {speed / 100}}}]\n"
            )
        ).steps

    assert work(1) < work(10) < work(99) == work(100)  # 99 and 100 m/s both need more than the cap


def test_a_pull_counts_the_finer_steps_the_runtime_takes_while_it_lasts():
    """On pybullet the extension steps at 960 Hz while a pull lasts: four substeps of a 240 Hz
    step, each with every placed brick moving; MuJoCo's extension does not split them."""
    pulled = "stackdsl: 1\nstructure: {tower: {levels: 3, bricks_per_layer: 3, spacing: 25 mm}}\nactions:\n  - remove: {brick: L02.2, at: after level 3, speed: 20 mm/s}\n"
    p = program(pulled)
    (pull,) = [a for a in p.actions if a.kind == "remove"]
    span, bricks = pull.end_step - pull.step, len(p.placements)
    without = estimate_work(program(pulled.split("actions:")[0]))
    work = estimate_work(p)
    assert work.steps - without.steps == pytest.approx(4 * span)
    assert work.moving - without.moving == pytest.approx(4 * span * bricks)
    pytest.importorskip("mujoco")
    on_mujoco = program(pulled + "engine: {backend: mujoco}\n")
    (pull,) = [a for a in on_mujoco.actions if a.kind == "remove"]
    mujoco = (
        estimate_work(on_mujoco).steps - estimate_work(program(pulled.split("actions:")[0] + "engine: {backend: mujoco}\n")).steps
    )
    assert mujoco == pytest.approx(pull.end_step - pull.step)


def test_compile_prints_the_estimate():
    from stackdsl import format_program

    p = program("stackdsl: 1\nstructure: {tower: {levels: 3}}\n")
    assert f"estimated work {p.work:.2g} body-steps" in format_program(p)


# the runaways, refused before simulating -------------------------------------------------

RUNAWAYS = {
    # 2000 bricks for 2001 s at 1 ms, 150 iterations: 6e9 body-steps, about two days
    "1000-level tower, tuned": ("structure: {tower: {levels: 1000}}\nengine: {mode: tuned}\n", "engine.mode"),
    # 60 bricks, 6.1 million steps: 2e8 body-steps (98 s of wall time for 11 s simulated)
    "timestep 10 us": ("structure: {tower: {levels: 30}}\nengine: {mode: raw, timestep: 1e-5 s}\n", "engine.timestep"),
    "10000 solver iterations": (
        "structure: {tower: {levels: 100}}\nengine: {mode: raw, solver_iterations: 10000}\n",
        "engine.solver_iterations",
    ),
    # 5000 bricks in extension mode: 2.4e8 body-steps (measured 70 s of CPU at 2000 bricks, growing as bricks^2)
    "5000-brick tower, extension": (
        "structure: {tower: {levels: 1000, bricks_per_layer: 5, spacing: 24 mm}}\ntiming: {interval: 0.5 s}\n",
        "structure.tower.levels",
    ),
    # 3775 bricks, the leaning pairs of V's placed together
    "card house 50 V's wide": ("structure: {card_house: {levels: 50}}\n", "structure.card_house.levels"),
}


@pytest.mark.parametrize("name", RUNAWAYS)
def test_runaway_scenes_are_refused_at_the_field_to_change(name, monkeypatch):
    def no_simulation(*args, **kwargs):
        raise AssertionError("simulated")

    monkeypatch.setattr(_loop.StepLoop, "__init__", no_simulation)
    text, field = RUNAWAYS[name]
    err = refusal("stackdsl: 1\n" + text)
    assert err.field == field and err.line is not None, str(err)
    assert "would take too long" in err.message and f"at most {MAX_WORK:,.0f}" in err.message
    work = float(err.message.split(" body-steps")[0].rsplit(" ", 1)[1].replace(",", ""))
    assert work > MAX_WORK


@pytest.mark.slow
def test_a_refusal_says_what_would_fit():
    err = refusal("stackdsl: 1\n" + RUNAWAYS["5000-brick tower, extension"][0])
    levels = int(err.message.split("At most ")[1].split(" levels")[0])
    assert 100 < levels < 1000
    assert (
        program(
            f"stackdsl: 1\nstructure: {{tower: {{levels: {levels}, bricks_per_layer: 5, spacing: 24 mm}}}}\n"
            "timing: {interval: 0.5 s}\n"
        ).work
        <= MAX_WORK
    )
    err = refusal(
        f"stackdsl: 1\nstructure: {{tower: {{levels: {levels + 1}, bricks_per_layer: 5, spacing: 24 mm}}}}\n"
        "timing: {interval: 0.5 s}\n"
    )
    assert err.field == "structure.tower.levels"
    timestep = refusal("stackdsl: 1\n" + RUNAWAYS["timestep 10 us"][0])
    assert "With the raw default, 4.17 ms, it would be" in timestep.message


@pytest.mark.slow
def test_every_shipped_scenario_and_bench_scene_fits_the_budget():
    files = sorted((ROOT / "scenarios").rglob("*.yaml"))
    assert len(files) > 20
    for path in files:
        assert compile_scenario(load_scenario(path)).work <= MAX_WORK, path
    works = [program_for(scene, setting).work for scene in scenes() for setting in SETTINGS]
    assert len(works) == len(scenes()) * len(SETTINGS)
    assert max(works) <= MAX_WORK
    assert max(works) > MAX_WORK / 10  # the bound is not far above the longest bench scene (39 minutes)


# while running -----------------------------------------------------------------------------


def test_substeps_are_capped_and_the_cap_is_recorded(monkeypatch):
    # 50 m/s at 240 Hz with a 1 mm threshold would need 209 substeps a step
    seen = []
    before_step = _subscribers.Substeps.before_step

    def spy(self, loop):
        before_step(self, loop)
        seen.append(self.substeps)

    monkeypatch.setattr(_subscribers.Substeps, "before_step", spy)
    outcome = run_program(
        program(
            "stackdsl: 1\nstructure: {tower: {levels: 1}}\ncollapse_threshold: 1 mm\ntiming: {settle: 0.5 s}\n"
            "impacts: [{id: fast, target: {level: 1, side: +y}, speed: 50, at: after level 1}]\n"
        )
    )
    assert max(seen) == MAX_SUBSTEPS
    capped = [e for e in outcome.events if e.kind == "substeps"]
    assert capped and capped[0].brick == "fast"
    needed = int(capped[0].detail.split("needs ")[1].split(" ")[0])
    assert needed > MAX_SUBSTEPS and f"capped at {MAX_SUBSTEPS}" in capped[0].detail


LONG = "stackdsl: 1\nstructure: {tower: {levels: 30}}\nengine: {mode: tuned}\nexpect: {stands: true}\n"


@pytest.mark.slow
def test_a_timeout_stops_the_run_cleanly_and_fails_its_expectations():
    scenario = parse_scenario(LONG, "long.yaml")
    p = compile_scenario(scenario)
    assert p.wall_estimate > 20  # a minute and a half of work
    outcome = run_program(p, timeout=0.5)
    assert outcome.stopped is not None and outcome.stopped.startswith("timeout after 0.5 s at t = ")
    assert f"{outcome.simulated_time:.1f} s simulated (of 61 s)" in outcome.stopped
    assert 0 < outcome.simulated_time < p.duration
    assert outcome.wall_time < 10  # generous: the clock is read every few steps
    verdicts = {v.name: v for v in evaluate(scenario.expect, outcome, p.collapse_threshold)}
    assert not verdicts["finished"].passed and verdicts["finished"].measured == outcome.stopped
    assert any(line.startswith("stopped: timeout after 0.5 s") for line in explain(scenario.expect, outcome, 0.004))


def test_without_a_timeout_a_run_finishes():
    outcome = run_program(program(TWO), timeout=None)
    assert outcome.stopped is None and outcome.simulated_time == pytest.approx(3.0)
    assert "finished" not in {v.name for v in evaluate(parse_scenario(TWO + "expect: {stands: true}\n").expect, outcome, 0.004)}
    with pytest.raises(ValueError, match="timeout"):
        run_program(program(TWO), timeout=-1.0)


def test_a_runs_wall_time_counts_the_brick_graph_built_after_its_last_step(monkeypatch):
    # the final brick graph is part of the run: a fallen 1000-level tower's took a minute that
    # neither its wall time nor its timeout saw
    graph = _subscribers.Stability.graph

    def slow(self, loop):
        time.sleep(0.4)
        return graph(self, loop)

    monkeypatch.setattr(_subscribers.Stability, "graph", slow)
    started = time.perf_counter()
    outcome = run_program(program(TWO))
    took = time.perf_counter() - started
    assert outcome.wall_time >= 0.4 and took - outcome.wall_time < 0.1
    assert outcome.final_graph.nodes and outcome.stopped is None


def test_statics_past_the_runs_deadline_stop_it_as_a_timeout_not_an_internal_error(monkeypatch):
    # a 3-level tower struck by 100 bricks, which lay about it, took 87 s of a 100 s budget to
    # certify, one program 15 s: the budget held for the engine's steps, not for the statics
    from stability import _extension
    from stability._lp import solve

    def slow(stack, areas):
        time.sleep(0.6)  # the run's 0.5 s are gone: the next program is asked past its deadline
        solve(np.array([1.0]), np.zeros((0, 1)), np.zeros(0))
        raise AssertionError("a program asked past the deadline was solved")

    monkeypatch.setattr(_extension, "certify", slow)
    outcome = run_program(program(TWO), timeout=0.5)
    assert outcome.stopped == "timeout after 0.5 s proving that it stands, at t = 3.0 s simulated (of 3 s)"
    assert outcome.certificate is None and outcome.collapse is None


# check --timeout: one budget for a whole sweep file -------------------------------------------
SWEEP = (
    "stackdsl: 1\nstructure: {tower: {levels: 3, bricks_per_layer: 1, turn: 0, "
    "shift: {uniform: [-10 mm, 10 mm], per: layer}}}\ntiming: {settle: 0.2 s}\nsweep: {samples: SAMPLES}\n"
)


def test_check_refuses_a_sweep_whose_runs_cannot_end_within_its_timeout(tmp_path, capsys):
    # 'samples: 1e5' under 'check -j 1 --timeout 5' was still at "0 of 1 done" after 80 s (10 hours queued)
    from stackdsl.cli.main import main

    (tmp_path / "s.yaml").write_text(SWEEP.replace("SAMPLES", "1e5"))
    start = time.perf_counter()
    assert main(["check", str(tmp_path / "s.yaml"), "-j", "1", "--timeout", "5"]) == 2
    assert time.perf_counter() - start < 30
    err = capsys.readouterr().err
    assert "s.yaml:4:18: sweep.samples: this sweep makes 100000 runs (1 cell x 100000 samples)" in err
    assert "past --timeout 5 s, which bounds the whole file" in err and "samples fit" in err


def test_a_sweeps_batches_share_one_budget_and_stop_where_it_runs_out():
    import pickle

    from stackdsl.batch.sweep import BUDGET_SPENT, Budget, SweepOptions, run_batch

    template = parse_scenario(SWEEP.replace("SAMPLES", "400"), "s.yaml").template
    budget = Budget(0.5)
    options = SweepOptions(timeout=100.0, budget=budget)
    copy = pickle.loads(pickle.dumps(options))  # a worker's: the clock started when it was handed out
    assert budget.started is not None and copy.budget is not None and copy.budget.started == budget.started
    results = run_batch(template, 0, range(400), copy)
    ran = [r for r in results if r.stopped != BUDGET_SPENT]
    assert 0 < len(ran) < 400 and results[-1].stopped == BUDGET_SPENT
    assert sum(r.wall_time for r in ran) < 0.5 + 0.5  # each run had what was left as its timeout
    assert all(r.stopped == BUDGET_SPENT for r in run_batch(template, 0, range(3), options))  # spent for every batch


def test_a_sweep_the_budget_cuts_short_is_one_failed_row_that_says_so(tmp_path):
    from stackdsl.batch.check import prepare, run_checks

    (tmp_path / "s.yaml").write_text(SWEEP.replace("SAMPLES", "300"))
    prepared = prepare([tmp_path / "s.yaml"], timeout=None)  # the estimate is not asked
    (result,) = run_checks(prepared, jobs=1, timeout=0.3)
    assert not result.held and result.stopped.startswith("timeout: the sweep's budget ran out after")
    assert "of 300 samples: --timeout bounds the whole sweep file" in result.stopped
