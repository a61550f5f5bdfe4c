"""What ``stackdsl bench`` writes: bench.csv, the tables of bench.md (each setting's wall
time as a ratio to the extension's on the same scene, and the extension on each backend
against the strongest peer, tuned MuJoCo with its own sleeping), the plots, and the targets
as measured.

Source: stackdsl's own.
"""

from __future__ import annotations

import csv
import statistics
from collections.abc import Callable
from dataclasses import asdict, dataclass
from pathlib import Path
from typing import Any

import numpy as np

from .bench import SETTINGS, Cell, fit_exponent, scene_label
from .plot import plot_error, plot_height


def write_outputs(cells: list[Cell], saved: list[tuple[str, str, float, int]], folder: Path) -> dict[str, Any]:
    """Write bench.csv, bench.md, wall_vs_error.png and wall_vs_height.png into ``folder``;
    return the target checks."""
    folder.mkdir(parents=True, exist_ok=True)
    with open(folder / "bench.csv", "w", newline="") as f:
        writer = csv.DictWriter(f, fieldnames=list(asdict(cells[0])))
        writer.writeheader()
        writer.writerows(asdict(c) for c in cells)
    targets = check_targets(cells)
    (folder / "bench.md").write_text(markdown(cells, saved, targets))
    plot_error(cells, folder / "wall_vs_error.png")
    plot_height(cells, folder / "wall_vs_height.png")
    return targets


def check_targets(cells: list[Cell]) -> dict[str, Any]:
    """The benchmark's targets, as measured: slant errors, the 30-level speed ratio, exponents."""
    by = {(c.setting, c.family, c.parameter): c for c in cells}
    slant = [c for c in cells if c.family != "upright"]
    out: dict[str, Any] = {
        "slant errors": {s: [c.error for c in slant if c.setting == s] for s in SETTINGS if any(c.setting == s for c in slant)}
    }
    raw, ext = by.get(("raw 240 Hz", "upright", 30)), by.get(("extension report", "upright", 30))
    if raw and ext:
        out["30-level speed-up, raw 240 Hz / extension"] = raw.wall / ext.wall
    out["peer"] = peer_ratios(cells)
    out["exponents"] = {
        s: fit_exponent([(c.bricks, c.wall) for c in cells if c.setting == s and c.family == "upright"])
        for s in SETTINGS
        if sum(c.setting == s and c.family == "upright" for c in cells) >= 2
    }
    return out


EXTENSIONS = ("extension report", "MuJoCo extension")
PEERS = ("MuJoCo lean", "MuJoCo tuned sleeping", "MuJoCo tuned sleeping parked", "pybullet lean", "raw 240 Hz")
"""The extension on each backend, and the peers: the strongest, tuned MuJoCo with its own
sleeping, first in its own lean loop (:mod:`stackdsl.bench.lean_mujoco`: the peer at its best,
the ratio the README quotes), then through stackdsl's loop in both of its forms (bricks added to
the model as they are placed, or parked up front): a second, labelled column; then raw pybullet,
in its own lean loop (:mod:`stackdsl.bench.lean_pybullet`) and through stackdsl's loop."""


@dataclass(frozen=True)
class PeerRatio:
    """The peer's wall time over the extension's on the same scene, in the same run: on the
    upright towers of 30 and 60 levels (a height not measured is absent), with each side's error in
    levels, and over the slant (collapsing) scenes, the least ratio and the geometric mean."""

    extension: str
    peer: str
    upright: dict[int, tuple[float, int, int]]
    slant_least: float | None
    slant_mean: float | None


def peer_ratios(cells: list[Cell]) -> list[PeerRatio]:
    """:class:`PeerRatio` for each extension setting against each peer measured."""
    by = {(c.setting, c.family, c.parameter): c for c in cells}
    out = []
    for ext in EXTENSIONS:
        for peer in PEERS:
            upright = {}
            for levels in (30, 60):
                e, p = by.get((ext, "upright", levels)), by.get((peer, "upright", levels))
                if e and p:
                    upright[levels] = (p.wall / e.wall, e.error, p.error)
            slant = [
                p.wall / e.wall
                for e in cells
                if e.setting == ext and e.family != "upright" and (p := by.get((peer, e.family, e.parameter)))
            ]
            if upright or slant:
                least = min(slant) if slant else None
                mean = float(np.exp(np.mean(np.log(slant)))) if slant else None
                out.append(PeerRatio(ext, peer, upright, least, mean))
    return out


