"""stackdsl search: thresholds against closed forms, counterexamples that reproduce, and the
search: block's errors (searches/, docs/searches.md)."""

import dataclasses
import json
from pathlib import Path

import pytest

from stackdsl import ScenarioError, parse_scenario
from stackdsl.cli.main import main

ROOT = Path(__file__).resolve().parents[1]


def search(tmp_path: Path, file: str, *more: str) -> tuple[int, dict]:
    out = tmp_path / "out"
    status = main(["search", str(ROOT / file), "-j", "1", "--out", str(out), *more])
    summary = json.loads((out / "search.json").read_text()) if (out / "search.json").is_file() else {}
    return status, summary


def _short_stack(tmp_path: Path) -> Path:
    """The shipped single-file search cut to 3 bricks (cheap): its critical shift 120 mm / 3 = 40 mm."""
    path = tmp_path / "short.yaml"
    text = (ROOT / "searches" / "single_file_shift.yaml").read_text().replace("levels: 5", "levels: 3")
    path.write_text(text.replace("between: [20 mm, 30 mm]", "between: [36 mm, 44 mm]"))
    return path


def test_a_short_single_file_stacks_critical_shift_is_bracketed_in_few_runs(tmp_path):
    # the shipped search's stack, 3 bricks (cheap): s* = 120 mm / 3 = 40 mm
    path = _short_stack(tmp_path)
    out = tmp_path / "out"
    assert main(["search", str(path), "-j", "1", "--out", str(out)]) == 0
    found = json.loads((out / "search.json").read_text())
    low, high = found["interval"]
    assert low <= 40.0 <= high and abs(low - 40.0) <= 0.2 and abs(high - 40.0) <= 0.2
    runs_low, runs_high = found["runs_interval"]
    assert runs_high - runs_low <= 0.1  # the tolerance; the ends carry the 0.1 mm tie band, 0.067 mm of shift here
    assert found["below"] == "stands" and found["above"].startswith("collapses")
    assert found["runs"] * 10 <= found["grid_runs"]  # at least 10x fewer than a grid at 0.1 mm
    assert (out / "samples.csv").read_text().count("\n") == found["runs"] + 1


def test_runs_spent_before_the_tolerance_are_not_set_against_a_grid(tmp_path, capsys):
    # --runs 3 printed "between 30 and 40.1 mm" and "a grid of the same resolution takes 201 (67.0x
    # as many)", as if it were an answer
    path = _short_stack(tmp_path)
    assert main(["search", str(path), "-j", "1", "--out", str(tmp_path / "o"), "--runs", "3"]) in (0, 1)
    out = capsys.readouterr().out
    assert "3 runs (brent), spent before the runs' interval was 0.1 mm wide" in out and "as many" not in out, out


def test_a_search_is_a_row_of_the_html_report_as_a_sweep_is(tmp_path):
    # the 3-brick stack of the shipped search: its row holds the verdict, the interval, the picture and the runs' files
    path = _short_stack(tmp_path)
    report = tmp_path / "report"
    assert main(["search", str(path), "-j", "1", "--report", str(report)]) == 0
    found = json.loads((report / "short" / "search.json").read_text())
    page = (report / "index.html").read_text()
    row = page[page.index('<section class="scenario"') : page.index("</section>")]
    assert '<span class="verdict pass">PASS</span>' in row and "short.yaml" in row
    assert f"between {found['interval'][0]:.6g} and {found['interval'][1]:.6g} mm" in row
    assert 'src="short/margin.png"' in row and 'href="short/samples.csv"' in row and 'href="short/samples.parquet"' in row
    assert 'href="short/search.json"' in row and "<code>stackdsl search " in row
    assert (report / "short" / "samples.csv").read_text().count("\n") == found["runs"] + 1


@pytest.mark.slow
def test_the_single_file_stacks_critical_shift_is_bracketed_in_few_runs(tmp_path):
    status, found = search(tmp_path, "searches/single_file_shift.yaml")
    assert status == 0
    low, high = found["interval"]
    assert low <= 24.0 <= high and abs(low - 24.0) <= 0.2 and abs(high - 24.0) <= 0.2  # the closed form: 120 mm / 5
    assert found["runs_interval"][1] - found["runs_interval"][0] <= 0.1  # the tolerance asked for
    assert found["below"] == "stands" and found["above"].startswith("collapses")
    assert found["runs"] * 10 <= found["grid_runs"]  # at least 10x fewer than a grid at 0.1 mm
    assert (tmp_path / "out" / "margin.png").stat().st_size > 10_000
    assert (tmp_path / "out" / "samples.csv").read_text().count("\n") == found["runs"] + 1


