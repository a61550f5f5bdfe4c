"""Monte-Carlo sweep plots as PNGs: one cell's collapse levels as a histogram, and a grid of
cells over one numeric parameter as a statistic with its 95 % interval against the value (the
mean with each cell's quantiles of the collapse level behind it, labelled ``mean (5%-95%)``).

Samples are collapse levels (an int) or None for a structure that stood. Statistics and
intervals come from :mod:`stackdsl.verdicts.stats` (Student t for the mean over collapsed samples,
Clopper-Pearson for P(stands)). Drawn on matplotlib's Agg canvas directly (no pyplot): safe in
threads and with no display. Empty or degenerate input (no samples, all stood, one level, one
cell) gives a plot that says so; it raises nothing but the errors listed.

Source: stackdsl's own.
"""

from __future__ import annotations

import itertools
import math
import os
from collections.abc import Sequence
from typing import Any, Literal

from matplotlib.axes import Axes
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure
from matplotlib.ticker import MaxNLocator

from ..verdicts import stats as _stats

#: Colours: collapse-level bars, the "stood" bar, the mean and its interval, grid points, and
#: what the file expects (its interval hatched, its threshold dashed).
COLLAPSED, STOOD, MEAN, POINT, EXPECTED = "#4c72b0", "#55a868", "#c44e52", "#8172b2", "#dd8452"
#: A grid plot's quantiles of the collapse level: their colour, and the gid of each cell's label of them.
SPREAD, SPREAD_LABEL = "#8c8c8c", "quantiles"
Statistic = Literal["p_stands", "mean"]
_CONFIDENCE = 0.95


