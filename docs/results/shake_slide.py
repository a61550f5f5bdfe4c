"""How far the 40 x 80 x 36 mm block of ``stackdsl bench verdicts --families shake`` (mu 0.5,
shaken along x at 2 Hz for one second) slips just past mu g, in every engine and mode, against
the Coulomb block (:func:`stackdsl.bench.shake_models.coulomb_slip`): the largest slip of its
base on the table while it shakes and settles, and where it ends, mm. The last column is tuned
MuJoCo with pyramidal friction cones (MuJoCo's own default) instead of its elliptic ones.

    python docs/results/shake_slide.py [RATIO ...]     # peak acceleration / mu g (default 1.05 1.1 1.2 1.3 1.5)

Output: docs/results/shake-table.md, "The MuJoCo slide".
"""

from __future__ import annotations

import math
import sys

from stackdsl import compile_scenario, parse_scenario
from stackdsl.bench.shake_family import BLOCKS, reference, scenario_text, shake_run
from stackdsl.bench.verdicts import Setting
from stackdsl.compile.program import Shake
from stackdsl.engines.mujoco.settings import MuJoCoSettings

BLOCK, FREQUENCY = BLOCKS[0], 2.0
COLUMNS = [(b, m) for b in ("pybullet", "mujoco") for m in ("raw", "tuned", "extension")] + [("mujoco", "pyramidal")]


def row(ratio: float) -> str:
    """One row of the table: the block at ``ratio`` of mu g."""
    amplitude = ratio * BLOCK.threshold / (2 * math.pi * FREQUENCY) ** 2
    text = scenario_text(BLOCK, FREQUENCY, amplitude, f"at {ratio:g} mu g")
    program = compile_scenario(parse_scenario(text, "shake.yaml"))
    shake = next(a for a in program.actions if isinstance(a, Shake))
    ref = reference(BLOCK, shake.amplitude, shake.frequency, shake.periods, program.collapse_threshold)
    cells = [f"{ref.slip * 1000:.2f}, {ref.final_slip * 1000:.2f}"]
    tuned = dict(MuJoCoSettings.DEFAULTS["tuned"])
    for backend, mode in COLUMNS:
        if mode == "pyramidal":
            MuJoCoSettings.DEFAULTS["tuned"] = dict(tuned, elliptic_cones=False)
        try:
            run = shake_run(text, Setting(mode, "tuned" if mode == "pyramidal" else mode, "report", backend), 120.0)
        finally:
            MuJoCoSettings.DEFAULTS["tuned"] = tuned
        cells.append(f"{run.slip * 1000:.2f}, {run.final_slip * 1000:.2f}" if not run.run.error else run.run.error)
    return f"| {ratio:g} mu g | {shake.amplitude * 1000:.2f} mm | " + " | ".join(cells) + " |"


def main(ratios: list[float]) -> None:
    print("| a_peak | A | Coulomb block | " + " | ".join(f"{b} {m}" for b, m in COLUMNS) + " |")
    print("|---:|---:|---:|" + "---:|" * len(COLUMNS))
    for ratio in ratios:
        print(row(ratio), flush=True)


if __name__ == "__main__":
    main([float(r) for r in sys.argv[1:]] or [1.05, 1.1, 1.2, 1.3, 1.5])