@pytest.mark.slow
def test_the_critical_shift_on_mujoco(tmp_path):
    pytest.importorskip("mujoco")
    status, found = search(tmp_path, "searches/single_file_shift.yaml", "--backend", "mujoco")
    low, high = found["interval"]
    assert status == 0 and low <= 24.0 <= high and abs(low - 24.0) <= 0.2 and abs(high - 24.0) <= 0.2
    assert found["runs"] * 10 <= found["grid_runs"]


@pytest.mark.slow
def test_a_rare_counterexample_is_found_shrunk_and_reproduces(tmp_path):
    pytest.importorskip("optuna")
    status, found = search(tmp_path, "searches/rare_overhang.yaml", "--seed", "3")
    assert status == 1  # a counterexample breaks the file's expectation
    assert found["found"] == 1 and found["first"] <= 100
    (file,) = found["files"]
    assert main(["run", file]) == 1  # the plain scenario file fails as the search's run did


@pytest.mark.parametrize(
    ("block", "said"),
    [
        ("search: {threshold: {field: structure.tower.shift, between: [30 mm, 20 mm]}}", "5:"),
        ("search: {threshold: {field: structure.tower.shift, between: [20 mm, 30 s]}}", "5:"),
        ("search: {threshold: {field: structure.tower.shift, between: [20 mm, 30 mm], tolerance: 20 mm}}", "5:"),
        ("search: {}", "5:"),
        ("search:", "5:"),
        ("search: {counterexample: {runs: 0}}", "5:"),
        ("search: {threshold: {field: structure.tower.sift, between: [20 mm, 30 mm]}}", "5:"),
    ],
)
def test_a_bad_search_block_is_refused_at_its_line(tmp_path, capsys, block, said):
    path = tmp_path / "bad.yaml"
    path.write_text(
        "stackdsl: 1\nstructure: {tower: {levels: 3, bricks_per_layer: 1, turn: 0, shift: 1 mm}}\n"
        f"timing: {{interval: 0.5 s}}\n\n{block}\n"
    )
    assert main(["search", str(path), "-j", "1", "--out", str(tmp_path / "out")]) == 2
    err = capsys.readouterr().err
    assert f"bad.yaml:{said}" in err and "Traceback" not in err
    assert not (tmp_path / "out" / "samples.csv").exists()


@pytest.mark.slow
def test_the_last_jenga_blocks_critical_offset(tmp_path):
    status, found = search(tmp_path, "searches/jenga_last_block.yaml")
    low, high = found["interval"]
    assert status == 0 and low <= 12.5 <= high and abs(low - 12.5) <= 0.2 and abs(high - 12.5) <= 0.2  # 25 mm / 2
    assert found["runs_interval"][1] - found["runs_interval"][0] <= 0.1
    assert found["runs"] * 10 <= found["grid_runs"]


def test_one_number_of_a_list_is_a_field():
    from stackdsl.batch.search import in_list

    data = {"structure": {"bricks": [{"at": [0, 0, "4 mm"]}], "tower": {"shift": "1 mm"}}}
    key, put = in_list(data, "structure.bricks[0].at.2")
    assert key == "structure.bricks.0.at" and put("5 mm") == [0, 0, "5 mm"]
    assert in_list(data, "structure.tower.shift") is None and in_list(data, "structure.bricks.0.at.3") is None


@pytest.mark.slow
def test_the_dominoes_reach_is_bracketed_on_the_expectations_verdict(tmp_path):
    status, found = search(tmp_path, "searches/dominoes_reach.yaml")
    low, high = found["interval"]
    assert status == 0 and found["below"] == "expectations held" and found["above"] == "expectations failed"
    # past h + t = 128 mm, where the top of a domino whose foot held would stop reaching the next: the
    # foot slides forward first (docs/results/domino_reach.py), by less than its 6 mm measured alone
    assert 128.0 < low < high < 128.0 + 6.0 and high - low <= 0.2
    assert found["runs"] * 10 <= found["grid_runs"]


