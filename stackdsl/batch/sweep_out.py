"""What a sweep leaves: per-sample files, a summary a cell, verdicts, plots.

* ``samples.csv``, ``samples.jsonl`` and ``samples.parquet``: one row a sample, in (cell,
  sample) order: the cell, the sample index, its seed, what it drew (a column a field, numbers
  in SI, angles in degrees, named with the unit when the file wrote one:
  ``timing.placement_error [m]``), the collapse level (empty: it stood), levels placed, wall
  and simulated seconds, the oracle's level and the rest of
  :class:`stackdsl.batch.sweep.SampleResult`; the Parquet file typed, with each column's
  unit in its metadata (:func:`write_parquet`), when pyarrow (the ``parquet`` extra) is installed;
* for each grid cell, the distribution of collapse levels (:func:`stackdsl.verdicts.stats.summary`)
  and the verdict of each statistical expectation (:func:`stackdsl.verdicts.stats.decide`);
* ``histogram.png`` (one a cell, up to :data:`MAX_HISTOGRAMS`) and, for a grid over one
  numeric field, ``grid.png``: P(stands) and the mean collapse level against it.

Source: stackdsl's own.
"""

from __future__ import annotations

import csv
import itertools
import json
from collections.abc import Iterable, Sequence
from dataclasses import fields, replace
from pathlib import Path
from typing import Any

from ..lang.errors import excerpt
from ..lang.expectations import CellExpect, Expect
from ..lang.expressions import parse
from ..lang.sampling import Template
from ..util.extras import installed, missing
from ..util.files import written
from ..verdicts.stats import MeanWithin, ProportionBound, ProportionWithin, QuantileWithin, StatVerdict, decide, summary
from .sweep import SampleResult

MAX_HISTOGRAMS = 12


def expectations(expect: Expect | CellExpect) -> list[Any]:
    """A scenario's statistical expectations (or those of one of its ``expect.cells``) as
    :mod:`stackdsl.verdicts.stats` forms, in file order."""
    return [form for _, form in _named(expect)]


def _named(expect: Expect | CellExpect, under: str = "") -> list[tuple[str, Any]]:
    """(field under ``expect``, form) of each statistical expectation, in file order; ``under``:
    the path of a cell's expectations (``"cells[0]."``)."""
    out: list[tuple[str, Any]] = []
    collapse = expect.collapse
    mean = getattr(collapse, "mean", None)
    quantile = getattr(collapse, "quantile", None)
    if mean is not None:
        out.append((f"{under}collapse", MeanWithin(mean.target, mean.tolerance)))
    if quantile is not None:
        out.append((f"{under}collapse", QuantileWithin(quantile.q, quantile.level.target, quantile.level.tolerance)))
    p = expect.p_stands
    if p is not None:
        form = ProportionWithin(p.bound, p.tolerance) if p.op == "±" else ProportionBound(p.op, p.bound)
        out.append((f"{under}p_stands", form))
    return out


def by_cell(results: Sequence[SampleResult], cells: int) -> list[list[SampleResult]]:
    """The results of each cell (cells in order)."""
    out: list[list[SampleResult]] = [[] for _ in range(cells)]
    for r in results:
        out[r.cell].append(r)
    return out


def levels_built(results: Sequence[SampleResult]) -> int | None:
    """The levels every sample of ``results`` (one cell's) built its tower to in full, when they
    agree; None without a tower, or when a grid or a distribution gave them different heights
    (a summary then names no height and bounds no interval by one)."""
    heights = {r.levels for r in results if not r.bad_input}
    return heights.pop() if len(heights) == 1 and 0 not in heights else None


def measured(results: Sequence[SampleResult]) -> list[int | None]:
    """The collapse levels of the samples that ran to their end (None: stood)."""
    return [r.collapse_level for r in results if not (r.error or r.bad_input or r.stopped)]


def cell_expectations(template: Template, expect: Expect, c: int) -> list[Any]:
    """The statistical expectations of cell ``c``: the file's own, then those of each of
    ``expect.cells`` whose condition holds on the cell's grid values."""
    return [form for _, form in _cell_named(template, expect, c)]


