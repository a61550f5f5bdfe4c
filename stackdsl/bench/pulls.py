"""``stackdsl bench pulls``: the sweep of Jenga pulls (``sweeps/jenga_pulls.yaml``), samples a second
with the extension against the lean MuJoCo peer over the same draws.

The extension runs the sweep as ``stackdsl sweep`` runs it (:func:`stackdsl.batch.sweep.run_sweep`,
``jobs`` processes, the file's own engine); the peer runs the same samples (each cell's sample k of
the same template, the same draws) compiled for tuned MuJoCo with its own sleeping at
:data:`stackdsl.bench.actions.PEER_SLEEP_TOLERANCE` in its own loop
(:func:`stackdsl.bench.lean_mujoco.run_lean`), in as many processes, and then on the cheaper
contacts of :data:`stackdsl.bench.actions.CHEAP_PEER`. Each side's processes are
fresh (spawned) and run a one-level tower first, untimed; the wall time of a side is from
handing out the first sample to the last result. The two sides' verdicts (the collapse level,
None: stands) are compared sample by sample, and each side's samples are judged, cell by cell,
against the file's statistical expectations (``p_stands >= 0.9`` for the shipped sweep) as
``stackdsl check`` judges them (:func:`stackdsl.verdicts.stats.decide`).

Source: stackdsl's own.
"""

from __future__ import annotations

import functools
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path

from ..batch.guard import SPAWN
from ..batch.sweep import SampleResult
from ..batch.sweep_out import cell_expectations, verdicts
from ..compile.program import Program
from ..lang.expectations import Expect
from ..lang.loader import load_scenario
from ..lang.sampling import Template
from ..verdicts.stats import expected_text

#: The lean peers that run the samples after the extension: the tuned peer, whose ratio is the
#: table's column, and the same on cheaper contacts (:data:`stackdsl.bench.actions.CHEAP_PEER`).
PEERS = ("MuJoCo lean", "MuJoCo lean pyramidal")

#: The shipped sweep the bench runs by default.
SWEEP = Path("sweeps/jenga_pulls.yaml")


@dataclass(frozen=True)
class Side:
    """One side's run of the samples: wall seconds, and each sample's collapse level (None: stood)."""

    name: str
    seconds: float
    levels: tuple[int | None, ...]

    @property
    def rate(self) -> float:
        """Samples a second."""
        return len(self.levels) / self.seconds if self.seconds > 0 else 0.0


def template(path: Path = SWEEP, samples: int | None = None) -> tuple[Template, Expect]:
    """The sweep's template, with ``samples`` samples (None: the file's own), and its expectations.

    Raises:
        ScenarioError: the file is not a valid sweep.
    """
    from ..lang.errors import ScenarioError

    scenario = load_scenario(path)
    if scenario.template is None:
        raise ScenarioError("this scenario has no sweep and no random field: nothing to sample", file=str(path))
    t: Template = scenario.template
    return (t if samples is None else t.with_samples(samples)), scenario.expect


def _warm(_: int) -> None:
    """A worker's untimed first run: a one-level tower on each side."""
    from ..compile.compiler import compile_scenario
    from ..lang.loader import parse_scenario
    from ..runtime.run import run_program
    from .bench import LEAN_TOLERANCE
    from .lean_mujoco import run_lean

    text = "stackdsl: 1\nstructure: {tower: {levels: 1}}\n"
    run_program(compile_scenario(parse_scenario(text, "warm-up.yaml")))
    for peer in PEERS:
        run_lean(
            _peer_program(compile_scenario(parse_scenario(text, "warm-up.yaml"), mode="tuned", backend="mujoco"), peer),
            tolerance=LEAN_TOLERANCE,
        )


def _peer_program(program: Program, peer: str) -> Program:
    """``program`` on the lean peer ``peer``'s settings (:func:`stackdsl.bench.actions.as_peer`)."""
    from .actions import as_peer

    return as_peer(program, peer)


def _extension(arguments: tuple[Template, int, Sequence[int]]) -> list[int | None]:
    from ..batch.sweep import SweepOptions, run_batch

    t, cell, samples = arguments
    return [r.collapse_level for r in run_batch(t, cell, samples, SweepOptions(timeout=None))]


def _peer(peer: str, arguments: tuple[Template, int, Sequence[int]]) -> list[int | None]:
    from ..compile.compiler import compile_scenario
    from .bench import LEAN_TOLERANCE
    from .lean_mujoco import run_lean

    t, cell, samples = arguments
    out = []
    for k in samples:
        program = _peer_program(compile_scenario(t.scenario(cell, k), mode="tuned", backend="mujoco"), peer)
        out.append(run_lean(program, tolerance=LEAN_TOLERANCE, settle=None).level)
    return out


