"""The picture of a threshold search: what each run's verdict was bracketed on (its signed margin,
still's margin, or the verdict itself: :func:`stackdsl.batch.search.followed`) against the field
searched, a stand (held) above zero and a collapse (failed) below, with the interval the search reports shaded
(``stackdsl search``, :mod:`stackdsl.batch.search`). Drawn on matplotlib's Agg canvas directly
(no pyplot), as the sweep's plots are.

Source: stackdsl's own.
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path

from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure


def plot_margin(
    values: Sequence[float],
    margins: Sequence[float | None],
    stood: Sequence[bool | None],
    interval: tuple[float, float] | None,
    field: str,
    unit: str,
    path: Path,
    quantity: tuple[str, str] = ("signed margin", "mm"),
    sides: tuple[str, str] = ("stands", "collapses"),
) -> Path:
    """Write ``path`` (PNG, about 1000 x 600 pixels): the runs at ``values`` (numbers of ``unit``,
    in the order run: each point labelled with its order), the quantity the search bracketed on
    (``margins``, named with its unit by ``quantity``; None: none, drawn at 0 in grey), green
    where the run ``stood`` (its expectations held), red where not, the legend naming the two
    verdicts ``sides``; the zero line; ``interval`` (the search's answer) shaded. Values spanning
    more than 50 and less than 1 are drawn on a symmetric log scale, linear within 1. Returns ``path``.

    Raises:
        OSError: the file cannot be written.
    """
    figure = Figure(figsize=(10, 6), dpi=100)
    FigureCanvasAgg(figure)
    ax = figure.add_subplot()
    ax.axhline(0.0, color="black", linewidth=0.8)
    if interval is not None:
        ax.axvspan(
            interval[0],
            interval[1],
            color="#ffd27f",
            alpha=0.6,
            label=f"threshold: {interval[0]:.6g} to {interval[1]:.6g} {unit}",
        )
    name, quantity_unit = quantity
    for n, (x, m, s) in enumerate(zip(values, margins, stood), 1):
        colour = "#999999" if s is None else "#2a9d3a" if s else "#d62728"
        ax.plot([x], [0.0 if m is None else m], "o", color=colour)
        ax.annotate(str(n), (x, 0.0 if m is None else m), textcoords="offset points", xytext=(4, 4), fontsize=8)
    ax.plot([], [], "o", color="#2a9d3a", label=f"{sides[0]} (> 0)")
    ax.plot([], [], "o", color="#d62728", label=f"{sides[1]} (< 0)")
    ax.set_xlabel(f"{field} [{unit}]" if unit else field)
    ax.set_ylabel(f"{name} [{quantity_unit}]" if quantity_unit else name)
    sizes = [abs(m) for m in margins if m is not None and m != 0]
    if sizes and max(sizes) > 50 and min(sizes) < 1:  # an overturned block's -4600 beside a share of 0.4: log beyond 1
        ax.set_yscale("symlog", linthresh=1.0)
    ax.set_title(f"{name} against {field}: {len(values)} runs (numbered in the order run)")
    ax.legend(loc="best", fontsize=9)
    ax.grid(alpha=0.3)
    figure.tight_layout()
    figure.savefig(path)
    return path
