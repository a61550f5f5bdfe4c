"""What a sweep leaves: per-sample files, a summary a cell, verdicts, plots.

* ``samples.csv`` and ``samples.jsonl``: one row a sample, in (cell, sample) order: the cell,
  the sample index, its seed, what it drew (a column a field, named with the unit its values
  are numbers of), the collapse level (empty: it stood), levels placed, wall and simulated
  seconds, the oracle's level and the rest of :class:`stackdsl.batch.sweep.SampleResult`;
* for each grid cell, the distribution of collapse levels (:func:`stackdsl.verdicts.stats.summary`)
  and the verdict of each statistical expectation (:func:`stackdsl.verdicts.stats.decide`);
* ``histogram.png`` (one a cell, up to :data:`MAX_HISTOGRAMS`) and, for a grid over one
  numeric field, ``grid.png``: P(stands) and the mean collapse level against it.

Source: stackdsl's own.
"""

from __future__ import annotations

import csv
import json
from collections.abc import Sequence
from pathlib import Path
from typing import Any

from ..lang.expectations import Expect
from ..lang.files import written
from ..lang.sampling import Template
from ..verdicts.stats import MeanWithin, ProportionBound, QuantileWithin, StatVerdict, decide, summary
from .sweep import SampleResult

MAX_HISTOGRAMS = 12


def expectations(expect: Expect) -> list[Any]:
    """A scenario's statistical expectations as :mod:`stackdsl.verdicts.stats` forms, in file order."""
    out: list[Any] = []
    collapse = expect.collapse
    mean = getattr(collapse, "mean", None)
    quantile = getattr(collapse, "quantile", None)
    if mean is not None:
        out.append(MeanWithin(mean.target, mean.tolerance))
    if quantile is not None:
        out.append(QuantileWithin(quantile.q, quantile.level.target, quantile.level.tolerance))
    if expect.p_stands is not None:
        out.append(ProportionBound(expect.p_stands.op, expect.p_stands.bound))
    return out


def by_cell(results: Sequence[SampleResult], cells: int) -> list[list[SampleResult]]:
    """The results of each cell (cells in order)."""
    out: list[list[SampleResult]] = [[] for _ in range(cells)]
    for r in results:
        out[r.cell].append(r)
    return out


def measured(results: Sequence[SampleResult]) -> list[int | None]:
    """The collapse levels of the samples that ran to their end (None: stood)."""
    return [r.collapse_level for r in results if not (r.error or r.bad_input or r.stopped)]


def verdicts(template: Template, expect: Expect, results: Sequence[SampleResult]) -> list[tuple[int, StatVerdict]]:
    """(cell, verdict) of every statistical expectation in every cell."""
    forms = expectations(expect)
    return [(c, decide(form, measured(rs))) for c, rs in enumerate(by_cell(results, template.cells)) for form in forms]


def write_samples(results: Sequence[SampleResult], folder: Path) -> tuple[Path, Path]:
    """``samples.csv`` and ``samples.jsonl`` in ``folder`` (made if missing); their paths.

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
        writer = csv.DictWriter(f, fieldnames=columns)
        writer.writeheader()
        for row in rows:
            writer.writerow(
                {k: json.dumps(v) if isinstance(v, (list, dict)) else ("" if v is None else v) for k, v in row.items()}
            )
    with written(lines) as part, open(part, "w", encoding="utf-8") as f:
        for row in rows:
            f.write(json.dumps(row) + "\n")
    return table, lines


def write_plots(template: Template, results: Sequence[SampleResult], levels_built: int, folder: Path) -> list[Path]:
    """The histograms (one a cell, up to :data:`MAX_HISTOGRAMS`) and, for a grid over one
    numeric field, the plot against it; the paths written."""
    from ..draw.sweepplot import plot_grid, plot_histogram

    written = []
    cells = by_cell(results, template.cells)
    for c, rs in enumerate(cells[:MAX_HISTOGRAMS]):
        name = "histogram.png" if template.cells == 1 else f"histogram_{c}.png"
        title = template.data.get("name", "") + (f" ({_cell_text(template, c)})" if template.grid else "")
        plot_histogram(measured(rs), folder / name, title=str(title), levels_built=levels_built)
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
                levels_built=levels_built or None,
                title=name,
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


def _cell_text(template: Template, c: int) -> str:
    return ", ".join(f"{k} = {v}" for k, v in template.cell(c).items())


def report(template: Template, expect: Expect, results: Sequence[SampleResult], levels_built: int) -> list[str]:
    """The summary as lines: for each cell its values, the distribution of collapse levels and
    the verdict of each statistical expectation."""
    lines = []
    judged = verdicts(template, expect, results)
    for c, rs in enumerate(by_cell(results, template.cells)):
        head = f"cell {c}: {_cell_text(template, c)}" if template.grid else "all samples"
        s = summary(measured(rs), levels_built)
        lines.append(f"{head}: {s.text()}")
        for cell, v in judged:
            if cell == c:
                more = (
                    f" ({v.samples_to_decide} samples would decide it)"
                    if v.outcome == "INCONCLUSIVE" and v.samples_to_decide
                    else ""
                )
                lines.append(f"  {v.outcome:<12} expected {v.expected}, measured {v.measured}{more}")
        problems = [r for r in rs if r.error or r.stopped]
        if problems:
            lines.append(
                f"  {len(problems)} samples did not finish: {problems[0].error or problems[0].stopped} (sample {problems[0].sample})"
            )
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
