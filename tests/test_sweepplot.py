"""Sweep plots (stackdsl.draw.sweepplot): PNGs on ordinary and degenerate input, with the marks
that should be there (and not the ones that should not), found by their colours."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from matplotlib.colors import to_rgb
from PIL import Image

from stackdsl.draw.sweepplot import COLLAPSED, MEAN, POINT, STOOD, plot_grid, plot_histogram


def png(path: Path) -> np.ndarray:
    with Image.open(path) as image:
        assert image.format == "PNG"
        assert image.width > 300 and image.height > 200
        return np.asarray(image.convert("RGB")).astype(int)


def pixels(image: np.ndarray, colour: str, tolerance: int = 6) -> int:
    rgb = np.array([round(255 * c) for c in to_rgb(colour)])
    return int(np.all(np.abs(image - rgb) <= tolerance, axis=-1).sum())


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
