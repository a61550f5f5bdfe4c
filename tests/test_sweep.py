"""Sweeps: the same per-sample results on every executor, batching, files, verdicts, exit codes."""

from __future__ import annotations

import csv
import json
import xml.etree.ElementTree as ET
from collections.abc import Iterator
from dataclasses import replace
from itertools import islice
from pathlib import Path

import pytest

from stackdsl import load_scenario, parse_scenario
from stackdsl.batch.sweep import SweepOptions, batches, collect, dask_executor, run_sweep
from stackdsl.bench.random_stack import mean_collapse_level
from stackdsl.cli.main import main

ROOT = Path(__file__).resolve().parents[1]
STACK = """stackdsl: 1
name: random single-file stack
structure:
  tower:
    levels: {levels}
    bricks_per_layer: 1
    turn: 0
    shift: {{uniform: [-60 mm, 60 mm], per: layer}}
timing: {{settle: 0.2 s}}
sweep: {{samples: {samples}}}
"""


def template(levels: int = 6, samples: int = 12):
    return parse_scenario(STACK.format(levels=levels, samples=samples), "stack.yaml").template


def without_wall_time(results):
    return [replace(r, wall_time=0.0) for r in results]


@pytest.mark.slow  # 3-5 s: in .ci/nightly's slow part
def test_every_executor_gives_the_same_per_sample_results():
    t = template()
    here = collect(run_sweep(t, jobs=1))
    assert [(r.cell, r.sample) for r in here] == [(0, k) for k in range(12)]
    assert not any(r.error or r.bad_input or r.stopped for r in here)
    pool = collect(run_sweep(t, jobs=2))
    with dask_executor("local:2") as (executor, threads, _):
        assert threads == 2
        dask = collect(run_sweep(t, executor=executor, workers=threads))
    assert without_wall_time(here) == without_wall_time(pool) == without_wall_time(dask)
    assert len({r.collapse_level for r in here}) > 1  # the samples differ


def test_batches_cover_every_sample_once_and_never_mix_cells():
    text = STACK.format(levels=4, samples=50).replace(
        "sweep: {samples: 50}", "sweep:\n  samples: 50\n  grid: {timing.interval: [0.5, 1, 2]}"
    )
    t = parse_scenario(text, "g.yaml").template
    t = replace(t, samples=50)
    plan = list(batches(t, workers=2))
    seen = [(c, k) for c, samples in plan for k in samples]
    assert sorted(seen) == [(c, k) for c in range(3) for k in range(50)]
    assert all(len(samples) <= 32 for _, samples in plan) and len(plan) >= 2 * 6


def test_batches_are_made_as_they_are_taken():
    """A sweep at the run cap is never a list of batches: taking the first few reads only them."""
    t = replace(parse_scenario(STACK.format(levels=4, samples=50), "g.yaml").template, samples=200_000)
    plan = batches(t, workers=2)
    assert isinstance(plan, Iterator)
    first = list(islice(plan, 3))
    assert [(c, s.start, s.stop) for c, s in first] == [(0, 0, 32), (0, 32, 64), (0, 64, 96)]


def test_a_local_dask_cluster_needs_a_sensible_size():
    from stackdsl.batch.address import cores

    for count in ("0", str(cores() + 1), "²", "", "1.5"):
        with pytest.raises(ValueError, match=f"local:N needs N, a whole number of worker processes from 1 to {cores()}"):
            with dask_executor(f"local:{count}"):
                pass


@pytest.mark.slow
@pytest.mark.parametrize(
    "address, problem",
    [
        ("", "give a scheduler's address"),
        ("  ", "give a scheduler's address"),
        ("tls://10.0.0.1:8786", "tls:// needs Dask's certificate settings"),
        ("scheduler", "is not an address"),
        ("tcp://host:0", "port 0 is not from 1 to 65535"),
        ("host:123456", "is not an address"),
    ],
)
def test_a_bad_dask_address_is_a_usage_error_before_anything_runs(address, problem, capsys):
    with pytest.raises(SystemExit) as usage:
        main(["sweep", "sweeps/random_single_file.yaml", "--dask", address])
    assert usage.value.code == 2 and problem in capsys.readouterr().err


