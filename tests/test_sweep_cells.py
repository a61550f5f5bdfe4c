"""A sweep's expectations for some grid cells (``expect.cells``), exact verdicts when a sweep draws
nothing, grid keys written with brackets, and per-run expectations refused in a sweep."""

from __future__ import annotations

import csv
import json
import math
from pathlib import Path

import numpy as np
import pytest

from stackdsl import parse_scenario
from stackdsl.batch.sweep import collect, run_sweep
from stackdsl.batch.sweep_out import cell_expectations, verdicts
from stackdsl.cli.main import main
from stackdsl.lang.errors import ScenarioError
from stackdsl.verdicts.stats import ProportionBound, decide

ROOT = Path(__file__).resolve().parents[1]
SHAKE = ROOT / "sweeps" / "shake_amplitude.yaml"

# a 60 x 60 x 30 mm block at mu 0.3: squat (b / h = 2 > mu), it slides at mu g = 2.94 m/s^2, an
# amplitude of 18.6 mm at 2 Hz (a_peak = A (2 pi f)^2)
BLOCK = """stackdsl: 1
materials: {{m: {{density: 600 kg/m^3, friction: 0.3}}}}
brick_types: {{blk: {{size: [60 mm, 60 mm, 30 mm], material: m}}}}
ground: {{material: m}}
structure: {{bricks: [{{id: b, at: [0, 0, 15 mm], brick: blk}}]}}
timing: {{settle: 0.5 s{error}}}
collapse_threshold: 2 mm
actions:
  - shake: {{amplitude: 5 mm, frequency: 2 Hz, duration: 1 s, at: 1 s}}
sweep:
  samples: 1
  grid: {{"{key}": [10 mm, 28 mm]}}
expect:
  cells:
    - {{where: "actions.0.shake.amplitude < 15 mm", p_stands: ">= 0.9"}}
    - {{where: "actions.0.shake.amplitude > 25 mm", p_stands: "<= 0.1"}}
"""


def block(key: str = "actions[0].shake.amplitude", error: str = "") -> str:
    return BLOCK.format(key=key, error=error)


@pytest.mark.parametrize("key", ["actions[0].shake.amplitude", "actions.0.shake.amplitude", "actions[ 0 ].shake.amplitude"])
def test_a_grid_key_may_index_a_list_with_brackets_or_a_dot(key):
    t = parse_scenario(block(key), "b.yaml").template
    assert [t.scenario(c, 0).actions[0].shake.amplitude for c in range(2)] == pytest.approx([0.010, 0.028])  # type: ignore[union-attr]
    assert t.values(1) == {"actions.0.shake.amplitude": pytest.approx(0.028)}


def test_each_cell_is_judged_by_the_expectations_whose_condition_holds_there():
    t = parse_scenario(block(), "b.yaml").template
    scenario = t.scenario(0, 0)
    assert cell_expectations(t, scenario.expect, 0) == [ProportionBound(">=", 0.9)]
    assert cell_expectations(t, scenario.expect, 1) == [ProportionBound("<=", 0.1)]


def test_a_sweep_that_draws_nothing_is_decided_from_one_run_each_cell():
    t = parse_scenario(block(), "b.yaml").template
    assert not t.random
    results = collect(run_sweep(t, jobs=1))
    judged = verdicts(t, t.scenario(0, 0).expect, results)
    assert [(c, v.outcome) for c, v in judged] == [(0, "PASS"), (1, "PASS")]  # stands at 10 mm, slides at 28 mm
    assert [r.collapse_level for r in results] == [None, 1]
    assert "exact" in judged[0][1].measured


def test_a_sweep_that_draws_is_still_judged_by_its_interval():
    t = parse_scenario(block(error=", placement_error: 1 mm"), "b.yaml").template
    assert t.random
    assert decide(ProportionBound(">=", 0.9), [None]).outcome == "INCONCLUSIVE"
    assert decide(ProportionBound(">=", 0.9), [None], exact=True).outcome == "PASS"
    assert decide(ProportionBound(">=", 0.9), [1], exact=True).outcome == "FAIL"


