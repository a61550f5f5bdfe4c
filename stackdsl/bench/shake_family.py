"""The shake family of ``stackdsl bench verdicts``: one block on a shake table at peak
accelerations from 0.8 to 1.2 of its closed-form threshold, against the closed forms and the
motion they are the onset of (:mod:`stackdsl.bench.shake_models`).

A block of half-width ``b`` along the shake and centre of mass ``h`` above its base, friction
coefficient ``mu``, slides from ``a > mu g`` and tips from ``a > g b / h``, whichever is lower
(docs/actions.md, "The closed forms it is checked against"). Each block of :data:`BLOCKS` is
shaken at each of its frequencies for one second (``A (1 - cos 2 pi f t)``, whole periods), then
left for the scenario's settle time (2 s). Sample ``k`` of a (block, frequency) cell of ``n``
has the peak acceleration ``1 + 0.2 v |v|`` times the threshold, ``v = -1 + 2 (k + u) / n``
with ``u`` drawn from ``SeedSequence([seed, FAMILY], spawn_key=(cell, k))``: one sample in each
of ``n`` strata from 0.8 to 1.2, denser near 1 (a quarter of them within 1.6% of it).

What a run is said to do, from the block's motion in the table's frame (:class:`Motion`):
*topples* (it ends tilted more than :data:`FALLEN`), *rocks* (it tilted more than :data:`ROCKED`
and came back), *slides* (its base's centre slipped more than :data:`SLID`), else *stays*.
The reference says the same of the model block (:func:`reference`): below the threshold it
stays; above it the Coulomb block slips (:func:`stackdsl.bench.shake_models.coulomb_slip`) or
the rigid block rocks, and topples or not (:func:`stackdsl.bench.shake_models.rocking`), judged
with the same thresholds. The reference's collapse verdict: it topples, or it slips further
than the collapse threshold. A run that rocked or slid and came back within the threshold but
is called a collapse is counted apart.

Units: metres, seconds, radians in code; the tables print mm, degrees and ratios. Source:
stackdsl's own (the closed forms and models as cited there).
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

import numpy as np

from ..runtime.loop import Subscriber
from .shake_models import G, coulomb_slip, rocking

if TYPE_CHECKING:
    from ..runtime.loop import StepLoop

#: Entropy mixed with the seed.
FAMILY = 7002
#: Radians: a block tilted more than this at the end has toppled.
FALLEN = math.radians(45.0)
#: Radians: a block tilted more than this has rocked (a woken block settles on its contacts by
#: 0.1 to 0.6 deg: docs/results/shake-table.md).
ROCKED = math.radians(1.0)
#: Metres: a block whose base's centre slipped more than this on the table has slid (MuJoCo's
#: compliant contacts let a block creep 0.35 mm at 0.9 of mu g).
SLID = 0.0005
#: Metres and radians: a block whose base slipped more than this, or that tilted more than
#: this, moved at all (the onset of motion; a block at rest on pybullet tilts 0.01 to 0.02 deg).
STIRRED = 1e-5
STIRRED_TILT = math.radians(0.05)
#: Seconds the table shakes; seconds a run (and the rocking model) goes on after it.
DURATION = 1.0
SETTLE = 2.0
#: Ratio bands of the peak acceleration to the threshold, (lower, upper].
BANDS: tuple[tuple[float, float], ...] = ((0.8, 0.9), (0.9, 0.95), (0.95, 1.0), (1.0, 1.05), (1.05, 1.1), (1.1, 1.2))
#: The motions, in the order of the tables.
MOTIONS = ("stays", "slides", "rocks", "topples")


@dataclass(frozen=True)
class Block:
    """A block on the table: its name, size (m, x y z of its brick type), how it is turned
    (``roll``, ``pitch`` in degrees, the scenario's), its height above the table when placed
    (m), the shake's direction (x, y), its half-width along the shake and the height of its
    centre of mass (m), its friction coefficient and the frequencies (Hz) it is shaken at."""

    name: str
    size: tuple[float, float, float]
    roll: float
    pitch: float
    height: float
    direction: tuple[int, int]
    half_width: float
    half_height: float
    mu: float
    frequencies: tuple[float, ...]

    @property
    def tips(self) -> bool:
        """It tips before it slides: ``b / h < mu``."""
        return self.half_width / self.half_height < self.mu

    @property
    def threshold(self) -> float:
        """m/s^2: the lower of ``mu g`` and ``g b / h``."""
        return min(self.mu * G, G * self.half_width / self.half_height)


KAPLA = (0.120, 0.024, 0.008)
#: The blocks, with KAPLA's (and the built-in material's) friction coefficient 0.5.
BLOCKS: tuple[Block, ...] = (
    Block("40 x 80 x 36 mm block, along x", (0.040, 0.080, 0.036), 0, 0, 0.036, (1, 0), 0.020, 0.018, 0.5, (2.0,)),
    Block("KAPLA flat, along y", KAPLA, 0, 0, 0.008, (0, 1), 0.012, 0.004, 0.5, (2.0,)),
    Block("KAPLA on edge, along y", KAPLA, 90, 0, 0.024, (0, 1), 0.004, 0.012, 0.5, (2.0, 4.0, 8.0)),
    Block("KAPLA on end, along x", KAPLA, 0, 90, 0.120, (1, 0), 0.004, 0.060, 0.5, (2.0, 4.0, 8.0)),
    Block("KAPLA on end, along y", KAPLA, 0, 90, 0.120, (0, 1), 0.012, 0.060, 0.5, (2.0, 4.0, 8.0)),
)
#: (block, frequency) cells, in order.
CELLS: tuple[tuple[Block, float], ...] = tuple((b, f) for b in BLOCKS for f in b.frequencies)


def band_of(ratio: float) -> int | None:
    """The index in :data:`BANDS` of ``ratio`` (a ratio of 0.8 is in the first band), or None outside them."""
    return next((i for i, (low, high) in enumerate(BANDS) if low < ratio <= high or (i == 0 and ratio == low)), None)


def ratio_of(seed: int, cell: int, k: int, per_cell: int) -> float:
    """The aimed ratio of peak acceleration to threshold of sample ``k`` of ``cell`` (module docstring)."""
    u = float(np.random.default_rng(np.random.SeedSequence([seed, FAMILY], spawn_key=(cell, k))).uniform())
    v = -1 + 2 * (k + u) / per_cell
    return 1 + 0.2 * v * abs(v)


def scenario_text(block: Block, frequency: float, amplitude: float, name: str) -> str:
    """The scenario of ``block`` shaken by ``amplitude`` (m) at ``frequency`` (Hz)."""
    x, y, z = (v * 1000 for v in block.size)
    dx, dy = block.direction
    return f"""stackdsl: 1
name: {name}
brick_types: {{blk: {{size: [{x:g} mm, {y:g} mm, {z:g} mm]}}}}
structure: {{bricks: [{{id: b, brick: blk, at: [0, 0, {block.height * 500:g} mm], roll: {block.roll:g}, pitch: {block.pitch:g}}}]}}
timing: {{settle: {SETTLE:g} s}}
actions:
  - shake: {{amplitude: {amplitude * 1000:.6f} mm, frequency: {frequency:g} Hz, duration: {DURATION:g} s, direction: [{dx}, {dy}], at: 1 s}}
"""


@dataclass(frozen=True)
class Reference:
    """What the model block does (module docstring): its motion (one of :data:`MOTIONS`), its
    collapse level (1 or None), the largest slip (m) and tilt (rad), and the final slip (m)."""

    motion: str
    level: int | None
    slip: float
    tilt: float
    final_slip: float


def reference(block: Block, amplitude: float, frequency: float, periods: int, threshold: float) -> Reference:
    """The model block's motion on a table shaken by ``amplitude`` (m) at ``frequency`` (Hz)
    for ``periods`` periods; ``threshold``: the run's collapse threshold (m)."""
    if block.tips:
        r = rocking(block.half_width, block.half_height, amplitude, frequency, periods, SETTLE)
        motion = "topples" if r.toppled else "rocks" if r.largest > ROCKED else "stays"
        return Reference(motion, 1 if r.toppled else None, 0.0, r.largest, 0.0)
    final, largest = coulomb_slip(amplitude, frequency, periods, block.mu)
    final = abs(final)
    return Reference("slides" if largest > SLID else "stays", 1 if final > threshold else None, largest, 0.0, final)


class Motion(Subscriber):
    """The block's largest slip (m: its base's centre on the table, in the table's frame) and
    tilt (rad, from its placed orientation) after each step, and both at the last step."""

    def __init__(self, brick: str = "b") -> None:
        self.brick = brick
        self.slip = self.tilt = self.final_slip = self.final_tilt = 0.0

    def after_step(self, loop: StepLoop) -> None:
        from scipy.spatial.transform import Rotation

        record = loop.structure.records.get(self.brick)
        if record is None:
            return
        offset = (0.0, 0.0, 0.0)
        for action in loop.program.actions:
            if action.kind == "shake":
                offset = action.at(loop.now)[0]
        position, q = loop.world.pose_floats(record.body)
        placed = Rotation.from_quat(record.pose.orientation)
        turned = Rotation.from_quat(q) * placed.inv()
        down = np.array([0.0, 0.0, float(record.corners[:, 2].min()) - float(record.pose.position[2])])  # to the base's centre
        base = np.asarray(position) + turned.apply(down) - np.asarray(offset)
        start = np.asarray(record.pose.position) + down
        self.final_slip = float(math.hypot(base[0] - start[0], base[1] - start[1]))
        self.final_tilt = float(turned.magnitude())
        self.slip, self.tilt = max(self.slip, self.final_slip), max(self.tilt, self.final_tilt)

    @property
    def motion(self) -> str:
        """One of :data:`MOTIONS` (module docstring)."""
        if self.final_tilt > FALLEN:
            return "topples"
        if self.tilt > ROCKED:
            return "rocks"
        return "slides" if self.slip > SLID else "stays"


@dataclass(frozen=True)
class ShakeRun:
    """One run of a shake sample: its :class:`stackdsl.bench.verdicts.Run` and what the block
    did (:class:`Motion`): its motion, largest and final slip (m) and tilt (rad)."""

    run: Any
    motion: str
    slip: float
    tilt: float
    final_slip: float
    final_tilt: float


@dataclass(frozen=True)
class ShakeSample:
    """One shake sample: its number (cell * per-cell + k), block name, frequency (Hz, as the
    compiler fitted it), amplitude (m), ratio of peak acceleration to threshold, which
    threshold ("slides" or "tips"), the collapse threshold (m), the reference, its runs, and
    an internal error that kept it from being drawn ('' else)."""

    sample: int
    block: str
    frequency: float
    amplitude: float
    ratio: float
    kind: str
    threshold: float
    reference: Reference | None
    runs: tuple[ShakeRun, ...]
    error: str = ""


def shake_run(text: str, setting: Any, timeout: float) -> ShakeRun:
    """Run the scenario ``text`` in ``setting`` (:class:`stackdsl.bench.verdicts.Setting`)
    with a :class:`Motion` subscriber; an internal error is the run's ``error``."""
    from ..compile.compiler import compile_scenario
    from ..lang.loader import parse_scenario
    from ..runtime.run import run_program
    from ..verdicts.golden_compare import near_tie
    from .verdicts import Run

    motion = Motion()
    try:
        scenario = parse_scenario(text, "shake.yaml")
        program = compile_scenario(scenario, setting.mode, setting.model, setting.backend)
        outcome = run_program(program, timeout=timeout, subscribers=(motion,))
    except Exception as exc:  # this run's internal error, reported with it
        message = (str(exc).splitlines() or [""])[0]
        return ShakeRun(Run(setting.name, 0.0, None, 0.0, error=f"{type(exc).__name__}: {message}"), "", 0, 0, 0, 0)
    level = outcome.collapse.level if outcome.collapse else None
    c = outcome.certificate
    certified = c is not None and (c.verdict == "collapse" if level is not None else c.kind == "equilibrium")
    active = tuple(n.id for n in outcome.final_graph.nodes if n.state == "active" and n.level is not None)
    run = Run(
        setting.name,
        scenario.timing.drop_gap,
        level,
        outcome.wall_time,
        active,
        outcome.stopped or "",
        certified,
        near_tie(outcome, program),
        c.kind if c is not None and level is not None else "",
    )
    return ShakeRun(run, motion.motion, motion.slip, motion.tilt, motion.final_slip, motion.final_tilt)


def shake_batch(seed: int, cell: int, samples: Sequence[int], per_cell: int, settings: Sequence[str]) -> list[ShakeSample]:
    """Samples ``samples`` of ``cell`` (an index into :data:`CELLS`), each run in ``settings``
    (names of :data:`stackdsl.bench.verdicts.SETTINGS`); a worker's task."""
    from ..compile.compiler import compile_scenario
    from ..compile.program import Shake
    from ..lang.loader import parse_scenario
    from .verdicts import SETTINGS, TIMEOUT

    block, frequency = CELLS[cell]
    out = []
    for k in samples:
        number = cell * per_cell + k
        try:
            aimed = ratio_of(seed, cell, k, per_cell)
            amplitude = aimed * block.threshold / (2 * math.pi * frequency) ** 2
            text = scenario_text(block, frequency, amplitude, f"{block.name} at {aimed:.4f} of its threshold, {frequency:g} Hz")
            program = compile_scenario(parse_scenario(text, "shake.yaml"))
            shake = next(a for a in program.actions if isinstance(a, Shake))
            ratio = shake.peak_acceleration / block.threshold
            ref = reference(block, shake.amplitude, shake.frequency, shake.periods, program.collapse_threshold)
        except Exception as exc:  # this sample's internal error, reported with it
            out.append(ShakeSample(number, block.name, frequency, 0.0, 0.0, "", 0.0, None, (), f"{type(exc).__name__}: {exc}"))
            continue
        runs = tuple(shake_run(text, SETTINGS[name], TIMEOUT) for name in settings)
        kind = "tips" if block.tips else "slides"
        out.append(
            ShakeSample(number, block.name, shake.frequency, shake.amplitude, ratio, kind, program.collapse_threshold, ref, runs)
        )
    return out


def run_shakes(
    seed: int, per_cell: int, jobs: int, settings: Sequence[str], each: Callable[[list[ShakeSample]], None] = lambda b: None
) -> list[ShakeSample]:
    """``per_cell`` samples of every cell of :data:`CELLS`, each run in ``settings``, on ``jobs``
    processes, in sample order; a task whose worker dies is its samples' error."""
    from ..batch.pool import WorkerLost, fan_out

    step = 5
    tasks = [
        (seed, c, tuple(range(s, min(s + step, per_cell))), per_cell, tuple(settings))
        for c in range(len(CELLS))
        for s in range(0, per_cell, step)
    ]

    def lost(task: tuple[Any, ...], error: WorkerLost) -> list[ShakeSample]:
        block, frequency = CELLS[task[1]]
        return [
            ShakeSample(task[1] * per_cell + k, block.name, frequency, 0.0, 0.0, "", 0.0, None, (), f"worker lost: {error}")
            for k in task[2]
        ]

    results: list[ShakeSample] = []
    costs = [1.0 * len(t[2]) * len(settings) for t in tasks]
    for batch in fan_out(shake_batch, tasks, costs, jobs, here=False, lost=lost):
        results += batch
        each(batch)
    return sorted(results, key=lambda s: s.sample)


def _band_name(i: int) -> str:
    low, high = BANDS[i]
    return f"{low:g}-{high:g}"


def came_back(sample: ShakeSample, run: ShakeRun) -> bool:
    """The run calls a collapse of a block that did not topple and ended within the collapse
    threshold of its place (it rocked or slid, and came back or was still rocking)."""
    return not run.run.error and run.run.level is not None and run.motion != "topples" and run.final_slip < sample.threshold


def onset(points: Sequence[tuple[float, str]]) -> str:
    """The first motion of (ratio, motion) pairs: the least ratio at which the block did more
    than stay, in % of the closed form, with '*' when it stayed at some larger ratio (not
    monotonic), or '-' when it never moved."""
    moved = sorted(r for r, m in points if m != "stays")
    if not moved:
        return "-"
    still_above = any(m == "stays" and r > moved[0] for r, m in points)
    return f"{moved[0] * 100:.1f}%" + ("*" if still_above else "")


def stirred(run: ShakeRun) -> bool:
    """The block moved at all on the table (slipped more than :data:`STIRRED` or tilted more
    than :data:`STIRRED_TILT`)."""
    return run.slip > STIRRED or run.tilt > STIRRED_TILT


def onset_within(points: Sequence[tuple[float, bool]], tolerance: float = 0.05) -> bool:
    """Whether the onset of motion of (ratio, moved) pairs is within ``tolerance`` of the closed
    form (ratio 1): still at every ratio below ``1 - tolerance``, moved at every ratio above
    ``1 + tolerance``."""
    return all(moved == (r > 1) for r, moved in points if abs(r - 1) > tolerance)


def _runs(s: ShakeSample, name: str) -> list[ShakeRun]:
    """The runs of sample ``s`` in setting ``name`` that ended without an internal error."""
    return [r for r in s.runs if r.run.setting == name and not r.run.error]


def _count(subset: Sequence[ShakeSample], name: str, same: Callable[[ShakeSample, ShakeRun], bool]) -> tuple[int, int]:
    """(runs that ``same`` holds for, runs) of ``subset`` in setting ``name``."""
    ran = [(s, r) for s in subset for r in _runs(s, name)]
    return sum(same(s, r) for s, r in ran), len(ran)


def _same_verdict(s: ShakeSample, r: ShakeRun) -> bool:
    return s.reference is not None and r.run.level == s.reference.level


def _same_motion(s: ShakeSample, r: ShakeRun) -> bool:
    return s.reference is not None and r.motion == s.reference.motion


def _cells(good: Sequence[ShakeSample]) -> list[tuple[Block, float, list[ShakeSample]]]:
    """Each (block, frequency) cell of :data:`CELLS` with its samples, the cells with none left out."""
    out = []
    for block, frequency in CELLS:
        mine = [s for s in good if s.block == block.name and round(s.frequency) == round(frequency)]
        if mine:
            out.append((block, frequency, mine))
    return out


def _cell_head(block: Block, frequency: float) -> str:
    kind = "mu g" if not block.tips else "g b / h"
    return f"{block.name:<32} {frequency:>3g} Hz {block.threshold:>5.3f} {kind:<6}"


def _verdict_table(
    samples: Sequence[ShakeSample],
    good: Sequence[ShakeSample],
    bands: list[list[ShakeSample]],
    settings: Sequence[str],
    seconds: float,
) -> list[str]:
    """Each setting's collapse verdicts against the reference, by ratio band."""
    from .verdicts import _cell

    head = f"{'setting':<25} " + " ".join(f"{_band_name(i):^14}" for i in range(len(BANDS)))
    lines = [
        f"{len(samples)} shake samples: {len(CELLS)} (block, frequency) cells from 0.8 to 1.2 of the closed-form threshold "
        f"({sum(s.kind == 'slides' for s in good)} at mu g, {sum(s.kind == 'tips' for s in good)} at g b / h), "
        + ", ".join(f"{len(b)} at {_band_name(i)}" for i, b in enumerate(bands))
        + f"; {seconds:.0f} s wall",
        "collapse verdicts against the reference (below the threshold it stands; above it the Coulomb block's slip past "
        "the collapse threshold, or the rigid rocking block toppling, is a collapse), agreeing/runs by peak acceleration "
        "/ threshold; 'upright': called a collapse, yet it did not topple and ended within the collapse threshold of its place",
        f"{head} {'upright':>9} {'no cert.':>8} {'errors':>6} {'median wall':>11}",
    ]
    for name in settings:
        mine = [r.run for s in good for r in s.runs if r.run.setting == name]
        walls = [r.wall for r in mine if not r.error] or [0.0]
        back = sum(came_back(s, r) for s in good for r in _runs(s, name))
        lines.append(
            f"{name:<25} {' '.join(_cell(_count(b, name, _same_verdict)) for b in bands)} {back:>9} "
            f"{sum(not r.error and not r.certified for r in mine):>8} {sum(bool(r.error) for r in mine):>6} "
            f"{float(np.median(walls)) * 1000:>8.0f} ms"
        )
    lines += [
        "",
        f"motions against the reference's (stays; slides: its base slipped > {SLID * 1000:g} mm; rocks: tilted > "
        f"{math.degrees(ROCKED):g} deg and came back; topples: ends tilted > {math.degrees(FALLEN):g} deg), agreeing/runs",
        head,
    ]
    lines += [f"{name:<25} {' '.join(_cell(_count(b, name, _same_motion)) for b in bands)}" for name in settings]
    return lines


def _onset_tables(good: Sequence[ShakeSample], settings: Sequence[str]) -> list[str]:
    """The first motion and the onset of motion of each (block, frequency) cell, in % of the
    closed form, and how many cells' onsets are within 5% of it."""
    lines = [
        "",
        "first motion (the least ratio at which the block did more than stay) in % of the closed form; "
        "*: it stayed at some larger ratio",
        f"{'block':<32} {'f':>5} {'threshold':>12} {'reference':>10} " + " ".join(f"{n:>25}" for n in settings),
    ]
    cells = _cells(good)
    for block, frequency, mine in cells:
        ref = onset([(s.ratio, s.reference.motion) for s in mine if s.reference is not None])
        firsts = [onset([(s.ratio, r.motion) for s in mine for r in _runs(s, name)]) for name in settings]
        lines.append(f"{_cell_head(block, frequency)} {ref:>10} " + " ".join(f"{x:>25}" for x in firsts))
    lines += [
        "",
        f"onset of motion (the least ratio at which the block moved at all: slipped > {STIRRED * 1000:g} mm or tilted > "
        f"{math.degrees(STIRRED_TILT):g} deg) in % of the closed form; *: it stayed still at some larger ratio; "
        "the closed form's own is 100%",
        f"{'block':<32} {'f':>5} {'threshold':>12} " + " ".join(f"{n:>25}" for n in settings),
    ]
    within = {name: 0 for name in settings}
    for block, frequency, mine in cells:
        onsets = []
        for name in settings:
            points = [(s.ratio, stirred(r)) for s in mine for r in _runs(s, name)]
            within[name] += onset_within(points)
            onsets.append(onset([(ratio, "moves" if moved else "stays") for ratio, moved in points]))
        lines.append(f"{_cell_head(block, frequency)} " + " ".join(f"{x:>25}" for x in onsets))
    lines.append(
        "cells whose onset is within 5% of the closed form (still below 95%, moving above 105%): "
        + ", ".join(f"{name} {within[name]}/{len(cells)}" for name in settings)
    )
    return lines


def _disagreements(samples: Sequence[ShakeSample], good: Sequence[ShakeSample], settings: Sequence[str]) -> list[str]:
    """Every verdict and motion that differs from the reference's, and the runs that stopped."""
    from .verdicts import _failures, _level

    wrong = [(s, r) for s in good for name in settings for r in _runs(s, name) if not _same_verdict(s, r)]
    lines = [
        "",
        f"verdict disagreements: {len(wrong)}"
        + (": sample, block, f, ratio, setting, measured (reference), motion" if wrong else ""),
    ]
    for s, r in wrong:
        lines.append(_shake_line(s, r, _level(r.run.level), _level(s.reference.level if s.reference else None)))
    moved = [(s, r) for s in good for name in settings for r in _runs(s, name) if not _same_motion(s, r)]
    lines += [
        f"motion disagreements: {len(moved)}" + (": sample, block, f, ratio, setting, motion (reference's)" if moved else "")
    ]
    for s, r in moved:
        lines.append(_shake_line(s, r, r.motion, s.reference.motion if s.reference else ""))
    failed = [line for s in samples for line in _failures(f"{s.sample:5d}", s.error, [r.run for r in s.runs], at_gap=False)]
    lines += ["runs that stopped with an internal error:", *failed] if failed else []
    return lines


def format_shakes(samples: Sequence[ShakeSample], settings: Sequence[str], seconds: float) -> str:
    """The shake family's tables: each setting's collapse verdicts and motions against the
    reference by ratio band, the first motion and the onset of motion of each (block,
    frequency) cell against the closed form (100%), and every disagreement."""
    good = [s for s in samples if not s.error and s.reference is not None and band_of(s.ratio) is not None]
    bands = [[s for s in good if band_of(s.ratio) == i] for i in range(len(BANDS))]
    lines = _verdict_table(samples, good, bands, settings, seconds)
    lines += _onset_tables(good, settings)
    lines += _disagreements(samples, good, settings)
    return "\n".join(lines)


def _shake_line(s: ShakeSample, r: ShakeRun, measured: str, expected: str) -> str:
    ref = s.reference
    model = f"model: slip {ref.slip * 1000:.2f} mm, tilt {math.degrees(ref.tilt):.1f} deg" if ref else ""
    proof = f" ({r.run.proof})" if r.run.proof else ""
    return (
        f"  {s.sample:5d}  {s.block:<32} {s.frequency:>3g} Hz  x{s.ratio:.3f}  {r.run.setting:<25} {measured}{proof} ({expected}); "
        f"slip {r.slip * 1000:.2f} mm, tilt {math.degrees(r.tilt):.1f} deg, at the end {r.final_slip * 1000:.2f} mm, "
        f"{math.degrees(r.final_tilt):.1f} deg; {model}"
    )