def run_sides(t: Template, jobs: int = 1, batch: int = 5, cells: int | None = None) -> list[Side]:
    """Run every sample of ``t`` (each grid cell's) with the extension (as ``stackdsl sweep``
    does) and with the lean peer, each on ``jobs`` fresh processes (batches of at most ``batch``
    samples of a cell), one side after the other, the first ``cells`` grid cells only when given;
    see the module's description."""
    samples = list(range(t.samples))
    chunks = [(c, samples[i : i + batch]) for c in range(min(t.cells, cells or t.cells)) for i in range(0, len(samples), batch)]
    sides = []
    works: list[tuple[str, Callable[[tuple[Template, int, Sequence[int]]], list[int | None]]]] = [("extension", _extension)]
    works += [(peer, functools.partial(_peer, peer)) for peer in PEERS]
    for name, work in works:
        with SPAWN.Pool(processes=jobs) as pool:
            pool.map(_warm, range(jobs), chunksize=1)  # each worker's first calls, untimed (one each, as likely as not)
            start = time.perf_counter()
            results = pool.map(work, [(t, c, k) for c, k in chunks], chunksize=1)
            seconds = time.perf_counter() - start
        sides.append(Side(name, seconds, tuple(level for r in results for level in r)))
    return sides


def judged(side: Side, t: Template, expect: Expect, cells: int) -> tuple[dict[str, int], list[str]]:
    """``side``'s samples judged cell by cell (the first ``cells`` of ``t``'s grid, ``t.samples``
    each, in order) against the file's statistical expectations, as ``stackdsl check`` judges a
    sweep (:func:`stackdsl.batch.sweep_out.verdicts`): how many verdicts are PASS, FAIL and
    INCONCLUSIVE, and a line for each that is not PASS (the cell, what was expected and measured,
    and for an undecided one how many samples would decide it)."""
    results = [
        SampleResult(c, k, 0, {}, level, 0, 0.0, 0.0)
        for c in range(cells)
        for k, level in enumerate(side.levels[c * t.samples : (c + 1) * t.samples])
    ]
    counts = {"PASS": 0, "FAIL": 0, "INCONCLUSIVE": 0}
    lines = []
    for c, v in verdicts(t, expect, results):
        if c >= cells:  # a cell this side did not run
            continue
        counts[v.outcome] += 1
        if v.outcome != "PASS":
            more = f"; about {v.samples_to_decide} samples would decide it" if v.samples_to_decide else ""
            lines.append(f"{side.name}, {t.label(c)}: {v.outcome}, {v.expected} expected, {v.measured}{more}")
    return counts, lines


def format_sides(sides: Sequence[Side], t: Template, expect: Expect, jobs: int, cells: int | None = None) -> str:
    """A Markdown table of :func:`run_sides`: each side's wall time, samples a second, how many
    stood, its verdicts against the file's expectations cell by cell (:func:`judged`), and the
    agreement of the verdicts sample by sample."""
    name = t.data.get("name", "sweep")
    ran = min(t.cells, cells or t.cells)
    forms = sorted({expected_text(f) for c in range(ran) for f in cell_expectations(t, expect, c)})
    lines = [
        f"{name}: {ran * t.samples} samples ({ran} of {t.cells} cells x {t.samples}; the same draws on each side), "
        f"{jobs} process(es) a side:",
        "",
        "| side | wall (s) | samples/s | stood | cells PASS / FAIL / INCONCLUSIVE | peer / this |",
        "|---|---:|---:|---:|---:|---:|",
    ]
    peer = next((s for s in sides if s.name == "MuJoCo lean"), None)
    notes = []
    for s in sides:
        ratio = f"{peer.seconds / s.seconds:.1f}" if peer is not None and s is not peer and s.seconds > 0 else ""
        stood = sum(level is None for level in s.levels)
        counts, said = judged(s, t, expect, ran)
        cells_said = " / ".join(str(counts[k]) for k in ("PASS", "FAIL", "INCONCLUSIVE")) if forms else "no expectation"
        lines.append(f"| {s.name} | {s.seconds:.1f} | {s.rate:.2f} | {stood} of {len(s.levels)} | {cells_said} | {ratio} |")
        notes += said
    if forms:
        lines += ["", f"cells: each cell's samples judged against the file's {', '.join(forms)}, as `stackdsl check` does"]
        lines += [f"  {line}" for line in notes]
    if peer is not None:
        lines += ["", "peer / this: the MuJoCo lean peer's wall time over the row's (above 1, the row's side is faster)"]
    for other in sides[2:]:  # a cheaper peer: the first side's ratio against it too
        if other.seconds > 0 and sides[0].seconds > 0:
            lines.append(f"{other.name} / {sides[0].name}: {other.seconds / sides[0].seconds:.1f}")
    if len(sides) >= 2:
        first = sides[0]
        lines.append("")
        for other in sides[1:]:
            same = sum((x is None) == (y is None) for x, y in zip(first.levels, other.levels))
            pair = "" if len(sides) == 2 else f"{first.name} and {other.name}: "
            lines.append(f"{pair}stands or falls alike on {same} of {len(first.levels)} samples")
    return "\n".join(lines)