def _cell_named(template: Template, expect: Expect, c: int) -> list[tuple[str, Any]]:
    """:func:`cell_expectations` with the field of each under ``expect``."""
    forms = _named(expect)
    values = template.values(c)
    for i, cell in enumerate(expect.cells or []):
        if parse(cell.where).holds(values):
            forms += _named(cell, f"cells[{i}].")
    return forms


def verdicts(template: Template, expect: Expect, results: Sequence[SampleResult]) -> list[tuple[int, StatVerdict]]:
    """(cell, verdict) of every statistical expectation in every cell (``expect.cells``' in the
    cells they are for); exact (:func:`stackdsl.verdicts.stats.decide`) when the sweep draws nothing."""
    if not expectations(expect) and not expect.cells:
        return []
    exact = not template.random
    return [
        (c, replace(decide(form, measured(rs), exact=exact), field=field))
        for c, rs in enumerate(by_cell(results, template.cells))
        for field, form in _cell_named(template, expect, c)
    ]


def failure_lines(
    template: Template, expect: Expect, judged: Sequence[tuple[int, StatVerdict]], prefix: str = "", *, shown: bool = True
) -> list[str]:
    """A line for each verdict of ``judged`` that did not pass: at the line of the file that wrote
    its expectation (``file:line:col: expect.FIELD: ``; with ``shown``, that line and a caret under
    the first one of a place, as a parse error is shown), else after ``prefix``; the cell (with a
    grid), what was expected and measured, and for an undecided one how many samples would decide it."""
    lines: list[str] = []
    places: set[str] = set()
    for c, v in judged:
        if v.outcome == "PASS":
            continue
        text = (
            v.outcome
            + (f" in cell {c} ({template.label(c)})" if template.grid else "")
            + f": expected {v.expected}, measured {v.measured}"
            + (f"; about {v.samples_to_decide} samples would decide it" if v.samples_to_decide else "")
        )
        at = expect.at(v.field)
        if at is None:
            lines.append(prefix + text)
            continue
        lines.append(f"{at}: expect.{v.field}: {text}")
        if shown and str(at) not in places:
            places.add(str(at))
            lines += excerpt(at.source_line, at.column)
    return lines


def write_samples(results: Sequence[SampleResult], folder: Path) -> tuple[Path, Path, Path | None]:
    """``samples.csv``, ``samples.jsonl`` and ``samples.parquet`` (:func:`write_parquet`) in
    ``folder`` (made if missing); their paths, the last None when pyarrow (the ``parquet`` extra,
    :data:`PARQUET_MISSING`) is not installed and only the first two are written.

    Raises:
        OSError: they cannot be written.
    """
    folder.mkdir(parents=True, exist_ok=True)
    rows = [r.row() for r in results]
    columns: list[str] = []
    for row in rows:
        columns += [k for k in row if k not in columns]
    table, lines = folder / "samples.csv", folder / "samples.jsonl"
    with written(table) as part, open(part, "w", newline="", encoding="utf-8") as f:
        writer = csv.DictWriter(f, fieldnames=[csv_text(c) for c in columns])
        writer.writeheader()
        for row in rows:
            writer.writerow(
                {
                    csv_text(k): json.dumps(v) if isinstance(v, (list, dict)) else ("" if v is None else csv_text(v))
                    for k, v in row.items()
                }
            )
    with written(lines) as part, open(part, "w", encoding="utf-8") as f:
        for row in rows:
            f.write(json.dumps(row) + "\n")
    if not installed("parquet"):
        return table, lines, None
    parquet = folder / "samples.parquet"
    try:
        write_parquet(rows, columns, parquet)
    except ImportError:  # a pyarrow that is there but does not import: the user's install, not a bug (exit 3 was)
        return table, lines, None
    return table, lines, parquet


#: What a sweep says when it writes no ``samples.parquet`` (:func:`write_samples`).
PARQUET_MISSING = missing("parquet", "samples.parquet") + "; the samples are in samples.csv and samples.jsonl"


#: What a spreadsheet reads as the start of a formula in a cell (OWASP, "CSV Injection").
FORMULA_START = ("=", "+", "-", "@", "\t", "\r")