@pytest.mark.slow
def test_a_cells_failed_expectation_points_at_its_line(tmp_path: Path, capsys):
    """The second cell expects the block to stand at 28 mm, where it slides: check names that
    cell's expectation at its line, shows the line, and JSON gives the place of each verdict."""
    path = tmp_path / "s.yaml"
    path.write_text(block().replace('p_stands: "<= 0.1"', 'p_stands: ">= 0.9"'))
    assert main(["check", str(path), "-j", "1"]) == 1
    out = capsys.readouterr().out.splitlines()
    head = next(i for i, line in enumerate(out) if "expect.cells[1].p_stands" in line)
    assert out[head].strip().startswith(f"{path}:16:52: expect.cells[1].p_stands: FAIL in cell 1 (")
    assert out[head + 1].strip() == '- {where: "actions.0.shake.amplitude > 25 mm", p_stands: ">= 0.9"}'
    assert out[head + 2] == " " * (6 + 4 + 51) + "^"  # under p_stands
    assert main(["check", str(path), "-j", "1", "--json"]) == 1
    verdicts = json.loads(capsys.readouterr().out)["results"][0]["verdicts"]
    assert [(v["passed"], v["at"]["line"]) for v in verdicts] == [(True, 15), (False, 16)]


def test_a_cell_condition_names_only_the_grids_fields():
    text = block().replace('"actions.0.shake.amplitude > 25 mm"', '"actions.0.shake.frequency > 25"')
    with pytest.raises(ScenarioError) as caught:
        parse_scenario(text, "b.yaml")
    assert "b.yaml:16:" in str(caught.value) and "expect.cells[1].where" in str(caught.value)
    assert "'actions.0.shake.frequency' is not a field of the grid" in str(caught.value)


@pytest.mark.parametrize("expectation", ["toppled: all", "moved: 1", "stays: 1", "stands: true"])
def test_a_per_run_expectation_in_a_sweep_is_refused_at_its_line(tmp_path: Path, capsys, expectation):
    text = block().split("expect:")[0] + f"expect:\n  {expectation}\n"
    (tmp_path / "s.yaml").write_text(text)
    assert main(["check", str(tmp_path / "s.yaml")]) == 2
    err = capsys.readouterr().err
    assert "s.yaml:14:" in err and f"expect.{expectation.split(':')[0]}:" in err and "statistics over its samples" in err


@pytest.mark.slow
@pytest.mark.parametrize("backend", ["pybullet", "mujoco"])
def test_the_shipped_shake_sweep_stands_below_the_tipping_threshold_and_falls_above(tmp_path: Path, capsys, backend):
    """sweeps/shake_amplitude.yaml on either engine (``sweep --backend``): the 30 x 30 x 90 mm
    block at mu 0.6 tips at g b / h = 3.27 m/s^2, 20.7 mm at 2 Hz; it stands to 20 mm and lies
    on its side from 26 mm (docs/actions.md)."""
    pytest.importorskip(backend)
    out = tmp_path / "o"
    assert main(["sweep", str(SHAKE), "--backend", backend, "-j", "1", "--out", str(out)]) == 0
    printed = capsys.readouterr().out
    assert f"{backend} extension" in printed and printed.count("  PASS ") == 6
    assert "(0 levels)" not in printed  # no tower: no levels to name
    assert "P(stands) 1.000 exact" in printed and "[0.025, 1.000]" not in printed  # no sampling interval on one run
    with open(out / "samples.csv", newline="") as f:
        collapsed = {int(row["cell"]): row["collapse_level"] != "" for row in csv.DictReader(f)}
    t = parse_scenario(SHAKE.read_text(), "s.yaml").template
    g, b, h, w = 9.81, 0.015, 0.045, (2 * math.pi * 2) ** 2
    threshold = g * b / h / w  # the amplitude at which rocking starts, 20.7 mm
    assert threshold == pytest.approx(0.0207, abs=1e-4)
    amplitude = {c: t.values(c)["actions.0.shake.amplitude"] for c in range(t.cells)}
    assert all(not collapsed[c] for c in amplitude if amplitude[c] < threshold)
    assert all(collapsed[c] for c in amplitude if amplitude[c] > 1.2 * threshold)
    assert sorted(collapsed.values()) == [False] * 5 + [True] * 3
    # each cell's histogram draws the expectations of that cell, and none where none holds (22 mm)
    drawn = {c: _expected_pixels(out / f"histogram_{c}.png") for c in range(t.cells)}
    assert all((drawn[c] > 50) is (not 20.5e-3 < amplitude[c] < 25.5e-3) for c in drawn), drawn
    assert _expected_pixels(out / "grid_p_stands.png") > 200  # the two cells' thresholds on the grid plot


