"""A sweep's samples for data work: samples.parquet beside the CSV (numbers in SI, units in the
column metadata and names), the expectation's interval and threshold on the plots, and the
report's sweep row linking its samples and plots."""

from __future__ import annotations

import csv
import json
import sys
from pathlib import Path

import numpy as np
import pyarrow as pa
import pyarrow.parquet as pq
import pytest
from PIL import Image

from stackdsl.batch import sweep_out
from stackdsl.batch.sweep import SampleResult
from stackdsl.batch.sweep_out import write_samples
from stackdsl.cli.main import main
from stackdsl.draw.sweepplot import EXPECTED, _cell_spans, plot_grid, plot_histogram
from stackdsl.verdicts.stats import MeanWithin, ProportionBound

GRID = """stackdsl: 1
name: walk
structure:
  tower:
    levels: 5
    bricks_per_layer: 1
    turn: 0
    shift: {{uniform: [-40 mm, 40 mm], per: layer}}
    yaw: {{uniform: [-2 deg, 2 deg]}}
timing: {{settle: 0.2 s}}
sweep:
  samples: {samples}
  grid: {{timing.placement_error: [0, 2 mm]}}
expect:
  p_stands: '>= 0.5'
"""


RESULTS = [SampleResult(0, k, 7 + k, {"timing.placement_error [m]": 0.001 * k}, None if k else 3, 5, 0.5, 4.0) for k in range(2)]


def test_the_samples_are_written_as_parquet_too_with_pyarrow(tmp_path):
    table, lines, parquet = write_samples(RESULTS, tmp_path)
    assert parquet == tmp_path / "samples.parquet"
    read = pq.read_table(parquet)
    assert read.column("collapse_level").to_pylist() == [3, None] and read.num_rows == 2
    assert table.is_file() and lines.is_file()


def test_without_pyarrow_the_samples_are_csv_and_json_lines_and_the_sweep_says_how_to_get_parquet(tmp_path, monkeypatch, capsys):
    monkeypatch.setitem(sys.modules, "pyarrow", None)  # as if the parquet extra were not installed
    monkeypatch.setitem(sys.modules, "pyarrow.parquet", None)
    _, lines, parquet = write_samples(RESULTS, tmp_path / "direct")
    assert parquet is None and sorted(p.name for p in (tmp_path / "direct").iterdir()) == ["samples.csv", "samples.jsonl"]
    assert [json.loads(line)["collapse_level"] for line in lines.read_text().splitlines()] == [3, None]
    monkeypatch.setattr(sweep_out, "write_plots", lambda *args: [])  # matplotlib's import is not under test here
    (tmp_path / "tower.yaml").write_text(
        "stackdsl: 1\nstructure: {tower: {levels: 1, bricks_per_layer: 1, shift: {uniform: [-1 mm, 1 mm], per: layer}}}\n"
        "timing: {settle: 0.1 s}\nsweep: {samples: 2}\n"
    )
    assert main(["sweep", str(tmp_path / "tower.yaml"), "-j", "1", "--out", str(tmp_path / "out")]) == 0
    captured = capsys.readouterr()
    said = [line for line in captured.err.splitlines() if "parquet" in line]
    assert said == [
        "stackdsl: samples.parquet needs pyarrow (Parquet files), which is not installed: pip install 'stackdsl[parquet]' (in a source checkout: pip install -c constraints.txt '.[parquet]'); "
        "the samples are in samples.csv and samples.jsonl"
    ]
    assert not (tmp_path / "out" / "samples.parquet").exists() and (tmp_path / "out" / "samples.jsonl").is_file()
    assert "samples.parquet" not in captured.out.splitlines()[-1]


@pytest.fixture(scope="module")
def swept(tmp_path_factory) -> Path:
    folder = tmp_path_factory.mktemp("sweep")
    (folder / "walk.yaml").write_text(GRID.format(samples=6))
    assert main(["sweep", str(folder / "walk.yaml"), "-j", "1", "--out", str(folder / "out")]) in (0, 1)  # 1: not decided PASS
    return folder / "out"