def peer_lines(rows: list[PeerRatio]) -> list[str]:
    """A Markdown table of :func:`peer_ratios` (empty without rows)."""
    if not rows:
        return []
    lines = [
        "| extension | peer | peer / extension, 30 levels | 60 levels | slant scenes: least | geometric mean |",
        "|---|---|---:|---:|---:|---:|",
    ]
    for r in rows:
        cols = [
            f"{r.upright[n][0]:.1f} (errors {r.upright[n][1]:+d}, {r.upright[n][2]:+d})" if n in r.upright else ""
            for n in (30, 60)
        ]
        slant = [f"{x:.1f}" if x is not None else "" for x in (r.slant_least, r.slant_mean)]
        lines.append(f"| {r.extension} | {r.peer} | " + " | ".join(cols + slant) + " |")
    return lines


def markdown(cells: list[Cell], saved: list[tuple[str, str, float, int]], targets: dict[str, Any]) -> str:
    """The tables of ``bench.md``."""
    settings = [s for s in SETTINGS if any(c.setting == s for c in cells)]
    lines = ["| scene | closed form | " + " | ".join(settings) + " |", "|---|---|" + "---|" * len(settings)]
    keys = sorted({(c.family, c.parameter) for c in cells}, key=lambda k: (k[0], k[1]))
    by = {(c.setting, c.family, c.parameter): c for c in cells}
    for family, parameter in keys:
        first = next(c for c in cells if (c.family, c.parameter) == (family, parameter))
        label = scene_label(family, parameter)
        expected = "stands" if first.closed_form is None else str(first.closed_form)
        row = []
        for s in settings:
            c = by.get((s, family, parameter))
            row.append(
                ""
                if c is None
                else f"{'stands' if c.collapse_level is None else c.collapse_level} ({c.error:+d}), {c.wall:.2f} s, {c.drift:.2f} mm"
            )
        lines.append(f"| {label} | {expected} | " + " | ".join(row) + " |")
    lines += ["", "Each cell: collapse level (error in levels), median wall time, drift of the standing bricks.", ""]
    lines += [
        "| setting | simulated s per wall s (all cells) | mean abs. error, slant scenes (levels) | peak memory (MB) | upright: exponent of wall time in bricks |",
        "|---|---:|---:|---:|---:|",
    ]
    for s in settings:
        mine = [c for c in cells if c.setting == s]
        slant = [abs(c.error) for c in mine if c.family != "upright"]
        speed = sum(c.simulated for c in mine) / sum(c.wall for c in mine)
        exponent = targets["exponents"].get(s)
        lines.append(
            f"| {s} | {speed:.1f} | {f'{statistics.mean(slant):.2f}' if slant else '-'} | "
            f"{max(c.peak_memory for c in mine):.0f} | {'' if exponent is None else f'{exponent:.2f}'} |"
        )
    lines += ["", *ratios(cells)]
    if any(len(c.walls.split()) > 1 for c in cells):
        lines += ["", "The same ratios from each cell's fastest round (the machine's other work only ever slows a run):", ""]
        lines += ratios(cells, wall=fastest)
    lines += ["", *phase_lines(cells), "", *certificate_lines(cells)]
    if saved:
        lines += ["", "| switched off (extension report) | scene | median wall time | physics steps |", "|---|---|---:|---:|"]
        lines += [f"| {name} | {scene} | {wall:.3f} s | {steps} |" for name, scene, wall, steps in saved]
    if targets["peer"]:
        lines += ["", *peer_lines(targets["peer"])]
    ratio = targets.get("30-level speed-up, raw 240 Hz / extension")
    if ratio:
        lines += ["", f"30-level 4 stack: raw 240 Hz takes {ratio:.0f} times the extension's wall time."]
    return "\n".join(lines) + "\n"


