"""``stackdsl bench verdicts --families near-tie,shake``: the near ties drawn where they are
meant to be, the shake table's references against their closed forms, the tables counted from
the runs, and the command's options."""

from __future__ import annotations

import math
from dataclasses import replace

import pytest

from stackdsl.bench.near_tie import band_of, draw, format_near_ties, near_tie_batch, top_at
from stackdsl.bench.random_stack import interface_margins
from stackdsl.bench.shake_family import (
    BLOCKS,
    CELLS,
    Reference,
    ShakeRun,
    ShakeSample,
    came_back,
    format_shakes,
    onset,
    onset_within,
    ratio_of,
    reference,
    shake_batch,
    stirred,
)
from stackdsl.bench.shake_models import G, coulomb_slip, rocking
from stackdsl.bench.verdicts import Run, Sample, certificate_margins, exact_margin, family_settings, format_single_file
from stackdsl.cli.main import main

# --- the near ties ------------------------------------------------------------------------


def test_each_draw_sits_in_its_band_on_its_side_of_the_edge():
    for k in range(16):
        d = draw(3, k)
        level, margin = exact_margin(d.x)
        assert band_of(margin) == k % 4, (k, margin)
        assert margin == pytest.approx(abs(d.target), abs=1e-9)
        assert (d.side == "inside") == (k // 4 % 2 == 0) and (d.shape == "overhang") == (k < 8)
        assert len(d.x) == 2 if d.shape == "overhang" else 3 <= len(d.x) <= 8
        assert level == (None if d.side == "inside" else len(d.x))
        # the brick below the top stands clear: the top brick decides
        assert exact_margin(d.x[:-1])[0] is None and exact_margin(d.x[:-1])[1] > 0.002
    assert draw(3, 9) == draw(3, 9) and draw(3, 9).x != draw(4, 9).x


def test_the_top_brick_is_put_where_the_least_margin_is_the_one_asked_for():
    below = [0.0, 0.03, 0.01]
    for target in (0.0007, 0.00005, -0.00005, -0.0009):
        for right in (True, False):
            x = top_at(below, target, right)
            assert interface_margins([*below, x]).min() == pytest.approx(target, abs=1e-12)
            assert (x > below[-1]) == right
    with pytest.raises(ValueError, match="at most"):
        top_at(below, 0.07, True)  # no top brick stands by more than half a length


def test_the_near_tie_table_counts_each_band_and_lists_each_disagreement(tmp_path):
    (a, b) = near_tie_batch(1, [1, 5], ["ext report pybullet"])  # an overhang 0.1-0.2 mm inside and one outside
    assert not a.error and a.exact is None and b.exact == 2 and band_of(a.margin) == band_of(b.margin) == 1
    assert all(len(s.runs) == 1 for s in (a, b))
    wrong = replace(a, runs=(replace(a.runs[0], level=2, proof="off its support", tie="a near tie, said so"),))
    right = replace(b, runs=(replace(b.runs[0], level=b.exact),))
    wide = Sample(0, None, 0.004, (Run("ext report pybullet", 0.0005, None, 0.1),))
    table = format_near_ties([wrong, right], ["ext report pybullet"], 1.0, [wide], tmp_path)
    row = next(line for line in table.splitlines() if line.startswith("ext report pybullet"))
    assert row.split()[3:13] == ["-", "1/2", "50%", "-", "-", "1/1", "100%", "0/1", "0%", "1/1"], row
    assert "      1  ext report pybullet       overhang of 2, inside: collapse 2 (off its support) (exact stands)" in table
    assert "margin 0.1" in table and "a near tie, said so" in table and "disagreements: 1, 1 that" in table
    assert (tmp_path / "near_tie_00001.yaml").read_text() == a.text


def test_certificate_margins_above_or_far_below_the_true_one_are_counted_and_listed():
    runs = [
        ("    1", 0.0005, Run("ext report mujoco", 0.0005, None, 0.1, margin=0.0004)),  # 0.1 mm below: fine
        ("    2", 0.0005, Run("ext report mujoco", 0.0005, None, 0.1, margin=0.0006)),  # above the true margin
        ("    3", 0.0020, Run("ext report mujoco", 0.0005, None, 0.1, margin=0.0012)),  # 0.8 mm below
        ("    4", 0.0020, Run("ext report pybullet", 0.0005, None, 0.1, margin=0.0020)),
    ]
    lines = certificate_margins(runs, ["ext report mujoco", "ext report pybullet"])
    assert lines[1].split()[3:] == ["3", "1", "1", "+0.100", "mm", "-0.800", "mm"], lines[1]
    assert lines[2].split()[3:] == ["1", "0", "0", "+0.000", "mm", "+0.000", "mm"], lines[2]
    assert lines[3:] == ["  above:     2  ext report mujoco         certificate 0.600 mm, true 0.500 mm"]


def test_the_single_file_table_says_whether_each_miss_is_an_exact_tie_and_what_the_certificate_said():
    tie = Sample(
        7, 3, 0.00004, (Run("ext report pybullet", 0.0005, 2, 0.1, proof="off its support", tie="collapses on a near tie (x)"),)
    )
    far = Sample(8, None, 0.0003, (Run("ext report pybullet", 0.0005, 2, 0.1, proof="off its support"),))
    table = format_single_file([tie, far], ["ext report pybullet"], 1.0)
    assert "disagreements: 2 (1 exact ties under 0.1 mm, 1 that the certificate calls a near tie)" in table
    assert "margin 0.040 mm  exact tie; collapses on a near tie (x)" in table
    assert "margin 0.300 mm; the certificate says no near tie" in table


def test_a_stands_certificate_margin_is_rounded_down_never_above_the_true_one():
    from stackdsl.compile.compiler import compile_scenario
    from stackdsl.lang.loader import parse_scenario
    from stackdsl.runtime.run import run_program

    # a two-brick overhang 0.47 mm inside its edge: 0.5 mm rounded, 0.4 mm rounded down
    text = "stackdsl: 1\nname: t\nstructure:\n  bricks:\n    - {id: a, at: [0, 0, 4 mm], level: 1}\n"
    text += "    - {id: b, at: [59.53 mm, 0, 12 mm], level: 2}\ntiming: {settle: 1 s}\n"
    outcome = run_program(compile_scenario(parse_scenario(text, "t.yaml"), "extension", "report", "pybullet"))
    assert outcome.collapse is None and outcome.certificate is not None
    assert outcome.certificate.margin_mm == pytest.approx(0.4), outcome.certificate


# --- the shake table -----------------------------------------------------------------------


def _amplitude(ratio: float, threshold: float, frequency: float) -> float:
    return ratio * threshold / (2 * math.pi * frequency) ** 2


def test_the_coulomb_block_slips_from_mu_g_and_as_far_as_the_shake_drift_table_says():
    mu = 0.5
    assert coulomb_slip(_amplitude(0.995, mu * G, 2.0), 2.0, 2, mu) == (0.0, 0.0)
    assert coulomb_slip(_amplitude(1.02, mu * G, 2.0), 2.0, 2, mu)[1] > 0
    # docs/results/shake-table.md, "How far a slipping brick goes": its closed-form column
    for ratio, frequency, slid in ((1.5, 2.0, 0.0128), (2.0, 5.0, 0.0061), (1.75, 4.0, 0.0061)):
        final, largest = coulomb_slip(_amplitude(ratio, mu * G, frequency), frequency, round(frequency), mu)
        assert final == pytest.approx(slid, abs=0.00006) and largest >= final


def test_the_rocking_block_starts_at_g_b_over_h_and_topples_or_comes_back():
    b, h = 0.004, 0.012  # a KAPLA brick on edge, across
    threshold = G * b / h
    assert rocking(b, h, _amplitude(0.999, threshold, 2.0), 2.0, 2).largest == 0.0
    assert rocking(b, h, _amplitude(1.02, threshold, 2.0), 2.0, 2).largest > 0.0
    assert rocking(b, h, _amplitude(1.2, threshold, 2.0), 2.0, 2).toppled
    back = rocking(0.012, 0.060, _amplitude(1.1, G * 0.2, 8.0), 8.0, 8)  # on end: rocks a few degrees and lands
    assert not back.toppled and math.radians(1) < back.largest < math.radians(10) and back.impacts > 2
    assert abs(back.final) < 1e-3


def test_the_samples_spread_over_0_8_to_1_2_densest_near_the_threshold():
    ratios = [ratio_of(1, 2, k, 20) for k in range(20)]
    assert ratios == sorted(ratios) and 0.8 <= ratios[0] and ratios[-1] <= 1.2
    assert sum(abs(r - 1) < 0.05 for r in ratios) == 10
    assert {b.tips for b in BLOCKS} == {True, False} and len(CELLS) == 11


def test_the_reference_stays_below_the_threshold_and_moves_above_it():
    block = next(b for b in BLOCKS if b.name == "KAPLA on edge, along y")
    assert block.tips and block.threshold == pytest.approx(G / 3)
    assert reference(block, _amplitude(0.95, block.threshold, 2.0), 2.0, 2, 0.004) == Reference("stays", None, 0, 0, 0)
    assert reference(block, _amplitude(1.2, block.threshold, 2.0), 2.0, 2, 0.004).motion == "topples"
    flat = next(b for b in BLOCKS if b.name == "KAPLA flat, along y")
    slid = reference(flat, _amplitude(1.2, flat.threshold, 2.0), 2.0, 2, 0.004)
    assert slid.motion == "slides" and slid.level is None and 0.0005 < slid.final_slip < 0.004


def test_a_shake_sample_measures_what_the_block_did():
    (low, high) = shake_batch(1, 2, [0, 29], 30, ["ext report pybullet"])  # KAPLA on edge along y, 2 Hz
    assert low.ratio < 0.83 and high.ratio > 1.17 and low.reference and high.reference
    assert low.runs[0].motion == "stays" and low.runs[0].run.level is None and low.runs[0].tilt < 0.01
    assert high.runs[0].motion == "topples" == high.reference.motion and high.runs[0].run.level == 1
    assert high.runs[0].final_tilt > math.radians(80)


def test_the_shake_tables_count_from_the_runs():
    def run(level: int | None, motion: str, tilt: float = 0.0) -> ShakeRun:
        return ShakeRun(Run("ext report pybullet", 0.0005, level, 0.1), motion, 0.0, tilt, 0.0, tilt)

    block = CELLS[2][0]
    ref = Reference("rocks", None, 0.0, 0.1, 0.0)
    samples = [
        ShakeSample(0, block.name, 2.0, 0.01, 0.85, "tips", 0.004, Reference("stays", None, 0, 0, 0), (run(None, "stays"),)),
        ShakeSample(1, block.name, 2.0, 0.01, 1.07, "tips", 0.004, ref, (run(1, "rocks", 0.1),)),  # rocked, called a collapse
        ShakeSample(2, block.name, 2.0, 0.01, 1.08, "tips", 0.004, ref, (run(None, "rocks", 0.1),)),
    ]
    assert came_back(samples[1], samples[1].runs[0]) and not came_back(samples[2], samples[2].runs[0])
    table = format_shakes(samples, ["ext report pybullet"], 1.0)
    rows = [line for line in table.splitlines() if line.startswith("ext report pybullet")]
    assert rows[0].split()[3:5] == ["1/1", "100%"] and "1/2" in rows[0] and rows[0].split()[-5] == "1"  # 'upright'
    assert "verdict disagreements: 1" in table and "x1.070  ext report pybullet       collapse 1 (stands)" in table
    assert onset([(0.9, "stays"), (1.02, "rocks"), (1.05, "stays")]) == "102.0%*" and onset([(1.1, "stays")]) == "-"
    # the onset of motion: the rocked samples tilted 0.1 rad, the first stayed still
    assert (
        "cells whose onset is within 5% of the closed form (still below 95%, moving above 105%): ext report pybullet 1/1" in table
    )
    onsets = table.split("onset of motion")[1].splitlines()
    assert onsets[2].split()[-1] == "107.0%", onsets


def test_the_onset_of_motion_is_within_5_percent_only_when_still_below_and_moving_above():
    still = ShakeRun(Run("s", 0.0, None, 0.1), "stays", 0.000005, math.radians(0.02), 0.0, 0.0)
    moved = replace(still, tilt=math.radians(0.06))
    assert not stirred(still) and stirred(moved) and stirred(replace(still, slip=0.00002))
    assert onset_within([(0.9, False), (0.97, False), (1.01, True), (1.1, True)])
    assert onset_within([(0.97, True), (1.03, False), (1.2, True)])  # within 5%, either way
    assert not onset_within([(0.9, True), (1.1, True)]) and not onset_within([(0.9, False), (1.1, False)])


# --- the command -----------------------------------------------------------------------------


def test_the_families_run_in_the_settings_asked_for():
    assert family_settings(["pybullet"]) == ["raw pybullet", "tuned pybullet", "ext report pybullet", "ext equilibrium pybullet"]
    assert family_settings(["mujoco"], baselines=False) == ["ext report mujoco", "ext equilibrium mujoco"]


def test_bench_verdicts_refuses_an_unknown_family_or_size(capsys):
    assert main(["bench", "verdicts", "--families", "near-ties"]) == 2
    assert "unknown family 'near-ties'" in capsys.readouterr().err
    assert main(["bench", "verdicts", "--families", "near-tie", "--near-tie", "-1"]) == 2
    assert main(["bench", "verdicts", "--families", "shake", "--shakes", "0"]) == 2
    assert "--shakes above 0" in capsys.readouterr().err


@pytest.mark.slow
def test_bench_verdicts_runs_the_new_families_and_writes_their_tables(capsys, tmp_path):
    args = ["bench", "verdicts", "--families", "near-tie,shake", "--near-tie", "4", "--shakes", "1"]
    assert main([*args, "--engines", "pybullet", "--no-baselines", "-j", "1", "--out", str(tmp_path)]) == 0
    out = capsys.readouterr().out
    assert "4 near-tie samples" in out and "11 shake samples" in out and "ext equilibrium pybullet" in out
    assert "mujoco" not in out.split("\n", 1)[1] and "tuned" not in out
    for name in ("near_tie.txt", "near_tie.jsonl", "shake.txt", "shake.jsonl"):
        assert (tmp_path / name).exists()
    assert len((tmp_path / "shake.jsonl").read_text().splitlines()) == 11