def plot_histogram(
    levels: Sequence[int | None],
    path: str | os.PathLike[str],
    *,
    title: str = "",
    levels_built: int | None = None,
    expected: Sequence[Any] = (),
    exact: bool = False,
) -> None:
    """Write a PNG histogram of one cell's collapse levels to ``path``.

    Left panel: one bar per collapse level (counts of samples), the mean collapse level over
    the collapsed samples as a vertical line with its 95 % t interval shaded. Right panel: one
    bar for the samples that stood (labelled with ``levels_built`` when given). The title
    adds n, the mean and P(stands) with their intervals (with ``exact``, a sweep that draws
    nothing, the estimates alone, said to be exact). ``expected``: the file's statistical
    expectations (:class:`~stackdsl.verdicts.stats.MeanWithin`,
    :class:`~stackdsl.verdicts.stats.QuantileWithin`, :class:`~stackdsl.verdicts.stats.ProportionBound`,
    :class:`~stackdsl.verdicts.stats.ProportionWithin`),
    drawn in :data:`EXPECTED`: a level's accepted interval hatched with its target dashed, a
    bound on P(stands) as a dashed line across the "stood" bar at that share of the samples (a
    P(stands) within a tolerance as its band hatched there), each named in the legend. Raises ValueError on a level that is
    not None or an int >= 1 (as :func:`stackdsl.verdicts.stats.summary`), OSError if ``path`` cannot be
    written.
    """
    s = _stats.summary(levels, levels_built, _CONFIDENCE, exact=exact)
    fig = Figure(figsize=(8.0, 4.2), dpi=100)
    FigureCanvasAgg(fig)
    grid = fig.add_gridspec(
        1, 2, width_ratios=(6, 1), wspace=0.05, left=0.08, right=0.97, bottom=0.13, top=0.8 if title else 0.87
    )
    ax = fig.add_subplot(grid[0, 0])
    side = fig.add_subplot(grid[0, 1], sharey=ax)
    if s.histogram:
        ax.bar(list(s.histogram), list(s.histogram.values()), width=0.8, color=COLLAPSED, label="collapsed")
        low, high = min(s.histogram), max(s.histogram)
        ax.set_xlim(low - 1, high + 1)
        ax.xaxis.set_major_locator(MaxNLocator(integer=True))
    else:
        ax.text(0.5, 0.5, "no collapse" if s.n else "no samples", transform=ax.transAxes, ha="center", va="center")
        ax.set_xticks([])
    for form in expected:
        if isinstance(form, (_stats.MeanWithin, _stats.QuantileWithin)):
            what = "mean" if isinstance(form, _stats.MeanWithin) else f"{form.q:.0%} quantile"
            start, end = form.target - form.tolerance, form.target + form.tolerance
            ax.axvspan(start, end, facecolor="none", edgecolor=EXPECTED, hatch="//", lw=1.0)
            ax.axvline(form.target, color=EXPECTED, lw=1.5, ls="--", label=f"expected {what} {form.target:g}±{form.tolerance:g}")
            ax.set_xlim(min(ax.get_xlim()[0], start - 0.5), max(ax.get_xlim()[1], end + 0.5))
        elif isinstance(form, _stats.ProportionBound) and s.n:  # named in the legend: a label there hid the bar
            side.axhline(form.bound * s.n, color=EXPECTED, lw=1.5, ls="--")
            ax.plot([], [], color=EXPECTED, lw=1.5, ls="--", label=f"expected P(stands) {form.op} {form.bound:g} (on 'stood')")
        elif isinstance(form, _stats.ProportionWithin) and s.n:  # its accepted counts of 'stood' hatched
            least, most = form.region
            side.axhspan(least * s.n, most * s.n, facecolor="none", edgecolor=EXPECTED, hatch="//", lw=1.0)
            ax.plot([], [], color=EXPECTED, lw=1.5, label=f"expected P(stands) {form.target:g}±{form.tolerance:g} (on 'stood')")
    if s.mean is not None:
        label = f"mean {s.mean:.2f}"
        if s.mean_interval is not None:
            lo, hi = s.mean_interval
            ax.axvspan(lo, hi, color=MEAN, alpha=0.25, lw=0)
            label += ", exact" if exact else f", 95% CI [{lo:.2f}, {hi:.2f}]"
        ax.axvline(s.mean, color=MEAN, lw=2, label=label)
    if ax.get_legend_handles_labels()[0]:
        ax.legend(loc="best", fontsize=8, framealpha=0.85, edgecolor="none")  # readable over a bar
    ax.yaxis.set_major_locator(MaxNLocator(integer=True))
    ax.set_xlabel("collapse level")
    ax.set_ylabel("samples")
    side.bar([0], [s.stood], width=0.6, color=STOOD, hatch="//", edgecolor="white")
    side.set_xlim(-0.7, 0.7)
    side.set_xticks([0], ["stood" if levels_built is None else f"stood\n({levels_built} levels)"])
    side.tick_params(axis="y", labelleft=False)
    if s.n == 0:
        ax.set_ylim(0, 1)
    fig.suptitle(_heading(title, s, exact), fontsize=10)
    fig.savefig(os.fspath(path), format="png")


def plot_grid(
    parameter: str,
    values: Sequence[float],
    cells: Sequence[Sequence[int | None]],
    path: str | os.PathLike[str],
    *,
    unit: str = "",
    statistic: Statistic = "p_stands",
    scale: float = 1.0,
    levels_built: int | None = None,
    title: str = "",
    expected: Sequence[Any] = (),
    cell_expected: Sequence[Sequence[Any]] = (),
    exact: bool = False,
) -> None:
    """Write :func:`grid_figure` of the same arguments as a PNG to ``path``. Raises as
    :func:`grid_figure`, and OSError if ``path`` cannot be written."""
    fig = grid_figure(
        parameter,
        values,
        cells,
        unit=unit,
        statistic=statistic,
        scale=scale,
        levels_built=levels_built,
        title=title,
        expected=expected,
        cell_expected=cell_expected,
        exact=exact,
    )
    fig.savefig(os.fspath(path), format="png")