def test_something_that_is_not_a_dask_scheduler_is_one_line(tmp_path, capsys):
    """A server that answers with bytes that are not Dask's (Dask then reads them as a message
    size of exabytes): one line naming the address, exit 2, no folder left."""
    import socket
    import threading

    server = socket.socket()
    server.bind(("127.0.0.1", 0))
    server.listen()
    port = server.getsockname()[1]

    def serve() -> None:
        while True:
            try:
                conn, _ = server.accept()
            except OSError:
                return
            conn.sendall(b"HTTP/1.1 200 OK\r\n\r\n" + b"not dask " * 100)
            conn.close()

    threading.Thread(target=serve, daemon=True).start()
    try:
        path = tmp_path / "stack.yaml"
        path.write_text(STACK.format(levels=2, samples=2))
        assert main(["sweep", str(path), "--dask", f"127.0.0.1:{port}", "--out", str(tmp_path / "out")]) == 2
    finally:
        server.close()
    err = capsys.readouterr().err.strip()
    assert err.startswith(f"--dask: not a Dask scheduler at tcp://127.0.0.1:{port}") and len(err.splitlines()) == 1
    assert not (tmp_path / "out").exists()


@pytest.mark.slow
def test_the_simulated_mean_collapse_level_agrees_with_an_independent_monte_carlo():
    # the shipped random single-file stack: 40 levels, so that nearly every sample collapses
    t = replace(load_scenario(ROOT / "sweeps" / "random_single_file.yaml").template, samples=40)
    results = collect(run_sweep(t, SweepOptions(oracle=True), jobs=2))
    levels = [r.collapse_level for r in results]
    assert None not in levels
    from stackdsl.verdicts.stats import mean_interval

    low, high = mean_interval([float(x) for x in levels if x is not None], 0.95)
    reference, *_ = mean_collapse_level(200_000, seed=1)
    assert low <= reference <= high, (low, reference, high)
    # rigid-block equilibrium on each sample's placed poses gives the same level
    assert sum(r.oracle_level == r.collapse_level for r in results) >= 0.95 * len(results)


@pytest.mark.slow
def test_the_sweep_command_writes_every_sample_and_decides_by_the_interval(tmp_path, capsys):
    (tmp_path / "s.yaml").write_text(STACK.format(levels=6, samples=16) + "expect:\n  p_stands: '<= 0.9'\n")
    out = tmp_path / "out"
    assert main(["sweep", str(tmp_path / "s.yaml"), "-j", "1", "--out", str(out)]) == 0
    printed = capsys.readouterr().out
    assert "PASS" in printed and "expected P(stands) <= 0.9" in printed
    rows = list(csv.DictReader(open(out / "samples.csv")))
    assert [int(r["sample"]) for r in rows] == list(range(16))
    assert {
        "cell",
        "sample",
        "seed",
        "collapse_level",
        "levels_placed",
        "wall_time",
        "simulated_time",
        "structure.tower.shift [m]",
    } <= set(rows[0])
    lines = [json.loads(line) for line in open(out / "samples.jsonl")]
    assert len(lines) == 16 and len(lines[0]["structure.tower.shift [m]"]) == 5  # one draw a layer above the first
    assert [str(r["collapse_level"] or "") for r in lines] == [r["collapse_level"] for r in rows]
    assert (out / "histogram.png").stat().st_size > 5000


@pytest.mark.slow
def test_an_undecided_or_failed_expectation_exits_1(tmp_path, capsys):
    (tmp_path / "s.yaml").write_text(STACK.format(levels=10, samples=10) + "expect:\n  collapse: {mean: '4.5 ± 0.2'}\n")
    assert main(["sweep", str(tmp_path / "s.yaml"), "-j", "1", "--out", str(tmp_path / "o")]) == 1
    verdict = next(line for line in capsys.readouterr().out.splitlines() if "expected mean 4.5±0.2" in line)
    assert verdict.split()[0] in ("INCONCLUSIVE", "FAIL")