def csv_text(value: Any) -> Any:
    """``value`` for a CSV cell a spreadsheet opens safely: a text starting with one of
    :data:`FORMULA_START` (a grid label ``=HYPERLINK(...)``) gets a single quote before it, as
    OWASP's "CSV Injection" page advises, so that it shows as text and runs nothing; numbers
    (``-3.2``) and other values are as they are. Source: OWASP, CSV Injection."""
    return "'" + value if isinstance(value, str) and value.startswith(FORMULA_START) else value


#: Units of the columns every sample has (a parameter's is in its name: ``"timing.placement_error [m]"``).
UNITS = {
    "wall_time": "s",
    "simulated_time": "s",
    "collapse_level": "level",
    "levels_placed": "level",
    "oracle_level": "level",
    "margin": "m",
}
#: Integer columns: every count of :class:`SampleResult` (the collapse and oracle levels may be
#: null: the sample stood); the seed is unsigned.
_INTEGERS = tuple(f.name for f in fields(SampleResult) if f.name != "seed" and str(f.type).startswith("int"))


def write_parquet(rows: Sequence[dict[str, Any]], columns: Sequence[str], path: Path) -> None:
    """``rows`` (:meth:`SampleResult.row`) as a Parquet file at ``path`` (pyarrow, the ``parquet`` extra; imported here only): a typed
    column each, in ``columns``' order: integers (the levels null where a sample stood, the seed
    unsigned), floats, lists of floats for a tower's per-layer or per-brick draws, strings for the
    rest; numbers in SI (angles in degrees), each column's unit in its field metadata
    (``b"unit"``: ``"m"``, ``"s"``, ``"level"``), and the file's metadata naming stackdsl's version
    and every column's unit (``b"stackdsl.units"``, JSON). pandas, DuckDB and Polars read it as it is.

    Raises:
        OSError: it cannot be written; ImportError: pyarrow is not installed.
    """
    import pyarrow as pa
    import pyarrow.parquet as pq

    from .._version import version

    fields, data, units = [], {}, {}
    for name in columns:
        kind, values = _arrow_column(name, [row.get(name) for row in rows])
        unit = UNITS.get(name) or (name[name.rindex("[") + 1 : -1] if name.endswith("]") and "[" in name else "")
        if unit:
            units[name] = unit
        fields.append(pa.field(name, kind, metadata={"unit": unit} if unit else None))
        data[name] = values
    schema = pa.schema(fields, metadata={"stackdsl": version(), "stackdsl.units": json.dumps(units)})
    table = pa.Table.from_pydict(data, schema=schema)
    with written(path) as part:
        pq.write_table(table, part)


def _arrow_column(name: str, values: list[Any]) -> tuple[Any, list[Any]]:
    """The pyarrow type of column ``name`` and its ``values`` as written: the seed unsigned, the
    counts of :data:`_INTEGERS` integers, numbers (or nulls) floats, lists of numbers lists of
    floats, and anything else a string (JSON where it is not one)."""
    import pyarrow as pa

    if name == "seed":
        return pa.uint64(), values
    if name in _INTEGERS:
        return pa.int64(), values
    if all(_number(v) or v is None for v in values):
        return pa.float64(), values
    if all(isinstance(v, list) and all(_number(x) for x in v) for v in values if v is not None):
        return pa.list_(pa.float64()), values
    return pa.string(), [None if v is None else v if isinstance(v, str) else json.dumps(v) for v in values]


def _number(value: Any) -> bool:
    return isinstance(value, (int, float)) and not isinstance(value, bool)


def file_names(cells: int) -> tuple[str, ...]:
    """The names of the files a sweep of ``cells`` grid cells may write into its folder
    (:func:`write_samples` and :func:`write_plots`).

    >>> file_names(1)
    ('samples.csv', 'samples.jsonl', 'samples.parquet', 'histogram.png', 'grid_p_stands.png', 'grid_mean.png')
    """
    histograms = ["histogram.png"] if cells == 1 else [_histogram_name(cells, c) for c in range(min(cells, MAX_HISTOGRAMS))]
    return ("samples.csv", "samples.jsonl", "samples.parquet", *histograms, "grid_p_stands.png", "grid_mean.png")