@pytest.mark.slow
def test_samples_parquet_holds_typed_si_numbers_with_their_units(swept):
    table = pq.read_table(swept / "samples.parquet")
    schema = table.schema
    assert table.num_rows == 12
    assert str(schema.field("collapse_level").type) == "int64" and str(schema.field("seed").type) == "uint64"
    assert all(str(schema.field(count).type) == "int64" for count in ("cell", "sample", "levels_placed", "draws"))
    error = schema.field("timing.placement_error [m]")
    assert str(error.type) == "double" and error.metadata == {b"unit": b"m"}
    shift = schema.field("structure.tower.shift [m]")
    assert pa.types.is_list(shift.type) and pa.types.is_float64(shift.type.value_type) and shift.metadata == {b"unit": b"m"}
    assert schema.field("structure.tower.yaw [deg]").metadata == {b"unit": b"deg"}
    assert schema.field("wall_time").metadata == {b"unit": b"s"}
    units = json.loads(schema.metadata[b"stackdsl.units"])
    assert units["timing.placement_error [m]"] == "m" and units["simulated_time"] == "s"
    data = table.to_pylist()
    assert sorted({r["timing.placement_error [m]"] for r in data}) == [0.0, 0.002]  # "2 mm" as metres
    shifts = np.concatenate([r["structure.tower.shift [m]"] for r in data])
    assert len(shifts) == 12 * 4 and np.abs(shifts).max() <= 0.04 and np.abs(shifts).max() > 0.004  # metres, not mm
    assert all(-2 <= r["structure.tower.yaw [deg]"] <= 2 for r in data)
    rows = list(csv.DictReader(open(swept / "samples.csv")))  # the same samples, the same numbers
    assert [float(r["timing.placement_error [m]"]) for r in rows] == [r["timing.placement_error [m]"] for r in data]
    assert [r["collapse_level"] or None for r in rows] == [
        None if r["collapse_level"] is None else str(r["collapse_level"]) for r in data
    ]


@pytest.mark.slow
def test_pandas_and_duckdb_read_the_samples(swept):
    pandas = pytest.importorskip("pandas")
    frame = pandas.read_parquet(swept / "samples.parquet")
    assert len(frame) == 12 and frame["timing.placement_error [m]"].dtype == "float64"
    duckdb = pytest.importorskip("duckdb")
    cells = duckdb.sql(
        f"""select "timing.placement_error [m]" as e, count(*) as n, avg((collapse_level is null)::int) as p
        from '{swept / "samples.parquet"}' group by e order by e"""
    ).fetchall()
    assert [(e, n) for e, n, _ in cells] == [(0.0, 6), (0.002, 6)]
    stood = frame.groupby("timing.placement_error [m]")["collapse_level"].apply(lambda s: s.isna().mean())
    assert [p for *_, p in cells] == pytest.approx(stood.tolist())


def expected_pixels(path: Path) -> int:
    rgb = np.asarray(Image.open(path).convert("RGB")).astype(int)
    target = np.array([int(EXPECTED[i : i + 2], 16) for i in (1, 3, 5)])
    return int((np.abs(rgb - target).max(axis=2) <= 12).sum())


@pytest.mark.slow
def test_sweep_plots_draw_the_threshold_and_the_expectations_interval(tmp_path):
    levels = [3, 4, 4, 5, 6, None, 7, 5]
    plot_histogram(levels, tmp_path / "plain.png")
    plot_histogram(levels, tmp_path / "mean.png", expected=[MeanWithin(5.0, 1.0), ProportionBound(">=", 0.5)])
    assert expected_pixels(tmp_path / "plain.png") == 0 and expected_pixels(tmp_path / "mean.png") > 200
    cells = [[None] * 8, [None] * 6 + [3, 4], [3, 4, 5, 6]]
    plot_grid("e", [0, 2, 4], cells, tmp_path / "p0.png", unit="mm")
    plot_grid("e", [0, 2, 4], cells, tmp_path / "p.png", unit="mm", expected=[ProportionBound(">=", 0.9)])
    plot_grid("e", [0, 2, 4], cells, tmp_path / "m.png", unit="mm", statistic="mean", expected=[MeanWithin(4.0, 0.5)])
    assert expected_pixels(tmp_path / "p0.png") == 0
    assert expected_pixels(tmp_path / "p.png") > 200 and expected_pixels(tmp_path / "m.png") > 200