@pytest.mark.slow
def test_a_grid_sweep_plots_against_its_parameter(tmp_path, capsys):
    text = STACK.format(levels=4, samples=4).replace(
        "sweep: {samples: 4}", "sweep:\n  samples: 4\n  grid: {timing.placement_error: [0, 5 mm]}"
    )
    (tmp_path / "g.yaml").write_text(text)
    assert main(["sweep", str(tmp_path / "g.yaml"), "-j", "1", "--out", str(tmp_path / "o")]) == 0
    out = capsys.readouterr().out
    assert "cell 0: timing.placement_error = 0" in out and "cell 1: timing.placement_error = 5 mm" in out
    assert (tmp_path / "o" / "grid_p_stands.png").is_file() and (tmp_path / "o" / "grid_mean.png").is_file()
    assert "threshold of timing.placement_error: " in out  # where P(stands) crosses 1/2, or that it does not


def test_sweep_refuses_what_it_cannot_run(tmp_path, capsys):
    (tmp_path / "plain.yaml").write_text("stackdsl: 1\nstructure: {tower: {levels: 2}}\n")
    assert main(["sweep", str(tmp_path / "plain.yaml")]) == 2
    assert "no sweep and no random field" in capsys.readouterr().err
    far = STACK.format(levels=4, samples=8).replace("[-60 mm, 60 mm]", "[-60 mm, 200 mm]")
    (tmp_path / "far.yaml").write_text(far)
    assert main(["sweep", str(tmp_path / "far.yaml"), "-j", "1", "--out", str(tmp_path / "o")]) == 2
    err = capsys.readouterr().err
    assert "far.yaml:8:12: structure.tower.shifts" in err and "rests on nothing when placed" in err and "sample " in err
    assert not (tmp_path / "o").exists()  # nothing written
    (tmp_path / "s.yaml").write_text(STACK.format(levels=4, samples=8))
    assert main(["sweep", str(tmp_path / "s.yaml"), "--samples", "0"]) == 2


@pytest.mark.slow
def test_sweep_refuses_a_require_no_draw_meets_before_any_sample_runs(tmp_path, capsys, monkeypatch):
    import stackdsl.batch.sweep as sweep_module
    import stackdsl.compile.require as require_module

    draws = []
    real_quantities = require_module.quantities
    monkeypatch.setattr(require_module, "quantities", lambda s, wanted=None: draws.append(wanted) or real_quantities(s, wanted))
    ran = []
    monkeypatch.setattr(sweep_module, "run_sweep", lambda *a, **k: ran.append(1) or iter(()))
    (tmp_path / "r.yaml").write_text(STACK.format(levels=5, samples=20) + "require: [com_offset > 1 m]\n")
    assert main(["sweep", str(tmp_path / "r.yaml"), "-j", "1", "--out", str(tmp_path / "o")]) == 2
    err = capsys.readouterr().err
    assert "r.yaml:11:11: require[0]: sample 0: none of 1000 draws met every condition" in err
    assert not ran and not (tmp_path / "o").exists()  # refused as check refuses it: no sample ran
    assert len([w for w in draws if w]) == require_module.MAX_DRAWS  # one sample's cap of draws, not one for each of the 20


def test_a_sample_refused_as_bad_input_stops_the_sweep():
    from stackdsl.batch.sweep import SampleResult

    def result(k: int, bad: str = "") -> SampleResult:
        return SampleResult(0, k, 0, {}, None, 0, 0.0, 0.0, bad_input=bad)

    closed = []

    def stream() -> Iterator[list[SampleResult]]:
        try:
            yield [result(0), result(1)]
            yield [result(2, "r.yaml:9:20: timing.placement_error: sample 2: ...")]
            yield [result(3)]
        finally:
            closed.append(True)

    assert [r.sample for r in collect(stream(), stop_at_bad_input=True)] == [0, 1, 2]
    assert closed == [True]
    assert [r.sample for r in collect(stream())] == [0, 1, 2, 3]  # check gathers a sweep's every batch