def grid_figure(
    parameter: str,
    values: Sequence[float],
    cells: Sequence[Sequence[int | None]],
    *,
    unit: str = "",
    statistic: Statistic = "p_stands",
    scale: float = 1.0,
    levels_built: int | None = None,
    title: str = "",
    expected: Sequence[Any] = (),
    cell_expected: Sequence[Sequence[Any]] = (),
    exact: bool = False,
) -> Figure:
    """A figure of a statistic per cell against a numeric parameter, with 95 % error bars
    (none when ``exact``: a sweep that draws nothing, each cell one run repeated);
    the file's expectation on that statistic (``expected``, as :func:`plot_histogram` takes
    them) in :data:`EXPECTED`: a bound on P(stands) as a dashed threshold line with its accepted
    side shaded, a mean's accepted interval hatched with its target dashed. ``cell_expected[i]``:
    expectations for ``cells[i]`` alone (a sweep's ``expect.cells``), drawn alike but only over
    the cells they are for (from halfway to the neighbouring cells), one legend entry each.

    ``values[i]`` is the parameter's value of ``cells[i]`` (that cell's samples: collapse
    levels or None). The value is drawn times ``scale`` (e.g. values in metres, ``scale=1000``,
    ``unit="mm"``); ``unit`` labels the axis. ``statistic``: "p_stands" (fraction that stood,
    Clopper-Pearson interval; "at N levels" when ``levels_built`` is given) or "mean" (mean
    collapse level over collapsed samples, t interval). A cell with no estimate (no samples;
    for the mean, no collapse) is left out and counted in a note; one with an estimate but no
    interval (a single collapse) is a point without a bar.

    With "mean", each cell also shows how its collapse levels spread: the quantiles the sweep
    computes (:data:`~stackdsl.verdicts.stats.SUMMARY_QUANTILES`, standing samples above every
    level) behind its point, 5 % to 95 % as a thin line and 25 % to 75 % as a thick bar, the
    median as a tick, and the point labelled ``mean (5%-95%)``, such as ``7.25 (5-10)``; a
    quantile among the standing samples is written "stands", its line running up to
    ``levels_built`` (or past the highest level drawn) and ending in an arrowhead.

    Raises ValueError when values and cells (or ``cell_expected``, when given) differ in length,
    on an unknown statistic, or a bad level (as :func:`stackdsl.verdicts.stats.summary`).
    """
    _check_grid(values, cells, cell_expected, statistic)
    points, spreads, sizes = _estimates(values, cells, statistic, scale, levels_built, exact)
    fig = Figure(figsize=(7.0, 4.5), dpi=100)
    FigureCanvasAgg(fig)
    ax = fig.add_axes((0.12, 0.13, 0.84, 0.75 if title else 0.79))
    room = _draw_points(ax, points, spreads, levels_built, exact) if points else None
    _draw_grid_expected(ax, statistic, expected, _cell_spans([float(v) * scale for v in values], cell_expected))
    _note_left_out(fig, ax, len(cells), bool(points), len(cells) - len(points))
    _label_y(ax, statistic, levels_built, room)
    ax.set_xlabel(f"{parameter} ({unit})" if unit else parameter)
    ax.grid(True, alpha=0.3)
    per_cell = f"n = {sizes.pop()} per cell" if len(sizes) == 1 else f"n = {min(sizes)}..{max(sizes)} per cell" if sizes else ""
    fig.suptitle(", ".join(t for t in (title, per_cell) if t), fontsize=10)
    return fig


def _check_grid(
    values: Sequence[float], cells: Sequence[Sequence[int | None]], cell_expected: Sequence[Sequence[Any]], statistic: str
) -> None:
    """Refuse what :func:`grid_figure` cannot draw.

    Raises:
        ValueError: values and cells (or ``cell_expected``, when given) differ in length, or an
            unknown statistic.
    """
    if len(values) != len(cells):
        raise ValueError(f"{len(values)} values for {len(cells)} cells")
    if cell_expected and len(cell_expected) != len(cells):
        raise ValueError(f"{len(cell_expected)} cells' expectations for {len(cells)} cells")
    if statistic not in ("p_stands", "mean"):
        raise ValueError(f"statistic must be 'p_stands' or 'mean', got {statistic!r}")