def any_sweep_files() -> tuple[str, ...]:
    """The names of the files any sweep may write into its folder, whatever its cells: those of
    an earlier sweep there that this one does not write are its leftovers (:func:`remove_leftovers`)."""
    histograms = [_histogram_name(2, c) for c in range(MAX_HISTOGRAMS)]
    return (*file_names(1), *histograms)


def remove_leftovers(folder: Path, ours: Iterable[Path | str]) -> list[str]:
    """Remove from ``folder`` the files an earlier sweep wrote there (:func:`any_sweep_files`)
    that are not in ``ours`` (this sweep's), so that the folder holds one sweep's files; only
    files of those names, never anything else of the user's (a folder of such a name is left).
    The names removed, in :func:`any_sweep_files`' order."""
    kept = {Path(w).name for w in ours}
    removed = []
    for name in any_sweep_files():
        path = folder / name
        if name not in kept and (path.is_symlink() or path.is_file()):
            path.unlink(missing_ok=True)  # a link itself, never what it points to
            removed.append(name)
    return removed


def _histogram_name(cells: int, c: int) -> str:
    return "histogram.png" if cells == 1 else f"histogram_{c}.png"


def write_plots(template: Template, results: Sequence[SampleResult], folder: Path, expect: Expect | None = None) -> list[Path]:
    """The histograms (one a cell, up to :data:`MAX_HISTOGRAMS`) and, for a grid over one
    numeric field, the plot against it, each with ``expect``'s statistical expectations drawn
    (their interval, their threshold; those of ``expect.cells`` on the cells they are for);
    the paths written."""
    from ..draw.sweepplot import plot_grid, plot_histogram

    forms = expectations(expect) if expect is not None else []

    written = []
    cells = by_cell(results, template.cells)
    for c, rs in enumerate(cells[:MAX_HISTOGRAMS]):
        name = _histogram_name(template.cells, c)
        title = template.data.get("name", "") + (f" ({_cell_text(template, c)})" if template.grid else "")
        own = cell_expectations(template, expect, c) if expect is not None else []
        plot_histogram(
            measured(rs),
            folder / name,
            title=str(title),
            levels_built=levels_built(rs),
            expected=own,
            exact=not template.random,
        )
        written.append(folder / name)
    numeric = _numeric_grid(template)
    if numeric is not None:
        key, unit, values = numeric
        for statistic in ("p_stands", "mean"):
            path = folder / f"grid_{statistic}.png"
            name = str(template.data.get("name", ""))
            plot_grid(
                key,
                values,
                [measured(rs) for rs in cells],
                path,
                unit=unit,
                statistic=statistic,
                levels_built=levels_built(results),  # one height in every cell, or none named
                title=name,
                expected=forms,  # the file's own, for every cell
                cell_expected=[[f for _, f in _cell_named(template, expect, c)[len(forms) :]] for c in range(len(cells))]
                if expect is not None and expect.cells
                else (),
                exact=not template.random,
            )
            written.append(path)
    return written


def _numeric_grid(template: Template) -> tuple[str, str, list[float]] | None:
    """(key, unit, values as numbers of that unit) for a grid over one numeric field, else None."""
    from ..lang.units import in_unit, split_quantity

    if len(template.grid) != 1:
        return None
    _, key, values = template.grid[0]
    try:
        unit = next((split_quantity(v)[1] for v in values if split_quantity(v)[1]), "")
        # a bare 0 is 0 of any unit; other bare numbers among values with units are SI: not compared here
        return key, unit, [0.0 if v == 0 and not isinstance(v, str) else in_unit(v, unit) for v in values]
    except ValueError:
        return None