@pytest.mark.parametrize("command", ["sweep", "check"])
def test_a_grid_value_the_compiler_refuses_is_refused_at_it_before_any_cell_runs(tmp_path, capsys, monkeypatch, command):
    import stackdsl.batch.check_sweep as check_sweep
    import stackdsl.batch.sweep as sweep_module

    ran = []
    real_run_batch = sweep_module.run_batch
    for module in (sweep_module, check_sweep):  # check's batches call check_sweep's own name for it
        monkeypatch.setattr(module, "run_batch", lambda *a: ran.append(a[1]) or real_run_batch(*a))
    monkeypatch.setattr(sweep_module, "run_sweep", lambda *a, **k: ran.append("sweep") or iter(()))
    text = STACK.format(levels=3, samples=2).replace("shift: {uniform: [-60 mm, 60 mm], per: layer}", "spacing: 96 mm")
    text = text.replace("sweep: {samples: 2}", "sweep:\n  samples: 2\n  grid: {timing.interval: [1 s, 0.5 s, 0.0011 s]}")
    (tmp_path / "g.yaml").write_text(text + "expect: {p_stands: '>= 0.5'}\n")
    assert main([command, str(tmp_path / "g.yaml"), "-j", "1"]) == 2
    captured = capsys.readouterr()
    # the third value of the grid's timing.interval, at its column of the sweep's line, by its key
    assert (
        "g.yaml:12:40: sweep.grid.timing.interval[2]: the grid value '0.0011 s': 0.0011 s is not a whole number" in captured.err
    )
    assert "timing.interval: [1 s, 0.5 s, 0.0011 s]" in captured.err
    assert not ran and "PASS" not in captured.out and "FAIL" not in captured.out  # no cell ran


UNREACHABLE = {
    "P(stands) above 1": ("expect: {p_stands: '> 1'}", "expect.p_stands", "can never hold: a probability is at most 1"),
    "P(stands) below 0": ("expect: {p_stands: '< 0'}", "expect.p_stands", "can never hold: a probability is at least 0"),
    "P(stands) 1 of drawn samples": ("expect: {p_stands: '>= 1'}", "expect.p_stands", "can never pass: the samples draw"),
    "a mean above the tower": ("expect: {collapse: {mean: 50 ± 1}}", "expect.collapse.mean", "builds at most 3 levels"),
    "a mean just above the tower": ("expect: {collapse: {mean: 4.2 ± 1}}", "expect.collapse.mean", "builds at most 3 levels"),
    "a mean below level 1": ("expect: {collapse: {mean: 0.2 ± 0.5}}", "expect.collapse.mean", "collapse levels start at 1"),
    "a median above the tower": (
        "expect: {collapse: {quantile: {q: 0.5, level: 40 ± 1}}}",
        "expect.collapse.quantile.level",
        "builds at most 3 levels",
    ),
    "a quantile between two levels": (
        "expect: {collapse: {quantile: {q: 0.9, level: 1.4 ± 0.3}}}",
        "expect.collapse.quantile.level",
        "'1.4 ± 0.3' holds none, so it could never pass",
    ),
    "a cell's mean above the tower": (
        "expect:\n  cells: [{where: 'timing.drop_gap > 1 mm', collapse: {mean: 9 ± 1}}]",
        "expect.cells[0].collapse.mean",
        "in grid cell 1 (timing.drop_gap = 2 mm)",
    ),
}


@pytest.mark.parametrize("command", ["sweep", "check"])
@pytest.mark.parametrize("case", UNREACHABLE, ids=list(UNREACHABLE))
def test_a_statistic_no_sample_can_pass_is_refused_at_it_before_any_sample_runs(case, command, tmp_path, capsys, monkeypatch):
    import stackdsl.batch.check_sweep as check_sweep
    import stackdsl.batch.sweep as sweep_module

    ran = []
    # check_sweep, imported here first, binds run_batch by name: patched there too, and undone with
    # the test (imported while only sweep's was patched, it kept the patch for every later test of
    # the process, whose sweeps then got no samples: an internal error)
    for module in (sweep_module, check_sweep):
        monkeypatch.setattr(module, "run_batch", lambda *a: ran.append(a[1]))
    monkeypatch.setattr(sweep_module, "run_sweep", lambda *a, **k: ran.append("sweep") or iter(()))
    expect, field, says = UNREACHABLE[case]
    text = STACK.format(levels=3, samples=2).replace(
        "sweep: {samples: 2}", "sweep: {samples: 2, grid: {timing.drop_gap: [0, 2 mm]}}"
    )
    (tmp_path / "s.yaml").write_text(text + expect + "\n")
    assert (
        main([command, str(tmp_path / "s.yaml"), "-j", "1", *(["--out", str(tmp_path / "o")] if command == "sweep" else [])]) == 2
    )
    captured = capsys.readouterr()
    first = captured.err.splitlines()[0]
    line = 11 if "cells" not in expect else 12
    assert first.startswith(f"{tmp_path / 's.yaml'}:{line}:") and f": {field}: " in first and says in first, first
    assert "would decide" not in captured.out + captured.err
    assert not ran and not (tmp_path / "o").exists()