def _draw_points(
    ax: Axes,
    points: list[tuple[float, float, float, float]],
    spreads: list[tuple[float, float, dict[float, float]]],
    levels_built: int | None,
    exact: bool,
) -> float | None:
    """Each cell's estimate with its 95 % error bar (``points``: x, estimate, low, high; none of
    them empty) over its spread of collapse levels (``spreads``, for the mean), and the legend;
    returns the top the y axis needs for the spreads' labels, or None (:func:`_draw_spreads`)."""
    xs = [p[0] for p in points]
    ys = [p[1] for p in points]
    below = [p[1] - p[2] for p in points]
    above = [p[3] - p[1] for p in points]
    room = _draw_spreads(ax, sorted(spreads, key=lambda c: c[0]), levels_built, max(p[3] for p in points))
    label = "exact: nothing is drawn" if exact else "estimate, 95% CI"
    ax.errorbar(xs, ys, yerr=[below, above], color=POINT, marker="o", ms=5, capsize=4, lw=1.5, label=label, zorder=3)
    ax.legend(loc="best", fontsize=8, frameon=False)
    if len(set(xs)) == 1:
        ax.set_xlim(xs[0] - 1, xs[0] + 1)
    return room


def _draw_grid_expected(
    ax: Axes, statistic: Statistic, expected: Sequence[Any], cell_spans: list[tuple[Any, float | None, float | None]]
) -> None:
    """The file's expectations on ``statistic`` over the whole axis (``expected``), then each
    cell's over its own span (``cell_spans``: form, start, end), one legend entry a form."""
    spans: list[tuple[Any, float | None, float | None]] = [(form, None, None) for form in expected]
    spans += cell_spans
    named: list[Any] = []
    for form, start, end in spans:
        if not _draw_expected(ax, form, statistic, start, end, cell=start is not None, named=form not in named):
            continue
        named.append(form)
        ax.legend(loc="best", fontsize=8, frameon=False)


def _estimates(
    values: Sequence[float],
    cells: Sequence[Sequence[int | None]],
    statistic: Statistic,
    scale: float,
    levels_built: int | None,
    exact: bool,
) -> tuple[list[tuple[float, float, float, float]], list[tuple[float, float, dict[float, float]]], set[int]]:
    """Each cell's estimate of ``statistic`` at its value times ``scale``: (x, estimate, low,
    high) sorted by x, a point without a bar where there is no interval, cells without an
    estimate left out; for the mean, (x, mean, quantiles) of each; the cells' sample counts."""
    points: list[tuple[float, float, float, float]] = []  # (x, estimate, low, high)
    spreads: list[tuple[float, float, dict[float, float]]] = []  # (x, mean, quantiles): "mean" only
    sizes: set[int] = set()
    for value, cell in zip(values, cells):
        s = _stats.summary(cell, levels_built, _CONFIDENCE, exact=exact)
        sizes.add(s.n)
        estimate, interval = (s.p_stands, s.p_stands_interval) if statistic == "p_stands" else (s.mean, s.mean_interval)
        if estimate is not None:
            low, high = interval if interval is not None else (estimate, estimate)
            points.append((float(value) * scale, estimate, low, high))
            if statistic == "mean":
                spreads.append((float(value) * scale, estimate, s.quantiles))
    points.sort()
    return points, spreads, sizes


def _note_left_out(fig: Figure, ax: Axes, cells: int, drawn: bool, missing: int) -> None:
    """Say how many of the ``cells`` had no estimate (``missing``), or that there are none: below
    the axes when some were ``drawn``, else in the middle of them."""
    if not missing and cells:
        return
    note = "no cells" if not cells else f"{missing} cell(s) without an estimate left out"
    if drawn:  # below the axes, clear of the legend and the marks
        fig.text(0.98, 0.01, note, ha="right", va="bottom", fontsize=8)
    else:
        ax.text(0.5, 0.5, note, transform=ax.transAxes, ha="center", va="center", fontsize=9)


