"""``stackdsl bench verdicts``: the plan of settings and drop gaps, the agreement table counted
from the runs, and the random single-file stack against the exact centre-of-mass rule."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from stackdsl.bench.random_stack import collapse_level
from stackdsl.bench.verdicts import (
    JOURNAL,
    MARGIN,
    SETTINGS,
    Journal,
    Run,
    Sample,
    Verdicts,
    exact_margin,
    format_single_file,
    format_verdicts,
    plan,
    rows,
    run_verdicts,
    single_file_batch,
)
from stackdsl.cli.main import main

PYBULLET = plan(["pybullet"], [0.0005], baselines=False)


def test_the_plan_runs_the_extension_at_every_gap_and_the_baselines_once():
    everything = plan()
    assert len(everything) == 3 + 4 * 4  # raw and tuned pybullet, tuned mujoco; 4 extension settings x 4 gaps
    assert {s for s, _ in everything} == set(SETTINGS)
    assert ("ext equilibrium mujoco", 0.0) in everything and ("raw pybullet", 0.0005) in everything
    assert plan(["pybullet"], [0.001]) == (
        ("raw pybullet", 0.0005),
        ("tuned pybullet", 0.0005),
        ("ext report pybullet", 0.001),
        ("ext equilibrium pybullet", 0.001),
    )
    with pytest.raises(ValueError, match="engines"):
        plan(["bullet"])
    with pytest.raises(ValueError, match="gap"):
        plan(gaps=[])


@pytest.fixture(scope="module")
def few() -> list[Verdicts]:
    """Five assemblies in the two pybullet extension settings at 0.5 mm (a few seconds)."""
    return run_verdicts(2, 5, 1, runs=PYBULLET)


@pytest.mark.slow
def test_every_assembly_runs_every_planned_setting(few):
    assert [v.index for v in few] == list(range(5))
    for v in few:
        assert not v.error and v.bricks >= 3
        assert [(r.setting, r.gap) for r in v.runs] == list(PYBULLET)
        assert all(not r.error and r.wall > 0 for r in v.runs)
    assert any(v.leaning for v in few)


@pytest.mark.slow
def test_the_table_counts_agreement_from_the_runs(few, tmp_path):
    table = format_verdicts(few, tmp_path, 1.0, PYBULLET)
    lines = table.splitlines()
    assert lines[0].startswith("5 random assemblies")
    for name, gap in PYBULLET:
        row = next(line for line in lines if line.startswith(name))
        agree = sum(v.run(name, gap).level == v.oracle for v in few)  # type: ignore[union-attr]
        assert row[len(name) :].split()[2] == f"{agree}/5", row
    # one run made to disagree: its row loses one, and its assembly is written out when it is sure
    v = max(few, key=lambda v: v.margin)
    assert v.margin > MARGIN
    name, gap = PYBULLET[0]
    run = v.run(name, gap)
    assert run is not None
    wrong = replace(run, level=99, active=())
    doctored = [replace(u, runs=(wrong, *u.runs[1:])) if u is v else u for u in few]
    before, after = rows(few, PYBULLET)[0], rows(doctored, PYBULLET)[0]
    assert after.every == (before.every[0] - 1, before.every[1]) and after.sure == (before.sure[0] - 1, before.sure[1])
    assert (after.leaning if v.leaning else after.flat)[0] == (before.leaning if v.leaning else before.flat)[0] - 1
    table = format_verdicts(doctored, tmp_path, 1.0, PYBULLET)
    assert f"assembly_{v.index:04d}.yaml" in table and (tmp_path / f"assembly_{v.index:04d}.yaml").read_text() == v.text
    # a run that says "stands" with a structure brick still active is counted; an error is left out
    active = replace(run, level=None, active=("b01",))
    failed = replace(run, level=None, error="RuntimeError: boom")
    counted = rows([replace(v, runs=(active, *v.runs[1:])), replace(few[0], runs=(failed, *few[0].runs[1:]))], PYBULLET)[0]
    assert counted.stands_active == 1 and counted.errors == 1 and counted.every[1] == 1
    broken = format_verdicts([replace(few[0], runs=(failed, *few[0].runs[1:]))], None, 1.0, PYBULLET)
    assert f"{failed.setting} at {failed.gap * 1000:.1f} mm: RuntimeError: boom" in broken
    # every real run has its certificate; one without is counted
    assert all(r.certified for u in few for r in u.runs if not r.error)
    bare = replace(run, certified=False)
    assert rows([replace(v, runs=(bare, *v.runs[1:]))], PYBULLET)[0].uncertified == 1


def test_the_exact_margin_is_how_far_a_verdict_is_from_flipping():
    assert exact_margin([0.0, 0.05, 0.1]) == (3, pytest.approx(0.010))
    assert exact_margin([0.0, 0.03, 0.0]) == (None, pytest.approx(0.03))
    rng = np.random.default_rng(4)
    for _ in range(200):
        x = np.concatenate([[0.0], np.cumsum(rng.uniform(-0.06, 0.06, 11))])
        level, margin = exact_margin(x)
        assert level == collapse_level(x) and margin > 0
        # moving each brick by under half the margin moves no centre of mass above a brick by the margin
        jiggled = x + rng.uniform(-0.49, 0.49, len(x)) * margin
        assert collapse_level(jiggled) == level


def test_single_file_samples_are_judged_by_the_exact_rule_on_their_placed_centres():
    samples = single_file_batch(1, [0, 2], ["ext report pybullet"])
    assert [s.sample for s in samples] == [0, 2] and all(not s.error for s in samples)
    assert [s.exact for s in samples] == [12, 4]  # seed 1's samples 0 and 2
    assert all(len(s.runs) == 1 and s.runs[0].setting == "ext report pybullet" for s in samples)
    off = Sample(7, 5, 0.0004, (Run("ext report pybullet", 0.0005, 6, 0.1),))
    table = format_single_file([*samples, off], ["ext report pybullet"], 1.0)
    agree = sum(s.runs[0].level == s.exact for s in samples)
    assert f"{agree}/3" in table.splitlines()[3]
    assert "collapse 6 (exact collapse 5), margin 0.400 mm; the certificate says no near tie" in table


@pytest.mark.slow
def test_bench_verdicts_runs_and_refuses_nonsense(capsys, tmp_path):
    args = ["bench", "verdicts", "--count", "1", "--engines", "pybullet", "--gaps", "2", "--no-baselines"]
    assert main([*args, "--single-file", "1", "-j", "1", "--out", str(tmp_path)]) == 0
    out = capsys.readouterr().out
    first, second = out.splitlines()[:2]
    assert first.startswith("engines: pybullet ") and second.startswith("1 random assemblies")
    assert "ext equilibrium pybullet  2.0 mm" in out
    assert "1 random single-file stacks" in out and "mujoco" not in out.split("\n", 1)[1]  # (the first line: versions)
    assert main(["bench", "verdicts", "--count", "-1"]) == 2
    assert main(["bench", "verdicts", "--count", "0", "--single-file", "0"]) == 2
    assert main(["bench", "verdicts", "--gaps", "5"]) == 2
    assert main(["bench", "verdicts", "--engines", "bullet"]) == 2


@pytest.mark.slow
def test_a_journal_keeps_finished_assemblies_and_refuses_another_run(few, tmp_path):
    journal = Journal(tmp_path / JOURNAL, 2, PYBULLET)
    assert journal.load() == {}
    for v in few[:3]:
        journal.add(v)
    assert journal.load() == {v.index: v for v in few[:3]}  # every field, the runs' too
    # resumed, only the two left run, and the table is the whole run's
    ran: list[int] = []
    done = run_verdicts(2, 5, 1, lambda v: ran.append(v.index), PYBULLET, journal.load())
    assert ran == [3, 4] and [v.index for v in done] == list(range(5))
    assert [v.runs[0].level for v in done] == [v.runs[0].level for v in few]
    with pytest.raises(ValueError, match="another seed, plan or source"):
        Journal(tmp_path / JOURNAL, 3, PYBULLET).load()
    with pytest.raises(ValueError, match="another seed, plan or source"):
        Journal(tmp_path / JOURNAL, 2, plan(["pybullet"], [0.001], baselines=False)).load()
    (tmp_path / "junk.jsonl").write_text("not json\n")
    with pytest.raises(ValueError, match="not a journal"):
        Journal(tmp_path / "junk.jsonl", 2, PYBULLET).load()


@pytest.mark.slow  # 7-22 s: in .ci/nightly's slow part
def test_bench_verdicts_resumes_from_its_journal(capsys, tmp_path):
    args = ["bench", "verdicts", "--count", "2", "--engines", "pybullet", "--gaps", "2", "--no-baselines"]
    args += ["--single-file", "0", "-j", "1", "--out", str(tmp_path)]
    assert main(args) == 0
    first = capsys.readouterr().out
    assert len((tmp_path / JOURNAL).read_text().splitlines()) == 3  # the header and two assemblies
    assert main(args) == 0
    again = capsys.readouterr().out
    assert "resuming: 2 of 2 assemblies done" in again
    assert first.splitlines()[3:] == again.splitlines()[4:]  # the same rows (the wall times are the runs')
    assert main([*args[:3], "3", *args[4:]]) == 0  # one more: assembly 2 runs, 0 and 1 are read
    assert len((tmp_path / JOURNAL).read_text().splitlines()) == 4
    assert main(["bench", "verdicts", "--count", "2", "--seed", "5", *args[4:]]) == 2  # another seed's folder
