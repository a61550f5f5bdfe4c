"""The near-tie family of ``stackdsl bench verdicts``: single-file stacks and two-brick overhangs
whose deciding brick sits 0 to 1 mm inside or outside its tipping edge, against the exact
centre-of-mass rule (:func:`stackdsl.bench.verdicts.exact_margin`).

Sample ``k`` of ``seed`` is drawn from ``SeedSequence([seed, FAMILY], spawn_key=(k,))``. Its
margin band and side are set by ``k`` so that every band of :data:`BANDS` (0-0.1, 0.1-0.2,
0.2-0.5, 0.5-1 mm) holds the same number of samples inside and outside: ``k mod 4`` is the
band, ``k // 4 mod 2`` the side (0: inside, the stack stands; 1: outside, it falls at its top
brick), and every fourth group of eight is a two-brick overhang (the others are stacks of 3 to
:data:`MOST` bricks). The margin is drawn uniformly within its band.

A stack's lower bricks are the random single-file stack's walk (each centre ``U(-L/2, L/2)``
from the one below, ``sweeps/random_single_file.yaml``), redrawn until every prefix stands by
more than :data:`CLEAR` (so its verdict is the top brick's). The top brick is then placed where
the least interface margin of the whole stack (:func:`stackdsl.bench.random_stack.interface_margins`:
``L/2 - |mean of x(j+1..n) - x(j)|``) is the drawn margin, plus inside or minus outside: that
least margin is a concave function of the top brick's centre, so each value it takes below its
peak is taken once on either side of the peak, and a side is drawn. The scenario places every
brick with ``at:`` to 1 nm; the exact rule judges the centres the compiler placed.

Units: metres in code, millimetres in the scenario files and tables. Source: stackdsl's own.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from .random_stack import LENGTH, interface_margins

#: Entropy mixed with the seed, so that sample k is not assembly k's draw.
FAMILY = 7001
#: Metres: the margin bands the family fills (lower, upper], and the one above 1 mm (the random
#: single-file stack's; the family draws none there).
BANDS: tuple[tuple[float, float], ...] = ((0.0, 0.0001), (0.0001, 0.0002), (0.0002, 0.0005), (0.0005, 0.001), (0.001, np.inf))
#: Metres every prefix of a stack under its top brick stands by.
CLEAR = 0.002
#: The most bricks a stack has.
MOST = 8
#: Samples one task draws and runs.
BATCH = 20

THICKNESS = 0.008


@dataclass(frozen=True)
class Draw:
    """One drawn sample: its number, its shape ("overhang": two bricks; "stack": 3 to
    :data:`MOST`), its side ("inside": it stands; "outside": it falls at its top brick), the
    margin aimed at (m), the brick centres along x (m, bottom first) and the scenario's text."""

    sample: int
    shape: str
    side: str
    target: float
    x: tuple[float, ...]
    text: str


def band_of(margin: float) -> int:
    """The index in :data:`BANDS` of ``margin`` (m; a margin of 0 is in the first band)."""
    return next(i for i, (low, high) in enumerate(BANDS) if margin <= high and (margin > low or i == 0))


def least_margin(x: Sequence[float] | np.ndarray) -> float:
    """Metres: the least interface margin of the stack of centres ``x`` (bottom first; negative:
    it does not stand). One brick or none: infinite."""
    return float(interface_margins(x).min()) if len(x) > 1 else float("inf")


def top_at(below: Sequence[float] | np.ndarray, target: float, right: bool) -> float:
    """The centre (m) of a brick put on the stack ``below`` (centres, m, bottom first) at which
    the whole stack's least interface margin is ``target`` (m, negative: outside), on the side
    of the peak toward +x when ``right``. Bisection on the concave least margin.

    Raises:
        ValueError: the least margin never reaches ``target`` (the stack below leaves no room).

    >>> round(top_at([0.0], 0.0005, True) * 1000, 6)  # a two-brick overhang 0.5 mm inside
    59.5
    """
    below = list(below)
    last = below[-1]
    grid = np.linspace(last - LENGTH / 2, last + LENGTH / 2, 2401)
    x = np.asarray(below)
    above = np.cumsum(x[::-1])[::-1] - x  # the centres above each brick below, summed, without the top's
    carried = np.arange(len(x), 0, -1)  # how many bricks each carries, the top one included
    values = (LENGTH / 2 - np.abs((above[:, None] + grid[None, :]) / carried[:, None] - x[:, None])).min(axis=0)
    peak = float(grid[int(np.argmax(values))])
    if values.max() <= target:
        raise ValueError(f"the stack below stands a top brick by at most {values.max() * 1000:.3f} mm")
    far = last + (LENGTH / 2 + 0.005) * (1 if right else -1)  # past the edge of the brick below: margin < -5 mm
    inner, outer = peak, far
    for _ in range(80):
        mid = (inner + outer) / 2
        inner, outer = (mid, outer) if least_margin([*below, mid]) > target else (inner, mid)
    return float((inner + outer) / 2)