def _label_y(ax: Axes, statistic: Statistic, levels_built: int | None, room: float | None) -> None:
    """The y axis of ``statistic``: P(stands) from 0 to 1, or the collapse level, raised to
    ``room`` for the quantiles' labels (with a legend of two columns)."""
    if statistic == "p_stands":
        ax.set_ylim(-0.03, 1.03)
        ax.set_ylabel("P(stands)" if levels_built is None else f"P(stands at {levels_built} levels)")
        return
    ax.set_ylabel("mean collapse level (collapsed samples)" if room is None else "collapse level")
    if room is not None:  # the quantiles' labels above their lines; a legend of two columns, low
        ax.set_ylim(top=max(ax.get_ylim()[1], room))
        ax.legend(loc="best", fontsize=7, frameon=False, ncols=2)


#: The quantiles a grid plot of the mean draws: the thin line's ends, the bar's ends, the tick.
_OUTER, _INNER, _MIDDLE = (0.05, 0.95), (0.25, 0.75), 0.5


def _draw_spreads(
    ax: Any, spreads: Sequence[tuple[float, float, dict[float, float]]], levels_built: int | None, highest: float
) -> float | None:
    """Each cell's quantiles of the collapse level behind its mean (see :func:`grid_figure`):
    ``spreads`` holds (x, mean, quantiles) a cell; ``highest``: the highest point drawn. The
    top the y axis needs for the labels, or None when nothing was drawn."""
    if not spreads or not all({*_OUTER, *_INNER, _MIDDLE} <= set(q) for _, _, q in spreads):
        return None
    finite = [v for _, _, q in spreads for v in q.values() if math.isfinite(v)]
    top = float(levels_built) + 0.5 if levels_built is not None else max([highest, *finite]) + 1.0

    def at(level: float) -> float:
        return level if math.isfinite(level) else top

    rotate = len(spreads) > 8  # side by side, the labels of many cells would run into each other
    named: set[str] = set()

    def label(text: str) -> str:  # each in the legend once
        if text in named:
            return "_"
        named.add(text)
        return text

    for x, mean, q in spreads:
        outer, inner = [at(q[e]) for e in _OUTER], [at(q[e]) for e in _INNER]
        ax.plot([x, x], outer, color=SPREAD, lw=1.2, zorder=1, label=label("5%-95% of levels"))
        ax.plot([x, x], inner, color=SPREAD, lw=7, alpha=0.45, solid_capstyle="butt", zorder=1, label=label("25%-75%"))
        if math.isfinite(q[_MIDDLE]):
            ax.plot([x], [q[_MIDDLE]], color=SPREAD, marker="_", ms=14, mew=2, ls="none", zorder=2, label=label("median"))
        if not math.isfinite(q[_OUTER[1]]):
            ax.plot([x], [top], color=SPREAD, marker="^", ms=6, ls="none", zorder=2)
        low, high = (_stats.format_level(q[e]) for e in _OUTER)
        ax.annotate(
            f"{mean:.2f} ({low}-{high})",
            (x, outer[1]),
            xytext=(0, 6),
            textcoords="offset points",
            ha="center",
            va="bottom",
            fontsize=7,
            rotation=90 if rotate else 0,
            gid=SPREAD_LABEL,
        )
    ax.plot([], [], ls="none", label="label: mean (5%-95%)")  # the key to the labels
    return top + (0.12 if rotate else 0.06) * (top - min([highest, *finite]) + 1.0) + 0.5