@pytest.mark.parametrize(
    "expect",
    [
        "expect: {collapse: {mean: 3.5 ± 0.6}}",  # reaches level 3
        "expect: {collapse: {quantile: {q: 0.5, level: 2.5 ± 0.5}}}",  # holds levels 2 and 3
        "expect: {p_stands: '> 0'}",
        "expect: {p_stands: '<= 1'}",
        # judged only in the 10-level cell, where it can be measured
        "expect:\n  cells: [{where: 'structure.tower.levels > 5', collapse: {mean: 9 ± 1}}]",
    ],
)
def test_a_statistic_some_samples_can_pass_is_not_refused(expect, tmp_path):
    from stackdsl.batch.check import prepare

    text = STACK.format(levels=3, samples=2).replace(
        "sweep: {samples: 2}", "sweep: {samples: 2, grid: {structure.tower.levels: [3, 10]}}"
    )
    if "cells" not in expect:
        text = text.replace("structure.tower.levels: [3, 10]", "timing.drop_gap: [0, 2 mm]")
    (tmp_path / "s.yaml").write_text(text + expect + "\n")
    assert len(prepare([tmp_path / "s.yaml"])) == 1


def test_drawn_levels_reach_as_high_as_their_highest_choice_unless_two_draws_add_up(tmp_path):
    """A tower of {choice: [3, 10]} levels: a mean of 8 is reachable, of 12 not. Two parts whose
    levels are both drawn stack up beyond either's bound: the levels are then not judged."""
    from stackdsl.batch.check import prepare
    from stackdsl.lang.errors import ScenarioErrors

    base = "stackdsl: 1\nstructure: {{tower: {{levels: {{choice: [3, 10]}}}}}}\nsweep: {{samples: 2}}\nexpect: {{collapse: {{mean: {m} ± 1}}}}\n"
    (tmp_path / "a.yaml").write_text(base.format(m=8))
    assert len(prepare([tmp_path / "a.yaml"])) == 1
    (tmp_path / "b.yaml").write_text(base.format(m=12))
    with pytest.raises(ScenarioErrors, match="builds at most 10 levels"):
        prepare([tmp_path / "b.yaml"])
    stacked = (
        "stackdsl: 1\nstructure:\n  - {name: low, tower: {levels: {choice: [2, 6]}}}\n"
        "  - {name: high, on: low, tower: {levels: {choice: [2, 6]}}}\nsweep: {samples: 2}\n"
        "expect: {collapse: {mean: 11 ± 0.5}}\n"
    )
    (tmp_path / "c.yaml").write_text(stacked)
    assert len(prepare([tmp_path / "c.yaml"])) == 1  # 6 + 6 levels reach 11: not refused


@pytest.mark.slow
def test_check_runs_a_sweep_as_one_row_beside_single_runs(tmp_path, capsys):
    (tmp_path / "walk.yaml").write_text(STACK.format(levels=6, samples=10) + "expect:\n  p_stands: '<= 0.95'\n")
    (tmp_path / "tower.yaml").write_text("stackdsl: 1\nstructure: {tower: {levels: 2}}\nexpect: {stands: true}\n")
    report = tmp_path / "report"
    assert main(["check", str(tmp_path), "-j", "2", "--report", str(report)]) == 0
    out = capsys.readouterr().out
    row = next(line for line in out.splitlines() if "walk.yaml" in line)
    assert row.startswith("PASS") and "P(stands) <= 0.95" in row and "n=10" in row
    assert (report / "walk" / "samples.csv").is_file() and (report / "walk" / "histogram.png").is_file()
    assert "walk/histogram.png" in (report / "index.html").read_text()