class ClosedForm:
    """An evaluator that judges searches/rare_overhang.yaml's draws by its closed form instead of
    running them: the margin is 60 mm - n s / 2 (at most 12 mm, the brick's half-width across)."""

    jobs = 1

    def __init__(self):
        self.runs = 0

    def run(self, tasks):
        from stackdsl.batch.sweep import SampleResult

        out = []
        for template, k in tasks:
            p = template.parameters(0, k)
            n, s = p["structure.tower.levels"], p["structure.tower.shift [m]"]
            margin = min(0.012, 0.060 - n * s / 2)
            out.append(SampleResult(0, self.runs, 0, p, None if margin > 0 else n, n, 0.0, 0.0, margin=margin))
            self.runs += 1
        return out


def test_the_search_finds_and_shrinks_a_rare_counterexample_on_the_closed_form():
    pytest.importorskip("optuna")
    from stackdsl import load_scenario
    from stackdsl.batch.search import find_counterexamples
    from stackdsl.lang.schema_search import Counterexample

    template = load_scenario(ROOT / "searches" / "rare_overhang.yaml").template
    firsts = []
    for seed in range(5):
        found = find_counterexamples(template, Counterexample(runs=200, shrink=12), False, ClosedForm(), seed)
        (f,) = found.found
        shrunk = {d.label: v for d, v in f.shrunk.items()}
        assert shrunk["structure.tower.levels"] == 5  # 4 levels never fail: not shrunk to the first choice
        s = float(shrunk["structure.tower.shift"].split()[0])
        assert 24.0 < s <= 24.04 and f.shrunk_result.collapse_level == 5
        firsts.append(found.first)
    assert sorted(firsts)[2] <= 1202 / 20  # the median beats plain sampling's 1 in 1202 by 20x


def test_timeout_bounds_the_whole_search(tmp_path, capsys):
    # refused up front: at least 2 + log2(10 mm / 0.001 mm) = 16 runs cannot fit in a millisecond
    path = tmp_path / "fine.yaml"
    path.write_text(
        (ROOT / "searches" / "single_file_shift.yaml").read_text().replace("tolerance: 0.1 mm", "tolerance: 0.001 mm")
    )
    assert main(["search", str(path), "-j", "1", "--out", str(tmp_path / "no"), "--timeout", "0.001"]) == 2
    err = capsys.readouterr().err
    assert "fine.yaml:" in err and "--timeout 0.001" in err and "whole search" in err
    assert not (tmp_path / "no" / "samples.csv").exists()


def test_a_search_stops_where_its_shared_budget_ran_out():
    from stackdsl import load_scenario
    from stackdsl.batch.search import Evaluator
    from stackdsl.batch.sweep import BUDGET_SPENT, Budget, SweepOptions

    template = load_scenario(ROOT / "searches" / "rare_overhang.yaml").template
    budget = Budget(0.0)
    with Evaluator(SweepOptions(None, None, False, 100.0, None, budget)) as evaluator:
        results = evaluator.run([(template, 0), (template, 0)])
    assert [r.stopped for r in results] == [BUDGET_SPENT, BUDGET_SPENT]  # not run: nothing is left


def test_the_picture_follows_what_the_search_bracketed_on():
    # an onset search follows still's share of its bound, not the verdict's margin in mm
    from stackdsl.batch.search import followed
    from stackdsl.batch.sweep import SampleResult

    def run(margin, held=None, still=None):
        return SampleResult(0, 0, 0, {}, None, 1, 0.0, 0.0, margin=margin, held=held, still_margin=still)

    name, unit, values = followed([run(0.012, True, 0.4), run(0.012, False, -2.0)])
    assert (unit, values) == ("", [0.4, -2.0]) and "still" in name
    name, unit, values = followed([run(0.012, True), run(-0.03, False)])
    assert (unit, values) == ("", [1.0, -1.0]) and "held" in name
    name, unit, values = followed([run(0.0002), run(-0.0046), run(None)])
    assert (name, unit) == ("signed margin", "mm") and values[:2] == pytest.approx([0.2, -4.6]) and values[2] is None


