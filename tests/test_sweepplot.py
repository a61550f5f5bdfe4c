"""Sweep plots (stackdsl.draw.sweepplot): PNGs on ordinary and degenerate input, with the marks
that should be there (and not the ones that should not), found by their colours."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from matplotlib.colors import to_rgb
from PIL import Image

from stackdsl.draw import sweepplot
from stackdsl.draw.sweepplot import COLLAPSED, MEAN, POINT, SPREAD, SPREAD_LABEL, STOOD, grid_figure, plot_grid, plot_histogram


def png(path: Path) -> np.ndarray:
    with Image.open(path) as image:
        assert image.format == "PNG"
        assert image.width > 300 and image.height > 200
        return np.asarray(image.convert("RGB")).astype(int)


def pixels(image: np.ndarray, colour: str, tolerance: int = 6) -> int:
    rgb = np.array([round(255 * c) for c in to_rgb(colour)])
    return int(np.all(np.abs(image - rgb) <= tolerance, axis=-1).sum())


@pytest.mark.slow  # about 1 s or more: in .ci/nightly's slow part
def test_histogram_of_a_cell(tmp_path: Path):
    path = tmp_path / "h.png"
    plot_histogram([3, 4, 4, 5, 5, 5, 6, 9, None, None], path, title="random stack", levels_built=30)
    image = png(path)
    assert pixels(image, COLLAPSED) > 2000
    assert pixels(image, STOOD) > 300
    assert pixels(image, MEAN) > 50


@pytest.mark.parametrize(
    "levels, collapsed, stood, mean",
    [
        ([], False, False, False),
        ([None] * 7, False, True, False),
        ([7] * 7, True, False, True),
        ([12], True, False, True),
    ],
    ids=["empty", "all stood", "one level", "one sample"],
)
def test_histogram_degenerate(tmp_path: Path, levels: list[int | None], collapsed: bool, stood: bool, mean: bool):
    path = tmp_path / "h.png"
    plot_histogram(levels, path)
    image = png(path)
    assert (pixels(image, COLLAPSED) > 500) is collapsed
    assert (pixels(image, STOOD) > 300) is stood
    assert (pixels(image, MEAN) > 50) is mean


@pytest.mark.slow  # about 1 s or more: in .ci/nightly's slow part
def test_grid_over_a_parameter(tmp_path: Path):
    rng = np.random.default_rng(0)
    values = np.linspace(0.0, 0.010, 6)  # metres
    cells = [[None if rng.random() < 1 - 60 * v else int(rng.integers(3, 30)) for _ in range(80)] for v in values]
    for statistic in ("p_stands", "mean"):
        path = tmp_path / f"{statistic}.png"
        plot_grid("placement error", values.tolist(), cells, path, unit="mm", scale=1000, statistic=statistic, levels_built=30)
        assert pixels(png(path), POINT) > 200


@pytest.mark.parametrize(
    "values, cells, statistic, points",
    [
        ([], [], "p_stands", False),
        ([1.0], [[None] * 5], "p_stands", True),
        ([1.0], [[None] * 5], "mean", False),  # all stood: no mean to show
        ([1.0], [[6] * 5], "mean", True),  # one level: a zero-width interval
        ([1.0, 2.0], [[], [4]], "mean", True),  # an empty cell, a single collapse (no interval)
    ],
    ids=["no cells", "one cell all stood", "mean of all stood", "mean of one level", "empty and single"],
)
def test_grid_degenerate(tmp_path: Path, values: list[float], cells: list[list[int | None]], statistic: str, points: bool):
    path = tmp_path / "g.png"
    plot_grid("x", values, cells, path, statistic=statistic)  # type: ignore[arg-type]
    assert (pixels(png(path), POINT) > 20) is points


def test_grid_errors(tmp_path: Path):
    with pytest.raises(ValueError, match="2 values for 1 cells"):
        plot_grid("x", [1.0, 2.0], [[3]], tmp_path / "g.png")
    with pytest.raises(ValueError, match="statistic"):
        plot_grid("x", [1.0], [[3]], tmp_path / "g.png", statistic="median")  # type: ignore[arg-type]
    with pytest.raises(ValueError):
        plot_histogram([0], tmp_path / "h.png")
    assert not (tmp_path / "g.png").exists() and not (tmp_path / "h.png").exists()


def quantile_labels(fig) -> list[tuple[float, str]]:
    """(x, text) of each cell's label of its quantiles, as the Axes hold them before saving."""
    (ax,) = fig.axes
    return sorted((t.xy[0], t.get_text()) for t in ax.texts if t.get_gid() == SPREAD_LABEL)