@pytest.mark.slow
def test_check_says_why_a_sweep_did_not_hold_and_refuses_a_bad_sample(tmp_path, capsys):
    (tmp_path / "walk.yaml").write_text(STACK.format(levels=6, samples=10) + "expect:\n  collapse: {mean: '4.5 ± 0.1'}\n")
    assert main(["check", str(tmp_path / "walk.yaml"), "-j", "1"]) == 1
    out = capsys.readouterr().out
    assert (
        "INCONCLUSIVE: expected mean 4.5±0.1" in out and "samples would decide it" in out
    ) or "FAIL: expected mean 4.5±0.1" in out
    far = STACK.format(levels=4, samples=8).replace("[-60 mm, 60 mm]", "[-60 mm, 200 mm]")
    (tmp_path / "far.yaml").write_text(far)
    assert main(["check", str(tmp_path / "far.yaml"), "-j", "1"]) == 2
    assert "rests on nothing when placed" in capsys.readouterr().err


def test_the_throughput_table_gives_each_executors_efficiency_with_and_without_its_start_up():
    from stackdsl.bench.sweep import Throughput, format_throughputs

    rows = [
        Throughput("1 process (-j 1)", 100, 10.0),
        Throughput("2 processes (-j 2)", 100, 6.0, 1.0),
        Throughput("Dask", 100, 5.5, 2.0),
    ]
    lines = format_throughputs("random stack: 100 samples on each executor", rows, True).splitlines()
    # the pool started within its 6 s: 83% with start-up, 100% once up; Dask's 2 s came before its 5.5 s: 67%, 91%
    assert lines[3].split()[-2:] == ["83%", "100%"] and lines[4].split()[-2:] == ["67%", "91%"]
    assert lines[-2].endswith("yes")
    assert lines[2].split()[4:6] == ["10.0", "s"] and lines[3].split()[4:6] == ["6.00", "s"]


def test_the_throughput_table_shows_a_short_runs_wall_time():
    # six samples of a small stack took 0.05 s on a fast machine, printed in tenths as 0.0 s
    from stackdsl.bench.sweep import Throughput, format_throughputs

    rows = [Throughput("1 process (-j 1)", 6, 0.0496), Throughput("2 processes (-j 2)", 6, 0.31, 0.26)]
    lines = format_throughputs("small: 6 samples on each executor", rows, True).splitlines()
    assert lines[2].split()[4:6] == ["0.05", "s"] and lines[3].split()[4:6] == ["0.31", "s"]
    assert lines[3].split()[7:9] == ["0.26", "s"]


@pytest.mark.slow  # 8-10 s: in .ci/nightly's slow part
def test_bench_sweep_measures_a_sweep_file_on_every_executor(tmp_path, capsys):
    path = tmp_path / "stack.yaml"
    path.write_text(STACK.format(levels=4, samples=50))
    assert main(["bench", "sweep", str(path), "--samples", "6", "--no-loaded"]) == 0
    versions, *lines = capsys.readouterr().out.splitlines()
    assert versions.startswith("engines: pybullet ")
    assert lines[0] == "random single-file stack: 6 samples on each executor"
    rows = [line for line in lines if line.split()[0] in ("1", "2", "Dask")]
    assert len(rows) == 3 and all(float(row.split(" s ")[0].split()[-1]) > 0 for row in rows)
    assert lines[-2].endswith("identical on every executor: yes")


@pytest.mark.slow
def test_the_loaded_rows_run_the_samples_beside_a_busy_core_and_stop_it(tmp_path, monkeypatch):
    import subprocess

    from stackdsl.bench.sweep import loaded, template

    path = tmp_path / "stack.yaml"
    path.write_text(STACK.format(levels=3, samples=50))
    spinners: list[subprocess.Popen[bytes]] = []
    popen = subprocess.Popen

    def spy(*args, **kwargs):
        spinners.append(popen(*args, **kwargs))
        return spinners[-1]

    monkeypatch.setattr(subprocess, "Popen", spy)
    rows, load = loaded(template(4, path), spin_up=0.2)
    assert [r.executor.split(" (")[0] for r in rows] == ["busy core: -j 1", "busy core: -j auto"]
    assert all(r.samples == 4 and r.seconds > 0 for r in rows) and load >= 0.0
    assert len(spinners) == 1 and spinners[0].poll() is not None  # the busy core is let go of


