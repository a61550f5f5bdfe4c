"""The benchmark's plots: wall time against error, and against tower height.

Source: stackdsl's own.
"""

from __future__ import annotations

import statistics
from pathlib import Path

from ..engines.registry import names
from .bench import SETTINGS, Cell, fit_exponent


def _marker(setting: str) -> str:
    """A marker of its own for each engine (:mod:`stackdsl.engines.registry`'s order): circles for
    pybullet's settings, squares for MuJoCo's."""
    return "osD^v<>"[names().index(SETTINGS[setting].backend) % 7]


def _pareto(points: list[tuple[float, float, str]]) -> list[tuple[float, float, str]]:
    """The points no other point beats in both wall time and error."""
    front = [p for p in points if not any(q[0] <= p[0] and q[1] <= p[1] and q != p for q in points)]
    return sorted(front)


def plot_error(cells: list[Cell], path: Path) -> None:
    """Wall time against error, one point per setting (all scenes summed), Pareto front drawn."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(7, 4.5))
    points = []
    for i, s in enumerate(SETTINGS):
        mine = [c for c in cells if c.setting == s]
        if not mine:
            continue
        wall = sum(c.wall for c in mine)
        error = statistics.mean(abs(c.error) for c in mine)
        points.append((wall, error, s))
        marker = _marker(s)
        ax.scatter([c.wall for c in mine], [abs(c.error) for c in mine], s=12, alpha=0.35, color=f"C{i}", marker=marker)
        ax.scatter([wall], [error], s=70, color=f"C{i}", edgecolor="k", zorder=3, label=s, marker=marker)
    front = _pareto(points)
    ax.plot(
        [p[0] for p in front],
        [p[1] for p in front],
        "k--",
        lw=1,
        marker="o",
        mfc="none",
        ms=12,
        label="Pareto front (per setting)",
    )
    ax.set_xscale("log")
    ax.set_xlabel("wall time, s (large: all scenes summed; small: one cell)")
    ax.set_ylabel("|collapse level - closed form|, levels (mean)")
    ax.set_title("Speed against error: every setting on the same scenes")
    ax.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def plot_height(cells: list[Cell], path: Path) -> None:
    """Wall time against tower height (bricks), log-log, with the fitted exponent per setting."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(7, 4.5))
    for i, s in enumerate(SETTINGS):  # the same colours as in plot_error
        mine = sorted((c.bricks, c.wall) for c in cells if c.setting == s and c.family == "upright")
        if len(mine) < 2:
            continue
        k = fit_exponent(mine)
        ax.plot([m[0] for m in mine], [m[1] for m in mine], _marker(s) + "-", color=f"C{i}", label=f"{s}: wall ~ bricks^{k:.2f}")
    ax.set_xscale("log")
    ax.set_yscale("log")
    ax.set_xlabel("bricks in the upright 4 stack")
    ax.set_ylabel("wall time, s")
    ax.set_title("Cost against tower height")
    if ax.get_legend_handles_labels()[0]:
        ax.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)