def _expected_pixels(path: Path) -> int:
    from PIL import Image

    from stackdsl.draw.sweepplot import EXPECTED

    rgb = np.asarray(Image.open(path).convert("RGB")).astype(int)
    target = np.array([int(EXPECTED[i : i + 2], 16) for i in (1, 3, 5)])
    return int((np.abs(rgb - target).max(axis=2) <= 12).sum())


def test_an_indexed_grid_key_unquoted_in_a_flow_mapping_gets_a_hint(tmp_path: Path, capsys):
    path = ROOT / "tests" / "hostile" / "sweep_grid_bracket_key_in_flow_mapping.yaml"
    assert main(["check", str(path)]) == 2
    err = capsys.readouterr().err
    assert "flow_mapping.yaml:6:35: not valid YAML" in err and '"actions[0].shake.amplitude": ...' in err


def test_a_cell_condition_may_name_the_grid_key_as_written_with_brackets():
    text = block().replace('"actions.0.shake.amplitude < 15 mm"', '"actions[0].shake.amplitude < 15 mm"')
    t = parse_scenario(text, "b.yaml").template
    assert cell_expectations(t, t.scenario(0, 0).expect, 0) == [ProportionBound(">=", 0.9)]


def test_an_exact_summary_has_its_estimates_for_intervals():
    from stackdsl.verdicts.stats import summary

    sampled, exact = summary([None, 3]), summary([None, 3], exact=True)
    assert sampled.p_stands_interval != (0.5, 0.5) and exact.p_stands_interval == (0.5, 0.5)
    assert exact.mean_interval == (3.0, 3.0) and "exact" in exact.text() and "95% CI" not in exact.text()


DROP = """stackdsl: 1
structure: {{tower: {{levels: 3}}}}
timing: {{settle: 0.2 s}}
sweep: {{samples: 2, grid: {{timing.drop_gap: [0, 1 mm], actions.0.shake.amplitude: [10 mm, 20 mm]}}}}
actions: [{{shake: {{amplitude: 5 mm, frequency: 2 Hz, duration: 1 s, at: 1 s}}}}]
expect:
  cells:
    - {{where: "timing.drop_gap < 2 mm", p_stands: ">= 0.1"}}
    - {{where: "{where}", p_stands: ">= 0.1"}}
"""


@pytest.mark.parametrize(
    "where",
    [
        "timing.drop_gap > 1 m",
        "timing.drop_gap > 0.5 mm and actions.0.shake.amplitude < 10 mm",
        "actions.0.shake.amplitude > 20 mm or timing.drop_gap < 0",
    ],
)
def test_a_cells_condition_no_grid_cell_meets_is_refused_at_it(where, tmp_path, capsys):
    """It was dropped: nothing judged in any cell, and the sweep passed on nothing (exit 0)."""
    with pytest.raises(ScenarioError) as err:
        parse_scenario(DROP.format(where=where), "c.yaml")
    assert (err.value.field, err.value.line) == ("expect.cells[1].where", 9)
    assert err.value.message.startswith("no grid cell meets this condition, so these expectations would judge nothing")
    assert "timing.drop_gap: 0, 1 mm; actions.0.shake.amplitude: 10 mm, 20 mm" in err.value.message
    (tmp_path / "c.yaml").write_text(DROP.format(where=where))
    assert main(["sweep", str(tmp_path / "c.yaml"), "-j", "1", "--out", str(tmp_path / "o")]) == 2
    assert "c.yaml:9:15: expect.cells[1].where: no grid cell meets" in capsys.readouterr().err