def test_an_exact_tie_the_engine_decided_does_not_end_the_interval_short_of_the_truth():
    # MuJoCo's single-file stack (60 mm - 5 s / 2): the run at 23.9991 mm, its centre of mass 0.002 mm
    # inside the edge, collapsed; the runs' interval 23.929 to 23.9991 mm stopped 0.001 mm short of 24 mm
    from stackdsl.batch.search import ThresholdFound, _bracket, tie_band, tie_widening
    from stackdsl.batch.sweep import SampleResult

    def run(shift, stood, margin):
        return shift, SampleResult(0, 0, 0, {}, None if stood else 5, 5, 0.0, 0.0, margin=margin)

    found = ThresholdFound("structure.tower.shift", "mm")
    found.probes = [run(20.0, True, 0.010), run(30.0, False, -0.0006), run(23.929, True, 0.0001775), run(23.9991, False, -0.0007)]
    _bracket(found)
    assert (found.low, found.high) == (23.929, 23.9991)
    tie = tie_band("extension", 0.001)
    assert tie == pytest.approx(1e-4) and tie_band("raw", 0.001) == pytest.approx(1e-3)
    found.widened = tie_widening(found, tie)
    low, high = found.interval
    assert low <= 24.0 <= high and high - 24.0 <= 0.2 and 24.0 - low <= 0.2  # the band: 0.1 mm / 2.5 = 0.04 mm each side
    # a stand proved with more margin than the band (0.18 mm) stays; a collapse placed inside may be a tie
    assert found.widened[0] == 0.0 and found.widened[1] == pytest.approx(0.04, rel=0.01)
    found.probes[2] = run(23.97, True, 0.000075)  # a stand within the band is moved too
    _bracket(found)
    assert tie_widening(found, tie) == pytest.approx((0.04, 0.04), rel=0.01)
    # nothing is moved on a judged verdict (not statics')
    found.probes = [(v, dataclasses.replace(r, held=r.collapse_level is None)) for v, r in found.probes]
    assert tie_widening(found, tie) == (0.0, 0.0)


@pytest.mark.parametrize(
    "search, at",
    [
        ("{threshold: {field: structure.tower.shift, between: [{uniform: [1 mm, 2 mm]}, 30 mm]}}", "search.threshold.between[0]"),
        (
            "{threshold: {field: structure.tower.shift, between: [1 mm, 30 mm], tolerance: {choice: [1 mm, 2 mm]}}}",
            "search.threshold.tolerance",
        ),
        ("{counterexample: {runs: {choice: [3, 4]}}}", "search.counterexample.runs"),
    ],
)
def test_a_distribution_in_search_is_refused_not_drawn(search, at):
    # it was drawn: the search ran in [1.94 mm, 30 mm], and with another seed in [1.54 mm, 30 mm]
    text = f"stackdsl: 1\nstructure: {{tower: {{levels: 3, bricks_per_layer: 1, turn: 0, shift: 10 mm}}}}\nsearch: {search}\nexpect: {{stands: true}}\n"
    with pytest.raises(ScenarioError) as err:
        parse_scenario(text, "s.yaml")
    assert err.value.field == at and "a distribution cannot stand in 'search'" in err.value.message


def test_a_counterexample_search_whose_every_run_is_refused_exits_2_not_0(tmp_path, capsys):
    # the search proposes the shifts itself, and each proposal failed require:; it said "no
    # counterexample in 4 runs" and exited 0
    path = tmp_path / "x.yaml"
    path.write_text(
        "stackdsl: 1\nstructure: {tower: {levels: 4, bricks_per_layer: 1, turn: 0, shift: {uniform: [0, 30 mm]}}}\n"
        "timing: {interval: 0.3 s, settle: 0.5 s}\nrequire: ['structure.tower.shift.0 < 0.5 mm']\nsweep: {samples: 4}\n"
        "search:\n  counterexample: {runs: 4}\nexpect: {p_stands: '>= 0.9'}\n"
    )
    assert main(["search", str(path), "-j", "1", "--out", str(tmp_path / "o")]) == 2
    captured = capsys.readouterr()
    assert "no counterexample" not in captured.out and f"{path}:4:10: require: none of the search's 4 proposals" in captured.err
    assert not (tmp_path / "o" / "search.json").exists()
    # where the condition can hold, the proposals that fail it are not run, and said so
    path.write_text(path.read_text().replace("< 0.5 mm", "< 15 mm").replace("runs: 4", "runs: 6"))
    assert main(["search", str(path), "-j", "1", "--out", str(tmp_path / "p")]) == 0
    summary = json.loads((tmp_path / "p" / "search.json").read_text())
    assert summary["search_runs"] == 6 and 0 < summary["outside_require"] < 6
    assert "bad input" not in capsys.readouterr().err


