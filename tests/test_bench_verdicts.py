"""``stackdsl bench verdicts``: the plan of settings and drop gaps, and the agreement table
counted from the runs."""

from __future__ import annotations

from dataclasses import replace

import pytest

from stackdsl._bench_verdicts import (
    MARGIN,
    SETTINGS,
    Verdicts,
    format_verdicts,
    plan,
    rows,
    run_verdicts,
)
from stackdsl._cli import main

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


def test_every_assembly_runs_every_planned_setting(few):
    assert [v.index for v in few] == list(range(5))
    for v in few:
        assert not v.error and v.bricks >= 3
        assert [(r.setting, r.gap) for r in v.runs] == list(PYBULLET)
        assert all(not r.error and r.wall > 0 for r in v.runs)
    assert any(v.leaning for v in few)


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


def test_bench_verdicts_runs_and_refuses_nonsense(capsys, tmp_path):
    args = ["bench", "verdicts", "--count", "1", "--engines", "pybullet", "--gaps", "2", "--no-baselines"]
    assert main([*args, "-j", "1", "--out", str(tmp_path)]) == 0
    out = capsys.readouterr().out
    assert out.startswith("1 random assemblies") and "ext equilibrium pybullet  2.0 mm" in out
    assert "mujoco" not in out
    assert main(["bench", "verdicts", "--count", "-1"]) == 2
    assert main(["bench", "verdicts", "--gaps", "5"]) == 2
    assert main(["bench", "verdicts", "--engines", "bullet"]) == 2