def _draw_expected(
    ax: Any, form: Any, statistic: Statistic, start: float | None, end: float | None, *, cell: bool, named: bool
) -> bool:
    """Draw ``form`` on the grid plot ``ax`` when it is about ``statistic``: across the whole plot
    (``start`` None), else from ``start`` to ``end`` along the parameter, in the legend when
    ``named``; whether it was drawn."""
    where = " (some cells)" if cell else ""
    if statistic == "p_stands" and isinstance(form, _stats.ProportionWithin):
        label = f"expected P(stands) {form.target:g}±{form.tolerance:g}{where}"
        _mark(ax, form.region, form.target, label if named else "_", start, end, hatched=True)
    elif statistic == "p_stands" and isinstance(form, _stats.ProportionBound):
        band = (form.bound, 1.03) if form.op in (">=", ">") else (-0.03, form.bound)
        label = f"expected P(stands) {form.op} {form.bound:g}{where}"
        _mark(ax, band, form.bound, label if named else "_", start, end, hatched=False)
    elif statistic == "mean" and isinstance(form, _stats.MeanWithin):
        band = (form.target - form.tolerance, form.target + form.tolerance)
        label = f"expected mean {form.target:g}±{form.tolerance:g}{where}"
        _mark(ax, band, form.target, label if named else "_", start, end, hatched=True)
    else:
        return False
    return True


def _mark(
    ax: Any, band: tuple[float, float], line: float, label: str, start: float | None, end: float | None, *, hatched: bool
) -> None:
    """An expectation's accepted ``band`` (hatched, or shaded) and a dashed line at ``line``,
    across the plot (``start`` None) or from ``start`` to ``end`` along the parameter."""
    style: dict[str, Any] = (
        {"facecolor": "none", "edgecolor": EXPECTED, "hatch": "//"} if hatched else {"color": EXPECTED, "alpha": 0.08, "lw": 0}
    )
    if start is None or end is None:
        ax.axhspan(*band, **style)
        ax.axhline(line, color=EXPECTED, lw=1.5, ls="--", label=label)
    else:
        ax.fill_between([start, end], *band, **style)
        ax.plot([start, end], [line, line], color=EXPECTED, lw=1.5, ls="--", label=label)


def _cell_spans(xs: Sequence[float], cell_expected: Sequence[Sequence[Any]]) -> list[tuple[Any, float | None, float | None]]:
    """(form, start, end): each expectation of some cells over the runs of neighbouring cells
    (by value) it holds in, from halfway to the cell before to halfway to the one after (half a
    unit either side of a lone value)."""
    if not cell_expected:
        return []
    order = sorted(range(len(xs)), key=lambda i: xs[i])
    ordered = [xs[i] for i in order]
    gaps = [b - a for a, b in itertools.pairwise(ordered) if b > a]
    half = min(gaps) / 2 if gaps else 0.5
    forms: list[Any] = []
    for i in order:
        forms += [f for f in cell_expected[i] if f not in forms]
    spans: list[tuple[Any, float | None, float | None]] = []
    for form in forms:
        run: list[int] = []
        for k, i in enumerate(order + [-1]):
            if i >= 0 and form in cell_expected[i]:
                run.append(k)
                continue
            if run:
                left = ordered[run[0]] - ((ordered[run[0]] - ordered[run[0] - 1]) / 2 if run[0] > 0 else half)
                last = run[-1]
                right = ordered[last] + ((ordered[last + 1] - ordered[last]) / 2 if last + 1 < len(ordered) else half)
                spans.append((form, left, right))
                run = []
    return spans


def _heading(title: str, s: _stats.CellSummary, exact: bool) -> str:
    parts = [f"n={s.n}: {s.collapsed} collapsed, {s.stood} stood"]
    if s.mean is not None:
        parts.append(f"mean {s.mean:.2f}" + (" exact" if exact else _ci(s.mean_interval, ".2f") if s.mean_interval else ""))
    if s.p_stands is not None and s.p_stands_interval is not None:
        parts.append(f"P(stands) {s.p_stands:.3f}" + (" exact" if exact else _ci(s.p_stands_interval, ".3f")))
    return "\n".join([title, "; ".join(parts)] if title else ["; ".join(parts)])


def _ci(interval: tuple[float, float], spec: str) -> str:
    low, high = interval
    return f" [{low:{spec}}, {high:{spec}}]" if math.isfinite(low) and math.isfinite(high) else ""