@pytest.mark.parametrize(
    ("where", "said"),
    [
        ("timing.drop_gap < 1 s", "compares timing.drop_gap (a length) with 1 s (a time)"),
        ("actions.0.shake.amplitude + 1 Hz > 0", "adds actions.0.shake.amplitude (a length) to 1 Hz"),
        ("max(timing.drop_gap, 1 s) > 0", "timing.drop_gap (a length)"),
    ],
)
def test_a_cells_condition_is_refused_for_mixed_units_as_require_is(where, said):
    with pytest.raises(ScenarioError) as err:
        parse_scenario(DROP.format(where=where), "c.yaml")
    assert err.value.field == "expect.cells[1].where" and said in err.value.message
    # one kind on both sides, or a bare number (SI), is read as before
    for fine in ("timing.drop_gap < 1 mm", "timing.drop_gap < 0.0005", "actions.0.shake.amplitude * 2 >= 40 mm"):
        parse_scenario(DROP.format(where=fine), "c.yaml")


@pytest.mark.parametrize(
    ("first", "second", "refused"),
    [
        (">= 0.9", "<= 0.1", "no sweep can meet both"),
        (">= 0.5", "<= 0.5", "which they leave out"),  # 0.5 alone: this sweep draws nothing, P(stands) is 0 or 1
        ("> 0.5", "<= 0.5", "no sweep can meet both"),
        (">= 0.5", "< 0.5", "no sweep can meet both"),
        (">= 0", "<= 1", ""),
        (">= 0.5", "<= 1", ""),
    ],
)
def test_two_rules_holding_one_cell_to_bounds_no_probability_meets_are_refused(first, second, refused):
    """Overlapping conditions could ask one cell for P(stands) >= 0.9 and <= 0.1: a sweep that
    can never pass was accepted. So was one met by 0.5 alone (>= 0.5, <= 0.5), which a sweep that
    draws nothing (P(stands) 0 or 1) never measures, nor one that draws (no interval is one value)."""
    text = f"""stackdsl: 1
structure: {{tower: {{levels: 2}}}}
actions: [{{shake: {{amplitude: 10 mm, frequency: 2 Hz, duration: 1 s, at: after level 2}}}}]
sweep:
  samples: 2
  grid: {{actions.0.shake.amplitude: [10 mm, 20 mm, 30 mm]}}
expect:
  cells:
    - {{where: "actions.0.shake.amplitude <= 20 mm", p_stands: "{first}"}}
    - {{where: "actions.0.shake.amplitude >= 20 mm", p_stands: "{second}"}}
"""
    if refused:
        with pytest.raises(ScenarioError) as err:
            parse_scenario(text, "c.yaml")
        assert err.value.field == "expect.cells[1].p_stands" and refused in err.value.message
    else:
        parse_scenario(text, "c.yaml")


# Two levels in single file, swept over the shift: at 0 mm the top brick sits on the bottom one and
# the tower stands; at 70 mm its centre is 10 mm past the bottom brick's end (half a length, 60 mm),
# so it falls at level 2. Nothing is drawn: each cell's one sample is exact.
EXACT = """stackdsl: 1
structure: {{tower: {{levels: 2, bricks_per_layer: 1, turn: 0}}}}
sweep:
  samples: 1
  grid: {{structure.tower.shift: [0 mm, 70 mm]}}
expect:
  {expect}
"""
FALLS = "structure.tower.shift > 50 mm"
# each of a sweep's statistical expectations, over the whole sweep and in some cells only, with the
# outcome in the standing cell and the falling one (None: not judged there)
EXACT_FORMS = {
    'collapse: {mean: "2 ± 0.5"}': ("FAIL", "PASS"),  # the standing cell has no collapse level near 2
    'collapse: {mean: "5 ± 1"}': ("FAIL", "FAIL"),
    'collapse: {quantile: {q: 0.5, level: "2 ± 0.5"}}': ("FAIL", "PASS"),  # standing: the median "stands"
    'collapse: {quantile: {q: 0.25, level: "1 ± 1"}}': ("FAIL", "PASS"),
    "collapse: {mean: 2}": ("FAIL", "PASS"),  # a level alone: ± 0, which an exact sweep decides
    'collapse: {quantile: {q: 0.5, level: "2"}}': ("FAIL", "PASS"),
    'p_stands: ">= 0.9"': ("PASS", "FAIL"),
    'p_stands: "< 0.5"': ("FAIL", "PASS"),
    'p_stands: "0.95 ± 0.05"': ("PASS", "FAIL"),
    f'cells: [{{where: "{FALLS}", p_stands: "0.1 ± 0.1"}}]': (None, "PASS"),
    f'cells: [{{where: "{FALLS}", collapse: {{mean: "2 ± 0.5"}}}}]': (None, "PASS"),
    f'cells: [{{where: "{FALLS}", collapse: {{mean: "3 ± 0.5"}}}}]': (None, "FAIL"),
    f'cells: [{{where: "{FALLS}", collapse: {{quantile: {{q: 0.5, level: "2 ± 0.5"}}}}}}]': (None, "PASS"),
    f'cells: [{{where: "{FALLS}", p_stands: "<= 0.1"}}]': (None, "PASS"),
    f'cells: [{{where: "not ({FALLS})", p_stands: "<= 0.1"}}]': ("FAIL", None),
}