def draw(seed: int, k: int) -> Draw:
    """Sample ``k`` of ``seed`` (module docstring).

    Raises:
        ValueError: ``k`` or ``seed`` negative.
    """
    if seed < 0 or k < 0:
        raise ValueError(f"seed and sample are 0 or more, not {seed}, {k}")
    rng = np.random.default_rng(np.random.SeedSequence([seed, FAMILY], spawn_key=(k,)))
    low, high = BANDS[k % 4]
    side = "inside" if (k // 4) % 2 == 0 else "outside"
    shape = "overhang" if (k // 8) % 4 == 0 else "stack"
    margin = float(rng.uniform(low, high))
    target = margin if side == "inside" else -margin
    right = bool(rng.integers(2))
    while True:
        n = 2 if shape == "overhang" else int(rng.integers(3, MOST + 1))
        below = np.concatenate([[0.0], np.cumsum(rng.uniform(-LENGTH / 2, LENGTH / 2, n - 2))])
        if all(least_margin(below[:m]) > CLEAR for m in range(2, n)):
            try:
                x = (*map(float, below), top_at(below, target, right))
            except ValueError:  # no room on top for this margin: draw the stack below again
                continue
            break
    return Draw(k, shape, side, target, x, scenario_text(f"near tie {seed}-{k}", x))


def scenario_text(name: str, x: Sequence[float]) -> str:
    """The scenario file of a single file of KAPLA bricks at centres ``x`` (m, bottom first)."""
    lines = ["stackdsl: 1", f"name: {name}", "structure:", "  bricks:"]
    for i, c in enumerate(x):
        lines.append(
            f"    - {{id: b{i + 1:02d}, at: [{c * 1000:.6f} mm, 0, {(i + 0.5) * THICKNESS * 1000:g} mm], level: {i + 1}}}"
        )
    return "\n".join([*lines, "timing: {settle: 1 s}", ""])


@dataclass(frozen=True)
class NearTie:
    """One near-tie sample run: its draw (shape, side, the scenario's text), the exact rule's
    collapse level on its placed centres (None: it stands) and margin (m), and its runs
    (:class:`stackdsl.bench.verdicts.Run`, at the scenario's drop gap); ``error``: why it
    could not be drawn or judged, else ''."""

    sample: int
    shape: str
    side: str
    bricks: int
    exact: int | None
    margin: float
    runs: tuple[Any, ...]
    text: str = ""
    error: str = ""


def near_tie_batch(seed: int, samples: Sequence[int], settings: Sequence[str]) -> list[NearTie]:
    """Draw, judge and run ``samples`` of ``seed`` in each of ``settings`` (names of
    :data:`stackdsl.bench.verdicts.SETTINGS`); a worker's task. A sample's internal error is
    its ``error``, not an exception."""
    from ..compile.compiler import compile_scenario
    from ..lang.loader import parse_scenario
    from .verdicts import SETTINGS, exact_margin, run_setting

    out = []
    for k in samples:
        d: Draw | None = None
        try:
            d = draw(seed, k)
            scenario = parse_scenario(d.text, f"near_tie_{k:05d}.yaml")
            places = sorted(compile_scenario(scenario).placements, key=lambda p: p.level)
            level, margin = exact_margin([p.position[0] for p in places])
        except Exception as exc:  # this sample's internal error, reported with it
            out.append(NearTie(k, "", "", 0, None, 0.0, (), d.text if d else "", f"{type(exc).__name__}: {exc}"))
            continue
        runs = tuple(run_setting(scenario, SETTINGS[name], scenario.timing.drop_gap) for name in settings)
        out.append(NearTie(k, d.shape, d.side, len(d.x), level, margin, runs, d.text))
    return out


def run_near_ties(
    seed: int, count: int, jobs: int, settings: Sequence[str], each: Callable[[list[NearTie]], None] = lambda b: None
) -> list[NearTie]:
    """Samples 0 to ``count - 1`` of ``seed``, each run in ``settings``, on ``jobs`` processes,
    in sample order; a task whose worker dies is its samples' error."""
    from ..batch.pool import WorkerLost, fan_out

    tasks = [(seed, tuple(range(s, min(s + BATCH, count))), tuple(settings)) for s in range(0, count, BATCH)]

    def lost(task: tuple[Any, ...], error: WorkerLost) -> list[NearTie]:
        return [NearTie(k, "", "", 0, None, 0.0, (), "", f"worker lost: {error}") for k in task[1]]

    results: list[NearTie] = []
    costs = [0.5 * len(t[1]) * len(settings) for t in tasks]
    for batch in fan_out(near_tie_batch, tasks, costs, jobs, here=False, lost=lost):
        results += batch
        each(batch)
    return sorted(results, key=lambda s: s.sample)


def _band_name(i: int) -> str:
    low, high = BANDS[i]
    return f"> {low * 1000:g} mm" if high == np.inf else f"{low * 1000:g}-{high * 1000:g} mm"


def _agreeing(subset: Sequence[Any], name: str) -> tuple[int, int]:
    """(runs that agree with the exact rule, runs) of ``subset`` in setting ``name``."""
    ran = [(s, r) for s in subset for r in s.runs if r.setting == name and not r.error]
    return sum(r.level == s.exact for s, r in ran), len(ran)


def _agreement_table(
    samples: Sequence[NearTie], good: Sequence[NearTie], wide: Sequence[Any], settings: Sequence[str], seconds: float
) -> list[str]:
    """The head and one row per setting: agreement by margin band and by side."""
    from .verdicts import _cell

    per_band = [[s for s in good if band_of(s.margin) == i] for i in range(len(BANDS) - 1)]
    overhangs = sum(s.shape == "overhang" for s in good)
    lines = [
        f"{len(samples)} near-tie samples ({overhangs} two-brick overhangs, {len(good) - overhangs} stacks of 3 to {MOST}; "
        f"{sum(s.side == 'inside' for s in good)} inside, {sum(s.side == 'outside' for s in good)} outside); "
        + ", ".join(f"{len(b)} at {_band_name(i)}" for i, b in enumerate(per_band))
        + (f"; {len(wide)} random single-file stacks above 1 mm" if wide else "")
        + f"; {seconds:.0f} s wall",
        "agreement with the exact centre-of-mass rule by margin band, agreeing/runs; inside: it stands, outside: it falls "
        "at its top brick",
        f"{'setting':<25} " + " ".join(f"{_band_name(i):^14}" for i in range(len(BANDS))) + f" {'inside':^14} {'outside':^14} "
        f"{'no cert.':>8} {'errors':>6} {'median wall':>11}",
    ]
    for name in settings:
        mine = [r for s in good for r in s.runs if r.setting == name]
        walls = [r.wall for r in mine if not r.error] or [0.0]
        cells = [_cell(_agreeing(b, name)) for b in per_band] + [_cell(_agreeing(wide, name))]
        sides = [_cell(_agreeing([s for s in good if s.side == side], name)) for side in ("inside", "outside")]
        lines.append(
            f"{name:<25} {' '.join(cells)} {' '.join(sides)} {sum(not r.error and not r.certified for r in mine):>8} "
            f"{sum(bool(r.error) for r in mine):>6} {float(np.median(walls)) * 1000:>8.0f} ms"
        )
    return lines


def _disagreements(good: Sequence[NearTie], out: Any) -> list[str]:
    """Every run that disagrees with the exact rule, with the certificate's words; with ``out``
    (a folder), each such sample's scenario written there as ``near_tie_NNNNN.yaml``."""
    from .verdicts import _level

    wrong = [(s, r) for s in good for r in s.runs if not r.error and r.level != s.exact]
    lines = [
        f"disagreements: {len(wrong)}, {sum(bool(r.tie) for _, r in wrong)} that the certificate calls a near tie"
        + (": sample, setting, shape, measured (exact rule), margin; the certificate's words" if wrong else "")
    ]
    written: set[int] = set()
    for s, r in wrong:
        where = ""
        if out is not None:
            path = out / f"near_tie_{s.sample:05d}.yaml"
            if s.sample not in written:
                out.mkdir(parents=True, exist_ok=True)
                path.write_text(s.text)
                written.add(s.sample)
            where = f"  {path.name}"
        tie = f"; {r.tie}" if r.tie else ""
        proof = f" ({r.proof})" if r.proof else ""
        lines.append(
            f"  {s.sample:5d}  {r.setting:<25} {s.shape} of {s.bricks}, {s.side}: {_level(r.level)}{proof} (exact {_level(s.exact)}), "
            f"margin {s.margin * 1000:.3f} mm{tie}{where}"
        )
    return lines


def format_near_ties(
    samples: Sequence[NearTie], settings: Sequence[str], seconds: float, above: Sequence[Any] = (), out: Any = None
) -> str:
    """The agreement table of ``samples`` with the exact rule, one row per setting and one
    column per margin band of :data:`BANDS` (the last, above 1 mm, from ``above``: the random
    single-file stack's :class:`stackdsl.bench.verdicts.Sample` list, when it ran), inside and
    outside apart; then every disagreement with its margin and, where the certificate calls
    the verdict a near tie, its words; then the "stands" certificates' margins against the
    exact rule's (:func:`stackdsl.bench.verdicts.certificate_margins`). With ``out`` (a folder), each misjudged sample's
    scenario is written there as ``near_tie_NNNNN.yaml``."""
    from .verdicts import SETTINGS, _failures, _stands_active, certificate_margins

    good = [s for s in samples if not s.error]
    wide = [s for s in above if not s.error and band_of(s.margin) == len(BANDS) - 1]
    lines = _agreement_table(samples, good, wide, settings, seconds)
    lines += _disagreements(good, out)
    lines += certificate_margins(
        [(f"{s.sample:5d}", s.margin, r) for s in good if s.exact is None for r in s.runs if r.level is None], settings
    )
    lines += _stands_active([(f"{s.sample:5d}", r) for s in good for r in s.runs if SETTINGS[r.setting].extension])
    failed = [line for s in samples for line in _failures(f"{s.sample:5d}", s.error, s.runs, at_gap=False)]
    lines += ["runs that stopped with an internal error:", *failed] if failed else []
    return "\n".join(lines)
