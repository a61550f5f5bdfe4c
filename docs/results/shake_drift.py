"""How far a flat KAPLA brick (mu 0.5) slips on a shake table past mu g, against the closed
form of a Coulomb block on a base moving by A (1 - cos 2 pi f t), integrated numerically: one
second of shaking, then the brick slides to rest. Every engine and mode, one run a cell, with
the compiler's limits off (past them).

    python docs/results/shake_drift.py K@F [K@F ...]     # K: peak acceleration in mu g; F: Hz

Output: docs/results/shake-table.md, "How far a slipping brick goes".
"""

from __future__ import annotations

import math
import sys

from stackdsl import compile_scenario, parse_scenario, run_program

MU, G = 0.5, 9.81
CELLS = [(b, m) for b in ("pybullet", "mujoco") for m in ("raw", "tuned", "extension")]


def drift(amplitude: float, frequency: float, duration: float = 1.0, dt: float = 2e-6) -> float:
    """m, the closed form's slip of the brick along the shake, once at rest."""
    w = 2 * math.pi * frequency
    end = max(1, round(duration * frequency)) / frequency
    x = v = t = 0.0
    while t < end:
        table_v, table_a = amplitude * w * math.sin(w * t), amplitude * w * w * math.cos(w * t)
        rel = v - table_v
        if abs(rel) < 1e-9 and abs(table_a) <= MU * G:  # stuck: rides the table
            v, a = table_v, table_a
        else:
            a = -MU * G * math.copysign(1, rel if abs(rel) > 1e-12 else -table_a)
        new = v + a * dt
        next_v = amplitude * w * math.sin(w * (t + dt))
        if (v - table_v) * (new - next_v) < 0 and abs(amplitude * w * w * math.cos(w * (t + dt))) <= MU * G:
            new = next_v  # caught up with the table, which it can follow
        x, v, t = x + v * dt, new, t + dt
    while abs(v) > 1e-9:  # slides to rest
        new = v - MU * G * math.copysign(1, v) * dt
        x, v = x + v * dt, 0.0 if new * v < 0 else new
    return x


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
        closed = drift(amplitude, f) * 1000
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