@pytest.fixture(scope="module")
def exact_samples():
    t = parse_scenario(EXACT.format(expect="p_stands: '>= 0.9'"), "e.yaml").template
    assert not t.random
    results = collect(run_sweep(t, jobs=1))
    assert [r.collapse_level for r in results] == [None, 2]  # as the centre-of-mass rule says
    return results


def test_every_statistical_form_is_tested_on_an_exact_sweep_in_cells_and_over_the_sweep():
    from typing import get_args

    from stackdsl.batch.sweep_out import expectations
    from stackdsl.verdicts.stats import Expectation

    whole, cells = set(), set()
    for text in EXACT_FORMS:
        expect = parse_scenario(EXACT.format(expect=text), "e.yaml").expect
        whole |= {type(f) for f in expectations(expect)}
        for rule in expect.cells or []:
            cells |= {type(f) for f in expectations(rule)}  # a cell rule has collapse and p_stands as Expect
    assert whole == cells == set(get_args(Expectation))


@pytest.mark.parametrize("text", list(EXACT_FORMS))
def test_an_exact_sweep_decides_every_statistical_expectation(exact_samples, text):
    t = parse_scenario(EXACT.format(expect=text), "e.yaml").template
    judged = verdicts(t, t.scenario(0, 0).expect, exact_samples)
    outcomes = tuple(next((v.outcome for c, v in judged if c == cell), None) for cell in range(2))
    assert outcomes == EXACT_FORMS[text]
    for _, v in judged:
        assert v.measured.endswith("(nothing is drawn)")
        assert v.interval is None or v.interval[0] == v.interval[1]  # no sampling interval on one run


@pytest.mark.slow
def test_an_exact_sweep_with_a_mean_gives_a_verdict_on_the_command_line(tmp_path: Path, capsys):
    """A grid of one sample a cell expecting a mean collapse level: sweep and check both judge it
    (this once failed with an internal error, exit 3, and check reported no file at all)."""
    text = EXACT.format(expect=f'cells: [{{where: "{FALLS}", collapse: {{mean: "2 ± 0.5"}}}}]')
    (tmp_path / "s.yaml").write_text(text)
    # a mean the cell's 2 levels can reach (4 ± 0.5 there is refused: no sample can pass it), not measured
    (tmp_path / "f.yaml").write_text(text.replace('"2 ± 0.5"', '"1 ± 0.5"'))
    assert main(["sweep", str(tmp_path / "s.yaml"), "-j", "1", "--out", str(tmp_path / "o")]) == 0
    assert "PASS         expected mean 2±0.5, measured mean 2.00 exact" in capsys.readouterr().out
    junit = tmp_path / "j.xml"
    assert main(["check", str(tmp_path / "s.yaml"), str(tmp_path / "f.yaml"), "-j", "1", "--junit-xml", str(junit)]) == 1
    out = capsys.readouterr().out
    assert "PASS  " in out and "FAIL  " in out and "expected mean 1±0.5, measured mean 2.00 exact" in out
    assert junit.read_text().count("<testcase") == 2


RANDOM = "stackdsl: 1\nstructure: {tower: {levels: 9}}\ntiming: {placement_error: 1 mm}\nsweep: {samples: 20}\n"