def test_the_grid_of_the_mean_labels_each_cell_with_its_mean_and_quantiles():
    """The sweep computes each cell's quantiles of the collapse level: grid_mean.png drew the
    mean alone. Each cell is now labelled 'mean (5%-95%)', its spread drawn behind the point."""
    cells = [
        [3] * 10 + [5] * 10,  # mean 4, 5% quantile 3, 95% quantile 5
        [4] * 5 + [None] * 5,  # half stood: the 95% quantile is among the standing samples
        [None] * 4,  # all stood: no mean, no label
        [2, 2, 2, 8],  # mean 3.5, from 2 to 8
    ]
    fig = grid_figure("e", [0.0, 1.0, 2.0, 3.0], cells, statistic="mean", levels_built=10)
    assert quantile_labels(fig) == [(0.0, "4.00 (3-5)"), (1.0, "4.00 (4-stands)"), (3.0, "3.50 (2-8)")]
    (ax,) = fig.axes
    spread = [line for line in ax.get_lines() if line.get_color() == SPREAD and len(line.get_xdata()) == 2]
    ends = sorted((line.get_xdata()[0], *sorted(line.get_ydata())) for line in spread)
    assert (0.0, 3.0, 5.0) in ends and (3.0, 2.0, 8.0) in ends  # 5% to 95%
    assert (1.0, 4.0, 10.5) in ends  # up to the levels built, for 'stands'
    labels = ax.get_legend_handles_labels()[1]
    assert {"5%-95% of levels", "25%-75%", "median", "label: mean (5%-95%)"} <= set(labels)
    assert ax.get_ylim()[1] > 10.5  # room for the labels above the highest line


def test_a_grid_of_many_cells_turns_its_quantile_labels_upright():
    values = [float(v) for v in range(12)]
    fig = grid_figure("e", values, [[3, 4, 5 + v % 3] for v in range(12)], statistic="mean")
    (ax,) = fig.axes
    labelled = [t for t in ax.texts if t.get_gid() == SPREAD_LABEL]
    assert len(labelled) == 12 and all(t.get_rotation() == 90 for t in labelled)


def test_the_grid_of_p_stands_has_no_quantiles():
    fig = grid_figure("e", [0.0, 1.0], [[3, None], [4, 5]], statistic="p_stands")
    assert quantile_labels(fig) == []
    assert not [line for line in fig.axes[0].get_lines() if line.get_color() == SPREAD]


@pytest.mark.slow
def test_a_sweeps_grid_mean_png_carries_each_cells_quantiles(tmp_path: Path, monkeypatch):
    """What ``stackdsl sweep`` writes: write_plots draws grid_mean.png with the labels."""
    from stackdsl.batch.sweep import SampleResult
    from stackdsl.batch.sweep_out import write_plots
    from stackdsl.lang.loader import parse_scenario

    template = parse_scenario(
        "stackdsl: 1\nstructure: {tower: {levels: 9}}\nsweep: {samples: 4, grid: {timing.interval: [1 s, 2 s]}}\n"
    ).template
    levels = [[3, 3, 5, 5], [6, 6, 6, None]]
    results = [SampleResult(c, k, 0, {}, level, 9, 0.1, 3.0, levels=9) for c in (0, 1) for k, level in enumerate(levels[c])]
    figures: dict[str, list[tuple[float, str]]] = {}
    drawn = sweepplot.grid_figure

    def keep(*args, **kwargs):
        fig = drawn(*args, **kwargs)
        figures[kwargs["statistic"]] = quantile_labels(fig)
        return fig

    monkeypatch.setattr(sweepplot, "grid_figure", keep)
    written = write_plots(template, results, tmp_path)
    assert tmp_path / "grid_mean.png" in written and (tmp_path / "grid_mean.png").stat().st_size > 0
    assert figures == {"p_stands": [], "mean": [(1.0, "4.00 (3-5)"), (2.0, "6.00 (6-stands)")]}