def phase_lines(cells: list[Cell]) -> list[str]:
    """Markdown lines: where the wall time of each collapsing scene goes, per setting: the
    seconds in the engine's own steps and the seconds after the collapse was decided (the
    settle time). Empty without collapsing scenes."""
    slant = [c for c in cells if c.closed_form is not None]
    settings = [s for s in SETTINGS if any(c.setting == s for c in slant)]
    if not settings:
        return []
    by = {(c.setting, c.family, c.parameter): c for c in slant}
    lines = ["| scene | " + " | ".join(settings) + " |", "|---|" + "---:|" * len(settings)]
    for family, parameter in sorted({(c.family, c.parameter) for c in slant}):
        row = [
            f"{c.wall:.2f}: {c.engine:.2f}, {c.after_collapse:.2f}" if (c := by.get((s, family, parameter))) else ""
            for s in settings
        ]
        lines.append(f"| {family}, {parameter:g} mm | " + " | ".join(row) + " |")
    lines += ["", "Each cell: wall time: the seconds of it in the engine's own steps, and after the collapse was decided."]
    return lines


def certificate_lines(cells: list[Cell]) -> list[str]:
    """Markdown lines: the most any run of each setting spent proving that its structure stands
    (rigid-block equilibrium of the final state, :class:`stackdsl.Certificate`), in seconds and
    as a share of that run's wall time."""
    lines = ["| setting | certificate, most | share of the run's wall time, most (scene) |", "|---|---:|---:|"]
    for s in [s for s in SETTINGS if any(c.setting == s for c in cells)]:
        mine = [c for c in cells if c.setting == s and c.wall > 0]
        worst = max(mine, key=lambda c: c.certificate / c.wall)
        lines.append(
            f"| {s} | {max(c.certificate for c in mine) * 1000:.1f} ms | "
            f"{worst.certificate / worst.wall:.1%} ({scene_label(worst.family, worst.parameter)}) |"
        )
    return lines


BASE = "extension report"
"""The setting every other is measured against in :func:`ratios`."""


def fastest(cell: Cell) -> float:
    """A cell's fastest run, seconds (its wall time when ``walls`` lists no run).

    >>> from stackdsl.bench.bench import Cell
    >>> fastest(Cell("s", "f", 1.0, 2, None, None, 0, 0.0, 0.2, "0.150 0.200 0.310", 0.1, 0.0, 1.0, 5.0, 90.0, 10, 0))
    0.15
    """
    return min((float(w) for w in cell.walls.split()), default=cell.wall)


def ratios(cells: list[Cell], base: str = BASE, wall: Callable[[Cell], float] = lambda c: c.wall) -> list[str]:
    """Markdown lines: per scene, each setting's wall time (``wall`` of a cell: the median by
    default, or :func:`fastest`) divided by ``base``'s on the same scene in the same run (above
    1: slower than ``base``), then the geometric mean per setting over the scenes of each
    family. Empty without ``base``'s cells."""
    settings = [s for s in SETTINGS if s != base and any(c.setting == s for c in cells)]
    by = {(c.setting, c.family, c.parameter): c for c in cells}
    keys = sorted({(c.family, c.parameter) for c in cells if c.setting == base})
    if not keys or not settings:
        return []
    lines = [
        f"| scene | {base} | " + " | ".join(f"{s} / {base}" for s in settings) + " |",
        "|---|---:|" + "---:|" * len(settings),
    ]
    logs: dict[tuple[str, str], list[float]] = {}
    for family, parameter in keys:
        ref = by[(base, family, parameter)]
        row = []
        for s in settings:
            c = by.get((s, family, parameter))
            row.append(f"{wall(c) / wall(ref):.2f}" if c else "")
            if c:
                logs.setdefault((family, s), []).append(float(np.log(wall(c) / wall(ref))))
        label = scene_label(family, parameter)
        lines.append(f"| {label} | {wall(ref):.2f} s | " + " | ".join(row) + " |")
    for family in sorted({f for f, _ in keys}):
        means = [f"{np.exp(np.mean(logs[(family, s)])):.2f}" if (family, s) in logs else "" for s in settings]
        lines.append(f"| {family}: geometric mean | | " + " | ".join(means) + " |")
    return lines