@pytest.mark.slow
def test_an_expectation_of_some_cells_is_drawn_over_those_cells_only(tmp_path):
    values, cells = [0, 2, 4, 6], [[None] * 8, [None] * 7 + [3], [3, 4, None], [3, 3, 4]]
    high = [[], [], [ProportionBound("<=", 0.5)], [ProportionBound("<=", 0.5)]]  # the two cells right of 2
    low = [[MeanWithin(3.0, 0.5)], [], [MeanWithin(3.0, 0.5)], []]
    # from halfway to the cell before (3 between 2 and 4) to half a gap past the last; apart where apart
    assert _cell_spans([float(v) for v in values], high) == [(ProportionBound("<=", 0.5), 3.0, 7.0)]
    assert _cell_spans([6.0, 4.0, 2.0, 0.0], low) == [(MeanWithin(3.0, 0.5), 1.0, 3.0), (MeanWithin(3.0, 0.5), 5.0, 7.0)]
    plot_grid("e", values, cells, tmp_path / "some.png", cell_expected=high)
    plot_grid("e", values, cells, tmp_path / "mean.png", statistic="mean", cell_expected=low)
    plot_grid("e", values, cells, tmp_path / "mean0.png", statistic="mean", cell_expected=high)  # not a mean's
    assert expected_pixels(tmp_path / "some.png") > 200 and expected_pixels(tmp_path / "mean.png") > 200
    assert expected_pixels(tmp_path / "mean0.png") == 0
    with pytest.raises(ValueError, match="3 cells' expectations for 4 cells"):
        plot_grid("e", values, cells, tmp_path / "bad.png", cell_expected=high[:3])


def test_a_histograms_bound_on_p_stands_is_a_line_on_the_stood_bar_not_text_over_it(tmp_path):
    plot_histogram([3, 4, None, None, None, None], tmp_path / "h.png", expected=[ProportionBound(">=", 0.5)])
    rgb = np.asarray(Image.open(tmp_path / "h.png").convert("RGB")).astype(int)
    target = np.array([int(EXPECTED[i : i + 2], 16) for i in (1, 3, 5)])
    mask = np.abs(rgb - target).max(axis=2) <= 12
    side = mask[:, int(0.85 * mask.shape[1]) :]  # the "stood" panel: the dashed line at 3 of 6 samples
    rows = np.flatnonzero(side.any(axis=1))
    assert len(rows) > 0 and rows.max() - rows.min() <= 3  # one line, no label on the bar
    assert mask[:, : int(0.8 * mask.shape[1])].any()  # named in the legend


@pytest.mark.slow
def test_a_p_stands_within_a_tolerance_is_drawn_as_its_band(tmp_path):
    from stackdsl.verdicts.stats import ProportionWithin

    levels, cells = [3, None, None, 4, None, None], [[None] * 8, [None] * 6 + [3, 4], [3, 4, 5, 6]]
    plot_histogram(levels, tmp_path / "h.png", expected=[ProportionWithin(0.67, 0.1)])
    plot_grid("e", [0, 2, 4], cells, tmp_path / "g.png", expected=[ProportionWithin(0.67, 0.1)])
    plot_grid("e", [0, 2, 4], cells, tmp_path / "m.png", statistic="mean", expected=[ProportionWithin(0.67, 0.1)])
    assert expected_pixels(tmp_path / "h.png") > 100 and expected_pixels(tmp_path / "g.png") > 200
    assert expected_pixels(tmp_path / "m.png") == 0  # not a mean's


def test_the_sweep_command_draws_the_expectation_on_its_plots(swept):
    assert expected_pixels(swept / "grid_p_stands.png") > 200  # the P(stands) >= 0.5 threshold