@pytest.mark.parametrize(
    "written, target, tolerance",
    [("7", 7, 0), ("'7'", 7, 0), ("'7 ± 0'", 7, 0), ("{target: 7}", 7, 0), ("'7.1 ± 0.5'", 7.1, 0.5), ("'9±1'", 9, 1)],
)
def test_a_sweeps_mean_and_quantile_take_a_level_alone_as_within_0(written, target, tolerance):
    for form, key in ((f"{{mean: {written}}}", "mean"), (f"{{quantile: {{q: 0.5, level: {written}}}}}", "quantile")):
        collapse = parse_scenario(RANDOM + f"expect: {{collapse: {form}}}\n", "s.yaml").expect.collapse
        within = collapse.mean if key == "mean" else collapse.quantile.level  # type: ignore[union-attr]
        assert (within.target, within.tolerance) == (target, tolerance)


@pytest.mark.parametrize("written", ["9", "'9±1'", "'9 +- 2'"])
def test_the_same_text_means_the_same_levels_in_a_run_and_in_a_sweep(written):
    run = parse_scenario(f"stackdsl: 1\nstructure: {{tower: {{levels: 9}}}}\nexpect: {{collapse: {written}}}\n").expect.collapse
    mean = parse_scenario(RANDOM + f"expect: {{collapse: {{mean: {written}}}}}\n").expect.collapse.mean  # type: ignore[union-attr]
    assert (run.level - run.tolerance, run.level + run.tolerance) == mean.levels()  # type: ignore[union-attr]


@pytest.mark.parametrize(
    "text, where, message",
    [
        (
            RANDOM + "expect: {collapse: {mean: '7.1 ± 0'}}\n",
            "expect.collapse.mean",
            "a mean within ± 0 passes only when every sample that collapses does so at that level",
        ),
        (
            RANDOM + "expect: {collapse: {quantile: {q: 0.25, level: 6.5}}}\n",
            "expect.collapse.quantile.level",
            "a quantile of collapse levels is one sample's level, a whole number from 1, and '6.5 ± 0' holds none",
        ),
        (
            EXACT.format(expect="collapse: {mean: '1.4 ± 0.2'}"),
            "expect.collapse.mean",
            "this sweep draws nothing, so each cell's samples are one run",
        ),
        (
            EXACT.format(expect=f'cells: [{{where: "{FALLS}", collapse: {{mean: "1.5 ± 0.4"}}}}]'),
            "expect.cells[0].collapse.mean",
            "'1.5 ± 0.4' holds none, so it could never pass",
        ),
    ],
)
def test_a_statistic_that_could_never_pass_is_refused_at_it(text, where, message):
    with pytest.raises(ScenarioError) as info:
        parse_scenario(text, "s.yaml")
    assert info.value.field == where and message in info.value.message and info.value.line


def test_a_fractional_mean_is_taken_where_samples_are_drawn():
    """'1.4 ± 0.2' holds no whole level: refused when nothing is drawn (above), taken when the
    placement error makes the samples differ, since a mean of several levels can lie there."""
    text = EXACT.format(expect="collapse: {mean: '1.4 ± 0.2'}").replace("sweep:", "timing: {placement_error: 1 mm}\nsweep:")
    assert parse_scenario(text, "s.yaml").template.random


@pytest.mark.slow
def test_a_sweep_that_draws_nothing_runs_one_sample_a_cell_however_many_are_asked(tmp_path: Path, capsys):
    """Every sample of a cell is the same run: 100000 of them ran for 15 minutes to one result."""
    (tmp_path / "s.yaml").write_text(EXACT.format(expect="p_stands: '>= 0.9'"))
    assert main(["sweep", str(tmp_path / "s.yaml"), "-j", "1", "--samples", "50", "--out", str(tmp_path / "o")]) == 1
    out = capsys.readouterr().out
    assert "2 cells x 50 samples (nothing is drawn: one run a cell stands for its 50)" in out
    assert "2 samples in" in out
    with open(tmp_path / "o" / "samples.csv", newline="") as f:
        assert [(r["cell"], r["sample"]) for r in csv.DictReader(f)] == [("0", "0"), ("1", "0")]


def test_an_empty_p_stands_is_told_the_forms_of_p_stands():
    """'p_stands:' left empty was told to give one "as 'stands: true' or 'toppled: all'": a run's."""
    with pytest.raises(ScenarioError) as err:
        parse_scenario(EXACT.format(expect="p_stands:"), "e.yaml")
    assert err.value.field == "expect.p_stands" and "'>= 0.9'" in err.value.message and "stands: true" not in err.value.message