def thresholds(template: Template, results: Sequence[SampleResult]) -> list[str]:
    """For a grid over one numeric field, where P(stands) crosses 1/2 between neighbouring grid
    values (a tipping amplitude, a critical overhang): a line each, or one saying it never does.
    Source: stackdsl's own.

    >>> from stackdsl.lang.loader import parse_scenario
    >>> t = parse_scenario("stackdsl: 1\\nstructure: {tower: {levels: 2}}\\nsweep: {grid: {timing.interval: [1 s, 2 s, 3 s]}}").template
    >>> rs = [SampleResult(c, 0, 0, {}, level, 2, 0.1, 3.0) for c, level in enumerate([None, None, 2])]
    >>> thresholds(t, rs)
    ['threshold of timing.interval: P(stands) falls from 1.00 at 2 s to 0.00 at 3 s']
    >>> thresholds(t, rs[:2])
    ['threshold of timing.interval: none in the grid (P(stands) 1.00 at 1 s, 1.00 at 2 s)']
    """
    numeric = _numeric_grid(template)
    if numeric is None:
        return []
    key, unit, values = numeric
    stands = []
    for rs in by_cell(results, template.cells):
        levels = measured(rs)
        stands.append(sum(level is None for level in levels) / len(levels) if levels else None)
    cells = sorted((v, p) for v, p in zip(values, stands, strict=True) if p is not None)
    out = []
    for (a, pa), (b, pb) in itertools.pairwise(cells):
        if (pa >= 0.5) != (pb >= 0.5):
            way = "falls" if pb < pa else "rises"
            out.append(
                f"threshold of {key}: P(stands) {way} from {pa:.2f} at {a:g}{_unit(unit)} to {pb:.2f} at {b:g}{_unit(unit)}"
            )
    if not out and len(cells) >= 2:
        (low, p_low), (high, p_high) = cells[0], cells[-1]
        out.append(
            f"threshold of {key}: none in the grid (P(stands) {p_low:.2f} at {low:g}{_unit(unit)}, "
            f"{p_high:.2f} at {high:g}{_unit(unit)})"
        )
    return out


def _unit(unit: str) -> str:
    return f" {unit}" if unit else ""


def _cell_text(template: Template, c: int) -> str:
    return template.label(c)


def report(template: Template, expect: Expect, results: Sequence[SampleResult]) -> list[str]:
    """The summary as lines: for each cell its values, the distribution of collapse levels and
    the verdict of each statistical expectation."""
    lines = []
    judged = verdicts(template, expect, results)
    for c, rs in enumerate(by_cell(results, template.cells)):
        lines += _cell_lines(template, c, rs, [v for cell, v in judged if cell == c])
    lines += thresholds(template, results)
    if template.data.get("require"):
        draws = sum(r.draws for r in results if not r.bad_input)
        accepted = sum(not r.bad_input for r in results)
        if draws:
            lines.append(f"require: {accepted} of {draws} draws accepted ({accepted / draws:.1%})")
    oracle = [r for r in results if r.oracle == "ok"]
    if oracle:
        agree = sum(r.oracle_level == r.collapse_level for r in oracle)
        lines.append(
            f"oracle: the simulated level is the equilibrium oracle's in {agree} of {len(oracle)} samples ({agree / len(oracle):.1%})"
        )
    return lines


def _cell_lines(template: Template, c: int, rs: Sequence[SampleResult], judged: Sequence[StatVerdict]) -> list[str]:
    """Cell ``c``'s lines of :func:`report`: its values and distribution of collapse levels
    (``rs``, its samples), the verdict of each of its statistical expectations (``judged``),
    and the samples that did not finish."""
    head = f"cell {c}: {_cell_text(template, c)}" if template.grid else "all samples"
    s = summary(measured(rs), levels_built(rs), exact=not template.random)  # the cell's own height, if one
    lines = [f"{head}: {s.text()}"]
    for v in judged:
        more = f" ({v.samples_to_decide} samples would decide it)" if v.outcome == "INCONCLUSIVE" and v.samples_to_decide else ""
        lines.append(f"  {v.outcome:<12} expected {v.expected}, measured {v.measured}{more}")
    problems = [r for r in rs if r.error or r.stopped]
    if problems:
        lines.append(
            f"  {len(problems)} samples did not finish: {problems[0].error or problems[0].stopped} (sample {problems[0].sample})"
        )
    return lines