def test_bench_sweep_refuses_a_file_with_nothing_to_sample(tmp_path, capsys):
    assert main(["bench", "sweep", str(ROOT / "scenarios" / "four_stack.yaml")]) == 2
    assert "nothing to sample" in capsys.readouterr().err
    assert main(["bench", "sweep", "--samples", "0"]) == 2


@pytest.mark.slow
def test_sweep_takes_one_executor_and_checks_the_dask_address_before_saying_anything(tmp_path, capsys):
    path = tmp_path / "stack.yaml"
    path.write_text(STACK.format(levels=3, samples=2))
    with pytest.raises(SystemExit) as usage:
        main(["sweep", str(path), "-j", "1", "--dask", "local:2"])
    assert usage.value.code == 2 and "not allowed with" in capsys.readouterr().err
    with pytest.raises(SystemExit) as usage:
        main(["sweep", str(path), "--dask", "local:0", "--out", str(tmp_path / "out")])
    captured = capsys.readouterr()
    assert usage.value.code == 2 and captured.out == "" and "local:N needs N, a whole number" in captured.err
    assert not (tmp_path / "out").exists()


def test_samples_given_on_the_command_line_meet_the_files_budget(tmp_path, capsys, monkeypatch):
    """A 1000-cell grid with --samples 100000 would be 10^8 runs: refused before anything runs,
    with the cap named, as the same numbers written in the file are."""
    from stackdsl.cli.main import main
    from stackdsl.lang.schema_sweep import MAX_SWEEP_RUNS

    values = ", ".join(f"{k / 10:g} mm" for k in range(10))
    grid = "\n".join(f"    {f}: [{values}]" for f in ("timing.placement_error", "timing.drop_gap", "structure.tower.shift"))
    path = tmp_path / "big.yaml"
    path.write_text(f"stackdsl: 1\nstructure: {{tower: {{levels: 2}}}}\nsweep:\n  samples: 1\n  grid:\n{grid}\n")
    monkeypatch.setattr("stackdsl.batch.sweep.run_batch", lambda *a, **k: pytest.fail("simulated"))
    assert main(["sweep", str(path), "--samples", "100000", "-j", "1", "--out", str(tmp_path / "out")]) == 2
    err = capsys.readouterr().err.strip()
    assert err == f"--samples: 1000 cells x 100000 samples is 100000000 runs; at most {MAX_SWEEP_RUNS} in a sweep"
    assert main(["sweep", str(path), "--samples", "0", "--out", str(tmp_path / "out")]) == 2
    assert "samples must be from 1 to" in capsys.readouterr().err and not (tmp_path / "out").exists()


def test_a_sweep_without_out_writes_into_a_new_private_folder_and_follows_no_planted_link(tmp_path, capsys, monkeypatch):
    """The default output is a folder made for this sweep (mkdtemp: this user's, mode 0700, an
    unpredictable name), never the shared path another user could plant a symlink at."""
    import os
    import stat

    from stackdsl.cli.main import main

    scratch, victim = tmp_path / "tmp", tmp_path / "victim"
    scratch.mkdir()
    victim.mkdir()
    (scratch / "stackdsl-sweep").symlink_to(victim)  # where the old default wrote
    monkeypatch.setenv("TMPDIR", str(scratch))
    monkeypatch.setattr("tempfile.tempdir", None)  # read TMPDIR again
    sweep = tmp_path / "tiny.yaml"
    sweep.write_text("stackdsl: 1\nstructure: {tower: {levels: 1}}\nsweep: {samples: 2}\n")
    assert main(["sweep", str(sweep), "-j", "1"]) == 0
    made = [p for p in scratch.iterdir() if p.name.startswith("stackdsl-sweep-tiny-")]
    assert len(made) == 1 and (made[0] / "samples.csv").exists()
    assert stat.S_IMODE(made[0].stat().st_mode) == 0o700 and made[0].stat().st_uid == os.getuid()
    assert list(victim.iterdir()) == [] and str(made[0]) in capsys.readouterr().out