@pytest.mark.parametrize(
    ("threshold", "begins", "says"),
    [
        # an end the compiler refuses: it was said at 1:1, at a sweep.grid key the file does not
        # have, after the search had begun
        (
            "{field: structure.tower.spacing, between: [10 mm, 96 mm]}",
            "4:57: search.threshold.between[0]",
            "the value '10 mm': brick L01.2",
        ),
        # a field of whole numbers: a new user's levels between 3 and 10 ran both ends, then 8.79
        # levels stopped the search with a sweep's words ("sample 0 of grid cell 0 ...")
        (
            "{field: structure.tower.levels, between: [3, 10], tolerance: 1}",
            "4:22: search.threshold.field",
            "structure.tower.levels does not take 6.5, between the ends, as the search proposes: expected a whole number",
        ),
        # ends of another kind than the field's: said as the search's end, not a sweep's sample
        (
            "{field: structure.tower.spacing, between: [1 s, 2 s]}",
            "4:22: search.threshold.field",
            "the search's lower end (structure.tower.spacing = 1 s): expected a length",
        ),
        # ends of two kinds: a search's words, not a distribution's
        (
            "{field: structure.tower.spacing, between: [60 mm, 90 s]}",
            "4:14: search.threshold",
            "between: '90 s' cannot be written in 'mm': give both ends of between and the tolerance in units of one kind",
        ),
    ],
)
def test_a_search_refused_before_it_runs_is_said_where_the_file_is_wrong(threshold, begins, says, tmp_path, capsys, monkeypatch):
    import stackdsl.batch.search as search

    monkeypatch.setattr(search, "find_threshold", lambda *a, **k: pytest.fail("the search ran"))
    path = tmp_path / "q.yaml"
    path.write_text(
        f"stackdsl: 1\nstructure: {{tower: {{levels: 3}}}}\nsearch:\n  threshold: {threshold}\nexpect: {{stands: true}}\n"
    )
    assert main(["search", str(path), "-j", "1", "--out", str(tmp_path / "o")]) == 2
    first = capsys.readouterr().err.splitlines()[0]
    assert first.startswith(f"{path}:{begins}: {says}") and "grid cell" not in first, first


def test_the_ends_are_compiled_for_the_backend_given(tmp_path, capsys):
    # a 2 mm pusher, below what pybullet simulates faithfully: with --backend mujoco the search's
    # ends were compiled for the file's pybullet and refused
    pytest.importorskip("mujoco", reason="the MuJoCo extra is not installed")
    path = tmp_path / "thin.yaml"
    path.write_text(
        "stackdsl: 1\nbrick_types: {finger: {size: [10 mm, 10 mm, 2 mm]}}\nstructure: {tower: {levels: 2}}\n"
        "actions: [{push: {target: {brick: L02.1}, direction: +x, speed: 0.05 m/s, distance: 5 mm, at: after level 2, "
        "pusher: finger}}]\n"
        "search:\n  threshold: {field: 'actions[0].push.distance', between: [10 mm, 40 mm]}\nexpect: {stands: true}\n"
    )
    assert main(["search", str(path), "-j", "1", "--out", str(tmp_path / "o")]) == 2  # pybullet: refused
    assert "a side of 2 mm is below what pybullet simulates faithfully" in capsys.readouterr().err
    assert main(["search", str(path), "-j", "1", "--out", str(tmp_path / "m"), "--backend", "mujoco", "--runs", "3"]) in (0, 1)
    said = capsys.readouterr()
    assert "simulates faithfully" not in said.err and "threshold of actions[0].push.distance" in said.out + said.err


@pytest.mark.parametrize(
    "search, runs, says",
    [
        ("{threshold: {field: structure.tower.shift, between: [1 mm, 30 mm]}}", "1", "must be from 3 to 10000, not 1"),
        ("{threshold: {field: structure.tower.shift, between: [1 mm, 30 mm]}}", "10001", "must be from 3 to 10000, not 10001"),
        ("{counterexample: {runs: 5}}", "100000", "--runs of a search must be from 1 to 10000, not 100000"),
    ],
)
def test_runs_on_the_command_line_has_the_files_bounds(tmp_path, capsys, search, runs, says):
    # --runs 1 made 3 runs of a threshold search, and 100000 was taken where the file allows 10000
    path = tmp_path / "s.yaml"
    shift = "{uniform: [0, 30 mm]}" if "counterexample" in search else "10 mm"
    sweep, expect = ("", "stands: true") if "threshold" in search else ("sweep: {samples: 4}\n", "p_stands: '>= 0.5'")
    path.write_text(
        f"stackdsl: 1\nstructure: {{tower: {{levels: 3, bricks_per_layer: 1, turn: 0, shift: {shift}}}}}\n"
        f"{sweep}search: {search}\nexpect: {{{expect}}}\n"
    )
    assert main(["search", str(path), "--runs", runs, "-j", "1"]) == 2
    assert says in capsys.readouterr().err