@pytest.mark.slow
def test_the_reports_sweep_row_links_its_samples_and_plots(tmp_path, capsys):
    (tmp_path / "s").mkdir()
    (tmp_path / "s" / "walk.yaml").write_text(GRID.format(samples=3))
    assert main(["check", str(tmp_path / "s"), "-j", "1", "--report", str(tmp_path / "r")]) in (0, 1)  # 1: not decided PASS
    html = (tmp_path / "r" / "index.html").read_text()
    for name in ("samples.csv", "samples.parquet", "samples.jsonl", "grid_p_stands.png", "grid_mean.png", "histogram_1.png"):
        assert f'href="walk/{name}"' in html, name
        assert (tmp_path / "r" / "walk" / name).is_file(), name


@pytest.mark.slow
def test_a_grid_over_the_towers_height_names_each_cells_own(tmp_path, capsys):
    """A grid over structure.tower.levels: every cell was summed up with the file's own height,
    its mean interval cut at it, and the grid plot crashed (a 95% interval below its estimate);
    each cell names the height its samples built, and the samples say it."""
    text = """stackdsl: 1
structure: {tower: {levels: 4, bricks_per_layer: 1, turn: 0, shift: {uniform: [-1 mm, 1 mm], per: layer}}}
timing: {interval: 0.5 s, settle: 0.2 s}
sweep: {samples: 3, grid: {structure.tower.levels: [2, 6]}}
expect: {p_stands: '>= 0.1'}
"""
    (tmp_path / "h.yaml").write_text(text)
    assert main(["sweep", str(tmp_path / "h.yaml"), "-j", "1", "--out", str(tmp_path / "o")]) in (0, 1)
    out = capsys.readouterr().out
    assert "cell 0: structure.tower.levels = 2: n=3: 0 collapsed, 3 stood (2 levels)" in out
    assert "cell 1: structure.tower.levels = 6: n=3: 0 collapsed, 3 stood (6 levels)" in out
    rows = list(csv.DictReader(open(tmp_path / "o" / "samples.csv")))
    assert sorted({(r["cell"], r["levels"]) for r in rows}) == [("0", "2"), ("1", "6")]
    assert (tmp_path / "o" / "grid_mean.png").is_file()


def test_samples_csv_escapes_a_text_a_spreadsheet_reads_as_a_formula(tmp_path):
    # a grid label '=HYPERLINK(...)' was written as it is: a formula where the CSV is opened
    from stackdsl.batch.sweep import SampleResult
    from stackdsl.batch.sweep_out import write_samples

    texts = ['=HYPERLINK("http://127.0.0.1/x","y")', "+1+2", "-2+3", "@SUM(A1)", "\tx", "\rx", "plain"]
    results = [
        SampleResult(0, k, 0, {"label": text, "timing.drop_gap [m]": -3.2e-4}, None, 2, 0.1, 1.0, bad_input=text)
        for k, text in enumerate(texts)
    ]
    write_samples(results, tmp_path)
    rows = list(csv.DictReader(open(tmp_path / "samples.csv", newline="", encoding="utf-8")))
    for row, text in zip(rows, texts):
        safe = text if text == "plain" else "'" + text
        assert (row["label"], row["bad_input"]) == (safe, safe)
        assert float(row["timing.drop_gap [m]"]) == -3.2e-4 and row["levels_placed"] == "2"


def test_a_pyarrow_that_does_not_import_leaves_the_csv_and_json_lines(tmp_path, monkeypatch):
    """A pyarrow found but broken (its import raises ImportError) was exit 3, an internal error: it
    is the user's install, so the samples are written as without pyarrow."""
    monkeypatch.setitem(sys.modules, "pyarrow.parquet", None)  # pyarrow is found, its parquet module fails to import
    _, lines, parquet = write_samples(RESULTS, tmp_path / "broken")
    assert parquet is None and sorted(p.name for p in (tmp_path / "broken").iterdir()) == ["samples.csv", "samples.jsonl"]
    assert lines.read_text()
