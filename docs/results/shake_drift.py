"""How far a flat KAPLA brick (mu 0.5) slips on a shake table past mu g, against the closed
form of a Coulomb block on a base moving by A (1 - cos 2 pi f t), integrated numerically
(stackdsl.bench.shake_models.coulomb_slip): one second of shaking, then the brick slides to rest. Every engine and mode, one run a cell, with
the compiler's limits off (past them).

    python docs/results/shake_drift.py K@F [K@F ...]     # K: peak acceleration in mu g; F: Hz

Output: docs/results/shake-table.md, "How far a slipping brick goes".
"""

from __future__ import annotations

import math
import sys

from stackdsl import compile_scenario, parse_scenario, run_program
from stackdsl.bench.shake_models import coulomb_slip

MU, G = 0.5, 9.81
CELLS = [(b, m) for b in ("pybullet", "mujoco") for m in ("raw", "tuned", "extension")]


def slid(amplitude: float, frequency: float, backend: str, mode: str) -> float:
    """m, where the brick's centre ends along x in ``backend``'s ``mode``."""
    text = (
        f"stackdsl: 1\nengine: {{backend: {backend}, mode: {mode}}}\nstructure:\n  bricks:\n    - {{id: a, at: [0, 0, 4 mm]}}\n"
        f"actions:\n  - shake: {{amplitude: {amplitude * 1000:.4f} mm, frequency: {frequency:g} Hz, duration: 1 s, "
        "direction: [1, 0], at: 1 s}\n"
    )
    outcome = run_program(compile_scenario(parse_scenario(text, "shake.yaml"), limits=False))
    return next(n.position_mm for n in outcome.final_graph.nodes if n.id == "a")[0] / 1000


def main(specs: list[str]) -> None:
    print("| a_peak | f | A | peak speed | closed form | " + " | ".join(f"{b} {m}" for b, m in CELLS) + " |")
    print("|---:|---:|---:|---:|---:|" + "---:|" * len(CELLS))
    for spec in specs:
        k, f = (float(v) for v in spec.split("@"))
        amplitude = k * MU * G / (2 * math.pi * f) ** 2
        closed = coulomb_slip(amplitude, f, max(1, round(f)), MU)[0] * 1000  # one second of shaking
        cells = []
        for backend, mode in CELLS:
            x = slid(amplitude, f, backend, mode) * 1000
            cells.append(f"{x:.1f}" if abs(x - closed) <= max(0.25 * closed, 2.0) else f"**{x:.1f}**")
        print(
            f"| {k:g} mu g ({k * MU * G:.3g} m/s^2) | {f:g} Hz | {amplitude * 1000:.3g} mm | "
            f"{amplitude * 2 * math.pi * f:.2g} m/s | {closed:.1f} | " + " | ".join(cells) + " |"
        )


if __name__ == "__main__":
    main(sys.argv[1:])