@pytest.mark.slow
def test_sigterm_stops_a_local_dask_sweep_quietly_and_leaves_no_scratch_space(tmp_path):
    """Dask's own logging of its workers' restarts used to flood the terminal, and its scratch
    folder stayed in $TMPDIR."""
    import os
    import signal
    import subprocess
    import sys
    import time

    scratch = tmp_path / "tmp"
    scratch.mkdir()
    sweep = subprocess.Popen(
        [sys.executable, "-m", "stackdsl", "sweep", str(ROOT / "sweeps" / "random_single_file.yaml")]
        + ["--samples", "5000", "--dask", "local:1", "--out", str(tmp_path / "out")],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        env={**os.environ, "TMPDIR": str(scratch)},
    )
    time.sleep(8.0)
    sweep.send_signal(signal.SIGTERM)
    _, stderr = sweep.communicate(timeout=60)
    assert "distributed" not in stderr and "Traceback" not in stderr and len(stderr.splitlines()) <= 1, stderr
    assert list(scratch.iterdir()) == []


OVERHANG = """stackdsl: 1
structure:
  tower: {levels: 2, bricks_per_layer: 1, turn: 0, shift: {uniform: [0 mm, 120 mm]}}
timing: {settle: 0.5 s}
sweep: {samples: 10}
expect:
  p_stands: ">= 0.5"
"""


@pytest.mark.slow
def test_check_of_an_undecided_sweep_says_inconclusive_everywhere_and_points_at_stackdsl_sweep(tmp_path, capsys):
    """Half its draws stand (shift beyond 60 mm tips), so 10 samples cannot decide P(stands) >= 0.5."""
    (tmp_path / "half.yaml").write_text(OVERHANG)
    junit = tmp_path / "j.xml"
    assert main(["check", str(tmp_path / "half.yaml"), "-j", "1", "--mode", "tuned", "--junit-xml", str(junit)]) == 1
    out = capsys.readouterr().out
    assert "expect.p_stands: INCONCLUSIVE: expected P(stands) >= 0.5" in out
    assert f"more: stackdsl sweep {tmp_path / 'half.yaml'} --mode tuned" in out  # every sample, not run's one
    assert "more: stackdsl run" not in out
    (failure,) = ET.parse(junit).getroot().iter("failure")
    assert failure.get("message", "").startswith(f"{tmp_path / 'half.yaml'}:7:3: INCONCLUSIVE: expected P(stands) >= 0.5")
    assert failure.text is not None and failure.text.endswith(f"more: stackdsl sweep {tmp_path / 'half.yaml'} --mode tuned")


def test_a_workers_sample_warning_is_a_line_as_the_command_shows_it(capsys):
    """A sweep's workers compile their own samples: a pull timed before one sample's build ends
    was shown as Python reports a warning, '.../stackdsl/compile/compiler.py:151: ScenarioWarning:
    ...', with the line of stackdsl's source under it. A worker's batch shows it as the command
    does, one line naming the file, line and column."""
    import warnings

    from stackdsl.batch.sweep import run_batch

    text = (
        "stackdsl: 1\nstructure: {tower: {levels: 4, bricks_per_layer: 3, spacing: 25 mm}}\n"
        "timing: {interval: {choice: [0.2 s, 0.25 s]}, settle: 0.5 s}\n"
        "actions:\n  - remove: {brick: L04.1, at: 2.6 s, speed: 40 mm/s}\n"
        "sweep: {samples: 4}\nexpect: {p_stands: '>= 0.5'}\n"
    )
    template = parse_scenario(text, "late.yaml").template
    late = [k for k in range(4) if template.scenario(0, k).timing.interval == 0.25]
    assert late, "no sample drew the longer interval"
    with warnings.catch_warnings():
        warnings.simplefilter("always")
        run_batch(template, 0, late[:1], SweepOptions())
    err = capsys.readouterr().err
    assert "late.yaml:5:32: warning: actions[0].remove.at: starts at 2.6 s, while bricks are still placed" in err
    assert "ScenarioWarning" not in err and "compiler.py" not in err, err
